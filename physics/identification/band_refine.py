"""Narrow-band refinement of free-decay poles: each mode fitted in its own band of the decays' discrete Fourier
transform, by the closed-form transform of truncated damped exponentials and a smooth background.

A decay ``y[n] = Re(a z^n)``, ``n = 0 .. N-1``, ``z = exp(lambda / fs)``, ``lambda = -sigma + i omega`` (rad/s),
has the discrete Fourier transform (lines ``k``, ``w_k = exp(-2 pi i k / N)``, ``w_k^N = 1``)

    Y_k = c G(z, k) + conj(c) G(conj(z), k),   G(z, k) = (1 - z^N) / (1 - z w_k),   c = a / 2,

exact for a record of any length (the truncation and the aliasing are in ``G``). Within a band of lines around
one mode (or a group of close modes, fitted together) the decay's transform is that sum over the band's poles plus
a background: the tails of the modes outside the band, and the response during the hit (a few samples, whose
spectrum is smooth), both smooth across a band narrow beside their distance; it is modelled by a complex
polynomial of order :data:`BACKGROUND_ORDER` in frequency. The amplitudes ``c`` of every decay and channel and
the background enter linearly and are projected out (variable projection); the poles are refined by
Levenberg-Marquardt steps (:func:`~physics.identification.damped_sinusoids.levenberg_marquardt`).

A band spans :data:`BAND_WIDTHS` half-power half-widths ``sigma / (2 pi)`` of its mode either side, and at least
:data:`BAND_LINES` lines ``1 / T`` of the longest decay (a lightly damped mode's peak is the truncation's, ``1 / T``
wide). Modes whose bands, grown by :data:`MERGE_FACTOR`, overlap are one group fitted in the union of their bands: a
neighbour that close is no smooth background. A chain of such pairs is one group: the first sweep subtracts no other
group's modes (their amplitudes are not known yet), so a close neighbour left out of a group would be left to its
background (:func:`mode_bands` with ``chains=False`` groups only modes every two of which are close, as the FRF
refinement does, which subtracts every other pole's terms before each sweep). The bands are swept :data:`SWEEPS`
times: from the second sweep on, each band is that of the refined pole (its half-power width, not the starting
pole's), and its data are less the closed-form transforms of the modes the other bands fitted, so the background
takes only what no band models (modes no model holds, the hit). From the second sweep on, a lightly damped mode
fitted alone (its band set by :data:`BAND_LINES`: six half-power half-widths are fewer lines) is also fitted in
bands twice, four times ... as wide, up to :data:`WIDE_LINES` lines and half the distance to the nearest other pole
(:func:`_wider_bands`): the level and slope take a share of the information the band holds about the pole, the
larger the narrower the band beside the peak (+-8 lines: 1.2-1.3x the Cramer-Rao bound of a decay that lasts the
record; +-32 lines: 1.0-1.1x). A wider band is kept while its fit's residual is white noise's size
(:func:`_wider_fits_as_well`): its mean square no larger than the narrower band's fit's, and the same on its added
lines as on the narrower band's, to the 1st and 99th percentiles of the F distribution; a component no pole holds
beside the band, or within it (a peak that is no one damped exponential: a component the record does not resolve, a
mode whose frequency moves with its amplitude), leaves a misfit and keeps the narrower band. Modes held fixed
(``fixed``: poles and amplitudes known, e.g. a model's modes while a further mode is refined beside them) are
subtracted, by their closed-form transforms, from every decay's transform before any band is fitted, and are not
refined: only the bands of the modes given are fitted (:mod:`physics.identification.band_amplitudes` gives the
amplitudes of fixed poles).

Two poles of one band closer than their half-power half-widths summed and than the main lobe of the longest
decay's transform (:data:`RESOLVED_LINES` lines), or closer than the record's resolution whatever their widths
(:data:`RESOLUTION_LINES` line ``1 / T`` of the longest decay: two lightly damped components that near are one
peak of the record's transform), are one peak: its split between two poles (a mode whose frequency moves as its
amplitude falls, components the decays do not resolve) changes from decay to decay with the noise and moves each
pole by a fraction of the peak's width, where the peak itself moves far less. After the first sweep the weaker of such
a pair (energy over the decays and channels) is merged into the stronger (:attr:`BandFit.merged`), which the second
sweep fits alone over the peak: one equivalent pole; a sweep that leaves such a pair (the refits move the poles) is
followed by another, until none is left.

White noise in time is white over the lines of each decay's transform (variance ``N s^2`` per line, real and
imaginary parts independent): each decay's lines are weighted by ``1 / sqrt(N)``, each channel by the inverse of
its residual's standard deviation in the bands, and ``s^2 (J^T J)^-1`` of the projected Jacobian is the
covariance of the poles, the amplitudes and background unknown. Only the lines near a mode inform it; the rest of
the record's spectrum (other modes, unmodelled ones, the hit) does not enter its fit. Each pole's amplitudes against
their own covariance (the pole held, the other columns refitted: the increase of the band's squared residual were the
pole left out, over the residual's variance) is its :attr:`BandFit.amplitude_chi2`: two degrees of freedom per decay
and channel for a pole on white noise alone at a given pole, the likeliest pole of a band some more (a pole started
beside a 67-Hz decay where the record holds noise alone, one decay and channel, 600 fits: median 5-7, 99th
percentile 14-29, largest 52, a pole grown to 7.6 % damping whose band reached the decay's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.damped_sinusoids import levenberg_marquardt, pole_statistics

__all__ = ["BACKGROUND_ORDER", "BAND_LINES", "BAND_WIDTHS", "MERGE_FACTOR", "RESOLUTION_LINES", "RESOLVED_LINES",
           "RESOLVED_WIDTHS", "SWEEPS", "WIDE_LINES", "BandFit", "band_data", "mode_bands",
           "decay_spectra", "mode_energies", "modes_on_lines", "projected_band", "refine_in_bands"]

#: A mode's band spans this many of its half-power half-widths either side of it ...
BAND_WIDTHS = 6.0
#: ... and at least this many lines (``1 / T`` of the longest decay) either side.
BAND_LINES = 8
#: Modes whose bands, each grown by this factor about its mode, overlap are fitted together.
MERGE_FACTOR = 2.0
#: A lightly damped mode fitted alone in its band (from the second sweep on) is also fitted in bands twice, four
#: times ... as wide, up to this many lines ``1 / T`` of the longest decay either side and half the distance to the
#: nearest other pole (:func:`_wider_bands`); the widest whose residual is white noise's size is kept
#: (:func:`_wider_fits_as_well`).
WIDE_LINES = 32
#: Order of the complex polynomial (in frequency across the band) that models the background: a level and a slope,
#: the first terms of a far mode's tail and of the hit's smooth spectrum.
BACKGROUND_ORDER = 1
#: Sweeps over the bands: from the second on, each band's data less the transforms of the modes the other bands
#: fitted (their closed form, exact), so the background takes only what no band models.
SWEEPS = 2
#: Two poles of a band are resolved when they lie further apart than their half-power half-widths summed (times
#: :data:`RESOLVED_WIDTHS`) or than the main lobe of the longest decay's transform, :data:`RESOLVED_LINES` lines
#: ``1 / T``; closer than both, they are one peak, whose split between two poles changes from decay to decay with
#: the noise and the peak's departure from one exponential decay: the weaker is merged into the stronger, which is
#: then fitted alone.
RESOLVED_WIDTHS, RESOLVED_LINES = 1.0, 2.0
#: Two poles of a band closer than this many lines ``1 / T`` of the longest decay are one peak whatever their
#: damping (the record's resolution: lightly damped components that near make one peak of its transform, and their
#: split follows the noise); the weaker is merged into the stronger, which then stands for the whole peak.
RESOLUTION_LINES = 1.0


@dataclass(frozen=True)
class BandFit:
    """Poles refined in their bands (see the module docstring).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s), in the order given.
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        One sigma from each group's covariance.
    amplitudes : ndarray, complex, shape (n_decays, n_channels, n_modes)
        ``a`` of ``Re(a z^n)`` of each decay, channel and mode (the channel's units) at the decay's first sample.
    bands_hz : ndarray, shape (n_modes, 2)
        The band each mode was fitted in (its group's, or a lightly damped lone mode's wider band where kept).
    group : ndarray of int, shape (n_modes,)
        The group each mode was fitted with.
    converged : ndarray of bool, shape (n_modes,)
        False where the group's fit failed (singular, or a pole left its band or lost its damping): the mode keeps
        its starting pole, with NaN standard deviations.
    n_lines : int
        Lines fitted, over every decay and group (per channel).
    merged_into : ndarray of int, shape (n_modes,)
        For a pole unresolved from a stronger one of its band (:data:`RESOLVED_WIDTHS`, :data:`RESOLVED_LINES`,
        :data:`RESOLUTION_LINES`: one
        peak, which the stronger pole, fitted alone, stands for), the stronger pole's index; -1 where not merged. A
        pole merged into one that is merged later stands for the one that one was merged into (followed to the
        end). A merged pole is not converged; its band is NaN and its group -1 (its eigenvalue is the one it was
        merged at).
    merged_with_hz : ndarray, shape (n_modes,)
        The natural frequency (Hz) of the stronger pole when each pole was merged into it (NaN where not merged).
    amplitude_chi2 : ndarray, shape (n_modes,)
        Each mode's amplitudes (every decay's and channel's) against their own covariance, the pole held: the
        increase of its band fit's squared residual were its columns left out (the others refitted), over the
        residual's variance (:func:`_amplitude_chi2`); a chi-square variable of :attr:`amplitude_dof` degrees of
        freedom for a pole on white noise alone (at a given pole; the fit's pole is the likeliest of its band). NaN
        where not converged.
    amplitude_dof : ndarray of int, shape (n_modes,)
        Two per decay fitted and channel (the amplitude's real and imaginary parts); 0 where not converged.
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    amplitudes: np.ndarray
    bands_hz: np.ndarray
    group: np.ndarray
    converged: np.ndarray
    n_lines: int
    merged_into: np.ndarray
    merged_with_hz: np.ndarray
    amplitude_chi2: np.ndarray
    amplitude_dof: np.ndarray

    @property
    def merged(self) -> np.ndarray:
        """Shape (n_modes,) of bool: the poles merged into a stronger one (:attr:`merged_into`)."""
        return self.merged_into >= 0


def mode_bands(eigenvalues, longest_s, nyquist_hz, chains=True):
    """Each pole's band and group (see the module docstring).

    Two modes are close where their bands, grown by :data:`MERGE_FACTOR` about their modes, overlap.

    Parameters
    ----------
    eigenvalues : array_like, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s).
    longest_s : float
        Length of the longest decay (s).
    nyquist_hz : float
    chains : bool
        True: a chain of close pairs is one group (single linkage). False: a group holds only modes every two of
        which are close, groups joined nearest first (complete linkage: of neighbouring groups, those whose farthest
        pair is the nearest, relative to the pair's half-widths summed, while that pair is close); a mode close to
        two that are not close to each other (a weak mode between two strong ones) joins the nearer, and no group
        stretches its band, and the one background it fits, over modes that are no neighbours.

    Returns
    -------
    bands_hz : ndarray, shape (n_modes, 2)
        The group's band of each mode (Hz), within ``(0, nyquist_hz)``.
    group : ndarray of int, shape (n_modes,)
    """
    lam = np.asarray(eigenvalues, complex)
    f = lam.imag / (2 * np.pi)
    half = np.maximum(BAND_WIDTHS * np.abs(lam.real) / (2 * np.pi), BAND_LINES / longest_s)
    order = np.argsort(f, kind="stable")
    fs_, hs = f[order], half[order]
    if chains:
        apart = fs_[1:] - MERGE_FACTOR * hs[1:] > fs_[:-1] + MERGE_FACTOR * hs[:-1]
        g_sorted = np.concatenate([[0], np.cumsum(apart)])
    else:
        g_sorted = _complete_groups(fs_, hs)
    group = np.empty(f.size, int)
    group[order] = g_sorted
    lo = np.array([np.min((f - half)[group == g]) for g in range(g_sorted[-1] + 1 if f.size else 0)])
    hi = np.array([np.max((f + half)[group == g]) for g in range(g_sorted[-1] + 1 if f.size else 0)])
    bands = np.stack([np.clip(lo, 0.0, nyquist_hz), np.clip(hi, 0.0, nyquist_hz)], axis=1)
    return bands[group] if f.size else np.zeros((0, 2)), group


def _complete_groups(f_hz, half_hz):
    """Groups (shape (m,) of int, 0, 1, ... in order) of poles sorted by frequency ``f_hz`` (Hz) with band
    half-widths ``half_hz`` (Hz): runs of neighbours every two of which are close, joined nearest first
    (:func:`mode_bands` with ``chains=False``)."""
    m = f_hz.size
    reach = np.abs(f_hz[:, None] - f_hz[None, :]) / (half_hz[:, None] + half_hz[None, :])   # close: <= MERGE_FACTOR
    starts = list(range(m))                             # first pole of each run
    while len(starts) > 1:
        ends = starts[1:] + [m]
        link = [reach[starts[i]:ends[i], starts[i + 1]:ends[i + 1]].max() for i in range(len(starts) - 1)]
        i = int(np.argmin(link))
        if link[i] > MERGE_FACTOR:
            break
        del starts[i + 1]
    first = np.zeros(m, int)
    first[starts[1:]] = 1
    return np.cumsum(first)


def band_data(spectra, lengths, fs, band_hz):
    """Each decay's transform ``Y`` (``spectra``: its rFFT, (n_ch, N // 2 + 1); ``lengths``: its samples ``N`` at
    ``fs`` Hz) on the lines of ``band_hz`` (Hz): a list of (lines ``k``, ``w_k = exp(-2 pi i k / N)``, ``Y / sqrt(N)``
    (n_ch, L), ``N``), None for a decay with fewer than :data:`BAND_LINES` lines in the band."""
    out = []
    for Y, n in zip(spectra, lengths):
        k = np.arange(max(1, int(np.ceil(band_hz[0] * n / fs))), min((n - 1) // 2, int(band_hz[1] * n / fs)) + 1)
        out.append((k, np.exp(-2j * np.pi * k / n), Y[:, k] / np.sqrt(n), n) if k.size >= BAND_LINES else None)
    return out


def modes_on_lines(w, n, fs, eigenvalues, amplitudes):
    """The transform ``(a/2) G(z) + conj(a/2) G(conj z)`` of modes ``Re(a z^t)`` of one decay of ``n`` samples on
    lines ``w_k``, summed over the modes: shape (n_channels, L); ``amplitudes`` shape (n_channels, m)."""
    z = np.exp(np.asarray(eigenvalues, complex) / fs)[None, :]
    w = w[:, None]
    g, gc = (1.0 - z ** n) / (1.0 - z * w), (1.0 - np.conj(z) ** n) / (1.0 - np.conj(z) * w)
    return (0.5 * amplitudes) @ g.T + (0.5 * np.conj(amplitudes)) @ gc.T


def _columns(w, n, sigma, omega, fs, centre_hz, half_hz, k, order):
    """Real-stacked basis (2L, 2m + 2(order+1)) and its pole derivatives (2L, 2m, 2): for each mode the columns of
    ``Re c`` and ``Im c``, then the background's; derivatives by ``(sigma_j, omega_j)`` of the mode's two columns."""
    lam = -sigma + 1j * omega
    z, zc = np.exp(lam / fs), np.exp(np.conj(lam) / fs)
    w = w[:, None]

    def g_and_dg(z):
        zn = z ** n
        den = 1.0 - z * w
        g = (1.0 - zn) / den
        dg_dz = (-n * zn / z * den + (1.0 - zn) * w) / den ** 2
        return g, dg_dz * z / fs                       # d G / d lambda

    g, dg = g_and_dg(z)
    gc, dgc = g_and_dg(zc)
    a, b = g + gc, 1j * (g - gc)                        # columns of Re c and Im c
    da_ds, da_dw = -(dg + dgc), 1j * (dg - dgc)
    db_ds, db_dw = 1j * (-dg + dgc), -(dg + dgc)
    x = ((k * fs / n) - centre_hz) / half_hz
    powers = x[:, None] ** np.arange(order + 1)
    cols = np.concatenate([np.stack([a, b], axis=2).reshape(a.shape[0], -1), powers, 1j * powers], axis=1)
    d = np.stack([np.stack([da_ds, db_ds], axis=2), np.stack([da_dw, db_dw], axis=2)], axis=1)   # (L, 2, m, 2)
    real = np.concatenate([cols.real, cols.imag], axis=0)
    d_real = np.concatenate([d.real, d.imag], axis=0)    # (2L, 2 (sigma/omega), m, 2 (column))
    return real, d_real


def projected_band(data, fs, sigma, omega, weights, band_hz, order):
    """Residuals, coefficients and Kaufman Jacobian blocks of every decay's band (as
    :func:`~physics.identification.damped_sinusoids.levenberg_marquardt` takes them)."""
    m = sigma.size
    centre, half = 0.5 * (band_hz[0] + band_hz[1]), max(0.5 * (band_hz[1] - band_hz[0]), np.finfo(float).tiny)
    res, coef, jac = [], [], []
    for item in data:
        if item is None:
            continue
        k, w, Y, n = item
        Phi, dPhi = _columns(w, n, sigma, omega, fs, centre, half, k, order)
        Yr = np.concatenate([Y.T.real, Y.T.imag], axis=0) * weights[None, :]
        norm = np.maximum(np.linalg.norm(Phi, axis=0), np.finfo(float).tiny)
        G_inv = np.linalg.pinv((Phi.T @ Phi) / np.outer(norm, norm), hermitian=True) / np.outer(norm, norm)
        C = G_inv @ (Phi.T @ Yr)                                            # (p, n_ch)
        R = Yr - Phi @ C
        Cm = C[:2 * m].reshape(m, 2, -1)                                     # (m, 2 columns, n_ch)
        D = np.einsum("eqmc,mch->eqmh", dPhi, Cm).reshape(Phi.shape[0], 2 * m, -1)   # (2L, 2m, n_ch)
        D = D - np.einsum("ek,kph->eph", Phi, np.einsum("kl,el,eph->kph", G_inv, Phi, D, optimize=True))
        res.append(R)
        coef.append(C)
        jac.append(D.transpose(0, 2, 1).reshape(-1, 2 * m))
    return res, coef, jac


def _fit_band(data, fs, band, lam, n_ch, order):
    """The variable-projection fit of poles ``lam`` in a band: ``(sigma, omega, cov, coef, weights, res)``, or None
    where the band holds too few lines or the fit fails (singular, or a pole left the band or lost its damping);
    ``res``: the weighted residual of each decay holding the band, as :func:`projected_band` gives it."""
    used = [d for d in data if d is not None]
    n_values = n_ch * sum(2 * d[0].size for d in used)
    n_params = 2 * lam.size + len(used) * n_ch * (2 * lam.size + 2 * (order + 1))
    if n_values <= 2 * n_params:
        return None

    def project(sigma, omega, weights):
        return projected_band(data, fs, sigma, omega, weights, band, order)

    try:
        sigma, omega, cov, res, coef, weights, _ = levenberg_marquardt(
            project, -lam.real, lam.imag, n_ch, n_values, n_params, decaying=True)
    except ConvergenceError:
        return None
    f = omega / (2 * np.pi)
    if np.any(sigma <= 0) or np.any(f < band[0]) or np.any(f > band[1]):
        return None
    return sigma, omega, cov, coef, weights, res


def _wider_bands(pole, band_hz, others, longest_s, nyquist_hz):
    """The wider bands a lone ``pole`` (rad/s) is also fitted in, narrowest first: its band ``band_hz`` (Hz) twice,
    four times ... as wide about the pole, up to :data:`WIDE_LINES` lines of the longest decay (``longest_s``) and
    half the distance to the nearest of ``others`` (poles, rad/s, shape (m,)), within ``(0, nyquist_hz)``; none where
    that reach is within a quarter of the band's half-width. A list of arrays of shape (2,).

    Only a lightly damped pole is widened: one whose six half-power half-widths (:data:`BAND_WIDTHS`) are fewer
    than :data:`BAND_LINES` lines (none otherwise)."""
    f = pole.imag / (2 * np.pi)
    if BAND_WIDTHS * abs(pole.real) / (2 * np.pi) >= BAND_LINES / longest_s:
        return []
    half = max(f - band_hz[0], band_hz[1] - f)
    gap = np.abs(np.asarray(others, complex).imag / (2 * np.pi) - f)
    reach = min(WIDE_LINES / longest_s, 0.5 * gap.min() if gap.size else np.inf)
    halves = [h for h in half * 2.0 ** np.arange(1, 8) if h < reach] + [reach]
    return [np.clip([f - h, f + h], 0.0, nyquist_hz) for h in halves if h > 1.25 * half]


@dataclass(frozen=True)
class _BandTrial:
    """One band fit of one pole (:func:`_fit_band`): its pole, covariance, coefficients, channel weights and
    residual (each used decay's weighted residual, (2 L, n_channels), real parts of its ``L`` lines over imaginary),
    the decays used (indices), their lines ``k`` and samples ``n``, and the background's order."""

    sigma: np.ndarray
    omega: np.ndarray
    cov: np.ndarray
    coef: list
    weights: np.ndarray
    res: list
    used: list
    lines: list
    lengths: list
    order: int

    @property
    def unknowns(self) -> float:
        """Unknowns per channel: the pole's two (shared by the channels), each decay's amplitudes and background."""
        return 2.0 / self.weights.size + len(self.used) * (2 + 2 * (self.order + 1))

    def mean_squares(self) -> np.ndarray:
        """The residual's mean square per value and channel (the channels' units squared), shape (n_channels,)."""
        ss = sum(np.sum(r ** 2, axis=0) for r in self.res) / self.weights ** 2
        return ss / (sum(2 * k.size for k in self.lines) - self.unknowns)

    def sums_of_squares(self, band_hz, fs):
        """The residual's sum of squares per channel (the channels' units) on the lines inside ``band_hz`` (Hz) and
        outside, and the number of values (per channel) of each: ``(ss_in (n_ch,), v_in, ss_out (n_ch,), v_out)``."""
        inside = [np.tile((k * fs / n >= band_hz[0]) & (k * fs / n <= band_hz[1]), 2)
                  for k, n in zip(self.lines, self.lengths)]
        ss_in = sum(np.sum(r[i] ** 2, axis=0) for r, i in zip(self.res, inside)) / self.weights ** 2
        ss_out = sum(np.sum(r[~i] ** 2, axis=0) for r, i in zip(self.res, inside)) / self.weights ** 2
        return ss_in, sum(int(i.sum()) for i in inside), ss_out, sum(int((~i).sum()) for i in inside)


def _amplitude_chi2(trial: _BandTrial, band_hz, fs) -> np.ndarray:
    """Each pole's amplitudes against their covariance, shape (m,): over the decays the band fit ``trial`` used
    (in ``band_hz``, Hz) and the channels, ``c^T V^-1 c / s^2``, ``c`` the real and imaginary parts of the pole's
    amplitude (its coefficients, unweighted), ``V`` their block of ``(Phi^T Phi)^-1`` (the pole's and the other
    columns of the band's basis at the fitted poles) and ``s^2`` the channel's residual mean square per value
    (:meth:`_BandTrial.mean_squares`, the channels' units squared): the increase of the squared residual were the
    pole's two columns left out and the rest refitted (the poles held), in noise variances."""
    sigma, omega, weights, mean_squares = trial.sigma, trial.omega, trial.weights, trial.mean_squares()
    m = sigma.size
    centre, half = 0.5 * (band_hz[0] + band_hz[1]), max(0.5 * (band_hz[1] - band_hz[0]), np.finfo(float).tiny)
    out = np.zeros(m)
    for k, n, C in zip(trial.lines, trial.lengths, trial.coef):
        Phi, _ = _columns(np.exp(-2j * np.pi * k / n), n, sigma, omega, fs, centre, half, k, trial.order)
        norm = np.maximum(np.linalg.norm(Phi, axis=0), np.finfo(float).tiny)
        G_inv = np.linalg.pinv((Phi.T @ Phi) / np.outer(norm, norm), hermitian=True) / np.outer(norm, norm)
        c = (C[:2 * m] / weights[None, :]).reshape(m, 2, -1)              # (m, 2, n_ch), the channels' units
        V = G_inv[:2 * m, :2 * m].reshape(m, 2, m, 2)[np.arange(m), :, np.arange(m), :]      # (m, 2, 2)
        out += np.sum(np.einsum("mac,mac->mc", c, np.linalg.solve(V, c)) / mean_squares[None, :], axis=1)
    return out


def _wider_fits_as_well(narrow: _BandTrial, wide: _BandTrial, band_hz, fs) -> bool:
    """Whether the fit in a wider band (``wide``) leaves a residual of white noise's size beside the fit in the band
    it holds (``narrow``, in ``band_hz``, Hz): its mean square per value no larger than the narrower fit's, and the
    same on its lines outside ``band_hz`` as on those inside, each to the 1st and 99th percentiles of the F
    distribution of the ratio (white noise: one variance on every line). A misfit outside (a component no pole
    holds) or inside (a mode's peak no damped exponential follows, a component beside it) keeps the narrower band.
    The pole and amplitudes take their unknowns from the lines inside, the background from all in proportion."""
    from scipy import stats  # scipy: only output-only identification

    _, v_n, _, _ = narrow.sums_of_squares(band_hz, fs)
    w_in, v_in, w_out, v_out = wide.sums_of_squares(band_hz, fs)
    n_ch = w_in.size
    background = len(wide.used) * 2 * (wide.order + 1)
    dof_n, dof_w = n_ch * (v_n - narrow.unknowns), n_ch * (v_in + v_out - wide.unknowns)
    dof_in = n_ch * (v_in - (wide.unknowns - background) - background * v_in / (v_in + v_out))
    dof_out = n_ch * v_out * (1.0 - background / (v_in + v_out))
    if min(dof_n, dof_w, dof_in, dof_out) <= 0:
        return False
    whole = np.mean(wide.mean_squares() / narrow.mean_squares())
    outside = np.mean((w_out / dof_out) / (w_in / dof_in))
    return bool(whole <= stats.f.ppf(0.99, dof_w, dof_n)
                and stats.f.ppf(0.01, dof_out, dof_in) <= outside <= stats.f.ppf(0.99, dof_out, dof_in))


def mode_energies(amplitudes, eigenvalues, lengths, fs) -> np.ndarray:
    """Each mode's energy over the decays and channels, shape (n_modes,): ``sum |a|^2 sum_t |z|^(2 t)`` of its
    amplitudes ``a`` (shape (n_decays, n_channels, n_modes), at each decay's first sample) over each decay's
    ``lengths`` samples at ``fs`` Hz, ``z = exp(eigenvalue / fs)``."""
    sigma = -np.asarray(eigenvalues, complex).real
    n = np.asarray(lengths, float)[:, None]
    return np.sum(np.abs(amplitudes) ** 2 * ((-np.expm1(-2 * sigma[None, :] * n / fs)) / -np.expm1(-2 * sigma / fs))
                  [:, None, :], axis=(0, 1))


def _unresolved(lam, amps, lengths, fs, group, converged):
    """The converged poles closer to a stronger converged pole of their group than :data:`RESOLVED_WIDTHS` times
    their half-power half-widths summed and than :data:`RESOLVED_LINES` lines of the longest decay, or than
    :data:`RESOLUTION_LINES` lines (energy: over the decays and channels): shape (n_modes,) of int, the stronger
    pole's index for each (-1: none)."""
    sigma, f = -lam.real, lam.imag / (2 * np.pi)
    energy = mode_energies(amps, lam, lengths, fs)
    out = np.full(lam.size, -1)
    line = fs / max(lengths)                            # 1 / T of the longest decay (Hz)
    for j in np.argsort(-energy, kind="stable"):
        if out[j] >= 0 or not converged[j]:
            continue
        gap = np.abs(f - f[j])
        one_peak = ((gap < RESOLVED_WIDTHS * (sigma + sigma[j]) / (2 * np.pi)) & (gap < RESOLVED_LINES * line)) \
            | (gap < RESOLUTION_LINES * line)
        close = converged & (out < 0) & (group == group[j]) & (np.arange(lam.size) != j) & one_peak \
            & (energy <= energy[j])
        out[close] = j
    return out


def decay_spectra(decays, fs, fixed):
    """Each decay's transform (all its lines), less the closed-form transforms of the ``fixed`` modes (``(eigenvalues
    (m_f,), amplitudes (n_decays, n_channels, m_f))`` or None)."""
    spectra = [np.fft.rfft(y, axis=1) for y in decays]
    if fixed is None or np.size(fixed[0]) == 0:
        return spectra
    lam_f, amps_f = np.asarray(fixed[0], complex), np.asarray(fixed[1], complex)
    if amps_f.shape != (len(decays), decays[0].shape[0], lam_f.size):
        raise ShapeError(f"fixed modes: amplitudes of shape {amps_f.shape}, expected "
                         f"{(len(decays), decays[0].shape[0], lam_f.size)} (decays, channels, modes)")
    out = []
    for Y, y, a in zip(spectra, decays, amps_f):
        n = y.shape[1]
        out.append(Y - modes_on_lines(np.exp(-2j * np.pi * np.arange(Y.shape[1]) / n), n, fs, lam_f, a))
    return out


def refine_in_bands(decays, sampling_frequency_hz, eigenvalues, background_order=BACKGROUND_ORDER,
                    fixed=None) -> BandFit:
    """Refine free-decay poles, each group of close modes in its own band of the decays' transforms (see the
    module docstring).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays, each from its own start (time 0 at its first sample), mean removed.
    sampling_frequency_hz : float
    eigenvalues : array_like, complex, shape (n_modes,)
        Starting poles ``-sigma + i omega`` (rad/s, Im > 0, Re < 0).
    background_order : int
    fixed : (ndarray, ndarray), optional
        Modes held fixed: their poles (complex, shape (m_f,), rad/s) and amplitudes (complex, shape (n_decays,
        n_channels, m_f), ``a`` of ``Re(a z^n)``, as :attr:`BandFit.amplitudes` or
        :func:`~physics.identification.band_amplitudes.band_amplitudes` give
        them). Their transforms are subtracted from every decay's; they are not refined, and only the bands of
        ``eigenvalues`` are fitted.

    Returns
    -------
    BandFit
        Of the modes of ``eigenvalues`` alone.

    Raises
    ------
    ShapeError
        ``fixed`` amplitudes of another shape than (n_decays, n_channels, m_f).
    """
    fs = float(sampling_frequency_hz)
    lam0 = np.asarray(eigenvalues, complex)
    m_all = lam0.size
    decays = [np.asarray(y, dtype=np.float64) for y in decays]
    n_ch = decays[0].shape[0]
    lengths = [y.shape[1] for y in decays]
    spectra = decay_spectra(decays, fs, fixed)
    lam_fixed = np.zeros(0, complex) if fixed is None else np.asarray(fixed[0], complex).ravel()
    bands, group = mode_bands(lam0, max(lengths) / fs, fs / 2)
    lam = lam0.copy()
    f_std, z_std = np.full(m_all, np.nan), np.full(m_all, np.nan)
    amps = np.zeros((len(decays), n_ch, m_all), complex)
    chi2, dof = np.full(m_all, np.nan), np.zeros(m_all, int)
    converged = np.zeros(m_all, bool)
    n_lines = 0
    into, with_hz = np.full(m_all, -1), np.full(m_all, np.nan)
    for sweep in range(SWEEPS + m_all):                 # past SWEEPS: while a sweep leaves an unresolved pair
        if sweep:                                       # the bands of the refined poles' half-power widths
            stronger = _unresolved(lam, amps, lengths, fs, group, converged)
            new = stronger >= 0
            if sweep >= SWEEPS and not new.any():
                break
            with_hz[new] = np.abs(lam[stronger[new]]) / (2 * np.pi)
            chain = np.flatnonzero(into >= 0)           # merged before into a pole merged now: into its stronger
            chain = chain[new[into[chain]]]
            into[chain] = stronger[into[chain]]
            into[new] = stronger[new]
            converged &= into < 0
            live = np.flatnonzero(into < 0)
            b_live, g_live = mode_bands(np.where(converged, lam, lam0)[live], max(lengths) / fs, fs / 2)
            bands, group = np.full((m_all, 2), np.nan), np.full(m_all, -1)
            bands[live], group[live] = b_live, g_live
        known = converged.copy()                        # the modes whose transform the other bands subtract
        lam_known, amps_known = lam.copy(), amps.copy()
        n_lines = 0
        for g in np.unique(group[group >= 0]):
            idx = np.flatnonzero(group == g)
            m, band = idx.size, bands[idx[0]]
            others = np.flatnonzero(known & (group != g))

            def fit_in(band, start):
                data = [None if d is None else
                        (d[0], d[1], d[2] - modes_on_lines(d[1], d[3], fs, lam_known[others],
                                                           amps_known[j][:, others]) / np.sqrt(d[3]), d[3])
                        for j, d in enumerate(band_data(spectra, lengths, fs, band))]
                fitted = _fit_band(data, fs, band, start, n_ch, background_order)
                used = [j for j, d in enumerate(data) if d is not None]
                return None if fitted is None else _BandTrial(*fitted, used, [data[j][0] for j in used],
                                                              [lengths[j] for j in used], background_order)

            best = fit_in(band, lam[idx])
            if best is None:
                continue
            if sweep and m == 1:                        # a lone mode: its wider bands, while their misfit is noise's
                alive = np.flatnonzero(into < 0)
                neighbours = np.concatenate([lam[alive[alive != idx[0]]], lam_fixed])
                for wide in _wider_bands(lam[idx[0]], band, neighbours, max(lengths) / fs, fs / 2):
                    trial = fit_in(wide, -best.sigma + 1j * best.omega)
                    if trial is None or not _wider_fits_as_well(best, trial, band, fs):
                        break
                    best, band = trial, wide
                bands[idx] = band
            sigma, omega, cov, coef, weights, used = best.sigma, best.omega, best.cov, best.coef, best.weights, \
                best.used
            n_values = n_ch * sum(2 * k.size for k in best.lines)
            _, _, f_std[idx], z_std[idx] = pole_statistics(sigma, omega, cov)
            chi2[idx], dof[idx] = _amplitude_chi2(best, band, fs), 2 * len(used) * n_ch
            lam[idx] = -sigma + 1j * omega
            converged[idx] = True
            n_lines += n_values // (2 * n_ch)
            for j, C in zip(used, coef):
                c = (C[0:2 * m:2] + 1j * C[1:2 * m:2]).T / weights[:, None]    # (n_ch, m): c = a / 2, scaled
                amps[j][:, idx] = 2 * c * np.sqrt(lengths[j])
    wn = np.abs(lam)
    return BandFit(lam, wn / (2 * np.pi), -lam.real / wn, f_std, z_std, amps, bands, group, converged, n_lines,
                   into, with_hz, np.where(converged, chi2, np.nan), np.where(converged, dof, 0))
