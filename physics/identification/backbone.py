"""The zero-amplitude frequency of a weakly nonlinear mode: one decay fitted, in the mode's band of its discrete
Fourier transform, by a damped oscillation whose frequency is linear in its envelope (its backbone).

A mode that stiffens (or softens) with amplitude decays as

    x(t) = A exp(-sigma t) cos(2 pi f0 t + 2 pi c (1 - exp(-sigma t)) / sigma + phi),

its instantaneous frequency ``f0 + c exp(-sigma t)``: ``f0 + c`` at the decay's start, ``f0`` (the backbone
extrapolated to zero amplitude) as the decay dies out; ``c = 0`` is the linear decay ``Re(a z^n)``. ``f0`` does not
depend on how hard the mode was hit; a linear fit (one damped exponential, which reads the slope of the phase
weighted by the squared envelope) reads ``f0`` plus a fraction of ``c``, so it follows each hit's strength.

The fit is that of :func:`~physics.identification.band_refine.refine_in_bands` with the damped exponential replaced
by this model: the same band (:func:`~physics.identification.band_refine.mode_bands`), the same lines of the
decay's transform weighted by ``1 / sqrt(N)``, the same background (a complex polynomial of order
``background_order`` in frequency across the band). The model's transform is that of its samples (an FFT: no closed
form). The amplitude ``A exp(i phi)`` and the background enter linearly and are projected out; ``(f0, c, sigma)``
are fitted by :func:`scipy.optimize.least_squares`, and ``s^2 (J^T J)^-1`` of the projected residual's Jacobian is
their covariance. ``c`` is significant when ``|c|`` exceeds :data:`SIGNIFICANT_SIGMAS` of its standard deviations.
Components of the band that the background cannot take (a weaker mode beside this one) can be fitted with it as
damped exponentials (``neighbours``: their poles refined too, their amplitudes projected out, their transforms the
closed form :func:`~physics.identification.band_refine.refine_in_bands` uses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from physics.errors import ConfigError, ConvergenceError, ShapeError
from physics.identification.band_refine import BACKGROUND_ORDER, band_data, mode_bands, modes_on_lines

__all__ = ["SIGNIFICANT_SIGMAS", "Backbone", "fit_backbone"]

#: ``c`` is significant (the mode's frequency moves with its amplitude) beyond this many standard deviations.
SIGNIFICANT_SIGMAS = 3.0


@dataclass(frozen=True)
class Backbone:
    """One mode's decay fitted with its frequency linear in its envelope (see the module docstring).

    Attributes
    ----------
    frequency_hz : float
        ``f0``: the frequency of oscillation at zero amplitude (Hz).
    natural_frequency_hz : float
        ``sqrt(f0^2 + (sigma / 2 pi)^2)``: the undamped natural frequency at zero amplitude (Hz), as
        :attr:`~physics.identification.band_refine.BandFit.natural_frequencies_hz` reads a pole.
    shift_hz : float
        ``c``: the frequency at the decay's start less ``f0`` (Hz; > 0 stiffening).
    decay_rate : float
        ``sigma`` (1/s).
    frequency_std_hz, shift_std_hz, decay_rate_std : float
        One sigma.
    correlation : float
        Of the estimates of ``f0`` and ``c``.
    amplitude : complex
        ``A exp(i phi)`` (the record's units).
    significant : bool
        ``|c| > SIGNIFICANT_SIGMAS * shift_std_hz``.
    band_hz : ndarray, shape (2,)
        The band fitted (Hz).
    n_lines : int
        Lines of the transform fitted.
    neighbours : ndarray, complex, shape (n_neighbours,)
        The refined poles of the neighbours fitted with the mode (rad/s).
    lines_hz : ndarray, shape (n_lines,)
        The frequencies of the lines fitted (Hz).
    residual : ndarray, complex, shape (n_lines,)
        The decay's transform on those lines less the fitted model (mode, neighbours and background), over
        ``sqrt(N)``.
    n_parameters : int
        Real parameters fitted: the nonlinear ones and the amplitudes and background projected out.
    """

    frequency_hz: float
    natural_frequency_hz: float
    shift_hz: float
    decay_rate: float
    frequency_std_hz: float
    shift_std_hz: float
    decay_rate_std: float
    correlation: float
    amplitude: complex
    significant: bool
    band_hz: np.ndarray
    n_lines: int
    neighbours: np.ndarray
    lines_hz: np.ndarray
    residual: np.ndarray
    n_parameters: int


def _basis(p, n, fs, k):
    """The transforms, on lines ``k`` and over ``sqrt(n)``, of ``exp(-sigma t) cos(theta)`` and
    ``-exp(-sigma t) sin(theta)`` (the columns of ``Re a`` and ``Im a``), ``p = (f0, c, sigma)``: shape (L, 2)."""
    f0, c, sigma = p
    t = np.arange(n) / fs
    env = np.exp(-sigma * t)
    theta = 2 * np.pi * (f0 * t - c * np.expm1(-sigma * t) / sigma)
    u = np.stack([env * np.cos(theta), -env * np.sin(theta)])
    return np.fft.rfft(u, axis=1)[:, k].T / np.sqrt(n)


def _projected(p, k, n, fs, Y, background, rows):
    """Residual (2L,) of the band's lines after projecting out the amplitudes and background, and the coefficients;
    ``p = (f0, c, sigma, sigma_1, omega_1, ...)``, the neighbours' poles after the mode's parameters."""
    lam = -p[3::2] + 1j * p[4::2]
    w = np.exp(-2j * np.pi * k / n)
    unit = np.kron(np.eye(lam.size), [1.0, 1j])                           # (m, 2 m): Re a and Im a of each pole
    near = modes_on_lines(w, n, fs, lam, unit.T).T / np.sqrt(n) if lam.size else np.zeros((k.size, 0))
    phi = np.concatenate([_basis(p[:3], n, fs, k), near, background], axis=1)
    real = np.concatenate([phi.real, phi.imag], axis=0)
    coef, *_ = np.linalg.lstsq(real, rows, rcond=None)
    return rows - real @ coef, coef


def fit_backbone(decay, sampling_frequency_hz, eigenvalue, band_hz=None, background_order=BACKGROUND_ORDER,
                 neighbours=()) -> Backbone:
    """Fit one mode's decay with its frequency linear in its envelope (see the module docstring).

    Parameters
    ----------
    decay : array_like, shape (n_samples,)
        One channel's decay, time 0 at its first sample, mean removed.
    sampling_frequency_hz : float
    eigenvalue : complex
        Starting pole ``-sigma + i omega`` (rad/s, Im > 0, Re < 0), e.g. the linear fit's.
    band_hz : (float, float), optional
        Lines fitted (Hz); default the band :func:`~physics.identification.band_refine.mode_bands` gives the pole.
    background_order : int
    neighbours : array_like, complex, shape (n_neighbours,)
        Starting poles (rad/s) of further components in the band, fitted as damped exponentials with the mode.

    Returns
    -------
    Backbone

    Raises
    ------
    ShapeError
        ``decay`` not one finite record, or the band holding too few lines for the fit.
    ConfigError
        ``eigenvalue`` not a decaying oscillation below the Nyquist frequency.
    ConvergenceError
        The least squares failing, or a singular Jacobian.
    """
    fs = float(sampling_frequency_hz)
    x = np.asarray(decay, dtype=np.float64)
    if x.ndim != 1 or x.size < 16 or not np.all(np.isfinite(x)):
        raise ShapeError(f"decay: expected one finite record of at least 16 samples, got shape {x.shape}")
    lam = complex(eigenvalue)
    if not (lam.real < 0 < lam.imag < np.pi * fs):
        raise ConfigError(f"eigenvalue: expected -sigma + i omega with sigma > 0 and 0 < omega < pi fs, got {lam}")
    near = np.atleast_1d(np.asarray(neighbours, complex))
    if near.ndim != 1 or not np.all((near.real < 0) & (near.imag > 0)):
        raise ConfigError(f"neighbours: expected poles -sigma + i omega with sigma, omega > 0, got {near}")
    n = x.size
    band = mode_bands([lam], n / fs, fs / 2)[0][0] if band_hz is None else np.asarray(band_hz, float)
    data = band_data([np.fft.rfft(x)[None]], [n], fs, band)[0]
    order = int(background_order)
    n_params = 3 + 2 + 4 * near.size + 2 * (order + 1)
    if data is None or data[0].size * 2 <= 2 * n_params:
        raise ShapeError(f"decay: band {band[0]:.4g}-{band[1]:.4g} Hz holds too few lines of a {n}-sample record")
    k, _, Y, _ = data
    centre, half = 0.5 * (band[0] + band[1]), max(0.5 * (band[1] - band[0]), np.finfo(float).tiny)
    powers = ((k * fs / n - centre) / half)[:, None] ** np.arange(order + 1)
    background = np.concatenate([powers, 1j * powers], axis=1)
    rows = np.concatenate([Y[0].real, Y[0].imag])
    p0 = np.concatenate([[lam.imag / (2 * np.pi), 0.0, -lam.real], np.stack([-near.real, near.imag], 1).ravel()])
    h = max(-lam.real / (2 * np.pi), fs / n)            # the peak's half-power half-width or one line (Hz)
    scale = np.concatenate([[h, h], np.full(1 + 2 * near.size, 2 * np.pi * h)])
    lower = np.concatenate([[band[0], -np.inf, 1e-9 * fs], np.tile([1e-9 * fs, 2 * np.pi * band[0]], near.size)])
    upper = np.concatenate([[band[1], np.inf, np.inf], np.tile([np.inf, 2 * np.pi * band[1]], near.size)])

    def residual(p):
        return _projected(p, k, n, fs, Y, background, rows)[0]

    try:
        fit = least_squares(residual, p0, jac="3-point", x_scale=scale, method="trf",
                            bounds=(lower, upper),
                            xtol=1e-12, ftol=1e-12, gtol=1e-12)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise ConvergenceError(f"backbone fit: {exc}") from None
    if not fit.success:
        raise ConvergenceError(f"backbone fit: {fit.message}")
    r, coef = _projected(fit.x, k, n, fs, Y, background, rows)
    s2 = float(r @ r) / max(r.size - n_params, 1)
    J = fit.jac
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        raise ConvergenceError("backbone fit: singular Jacobian") from None
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    f0, c, sigma = (float(v) for v in fit.x[:3])
    return Backbone(f0, float(np.hypot(f0, sigma / (2 * np.pi))), c, sigma, float(std[0]), float(std[1]), float(std[2]),
                    float(cov[0, 1] / (std[0] * std[1])) if std[0] * std[1] > 0 else np.nan,
                    complex(coef[0], coef[1]), bool(abs(c) > SIGNIFICANT_SIGMAS * std[1]),
                    band.copy(), int(k.size), -fit.x[3::2] + 1j * fit.x[4::2], k * fs / n,
                    r[:k.size] + 1j * r[k.size:], n_params)
