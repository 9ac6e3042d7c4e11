"""The clear peaks of a free decay's spectrum that its ERA model holds no mode at: each started at its peak and
refined in its own band of the decays' transforms.

A clear peak (:func:`~physics.identification.decay_peaks.decay_peaks`) is the evidence the zero-padded FFT peak
(``fftpeak``) reports a mode on. The ERA model can miss such a mode: a low, weak mode under much stronger ones of
the band (a model of order ``2 m`` holds the ``m`` strongest), or a band whose stabilisation diagram shows no pole
stable over enough orders. The narrow-band refinement
(:func:`~physics.identification.band_refine.refine_in_bands`) needs no model of the rest of the spectrum: it fits
the truncated damped exponentials of the modes of one band and a smooth background on that band's lines alone.
Started at the peak's frequency with the damping of its half-power width (:func:`seed_poles`), it gives the mode
with the covariance of its fit, as it does each ERA pole, in its own band alone: the modes already held are fixed
(subtracted by their closed-form transforms, not refined again), but for a held mode that shares the seed's band,
which is fitted with it (a neighbour that close is no background, and its own fit took the seed's peak for
background). A seed is kept when its fit converged within the peak's tolerance, with a damping ratio in
``(0, max_damping)`` and at least :data:`MIN_DECAY_SIGMAS` of its one sigma, apart from every mode held
(:func:`refine_seeds`). A mode of a free decay decays: a peak whose fitted decay rate is not significantly positive
is a sinusoid that lasts the record (mains hum, a quantisation product of a coarse capture, a noise line), which a
stabilisation diagram would not hold either. A mode re-excited within a decay (a later, softer excitation: a
footstep on a bridge excites its low modes and adds little to the record's energy, so the segmentation misses it)
does not decay across the record either: its energy in its own band falls, rises at the re-excitation and falls
again, while a sinusoid's stays level and a noise-like component's (quantisation products) rises and falls at
random. A seed whose fit shows no decay is fitted again on the decays cut where the energy in its band rises
:data:`REEXCITE_RISE` fold, once within a decay (:func:`band_rises`): the pieces are decays of their own (their own
amplitudes, the poles common), and the seed is kept if it decays there. The cut is placed where the band's
amplitude, the fitted decay divided out, steps (:func:`band_jump`). A mode re-excited before its first decay died
out still decays across the record, but its fit there is biased (the band's energy need not rise at all: the
re-excitation may come in any phase); a seed that decays, alone in its band, is cut where its band's amplitude steps
by :data:`REEXCITE_JUMP` times the step's noise and the step is one, not a smooth change (at most
:data:`REEXCITE_OVER_RAMP` of a linear change's residual, as for the modes a model holds,
:mod:`~physics.identification.held_reexcitation`: the pyFRF hits' 5970-Hz mode, read 3-4 Hz low on pieces cut at
its smooth amplitude change), and its fit on the pieces replaces the whole record's where it is still a mode of its
peak.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.identification.band_amplitudes import band_amplitudes
from physics.identification.band_refine import MERGE_FACTOR, mode_bands, refine_in_bands
from physics.identification.fdd import ClearPeaks

__all__ = ["JUMP_SAMPLES_PER_CORRELATION", "JUMP_SEARCH_LINES", "JUMP_SEARCH_STEPS", "JUMP_SIGMA_OCTAVES",
           "MIN_DECAY_SIGMAS", "REEXCITE_JUMP", "REEXCITE_OVER_RAMP", "REEXCITE_RISE", "REEXCITE_STEP", "BandJump",
           "SeededModes", "band_jump", "band_rises", "cut_at_rises", "decay_pieces", "dominant_shapes",
           "refine_seeds", "seed_fit", "seed_poles", "seed_unheld_peaks", "unheld_peaks"]

#: A seeded mode's damping ratio is at least this many of its one sigma (it decays within the record).
MIN_DECAY_SIGMAS = 2.0
#: A re-excitation: the energy in a seed's band over the next window at least this many times that over the window
#: before and than the quietest tenth of the windows (:func:`band_rises`).
REEXCITE_RISE = 4.0
#: A re-excitation of a seed that decays: the decay's amplitude in the seed's band, the fitted decay divided out,
#: jumps once by this many times the jump's noise (:func:`band_jump`; white noise alone passes 25 with probability
#: about ``n_windows exp(-25)``).
REEXCITE_JUMP = 25.0
#: The jump is sought with the fitted pole's frequency moved by up to this many lines ``1 / T`` either side, in
#: this many steps each way (a re-excitation biases the fit across it: 0.13 Hz, half a line of 4 s, at half
#: amplitude).
JUMP_SEARCH_LINES, JUMP_SEARCH_STEPS = 2.0, 20
#: ... and leaves at most this fraction of the squared residual the likeliest linear change of the amplitude leaves
#: (:attr:`BandJump.over_ramp`; a step, not a smooth change: simulated re-excitations 0.16-0.39, the real sets' modes
#: scoring :data:`REEXCITE_JUMP` 0.56-0.96, :mod:`~physics.identification.held_reexcitation`).
REEXCITE_OVER_RAMP = 0.5
#: ... and changes the amplitude by at least this fraction of the amplitude before it (a single decay's band filter,
#: rung by its sharp start, steps by under a tenth: 0.08-0.1 on the precision bench's decays, scored up to 93; a
#: re-excitation at half amplitude, 0.8-1.1).
REEXCITE_STEP = 0.25
#: ... and its decay rate by up to this many octaves either side, in quarter octaves (a re-excitation slows the
#: decay fitted across it: 0.0018 for 0.003).
JUMP_SIGMA_OCTAVES = 2
#: The band's signal is read this many times per correlation length (its time resolution).
JUMP_SAMPLES_PER_CORRELATION = 8


@dataclass(frozen=True)
class SeededModes:
    """Modes refined from clear peaks no model pole held (see the module docstring).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s), by frequency.
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        One sigma from the band fit's covariance.
    amplitudes : ndarray, complex, shape (n_decays, n_channels, n_modes)
        ``a`` of ``Re(a z^n)`` of each decay, channel and mode at the decay's first sample.
    peak_hz : ndarray, shape (n_modes,)
        The clear peak each mode was started at.
    tried_hz : ndarray, shape (n_tried,)
        Every clear peak started (kept or not).
    """

    eigenvalues: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    amplitudes: np.ndarray
    peak_hz: np.ndarray
    tried_hz: np.ndarray


def unheld_peaks(peaks: ClearPeaks, modes_hz, band_hz) -> np.ndarray:
    """Indices of the clear peaks within ``band_hz`` (Hz) farther than their tolerance from every one of
    ``modes_hz``, shape (n,)."""
    f, tol = peaks.frequency_hz, peaks.tolerance_hz
    held = np.asarray(modes_hz, dtype=np.float64)
    near = np.any(np.abs(f[:, None] - held[None, :]) <= tol[:, None], axis=1) if held.size else np.zeros(f.size, bool)
    return np.flatnonzero((f >= band_hz[0]) & (f <= band_hz[1]) & ~near)


def seed_unheld_peaks(decays, sampling_frequency_hz, held_eigenvalues, peaks: ClearPeaks, band_hz, max_damping,
                      held_amplitudes=None) -> SeededModes:
    """The modes of the clear peaks within ``band_hz`` (Hz) that no held mode explains (:func:`unheld_peaks`),
    each started at its peak and refined in its band with the held modes fixed (:func:`refine_seeds`; the
    arguments are its)."""
    held = np.asarray(held_eigenvalues, complex)
    seeds = unheld_peaks(peaks, np.abs(held) / (2 * np.pi), band_hz)
    return refine_seeds(decays, sampling_frequency_hz, held, peaks, seeds, max_damping,
                        held_amplitudes=held_amplitudes)


def dominant_shapes(amplitudes) -> np.ndarray:
    """Each mode's shape: the dominant direction (first left singular vector) of its complex amplitudes over the
    decays, ``amplitudes`` shape (n_decays, n_channels, n_modes); unit-norm, shape (n_channels, n_modes)."""
    a = np.moveaxis(np.asarray(amplitudes, complex), 2, 0)             # (n_modes, n_decays, n_channels)
    u = np.linalg.svd(np.swapaxes(a, 1, 2), full_matrices=False)[0]    # (n_modes, n_channels, k)
    return u[:, :, 0].T


def seed_poles(frequency_hz, tolerance_hz, longest_s) -> np.ndarray:
    """Starting poles ``-sigma + i omega`` (rad/s) at peaks of ``frequency_hz`` (Hz), ``tolerance_hz`` wide
    (:attr:`~physics.identification.fdd.ClearPeaks.tolerance_hz`, at least the peak's half-power half-width):
    ``sigma`` of a half-power half-width ``sigma / 2 pi`` of half the tolerance, and no less than one over the longest
    decay ``longest_s`` (a peak no wider than the record's resolution: a decay that lasts the record)."""
    f = np.asarray(frequency_hz, dtype=np.float64)
    sigma = np.maximum(2 * np.pi * 0.5 * np.asarray(tolerance_hz, dtype=np.float64), 1.0 / longest_s)
    return -sigma + 2j * np.pi * f                  # a decay's spectrum peaks at its damped frequency


@dataclass(frozen=True)
class BandJump:
    """The likeliest single jump of a decay's amplitude in a band (see :func:`band_jump`).

    Attributes
    ----------
    sample : int
        First sample after the jump.
    score : float
        The two amplitudes' weighted squared difference over its noise (0: no sample to test).
    step : float
        The amplitude's change at the jump over its amplitude before (the decay divided out; channels summed in
        quadrature).
    over_ramp : float
        The squared residual the jump leaves over the one the likeliest linear change of the amplitude leaves (each
        with its own pole of the search): a fraction for a step (a re-excitation), about 1 or more for a smooth
        change (two modes beating, a frequency drifting with the amplitude, a component no model holds).
    """

    sample: int
    score: float
    step: float = 0.0
    over_ramp: float = 1.0

    @property
    def re_excitation(self) -> bool:
        """Whether the jump is a re-excitation to cut the decay at: a score of at least :data:`REEXCITE_JUMP`, a
        step of :data:`REEXCITE_STEP` and at most :data:`REEXCITE_OVER_RAMP` of a linear change's residual (a step,
        not a smooth change)."""
        return self.score >= REEXCITE_JUMP and self.step >= REEXCITE_STEP and self.over_ramp <= REEXCITE_OVER_RAMP


def _in_band(y, fs, band_hz, analytic=False) -> np.ndarray:
    """The decays ``y`` (n_channels, n) on the lines of ``band_hz`` (Hz) alone, transformed back from their
    transform zero-padded to ``2 n`` samples (the loud start does not wrap onto the end): real, or with ``analytic``
    the complex signal of the positive-frequency lines; shape (n_channels, 2 n)."""
    fft, ifft, lines = (np.fft.fft, np.fft.ifft, np.fft.fftfreq) if analytic else \
        (np.fft.rfft, np.fft.irfft, np.fft.rfftfreq)
    f = lines(2 * y.shape[1], 1.0 / fs)
    Y = fft(y, 2 * y.shape[1], axis=1)
    Y[:, (f < band_hz[0]) | (f > band_hz[1])] = 0.0
    return ifft(Y, 2 * y.shape[1], axis=1)


def band_jump(decay, sampling_frequency_hz, band_hz, eigenvalue) -> BandJump:
    """Where the amplitude of a decay in a band, the decay of pole ``eigenvalue`` divided out, jumps (a
    re-excitation of the mode while its first decay still rings): the likeliest single change point.

    The decay's transform (zero-padded to twice its length) on the positive-frequency lines of ``band_hz`` alone,
    transformed back, is the band's complex (analytic) signal ``b(t)``; a free decay of the pole ``lambda`` is
    ``b(t) = c exp(lambda t)``, so ``s(t) = b(t) exp(-lambda t)`` is constant, its noise's variance growing as
    ``exp(2 sigma t)``. A re-excitation at ``t_h`` adds ``d exp(lambda (t - t_h))`` from ``t_h`` on: ``s`` steps
    from ``c`` to ``c + d exp(-lambda t_h)``, whatever the re-excitation's phase (the band's energy, which a
    half-amplitude re-excitation of a decay that has fallen to half may not raise at all, is the modulus). Each
    split of ``s`` (weights ``exp(-2 sigma t)``) into two parts of their own weighted means reduces the squared
    residual by ``W1 W2 / W |m1 - m2|^2``; the largest, over the residual's noise variance per sample times the
    band-limited signal's correlation length ``fs / width`` (white noise: an exponential variable of mean 1 at
    each split), is the score. The first and last correlation lengths (the band filter's response to the decay's
    start and end) are left out. The same residual of a linear change ``s = a + c (t - t_mean)`` (weighted alike,
    its own pole searched) is the smooth alternative the jump is compared with (:attr:`BandJump.over_ramp`).

    Parameters
    ----------
    decay : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float)
    eigenvalue : complex
        The decay's fitted pole ``-sigma + i omega`` (rad/s).

    Returns
    -------
    BandJump
    """
    y = np.asarray(decay, dtype=np.float64)
    fs, n = float(sampling_frequency_hz), y.shape[1]
    corr = int(np.ceil(fs / max(band_hz[1] - band_hz[0], np.finfo(float).tiny)))
    if n < 4 * corr:
        return BandJump(0, 0.0, 0.0, 1.0)
    hop = max(1, corr // JUMP_SAMPLES_PER_CORRELATION)     # s(t) varies over a correlation length: read it on a hop
    t = np.arange(corr, n - corr, hop)
    b = _in_band(y, fs, band_hz, analytic=True)[:, t]
    lam = complex(eigenvalue)
    shifts = 2j * np.pi * JUMP_SEARCH_LINES * fs / n * np.linspace(-1.0, 1.0, 2 * JUMP_SEARCH_STEPS + 1)
    sigmas = -lam.real * 2.0 ** np.linspace(-JUMP_SIGMA_OCTAVES, JUMP_SIGMA_OCTAVES, 4 * JUMP_SIGMA_OCTAVES + 1)
    poles = (-sigmas[:, None] + 1j * lam.imag + shifts[None, :]).ravel()     # the poles tried
    decay_t = np.exp(np.outer(poles, t) / fs)                                # (poles, samples)
    w = np.abs(decay_t) ** 2                            # the weights of s = b / decay_t, and w s = b conj(decay_t)
    ws = b[None, :, :] * np.conj(decay_t)[:, None, :]                        # (poles, channels, samples)
    tiny = np.finfo(float).tiny
    W1 = np.maximum(np.cumsum(w, axis=1)[:, :-1], tiny)
    S1 = np.cumsum(ws, axis=2)[:, :, :-1]
    total_w = np.sum(w, axis=1)
    total_s = np.sum(ws, axis=2)
    W2 = np.maximum(total_w[:, None] - W1, tiny)
    S2 = total_s[:, :, None] - S1
    gain = np.sum(np.abs(S1 * W2[:, None, :] - S2 * W1[:, None, :]) ** 2, axis=1) / (W1 * W2 * total_w[:, None])
    gain[np.minimum(W1, W2) < 1e-9 * total_w[:, None]] = 0.0      # a part of no weight: its mean is rounding
    one = np.sum(np.abs(b) ** 2) - np.sum(np.abs(total_s) ** 2, axis=1) / total_w
    two = one[:, None] - gain                           # the squared residual of one decay, of two parts
    i, k = np.unravel_index(int(np.argmin(two)), two.shape)
    noise = max(two[i, k] / t.size * corr / hop, tiny)
    m1, m2 = S1[i, :, k] / W1[i, k], S2[i, :, k] / W2[i, k]
    step = np.linalg.norm(m2 - m1) / max(np.linalg.norm(m1), tiny)
    dt = t[None, :] / fs - (w @ (t / fs) / np.maximum(total_w, tiny))[:, None]     # (poles, samples)
    slope = np.sum(ws * dt[:, None, :], axis=2)                                     # sum w s dt, (poles, channels)
    ramp = one - np.sum(np.abs(slope) ** 2, axis=1) / np.maximum(np.sum(w * dt ** 2, axis=1), tiny)
    over_ramp = two[i, k] / max(ramp.min(), tiny)
    return BandJump(int(t[k + 1]), float((one.min() - two[i, k]) / noise), float(step), float(over_ramp))


def band_rises(decay, sampling_frequency_hz, band_hz) -> np.ndarray:
    """Where the energy of a decay in a band rises (a re-excitation): the samples, shape (n_cuts,) of int.

    The decay's transform (zero-padded to twice its length) on the lines of ``band_hz`` (Hz) alone, transformed
    back, is the decay in the band; its
    energy (summed over the channels) over the next window of two over the band's width (the band-limited signal's
    time resolution) is at least :data:`REEXCITE_RISE` times that over the window before and than the quietest tenth
    of the windows. Each run of such samples gives one cut, where that ratio is largest (the rise's middle). A free
    decay's energy in the band of its modes falls (two modes of the band beat, at most rising back to where it was);
    a sinusoid's stays level.

    Parameters
    ----------
    decay : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float)
    """
    y = np.asarray(decay, dtype=np.float64)
    fs, n = float(sampling_frequency_hz), y.shape[1]
    w = int(np.ceil(2 * fs / max(band_hz[1] - band_hz[0], np.finfo(float).tiny)))
    if n < 3 * w:
        return np.zeros(0, int)
    c = np.concatenate([[0.0], np.cumsum(np.sum(_in_band(y, fs, band_hz)[:, :n] ** 2, axis=0))])
    k = np.arange(w, n - w + 1)
    before, after = c[k] - c[k - w], c[k + w] - c[k]
    floor = np.percentile(c[w:] - c[:-w], 10)
    rise = (after >= REEXCITE_RISE * before) & (after >= REEXCITE_RISE * floor) & (after > 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], rise.astype(int), [0]])))
    ratio = after / np.maximum(before, np.finfo(float).tiny)
    return np.array([k[a + int(np.argmax(ratio[a:b]))] for a, b in zip(edges[0::2], edges[1::2])], int)


