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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError

__all__ = ["DampedSinusoidFit", "fit_damped_sinusoids", "levenberg_marquardt", "pole_statistics"]

#: Levenberg-Marquardt iterations at most, and the relative pole step below which the fit has converged.
MAX_ITERATIONS, STEP_TOL = 30, 1e-10


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


def _basis(t, sigma, omega):
    """``[exp(-sigma t) cos(omega t), exp(-sigma t) sin(omega t), 1]``, shape (n_t, 2 m + 1)."""
    e = np.exp(-np.outer(t, sigma))
    wt = np.outer(t, omega)
    return np.concatenate([e * np.cos(wt), e * np.sin(wt), np.ones((t.size, 1))], axis=1)


def _projected(decays, fs, sigma, omega, weights):
    """Residuals, coefficients and Kaufman Jacobian blocks of every decay: lists of (n_t, n_ch), (2m+1, n_ch),
    (n_t * n_ch, 2m)."""
    m = sigma.size
    res, coef, jac = [], [], []
    for y in decays:
        t = np.arange(y.shape[1]) / fs
        Phi = _basis(t, sigma, omega)
        norm = np.maximum(np.linalg.norm(Phi, axis=0), np.finfo(float).tiny)
        G = (Phi.T @ Phi) / np.outer(norm, norm)                          # Gram matrix of the unit columns
        G_inv = np.linalg.pinv(G, hermitian=True) / np.outer(norm, norm)   # (Phi^T Phi)^+
        Yw = y.T * weights[None, :]
        C = G_inv @ (Phi.T @ Yw)
        R = Yw - Phi @ C
        cos, sin = Phi[:, :m, None], Phi[:, m:2 * m, None]
        ca, cb = C[None, :m, :], C[None, m:2 * m, :]
        d_sigma = -t[:, None, None] * (cos * ca + sin * cb)                # (n_t, m, n_ch)
        d_omega = t[:, None, None] * (cos * cb - sin * ca)
        D = np.concatenate([d_sigma, d_omega], axis=1)                     # (n_t, 2m, n_ch)
        D = D - np.einsum("tk,kpc->tpc", Phi, np.einsum("kl,tl,tpc->kpc", G_inv, Phi, D, optimize=True))
        res.append(R)
        coef.append(C)
        jac.append(D.transpose(0, 2, 1).reshape(-1, 2 * m))
    return res, coef, jac


def levenberg_marquardt(project, sigma, omega, n_channels, n_values, n_params, decaying=False):
    """Levenberg-Marquardt refinement of poles by variable projection.

    Parameters
    ----------
    project : callable
        ``project(sigma, omega, weights)`` returns lists of residual blocks (each ``(n_rows, n_channels)``, weighted),
        linear coefficients and Kaufman Jacobian blocks (each ``(n_rows * n_channels, 2 m)`` by ``(sigma, omega)``).
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
        J = np.concatenate(jac, axis=0)
        r = np.concatenate([x.ravel() for x in res])
        JtJ, g = J.T @ J, J.T @ r
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
    J = np.concatenate(jac, axis=0)
    s2 = cost / max(n_values - n_params, 1)
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
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
