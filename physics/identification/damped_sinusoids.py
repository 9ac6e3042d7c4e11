"""Nonlinear least-squares fit of common damped sinusoids to free decays (variable projection).

Each decay ``d`` (samples ``t = 0, 1/fs, ...`` after its start) and channel ``c`` is modelled as

    y_dc(t) = sum_j exp(-sigma_j t) (a_dcj cos(omega_j t) + b_dcj sin(omega_j t)) + e_dc

with poles ``lambda_j = -sigma_j + i omega_j`` common to every decay and channel, and amplitudes ``a, b`` and
offsets ``e`` of their own. The amplitudes enter linearly and are projected out (variable projection, Golub and
Pereyra); the poles are refined by Levenberg-Marquardt steps on the projected residual with Kaufman's Jacobian
``(I - P) dPhi/dtheta C``. At the optimum that Jacobian's normal matrix is the Schur complement of the full Fisher
information, so ``s^2 (J^T J)^-1`` is the covariance of the poles with the amplitudes unknown: in white noise the
frequencies' one sigma of the Cramer-Rao bound. Channels are weighted by the inverse of their residual standard
deviation.

The basis' Gram matrices ``Phi^T diag(t^p) Phi`` (``p = 0, 1, 2``) are sums of geometric series, taken in closed form
(:func:`power_sums`), and the Kaufman normal equations follow from them and the coefficients; each evaluation passes
over the samples only for ``Phi^T y``, the residual and ``Phi^T diag(t) r``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError

__all__ = ["DampedSinusoidFit", "NormalEquations", "fit_damped_sinusoids", "levenberg_marquardt", "mode_snr",
           "pole_statistics", "power_sums"]

#: Levenberg-Marquardt iterations at most, and the relative pole step below which the fit has converged.
MAX_ITERATIONS, STEP_TOL = 30, 1e-10
#: ``|n s|`` below which :func:`power_sums` takes the Taylor series, and the series' terms.
SERIES_RADIUS, SERIES_TERMS = 1.0, 24
_LOG_MAX = np.log(np.finfo(float).max)


@dataclass(frozen=True)
class DampedSinusoidFit:
    """Poles fitted to free decays (see the module docstring).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s), ``omega`` the damped angular frequency.
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        One sigma from the fit's covariance (first order in the noise).
    covariance : ndarray, shape (2 n_modes, 2 n_modes)
        Of ``(sigma_1..sigma_m, omega_1..omega_m)`` (rad/s).
    amplitudes : ndarray, complex, shape (n_decays, n_channels, n_modes)
        ``a - i b`` of each decay, channel and mode (the channel's units): ``Re(amp exp(lambda t))``.
    noise_std : ndarray, shape (n_channels,)
        Residual standard deviation of each channel.
    iterations : int
    residuals : tuple of ndarray, each shape (n_channels, n_samples_d)
        Each decay less the fitted model (the channel's units).
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    covariance: np.ndarray
    amplitudes: np.ndarray
    noise_std: np.ndarray
    iterations: int
    residuals: tuple = ()


@dataclass(frozen=True)
class NormalEquations:
    """The Gauss-Newton normal equations of a projected residual: what a ``project`` callable of
    :func:`levenberg_marquardt` may return in place of its Jacobian blocks.

    Attributes
    ----------
    jtj : ndarray, shape (2 m, 2 m)
        ``J^T J`` of the Kaufman Jacobian by ``(sigma, omega)``.
    jtr : ndarray, shape (2 m,)
        ``J^T r``, ``r`` the weighted residual.
    """

    jtj: np.ndarray
    jtr: np.ndarray


def _expm1(x):
    """``exp(x) - 1`` of complex ``x``, to full relative precision near 0."""
    a, b = x.real, x.imag
    return np.expm1(a) * np.cos(b) - 2 * np.sin(b / 2) ** 2 + 1j * np.exp(a) * np.sin(b)


@functools.lru_cache(maxsize=32)
def _power_moments(n):
    """``mu_q = sum_{k<n} (k / n)^q / n`` for ``q < SERIES_TERMS + 3``, shape (SERIES_TERMS + 3,)."""
    u = np.arange(n) / n
    return np.array([np.sum(u ** q) for q in range(SERIES_TERMS + 3)]) / n


def power_sums(s, n, shift=0.0):
    """``sum_{k<n} k^p exp(s k - shift)`` for ``p = 0, 1, 2`` in closed form (its Taylor series where ``|n s|`` is
    below :data:`SERIES_RADIUS`); error a few units of ``eps`` of the sums of the moduli.

    Parameters
    ----------
    s : array_like, complex
    n : int
    shift : array_like, float, broadcast with ``s``
        A growing ``s`` (``Re s > 0``) over ``n`` terms overflows unless shifted by about ``Re(s) (n - 1)``.

    Returns
    -------
    ndarray, complex, shape (3,) + s.shape
    """
    s = np.asarray(s, complex)
    s = s - 2j * np.pi * np.round(s.imag / (2 * np.pi))          # k integer: the sums are 2 pi i periodic in s
    shift = np.broadcast_to(np.asarray(shift, float), s.shape)
    ns = n * s
    with np.errstate(all="ignore"):                  # a growing trial pole can still overflow: an infinite cost
        x, d, xn = np.exp(s), _expm1(s), np.exp(ns - shift)
        s0 = np.where(ns.real < 700, _expm1(ns) * np.exp(-shift), xn - np.exp(-shift)) / d
        s1 = (n * xn - x * s0) / d
        s2 = (n * n * xn - x * s0 - 2 * x * s1) / d
    out = np.stack([s0, s1, s2])
    small = np.abs(ns) < SERIES_RADIUS
    if np.any(small):
        fact = np.cumprod(np.concatenate([[1.0], np.arange(1.0, SERIES_TERMS)]))
        terms = ns[small][:, None] ** np.arange(SERIES_TERMS) / fact
        mu = _power_moments(int(n))
        scale = np.exp(-shift[small])
        for p in range(3):
            out[p][small] = float(n) ** (p + 1) * scale * (terms @ mu[p:p + SERIES_TERMS])
    return out


def _exponentials(lam_dt, n, shift):
    """``exp(lam_dt k - shift)`` for ``k < n``, shape (n, m): products of a coarse and a fine table
    (``k = b B + r``)."""
    width = max(1, int(np.ceil(np.sqrt(n))))
    coarse = np.exp(np.multiply.outer(np.arange(-(-n // width)) * float(width), lam_dt) - shift)
    fine = np.exp(np.multiply.outer(np.arange(width, dtype=float), lam_dt))
    return (coarse[:, None, :] * fine[None, :, :]).reshape(-1, lam_dt.size)[:n]


def _grams(lam_dt, n, shift):
    """``Phi^T diag(k^p) Phi`` for ``p = 0, 1, 2`` of ``Phi = [Re Z, Im Z, 1]``, ``Z = exp(lam_dt k - shift)``,
    ``k < n``: shape (3, 2 m + 1, 2 m + 1), from :func:`power_sums` (no sum over samples)."""
    m = lam_dt.size
    both = shift[:, None] + shift[None, :]
    pair = power_sums(lam_dt[:, None] + lam_dt[None, :], n, both)            # sum k^p z_j z_l
    cross = power_sums(lam_dt.conj()[:, None] + lam_dt[None, :], n, both)    # sum k^p conj(z_j) z_l
    single = power_sums(np.append(lam_dt, 0.0), n, np.append(shift, 0.0))    # sum k^p z_j, sum k^p
    G = np.empty((3, 2 * m + 1, 2 * m + 1))
    G[:, :m, :m] = (pair.real + cross.real) / 2                        # Re z_j Re z_l
    G[:, m:2 * m, m:2 * m] = (cross.real - pair.real) / 2              # Im z_j Im z_l
    G[:, :m, m:2 * m] = (pair.imag + cross.imag) / 2                   # Re z_j Im z_l
    G[:, m:2 * m, :m] = G[:, :m, m:2 * m].transpose(0, 2, 1)
    G[:, :m, 2 * m], G[:, m:2 * m, 2 * m] = single[:, :m].real, single[:, :m].imag
    G[:, 2 * m, :2 * m] = G[:, :2 * m, 2 * m]
    G[:, 2 * m, 2 * m] = single[:, m].real
    return G


def _projected(decays, fs, sigma, omega, weights):
    """Residuals and coefficients of every decay, lists of (n_t, n_ch) and (2m+1, n_ch), and the normal equations
    of the Kaufman Jacobian (:class:`NormalEquations`).

    With ``Phi_m = [cos, sin]`` the damped columns, ``T = diag(t)`` and ``C`` a channel's coefficients, the model's
    derivative by ``(sigma, omega)`` is ``T Phi_m M`` with ``M = [[-diag(a), diag(b)], [-diag(b), -diag(a)]]``, so
    ``J^T J = M^T (Phi_m^T T^2 Phi_m - (Phi^T T Phi_m)^T (Phi^T Phi)^+ Phi^T T Phi_m) M`` and
    ``J^T r = M^T Phi_m^T T r``: the Gram matrices in closed form, one pass over the samples for ``Phi^T Y``, the
    residual and ``Phi_m^T T r``.
    """
    m, dt = sigma.size, 1.0 / fs
    lam_dt = (-sigma + 1j * omega) * dt
    order = np.append(np.stack([np.arange(m), m + np.arange(m)], axis=1).ravel(), 2 * m)   # cos_1, sin_1, .. 1
    back = np.argsort(order)
    res, coef = [], []
    jtj, jtr = np.zeros((2 * m, 2 * m)), np.zeros(2 * m)
    for y in decays:
        n = y.shape[1]
        shift = np.maximum(lam_dt.real * (n - 1), 0.0)         # columns of growing poles scaled to at most 1
        G0, G1, G2 = _grams(lam_dt, n, shift)
        with np.errstate(divide="ignore"):
            if np.any(np.log(np.diag(G0)[:2 * m]) + 2 * np.tile(shift, 2) >= _LOG_MAX):
                raise np.linalg.LinAlgError("a pole grows beyond the floating-point range over a decay")
        with np.errstate(over="ignore", invalid="ignore"):
            Phi = _exponentials(lam_dt, n, shift).view(float)         # (n, 2m): cos_1, sin_1, cos_2, ..
        norm = np.sqrt(np.maximum(np.diag(G0), np.finfo(float).tiny))
        G_inv = np.linalg.pinv(G0 / np.outer(norm, norm), hermitian=True) / np.outer(norm, norm)   # (Phi^T Phi)^+
        Yw = y.T * weights[None, :]
        C = G_inv @ np.concatenate([Phi.T @ Yw, Yw.sum(axis=0)[None]])[back]
        Ci = C[order]
        R = Yw - Phi @ Ci[:2 * m] - Ci[2 * m]
        H = G1[:, :2 * m] * dt                                             # Phi^T T Phi_m
        K = G2[:2 * m, :2 * m] * dt ** 2 - H.T @ G_inv @ H
        a, b = C[:m].T, C[m:2 * m].T                                       # (n_ch, m)
        M = np.zeros((a.shape[0], 2 * m, 2 * m))
        idx = np.arange(m)
        M[:, idx, idx], M[:, m + idx, idx] = -a, -b
        M[:, idx, m + idx], M[:, m + idx, m + idx] = b, -a
        g = (Phi.T @ (R * (np.arange(n) * dt)[:, None]))[back[:2 * m]]    # Phi_m^T T r, (2m, n_ch)
        MT = M.transpose(0, 2, 1)
        jtj += np.sum(MT @ K @ M, axis=0)
        jtr += np.sum(MT @ g.T[:, :, None], axis=0)[:, 0]
        res.append(R)
        with np.errstate(under="ignore"):
            coef.append(C * np.exp(-np.concatenate([shift, shift, [0.0]]))[:, None])
    return res, coef, NormalEquations(jtj, jtr)


def _normal_equations(jac, res):
    """``(J^T J, J^T r)`` of Jacobian blocks and residual blocks, or of :class:`NormalEquations`."""
    if isinstance(jac, NormalEquations):
        return jac.jtj, jac.jtr
    J = np.concatenate(jac, axis=0)
    return J.T @ J, J.T @ np.concatenate([x.ravel() for x in res])


def levenberg_marquardt(project, sigma, omega, n_channels, n_values, n_params, decaying=False):
    """Levenberg-Marquardt refinement of poles by variable projection.

    Parameters
    ----------
    project : callable
        ``project(sigma, omega, weights)`` returns lists of residual blocks (each ``(n_rows, n_channels)``, weighted),
        linear coefficients and Kaufman Jacobian blocks (each ``(n_rows * n_channels, 2 m)`` by ``(sigma, omega)``),
        or in place of the blocks their :class:`NormalEquations`.
    sigma, omega : ndarray, shape (m,)
        Starting decay rates and damped angular frequencies (rad/s).
    n_channels, n_values, n_params : int
        Channels, fitted values and parameters (poles, amplitudes and the rest) for the noise variance's degrees of
        freedom.
    decaying : bool
        Only steps that keep every pole decaying (``sigma > 0``) are taken (a model whose transform holds
        ``exp(-sigma T)`` for a long record ``T``).

    Returns
    -------
    sigma, omega : ndarray, shape (m,)
    covariance : ndarray, shape (2 m, 2 m)
        Of ``(sigma, omega)``: ``s^2 (J^T J)^-1``, ``s^2`` the weighted residual variance.
    residuals, coefficients : list of ndarray
        Of the last projection (weighted).
    weights : ndarray, shape (n_channels,)
        Each channel's weight: the inverse of its residual's standard deviation at the start.
    iterations : int

    Raises
    ------
    ConvergenceError
        The normal matrix is singular (two poles merged, or a pole with no amplitude).
    """
    m = sigma.size
    weights = np.ones(n_channels)
    res, coef, jac = project(sigma, omega, weights)
    rms = np.sqrt(sum(np.sum(r ** 2, axis=0) for r in res) / (n_values / n_channels))
    weights = 1.0 / np.where(rms > 0, rms, 1.0)
    res, coef, jac = project(sigma, omega, weights)
    cost = sum(np.sum(r ** 2) for r in res)
    mu, it = 1e-3, 0
    theta = np.concatenate([sigma, omega])
    for it in range(1, MAX_ITERATIONS + 1):
        JtJ, g = _normal_equations(jac, res)
        scale = np.sqrt(np.maximum(np.diag(JtJ), np.finfo(float).tiny))
        N = JtJ / np.outer(scale, scale)
        accepted = False
        for _ in range(12):
            step = np.linalg.solve(N + mu * np.eye(2 * m), g / scale) / scale
            trial = theta + step
            if np.all(trial[m:] > 0) and (not decaying or np.all(trial[:m] > 0)):
                try:                                     # a growing pole overflows over a long decay: no step
                    with np.errstate(over="ignore", invalid="ignore"):
                        out = project(trial[:m], trial[m:], weights)
                    c = sum(np.sum(x ** 2) for x in out[0])
                except np.linalg.LinAlgError:
                    c = np.inf
                if c <= cost:
                    theta, cost, (res, coef, jac) = trial, c, out
                    mu, accepted = max(mu / 10, 1e-12), True
                    break
            mu *= 10
        if not accepted or np.all(np.abs(step) <= STEP_TOL * np.abs(theta[m:]).max()):
            break
    s2 = cost / max(n_values - n_params, 1)
    try:
        cov = s2 * np.linalg.inv(_normal_equations(jac, res)[0])
    except np.linalg.LinAlgError:
        raise ConvergenceError("the damped-sinusoid fit is singular (two poles merged, or a pole without "
                               "amplitude)") from None
    return theta[:m], theta[m:], cov, res, coef, weights, it


def pole_statistics(sigma, omega, covariance):
    """Natural frequencies (Hz), damping ratios and their one sigma from poles ``-sigma + i omega`` (rad/s) and
    the covariance of ``(sigma, omega)``, to first order: ``d wn = (sigma d sigma + omega d omega) / wn``,
    ``d zeta = (omega^2 d sigma - sigma omega d omega) / wn^3``. Four arrays of shape (m,)."""
    m = sigma.size
    wn = np.hypot(sigma, omega)
    idx = np.arange(m)
    g_w = np.zeros((m, 2 * m))
    g_w[idx, idx], g_w[idx, m + idx] = sigma / wn, omega / wn
    g_z = np.zeros((m, 2 * m))
    g_z[idx, idx], g_z[idx, m + idx] = omega ** 2 / wn ** 3, -sigma * omega / wn ** 3
    f_std = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g_w, covariance, g_w), 0)) / (2 * np.pi)
    z_std = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g_z, covariance, g_z), 0))
    return wn / (2 * np.pi), sigma / wn, f_std, z_std