def seed_fit(decays, fs, held, start, held_amplitudes):
    """The band fit of the seeds ``start`` (complex (n_seeds,), rad/s) on ``decays`` (each (n_channels, n_samples),
    at ``fs`` Hz) with the modes ``held`` (complex (n_held,), rad/s) of their bands refitted and the others fixed at
    ``held_amplitudes`` (see :func:`refine_seeds`): the :class:`~physics.identification.band_refine.BandFit` and
    the seeds' indices into it, shape (n_seeds,)."""
    n_ch = decays[0].shape[0]
    longest_s = max(y.shape[1] for y in decays) / fs
    _, group = mode_bands(np.concatenate([held, start]), longest_s, fs / 2)
    near = np.isin(group[:held.size], group[held.size:])    # a held mode in a seed's band: refitted with it
    amps = np.full((len(decays), n_ch, held.size), np.nan, complex) if held_amplitudes is None else \
        np.array(held_amplitudes, complex)
    lone = ~near & np.any(np.isnan(amps), axis=(0, 1))  # amplitudes unknown: each group's linear fit in its band
    if lone.any():
        amps[:, :, lone] = band_amplitudes(decays, fs, held[lone])
    fit = refine_in_bands(decays, fs, np.concatenate([held[near], start]), fixed=(held[~near], amps[:, :, ~near]))
    return fit, near.sum() + np.arange(start.size)


