"""Modes the ERA model holds that were re-excited before their first decay died out: each refitted in its band on
the decays cut where its band's amplitude steps, when the step is a re-excitation and not a smooth change.

A mode hit again while its first decay still rings (a double hit, a later softer excitation the segmentation misses)
decays across the record, but its band fit there is biased: a 0.3 %-damped mode re-excited at half its amplitude
reads up to 10 of its sigmas off in frequency. Its band's amplitude, the fitted decay divided out, steps at the
re-excitation (:func:`~physics.identification.peak_seeds.band_jump`). The amplitude of a mode that is *not*
re-excited varies too where the band is not one damped exponential: a neighbour no model holds beats with it, its
frequency drifts with its amplitude (a stiffening joint), a close mode shares its band. A single step removes part
of such a variation as well, often more than the noise allows by chance (on the pyFRF hits' 5970-Hz mode a score
of 30, a step of 0.38 of the amplitude; on the DS5 board's 2394-Hz mode 26-44 and 0.3-0.5), and cutting there moves
the mode by several Hz. What tells a re-excitation from a smooth change is the step itself: the amplitude is
constant either side of it, so the step leaves a fraction of the residual the likeliest *linear* change of the
amplitude leaves (:attr:`~physics.identification.peak_seeds.BandJump.over_ramp`: 0.16-0.25 on simulated
re-excitations at half the first amplitude and 1e-3 to 3e-2 noise, 0.24-0.39 at a quarter), while a smooth change
leaves both alike (0.71-0.96 on the held modes alone in their bands the step rules pass on the real sets, the pyFRF
hits, the USC bridge, the DS5 shocks and the DROPBEAR dwells; 0.56 the lowest of any scoring 25). A held mode
alone in its band whose band's amplitude steps by at least :data:`~physics.identification.peak_seeds.REEXCITE_JUMP`
times the step's noise, by :data:`~physics.identification.peak_seeds.REEXCITE_STEP` of the amplitude, and leaves at
most :data:`~physics.identification.peak_seeds.REEXCITE_OVER_RAMP` of the linear change's residual
(:attr:`~physics.identification.peak_seeds.BandJump.re_excitation`) is refitted on its decays cut there (the pieces'
amplitudes their own, the pole common; the other modes held fixed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.identification.band_refine import MERGE_FACTOR, BandFit, mode_bands
from physics.identification.peak_seeds import MIN_DECAY_SIGMAS, band_jump, decay_pieces, seed_fit

__all__ = ["HeldRefit", "refit_held_re_excited"]


@dataclass(frozen=True)
class HeldRefit:
    """Held modes' band fits, those re-excited within a decay refitted on its pieces (see the module docstring).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s), the band fit's order.
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
    amplitudes : ndarray, complex, shape (n_decays, n_channels, n_modes)
        At each decay's first sample (its first piece's for a refitted mode).
    refitted : ndarray of bool, shape (n_modes,)
        The modes whose values are their fit on the cut decays.
    """

    eigenvalues: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    amplitudes: np.ndarray
    refitted: np.ndarray


def refit_held_re_excited(decays, sampling_frequency_hz, bands: BandFit, max_damping) -> HeldRefit:
    """The band fits ``bands`` of the modes a model holds, those re-excited before their first decay died out
    refitted on the decays cut at their band amplitude's step (see the module docstring).

    Each converged mode that decays (damping at least :data:`~physics.identification.peak_seeds.MIN_DECAY_SIGMAS`
    of its one sigma) alone in its band (:func:`~physics.identification.band_refine.mode_bands`) is searched for a
    step over :data:`~physics.identification.band_refine.MERGE_FACTOR` half-widths of its band either side. A refit
    replaces the whole decays' fit where it converged with a damping ratio in ``(0, max_damping)`` and at least
    :data:`~physics.identification.peak_seeds.MIN_DECAY_SIGMAS` of its one sigma.

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays ``bands`` was fitted on.
    sampling_frequency_hz : float
    bands : BandFit
    max_damping : float

    Returns
    -------
    HeldRefit
    """
    fs = float(sampling_frequency_hz)
    lam, f_std, z_std = bands.eigenvalues.copy(), bands.frequency_std_hz.copy(), bands.damping_std.copy()
    amps = bands.amplitudes.copy()
    refitted = np.zeros(lam.size, bool)
    live = np.flatnonzero(bands.converged & ~np.asarray(bands.merged, bool))
    if live.size == 0:
        return HeldRefit(lam, f_std, z_std, amps, refitted)
    longest_s = max(y.shape[1] for y in decays) / fs
    zone_bands, group = mode_bands(lam[live], longest_s, fs / 2)
    alone = np.bincount(group)[group] == 1
    decaying = bands.damping_ratios[live] >= MIN_DECAY_SIGMAS * bands.damping_std[live]
    half = MERGE_FACTOR * 0.5 * (zone_bands[:, 1] - zone_bands[:, 0])
    f_d = lam[live].imag / (2 * np.pi)
    cuts, cand = [[] for _ in decays], []
    for k in np.flatnonzero(alone & decaying):
        zone = (max(f_d[k] - half[k], 0.0), min(f_d[k] + half[k], fs / 2))
        steps = [(d, j) for d, j in enumerate(band_jump(y, fs, zone, lam[live[k]]) for y in decays)
                 if j.re_excitation]
        for d, j in steps:
            cuts[d].append(j.sample)
        if steps:
            cand.append(live[k])
    pieces, first = decay_pieces(decays, cuts)
    if pieces is None:
        return HeldRefit(lam, f_std, z_std, amps, refitted)
    cand = np.array(cand, int)
    others = np.setdiff1d(live, cand)
    refit, jr = seed_fit(pieces, fs, lam[others], lam[cand], None)     # the others: their bands' linear fits
    z = refit.damping_ratios[jr]
    good = refit.converged[jr] & (z > 0) & (z < max_damping) & (z >= MIN_DECAY_SIGMAS * refit.damping_std[jr])
    c, jr = cand[good], jr[good]
    lam[c], f_std[c], z_std[c] = refit.eigenvalues[jr], refit.frequency_std_hz[jr], refit.damping_std[jr]
    amps[:, :, c] = refit.amplitudes[first][:, :, jr]
    refitted[c] = True
    return HeldRefit(lam, f_std, z_std, amps, refitted)