def fit_damped_sinusoids(decays, sampling_frequency_hz, eigenvalues) -> DampedSinusoidFit:
    """Refine poles on free decays by variable projection (see the module docstring).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays, each from its own start (time 0 at its first sample).
    sampling_frequency_hz : float
    eigenvalues : array_like, complex, shape (n_modes,)
        Starting poles ``-sigma + i omega`` (rad/s, Im > 0).

    Returns
    -------
    DampedSinusoidFit

    Raises
    ------
    ConvergenceError
        The decays hold fewer samples than the model's parameters, or the normal matrix is singular (two poles
        merged, or a pole with no amplitude).
    """
    fs = float(sampling_frequency_hz)
    lam = np.asarray(eigenvalues, complex)
    m = lam.size
    n_ch = decays[0].shape[0]
    n_values = sum(y.size for y in decays)
    n_params = 2 * m + len(decays) * n_ch * (2 * m + 1)
    if n_values <= n_params:
        raise ConvergenceError(f"{n_values} decay samples are too few for {m} damped sinusoids "
                               f"({n_params} parameters)")

    def project(sigma, omega, weights):
        return _projected(decays, fs, sigma, omega, weights)

    sigma, omega, cov, res, coef, weights, it = levenberg_marquardt(project, -lam.real.astype(float),
                                                                    lam.imag.astype(float), n_ch, n_values, n_params)
    fn, zeta, f_std, z_std = pole_statistics(sigma, omega, cov)
    amps = np.array([(C[:m] - 1j * C[m:2 * m]).T / weights[:, None] for C in coef])      # (n_decays, n_ch, m)
    noise = np.sqrt(sum(np.sum(r ** 2, axis=0) for r in res) / (n_values / n_ch)) / weights
    return DampedSinusoidFit(-sigma + 1j * omega, fn, zeta, f_std, z_std, cov, amps, noise, it,
                             tuple((r / weights[None, :]).T for r in res))


def mode_snr(fit: DampedSinusoidFit, lengths, sampling_frequency_hz) -> np.ndarray:
    """Each fitted mode's energy over the decays (of ``lengths`` samples) and channels, in units of each channel's
    noise variance, shape (n_modes,): about 2 per decay and channel for a pole fitted to noise alone."""
    sigma = -fit.eigenvalues.real
    decay = np.array([np.sum(np.exp(-2 * np.outer(np.arange(n) / sampling_frequency_hz, sigma)), axis=0)
                      for n in lengths])                                    # (n_decays, n_modes)
    amp2 = np.abs(fit.amplitudes) ** 2 / np.maximum(fit.noise_std, np.finfo(float).tiny)[None, :, None] ** 2
    return 0.5 * np.einsum("dcm,dm->m", amp2, decay)