def cut_at_rises(decays, fs, bands_hz, eigenvalues):
    """The decays cut where their energy in one of ``bands_hz`` (shape (n_bands, 2), Hz) rises once
    (:func:`band_rises`): the pieces, and the index of each decay's first piece (None where no decay is cut). A decay
    re-excited once falls, rises once and falls again; a band whose energy rises more than once within a decay
    fluctuates (a noise-like component: the quantisation products of a coarse capture, an ambient excitation) and
    cuts nothing. The cut is placed at the band's amplitude jump (:func:`band_jump`, the decay of the band's pole of
    ``eigenvalues`` divided out) where it lies within the rise's window of the rise: the rise's own place is only
    as fine as that window (two over the band's width)."""
    cuts = []
    for y in decays:
        cuts.append([])
        for b, lam in zip(bands_hz, eigenvalues):
            rise = band_rises(y, fs, b)
            if rise.size == 1:
                jump = band_jump(y, fs, b, lam)
                near = abs(jump.sample - rise[0]) <= 2 * fs / max(b[1] - b[0], np.finfo(float).tiny)
                cuts[-1].append(jump.sample if near and jump.score >= REEXCITE_JUMP else int(rise[0]))
    return decay_pieces(decays, cuts)


def _cut_at_jumps(decays, fs, bands_hz, eigenvalues):
    """The decays cut where the amplitude in one of ``bands_hz`` (shape (n_bands, 2), Hz), the decay of its pole
    ``eigenvalues`` divided out, steps (:func:`band_jump`, a score of at least :data:`REEXCITE_JUMP`, a step of
    :data:`REEXCITE_STEP` and at most :data:`REEXCITE_OVER_RAMP` of a linear change's residual): the pieces,
    and the index of each decay's first piece (None where no decay is cut)."""
    cuts = [[j.sample for j in (band_jump(y, fs, b, lam) for b, lam in zip(bands_hz, eigenvalues)) if j.re_excitation]
            for y in decays]
    return decay_pieces(decays, cuts)


