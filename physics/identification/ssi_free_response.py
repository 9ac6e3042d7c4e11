"""SSI-cov's modes of a free response refined on its decays.

A free response (:func:`~physics.identification.decays.free_response`) is no stationary record: its correlations'
error, the noise times the decaying response, has the modes' spectrum, and the poles of a model above the modes'
order sit beside each mode and move it (a 1 %-damped 12 Hz decay over 4 s at 77 Hz, noise 1e-3: 1.1-1.9x the
Cramer-Rao bound at order 2, 110-480x at orders 4-30). Its selected poles are refined in their bands of the decays'
transforms as ``era``'s are (:func:`~physics.identification.band_refine.refine_in_bands`): the one sigma is the
band fit's, a pole merged into a stronger one of its peak is dropped, one drawn out of the band keeps SSI-cov's.
The model's extra poles (the correlations' error, stable over many orders) fit noise in their bands: a pole whose
amplitudes' chi-square (:attr:`~physics.identification.band_refine.BandFit.amplitude_chi2`, the increase of its
band fit's squared residual without it, in noise variances) white noise alone exceeds with a probability above
:data:`NOISE_POLE_PROBABILITY` (a chi-square of 30 at two degrees of freedom) is dropped
(:func:`noise_poles`) and the rest refitted without it, until none is left (closed-form decays of 21, 67 and 143
Hz, one channel, noise 1e-3: extra poles at 79.8, 100.4 and 125.4 Hz of chi-square 7-11, the modes 10^5-10^9; a
pole that held 108 beside another noise pole of its band holds 10 refitted without it). A group of close poles whose
band fit fails has no chi-square to judge its poles by: its weakest starting pole is dropped
(:func:`failed_group_weakest`) and the rest refitted, until every group converges or is one pole.
The clear peaks of the decays' spectrum that no refined pole holds are started at their peak and refined in their
bands as ``era``'s seeds are (:func:`~physics.identification.peak_seeds.seed_unheld_peaks`), flagged weakly stable.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from physics.identification.band_amplitudes import band_amplitudes
from physics.identification.band_refine import BandFit, mode_energies, refine_in_bands
from physics.identification.decay_peaks import decay_peaks
from physics.identification.decays import decay_spectrum, find_decays
from physics.identification.fdd import height_db, unit_shapes
from physics.identification.peak_seeds import SeededModes, dominant_shapes, seed_unheld_peaks

__all__ = ["NOISE_POLE_PROBABILITY", "ModeColumns", "failed_group_weakest", "noise_poles", "refine_free_response"]

#: A refined pole is a mode when white noise alone gives its amplitudes' chi-square (two degrees of freedom per decay
#: and channel) with at most this probability: that of 30 at two degrees of freedom (one decay and channel). Measured:
#: SSI-cov's extra poles on the precision bench's decays (96 records) and bench_free_response's free families (145)
#: 3-17, the weakest modes they hold (noise 1e-1 of the ringing's peak) 47 and more; a pole started on noise beside a
#: decay (600 fits, one decay and channel) 99 % below 14-29 as started at 0.1, 1 or 5 % damping, the largest 52.
NOISE_POLE_PROBABILITY = float(np.exp(-15.0))


class ModeColumns(NamedTuple):
    """SSI-cov's modes, one column (or entry) per mode.

    Attributes
    ----------
    eigenvalues : ndarray, shape (n_modes,), complex (rad/s)
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
    weak : ndarray of bool, shape (n_modes,)
        Weakly stable (a mode kept at a clear peak, or a seeded one).
    shapes : ndarray, shape (n_channels, n_modes), complex
    segment_frequencies_hz, segment_damping_ratios : ndarray, shape (n_segments, n_modes)
    """

    eigenvalues: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    weak: np.ndarray
    shapes: np.ndarray
    segment_frequencies_hz: np.ndarray
    segment_damping_ratios: np.ndarray

    def take(self, idx) -> ModeColumns:
        """The modes ``idx`` (an index array), in its order."""
        return ModeColumns(self.eigenvalues[idx], self.frequency_std_hz[idx], self.damping_std[idx], self.weak[idx],
                           self.shapes[:, idx], self.segment_frequencies_hz[:, idx],
                           self.segment_damping_ratios[:, idx])


def noise_poles(bands: BandFit) -> np.ndarray:
    """Shape (n_modes,) of bool: the converged poles of ``bands`` whose amplitudes' chi-square
    (:attr:`~physics.identification.band_refine.BandFit.amplitude_chi2`) white noise alone exceeds with a
    probability above :data:`NOISE_POLE_PROBABILITY`."""
    from scipy import stats  # scipy: only output-only identification

    with np.errstate(invalid="ignore"):
        return bands.amplitude_chi2 < stats.chi2.isf(NOISE_POLE_PROBABILITY, np.maximum(bands.amplitude_dof, 1))


def failed_group_weakest(bands: BandFit, decays, sampling_frequency_hz) -> np.ndarray:
    """Shape (n_modes,) of bool: in each group of two or more poles of ``bands`` whose band fit failed (a pole not
    converged nor merged), the weakest of its starting poles: the least energy (over the decays, shape (n_channels,
    n_samples_d) each, and the channels) of its amplitudes fitted with the poles held
    (:func:`~physics.identification.band_amplitudes.band_amplitudes`). Its band fit's misfit is no pole's to judge."""
    failed = ~bands.converged & ~np.asarray(bands.merged, bool) & (bands.group >= 0)
    out = np.zeros(failed.size, bool)
    groups = [g for g in np.unique(bands.group[failed]) if np.count_nonzero(bands.group == g) > 1]
    if not groups:
        return out
    idx = np.flatnonzero(np.isin(bands.group, groups))
    lam = bands.eigenvalues[idx]
    fs = float(sampling_frequency_hz)
    energy = mode_energies(band_amplitudes(decays, fs, lam), lam, [y.shape[1] for y in decays], fs)
    for g in groups:
        mine = np.flatnonzero(bands.group[idx] == g)
        out[idx[mine[np.argmin(energy[mine])]]] = True
    return out


def refine_free_response(checked, modes: ModeColumns, sv, band_hz, n_modes, max_damping) \
        -> tuple[BandFit | None, SeededModes | None, ModeColumns]:
    """``(band fit, seeded modes, modes)`` of SSI-cov's ``modes`` of the checked record ``checked``, a free
    response (:func:`~physics.identification.decays.free_response`): each pole refined in its band of the decays
    (each decay from its hit's onset, a hit adding energy over a period of the lowest pole, as ``era`` finds them)
    where the fit converged inside ``band_hz`` (Hz), a pole merged into a stronger one of its peak dropped, and the
    clear peaks no refined pole holds added as seeded modes (their highest on the singular-value spectrum ``sv``
    first, up to ``n_modes`` in all), sorted by frequency; ``(None, None, modes)`` unchanged for a record in which
    no decay is found."""
    lam = modes.eigenvalues
    d = find_decays(checked, lowest_hz=float(np.min(np.abs(lam))) / (2 * np.pi))
    if not d.onsets.size:
        return None, None, modes
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    decays = [x[:, a:b] for a, b in zip(d.onsets.tolist(), d.stops.tolist())]
    fs = checked.sampling_frequency_hz
    bands = refine_in_bands(decays, fs, lam)
    noise = noise_poles(bands) | failed_group_weakest(bands, decays, fs)
    while noise.any():                                  # the rest refitted without them: a group's poles move
        modes = modes.take(np.flatnonzero(~noise))
        lam = modes.eigenvalues
        bands = refine_in_bands(decays, fs, lam)
        noise = noise_poles(bands) | failed_group_weakest(bands, decays, fs)
    converged, kept = bands.converged, ~np.asarray(bands.merged, bool)
    held = np.where(converged, bands.eigenvalues, lam)[kept]
    amps = np.where(converged, bands.amplitudes, np.nan)[:, :, kept]     # NaN: refitted in its band with the seeds
    seeded = seed_unheld_peaks(decays, fs, held, decay_peaks(decay_spectrum(checked)), checked.band_hz, max_damping,
                               held_amplitudes=amps)
    f = bands.natural_frequencies_hz
    ok = converged & (f >= band_hz[0]) & (f <= band_hz[1])
    modes = modes._replace(eigenvalues=np.where(ok, bands.eigenvalues, lam),
                           frequency_std_hz=np.where(ok, bands.frequency_std_hz, modes.frequency_std_hz),
                           damping_std=np.where(ok, bands.damping_std, modes.damping_std)).take(np.flatnonzero(kept))
    n_seed = seeded.eigenvalues.size if n_modes is None else min(seeded.eigenvalues.size,
                                                                 n_modes - modes.eigenvalues.size)
    if n_seed > 0:                                      # the clear peaks no pole held, their highest first
        s = np.sort(np.argsort(-height_db(sv, seeded.peak_hz), kind="stable")[:n_seed])
        pad = ((0, 0), (0, s.size))
        modes = ModeColumns(np.concatenate([modes.eigenvalues, seeded.eigenvalues[s]]),
                            np.concatenate([modes.frequency_std_hz, seeded.frequency_std_hz[s]]),
                            np.concatenate([modes.damping_std, seeded.damping_std[s]]),
                            np.concatenate([modes.weak, np.ones(s.size, bool)]),
                            np.concatenate([modes.shapes, unit_shapes(dominant_shapes(seeded.amplitudes[:, :, s]))],
                                           axis=1),
                            np.pad(modes.segment_frequencies_hz, pad, constant_values=np.nan),
                            np.pad(modes.segment_damping_ratios, pad, constant_values=np.nan))
    return bands, seeded, modes.take(np.argsort(np.abs(modes.eigenvalues), kind="stable"))  # refinement reorders
