"""A component inside a mode's band that no mode of the model holds: found by a model-order test on the band's lines,
so that the mode's band fit does not read it as part of the mode.

The band refinement (:mod:`~physics.identification.band_refine`) fits each mode in its band of the decays'
transforms with a smooth background (a level and a slope). A narrow component a few half-widths from the mode (a
weak mode of the structure, or a second component of a mode that is not one damped exponential), which no pole of
the model holds because it makes no peak of its own (a shoulder on the mode's flank: neither a clear peak of the
spectrum nor a stable pole of the stabilisation diagram), is no smooth background: the mode's pole moves towards
it. On the pyFRF hammer hits' 5969-Hz mode a component at 5983.5 Hz (0.04 % damped, 11 % of the mode's amplitude)
moves the one-pole band fit 0.73 Hz up (5970.24 against 5969.51 Hz with the component modelled,
``experiments/benches/bench_bias.py``).

The test (:func:`band_neighbour`): the mode's pole alone, its amplitudes and the band's background projected out
(every decay and channel its own), on the band's lines of each decay (the modes held fixed subtracted by their
closed-form transforms, :func:`~physics.identification.band_refine.modes_on_lines`); then a damped exponential
started at the largest line of that fit's residual further than
:data:`~physics.identification.band_refine.RESOLVED_LINES` lines from the mode, both poles refitted
(``scipy.optimize.least_squares``). The neighbour is kept when the fit converges inside the band, it is resolved
from the mode (further apart than their half-power half-widths summed and than ``RESOLVED_LINES`` lines, as
:func:`~physics.identification.band_refine.refine_in_bands` resolves two poles), it is a peak, not background
(half-power half-width at most :data:`~physics.identification.amplitude_frequency.MAX_NEIGHBOUR_WIDTH` of the band's
half-width), it takes at least :data:`~physics.identification.amplitude_frequency.MIN_RESIDUAL_DROP` of the band's
residual energy and it lowers the Bayesian information criterion of the band's values: the rule
:func:`~physics.identification.amplitude_frequency.backbone_with_neighbours` keeps a backbone's neighbour by, for a
linear decay.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.identification.band_refine import (RESOLVED_LINES, RESOLVED_WIDTHS, BandFit, band_data, modes_on_lines,
                                                refine_in_bands)

__all__ = ["BandNeighbour", "NeighbourRefit", "band_neighbour", "refine_with_neighbours"]


@dataclass(frozen=True)
class BandNeighbour:
    """The model-order test of one mode's band (see the module docstring).

    Attributes
    ----------
    eigenvalue : complex
        The neighbour's pole (rad/s), NaN when none is kept.
    mode_eigenvalue : complex
        The mode's pole fitted beside it (NaN when none is kept).
    residual_drop : float
        Share of the band's residual energy the neighbour takes (NaN: no trial fit).
    kept : bool
    """

    eigenvalue: complex
    mode_eigenvalue: complex
    residual_drop: float
    kept: bool


def _lines(decays, fs, band_hz, fixed):
    """Each decay's band lines less the fixed modes: a list of (w_k, Y (n_ch, L), n, x (L,), f_k (L,) Hz), decays
    with too few lines left out."""
    spectra = [np.fft.rfft(y, axis=1) for y in decays]
    centre, half = 0.5 * (band_hz[0] + band_hz[1]), 0.5 * (band_hz[1] - band_hz[0])
    out = []
    for j, d in enumerate(band_data(spectra, [y.shape[1] for y in decays], fs, band_hz)):
        if d is None:
            continue
        k, w, y, n = d
        if fixed is not None and np.size(fixed[0]):
            y = y - modes_on_lines(w, n, fs, fixed[0], fixed[1][j]) / np.sqrt(n)
        out.append((w, y, n, (k * fs / n - centre) / half, k * fs / n))
    return out


def _residuals(p, lines, fs):
    """The band's residual after projecting out the poles ``p`` ((sigma, omega) pairs, flat) with their amplitudes
    and a level and slope per decay and channel: real-stacked, all decays and channels concatenated."""
    lam = -p[0::2] + 1j * p[1::2]
    out = []
    for w, y, n, x, _ in lines:
        z = np.exp(lam / fs)[None, :]
        g = (1 - z ** n) / (1 - z * w[:, None]) / np.sqrt(n)
        gc = (1 - np.conj(z) ** n) / (1 - np.conj(z) * w[:, None]) / np.sqrt(n)
        basis = np.concatenate([g + gc, 1j * (g - gc), np.ones((w.size, 1)), x[:, None]], axis=1)
        basis = np.concatenate([basis, 1j * basis[:, -2:]], axis=1)
        b = np.vstack([basis.real, basis.imag])
        rhs = np.vstack([y.real.T, y.imag.T])
        coef = np.linalg.lstsq(b, rhs, rcond=None)[0]
        out.append((rhs - b @ coef).ravel())
    return np.concatenate(out)


def _bic(rss, m, n_params):
    return m * np.log(max(rss, np.finfo(float).tiny) / m) + n_params * np.log(m)


def band_neighbour(decays, sampling_frequency_hz, eigenvalue, band_hz, fixed=None) -> BandNeighbour:
    """The model-order test for one neighbour of a mode in its band (module docstring).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays, each from its own start, mean removed (as :func:`refine_in_bands` takes them).
    sampling_frequency_hz : float
    eigenvalue : complex
        The mode's band-refined pole ``-sigma + i omega`` (rad/s).
    band_hz : (float, float)
        The mode's band.
    fixed : (ndarray, ndarray), optional
        The other modes' poles (m_f,) and amplitudes (n_decays, n_channels, m_f), subtracted.

    Returns
    -------
    BandNeighbour
    """
    from scipy.optimize import least_squares  # scipy.optimize: about 1 s to import, only free-decay identification
    from physics.identification.amplitude_frequency import MAX_NEIGHBOUR_WIDTH, MIN_RESIDUAL_DROP  # scipy: backbone

    fs = float(sampling_frequency_hz)
    decays = [np.asarray(y, dtype=np.float64) for y in decays]
    none = BandNeighbour(complex(np.nan, np.nan), complex(np.nan, np.nan), np.nan, False)
    lines = _lines(decays, fs, band_hz, fixed)
    if not lines or not np.all(np.isfinite(band_hz)):
        return none
    lam = complex(eigenvalue)
    lo1, hi1 = np.array([0.0, 2 * np.pi * band_hz[0]]), np.array([np.inf, 2 * np.pi * band_hz[1]])
    try:                                                # the mode alone, refitted on these lines
        alone = least_squares(_residuals, np.clip([-lam.real, lam.imag], lo1 + 1e-9, hi1 - 1e-9),
                              bounds=(lo1, hi1), args=(lines, fs), x_scale="jac")
    except (np.linalg.LinAlgError, ValueError):
        return none
    one, r1 = alone.x, alone.fun
    rss1 = float(r1 @ r1)
    longest = max(lines, key=lambda d: d[2])
    line_hz = fs / longest[2]
    far = np.abs(longest[4] - one[1] / (2 * np.pi)) > RESOLVED_LINES * line_hz
    if not np.any(far):
        return none
    seg = _residuals(one, [longest], fs).reshape(2, longest[0].size, -1)     # (re/im, L, n_ch)
    power = np.sum(seg ** 2, axis=(0, 2))
    seed_hz = longest[4][np.argmax(np.where(far, power, -1.0))]
    start = np.concatenate([one, [2 * np.pi * line_hz, 2 * np.pi * seed_hz]])
    lo, hi = np.concatenate([lo1, lo1]), np.concatenate([hi1, hi1])
    try:
        fit = least_squares(_residuals, np.clip(start, lo + 1e-9, hi - 1e-9), bounds=(lo, hi),
                            args=(lines, fs), x_scale="jac")
    except (np.linalg.LinAlgError, ValueError):
        return none
    rss2 = float(fit.fun @ fit.fun)
    drop = 1 - rss2 / max(rss1, np.finfo(float).tiny)
    s1, w1, s2, w2 = fit.x
    f1, f2, b1, b2 = w1 / (2 * np.pi), w2 / (2 * np.pi), s1 / (2 * np.pi), s2 / (2 * np.pi)
    n_ch = decays[0].shape[0]
    m = r1.size
    per_pole = 2 + 2 * n_ch * len(lines)
    apart = abs(f2 - f1)
    inside = band_hz[0] < f2 < band_hz[1] and band_hz[0] < f1 < band_hz[1]
    kept = bool(fit.success and s2 > 0 and s1 > 0 and inside
                and apart > RESOLVED_LINES * line_hz and apart > RESOLVED_WIDTHS * (b1 + b2)
                and b2 <= MAX_NEIGHBOUR_WIDTH * 0.5 * (band_hz[1] - band_hz[0])
                and drop >= MIN_RESIDUAL_DROP
                and _bic(rss2, m, 2 * per_pole) < _bic(rss1, m, per_pole))
    return BandNeighbour(complex(-s2, w2), complex(-s1, w1), float(drop), kept)


@dataclass(frozen=True)
class NeighbourRefit:
    """Modes refitted beside the neighbours their bands keep (:func:`refine_with_neighbours`).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
    amplitudes : ndarray, complex, shape (n_decays, n_channels, n_modes)
    neighbours_hz : ndarray, shape (n_modes,)
        The natural frequency of each mode's neighbour (NaN: none kept, the mode as given).
    """

    eigenvalues: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    amplitudes: np.ndarray
    neighbours_hz: np.ndarray


def refine_with_neighbours(decays, sampling_frequency_hz, bands: BandFit, tested) -> NeighbourRefit:
    """Each tested mode of a band refinement with the neighbour its band keeps (:func:`band_neighbour`, the other
    usable modes subtracted), refitted beside it by :func:`~physics.identification.band_refine.refine_in_bands`;
    the modes whose band keeps none, or whose refit does not converge with both poles resolved, as given.

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays ``bands`` was fitted to.
    sampling_frequency_hz : float
    bands : BandFit
    tested : ndarray of bool, shape (n_modes,)
        The modes to test (converged, their amplitudes valid over the decays); the others are neither tested nor
        subtracted.

    Returns
    -------
    NeighbourRefit
    """
    fs = float(sampling_frequency_hz)
    lam = np.array(bands.eigenvalues, complex)
    f_std, z_std = np.array(bands.frequency_std_hz, float), np.array(bands.damping_std, float)
    amps = np.array(bands.amplitudes, complex)
    tested = np.asarray(tested, bool)
    near = np.full(lam.size, np.nan)
    for j in np.flatnonzero(tested):                   # one model-order test per mode, each in its own band
        others = np.flatnonzero(tested & (np.arange(lam.size) != j))
        fixed = (lam[others], amps[:, :, others])
        test = band_neighbour(decays, fs, lam[j], bands.bands_hz[j], fixed)
        if not test.kept:
            continue
        refit = refine_in_bands(decays, fs, [test.mode_eigenvalue, test.eigenvalue], fixed=fixed)
        if not (np.all(refit.converged) and np.all(refit.merged_into < 0)):
            continue
        lam[j], f_std[j], z_std[j] = refit.eigenvalues[0], refit.frequency_std_hz[0], refit.damping_std[0]
        amps[:, :, j] = refit.amplitudes[:, :, 0]
        near[j] = refit.natural_frequencies_hz[1]
    return NeighbourRefit(lam, f_std, z_std, amps, near)