def decay_pieces(decays, cuts):
    """The decays cut at their ``cuts`` (one list of samples per decay): the pieces, and the index of each decay's
    first piece; ``(None, None)`` where no decay is cut."""
    pieces, first = [], []
    for y, c in zip(decays, cuts):
        edges = [0, *np.unique(np.array(c, int)).tolist(), y.shape[1]]
        first.append(len(pieces))
        pieces += [y[:, a:b] for a, b in zip(edges[:-1], edges[1:])]
    return (pieces, np.array(first, int)) if len(pieces) > len(decays) else (None, None)


def _mode_of_peak(converged, eigenvalues, damping_std, peak_hz, tolerance_hz, max_damping) -> np.ndarray:
    """Which fitted seeds are modes of their peaks: converged within the peak's tolerance (Hz), damped in
    ``(0, max_damping)`` and by at least :data:`MIN_DECAY_SIGMAS` of the damping's one sigma (shape (n_seeds,))."""
    lam = np.asarray(eigenvalues, complex)
    fn, zeta = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    return converged & (np.abs(fn - peak_hz) <= tolerance_hz) & (zeta > 0) & (zeta < max_damping) \
        & (zeta >= MIN_DECAY_SIGMAS * damping_std)


def refine_seeds(decays, sampling_frequency_hz, held_eigenvalues, peaks: ClearPeaks, seeds, max_damping,
                 freq_tol=0.01, held_amplitudes=None) -> SeededModes:
    """The modes of the clear peaks ``seeds`` (indices into ``peaks``), each refined in its own band with the modes
    held fixed (see the module docstring).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays at the record's rate, each from its onset, mean removed.
    sampling_frequency_hz : float
    held_eigenvalues : array_like, complex, shape (n_held,)
        The modes already held (rad/s). Only the seeds' bands are fitted
        (:func:`~physics.identification.band_refine.refine_in_bands` with ``fixed``): a held mode whose band a seed
        shares (:func:`~physics.identification.band_refine.mode_bands`) is refitted with it (its own fit took the
        seed's peak for background), and its refit is not returned; the others are held fixed (their closed-form
        transforms subtracted from the decays').
    peaks : ClearPeaks
    seeds : array_like of int
    max_damping : float
    freq_tol : float
        A seed within this relative distance of a held mode, or of a seed kept before it, is dropped (within its
        peak's tolerance, when that is the smaller: two clear peaks closer than ``freq_tol`` are two modes). Each
        seed starts (:func:`seed_poles`) as wide as the larger of its peak's tolerance and ``freq_tol`` of its
        frequency.
    held_amplitudes : array_like, complex, shape (n_decays, n_channels, n_held), optional
        The held modes' amplitudes on ``decays``; a fixed mode's that are not given (default) or NaN are each group's
        linear fit in its band (:func:`~physics.identification.band_amplitudes.band_amplitudes`).

    Returns
    -------
    SeededModes
    """
    seeds = np.asarray(seeds, int)
    held = np.asarray(held_eigenvalues, complex)
    n_ch = decays[0].shape[0]
    empty = SeededModes(np.zeros(0, complex), np.zeros(0), np.zeros(0), np.zeros((len(decays), n_ch, 0), complex),
                        np.zeros(0), peaks.frequency_hz[seeds])
    if seeds.size == 0:
        return empty
    fs = float(sampling_frequency_hz)
    longest_s = max(y.shape[1] for y in decays) / fs
    f_seed = peaks.frequency_hz[seeds]
    start = seed_poles(f_seed, np.maximum(peaks.tolerance_hz[seeds], freq_tol * f_seed), longest_s)
    fit, j = seed_fit(decays, fs, held, start, held_amplitudes)
    lam, conv, amps = fit.eigenvalues[j], fit.converged[j], fit.amplitudes[:, :, j]
    f_std, z_std = fit.frequency_std_hz[j], fit.damping_std[j]
    flat = conv & ~(fit.damping_ratios[j] >= MIN_DECAY_SIGMAS * z_std)     # no decay shown: re-excited, or a sinusoid
    if flat.any():
        bands_hz = mode_bands(np.concatenate([held, start]), longest_s, fs / 2)[0][held.size:][flat]
        pieces, first = cut_at_rises(decays, fs, bands_hz, start[flat])
        if pieces is not None:                          # the decays cut where the flat seeds' bands are re-excited
            refit, jr = seed_fit(pieces, fs, held, start[flat], None)
            lam[flat], conv[flat] = refit.eigenvalues[jr], refit.converged[jr]
            f_std[flat], z_std[flat] = refit.frequency_std_hz[jr], refit.damping_std[jr]
            amps[:, :, flat] = refit.amplitudes[first][:, :, jr]
    bands_hz, group = mode_bands(np.concatenate([held, lam]), longest_s, fs / 2)
    alone = np.bincount(group)[group[held.size:]] == 1                  # no other mode in the seed's band
    decaying = conv & ~flat & alone
    if decaying.any():                                  # re-excited before the first decay died out: one jump
        half = MERGE_FACTOR * 0.5 * (bands_hz[held.size:, 1] - bands_hz[held.size:, 0])
        f_d = lam.imag / (2 * np.pi)
        zones = np.stack([np.maximum(f_d - half, 0.0), np.minimum(f_d + half, fs / 2)], axis=1)[decaying]
        pieces, first = _cut_at_jumps(decays, fs, zones, lam[decaying])
        if pieces is not None:
            refit, jr = seed_fit(pieces, fs, held, lam[decaying], None)
            better = np.zeros(lam.size, bool)           # the pieces' fit where it is still a mode of the peak
            better[decaying] = _mode_of_peak(refit.converged[jr], refit.eigenvalues[jr], refit.damping_std[jr],
                                             peaks.frequency_hz[seeds][decaying],
                                             peaks.tolerance_hz[seeds][decaying], max_damping)
            jr = jr[better[decaying]]
            lam[better], f_std[better], z_std[better] = refit.eigenvalues[jr], refit.frequency_std_hz[jr], \
                refit.damping_std[jr]
            amps[:, :, better] = refit.amplitudes[first][:, :, jr]
    fn = np.abs(lam) / (2 * np.pi)
    ok = _mode_of_peak(conv, lam, z_std, peaks.frequency_hz[seeds], peaks.tolerance_hz[seeds], max_damping)
    taken = list(np.abs(held) / (2 * np.pi))
    apart = peaks.tolerance_hz[seeds]
    keep = []
    for k in np.argsort(-peaks.height_db[seeds], kind="stable"):     # the highest peak first: one mode per peak
        if ok[k] and all(abs(fn[k] - g) > min(freq_tol * g, apart[k]) for g in taken):
            keep.append(k)
            taken.append(fn[k])
    keep = np.array(sorted(keep, key=lambda k: fn[k]), int)
    if keep.size == 0:
        return empty
    return SeededModes(lam[keep], f_std[keep], z_std[keep], amps[:, :, keep], peaks.frequency_hz[seeds][keep],
                       peaks.frequency_hz[seeds])
