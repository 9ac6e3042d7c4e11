"""The decay an exponential window adds to every pole of an impact test, and its removal from identified modes.

An impact FRF is commonly estimated from response (and force) records multiplied by ``w(t) = exp(-t / tau_s)``
so that a response that outlasts the record does not leak. The windowed impulse response
``h(t) exp(-t / tau_s)`` has the poles ``lambda - 1 / tau_s``: every mode's decay rate
``sigma = zeta omega_n = -Re(lambda)`` grows by ``1 / tau_s`` while the damped frequency
``omega_d = |Im(lambda)|`` is unchanged. A fit of the windowed FRF therefore returns

    ``sigma_identified = sigma + 1 / tau_s``,  ``omega_d`` exact,

and the true mode follows from the corrected pole ``lambda = lambda_identified + 1 / tau_s``:
``omega_n = |lambda| = sqrt(sigma^2 + omega_d^2)`` (slightly below the identified one) and
``zeta = sigma / omega_n``.

A window that falls to ``end_value`` at the end of a record of ``duration_s`` has
``tau_s = duration_s / ln(1 / end_value)``; for an FRF of line spacing ``df`` the record lasts ``1 / df``.

Conjugate pairs: the shift is real, so it applies alike to both members of a pair; the functions accept either
member and return it with the sign of its imaginary part kept (the package keeps ``Im > 0``,
see :mod:`physics.modal`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConfigError, ShapeError
from physics.modal import eigenvalues_from_modal, modal_parameters

__all__ = ["NOISE_SHARE", "NOISE_STDS", "WindowCorrection", "remove_window_decay", "remove_window_decay_modal",
           "slower_than_window", "tau_from_end_value"]

#: Share of the window's added decay rate ``1 / tau_s`` a corrected mode may fall below zero by and still be
#: read as noise (set to zero damping, flagged) rather than refused.
NOISE_SHARE = 0.01

#: A corrected decay rate below zero by less than this many one-sigma damping uncertainties (``damping_std``
#: times ``omega_n``) is read as noise too.
NOISE_STDS = 3.0


@dataclass(frozen=True)
class WindowCorrection:
    """Modes with the exponential window's added decay removed.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        Corrected poles (rad/s), the same member of each pair as given.
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
        From the corrected poles.
    tau_s : float
        Time constant of the window (s).
    added_decay_rate_1_s : float
        ``1 / tau_s`` (1/s), removed from every mode's decay rate.
    at_zero : ndarray of bool, shape (n_modes,)
        Modes whose corrected decay rate fell below zero by no more than the noise allowance: set to zero damping.
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    tau_s: float
    added_decay_rate_1_s: float
    at_zero: np.ndarray


def tau_from_end_value(duration_s, end_value) -> float:
    """Time constant (s) of ``exp(-t / tau_s)`` falling to ``end_value`` at ``t = duration_s``.

    ``tau_s = duration_s / ln(1 / end_value)``.

    Parameters
    ----------
    duration_s : float
        Record length (s) the window spans (``1 / df`` for FRF lines ``df`` Hz apart).
    end_value : float in (0, 1)
        The window's value at the record end (0.01: it decays to 1 %).

    Raises
    ------
    ConfigError
        ``end_value`` outside (0, 1) or ``duration_s`` not finite and positive.
    """
    end, t = float(end_value), float(duration_s)
    if not 0 < end < 1:
        raise ConfigError(f"exponential window end value {end:g} must be in (0, 1) (0.01: the window decays to 1 % "
                          "at the record end)", parameter="end_value")
    if not (np.isfinite(t) and t > 0):
        raise ConfigError(f"record duration {t:g} s must be finite and > 0", parameter="duration_s")
    return t / np.log(1 / end)


def remove_window_decay(eigenvalues, tau_s, damping_std=None, noise_share=NOISE_SHARE,
                        noise_stds=NOISE_STDS) -> WindowCorrection:
    """Remove an exponential window's added decay ``1 / tau_s`` from identified poles (vectorised).

    ``lambda = lambda_identified + 1 / tau_s``; the natural frequency and damping ratio follow from the corrected
    pole (``omega_d`` is kept, ``omega_n`` falls slightly).

    Parameters
    ----------
    eigenvalues : array_like, complex, shape (n_modes,)
        Identified poles (rad/s), either member of each conjugate pair, ``Re <= 0``.
    tau_s : float
        Time constant of the window ``exp(-t / tau_s)`` (s), finite and > 0.
    damping_std : array_like, shape (n_modes,), optional
        One-sigma uncertainty of each identified damping ratio (NaN: none), widening the noise allowance.
    noise_share, noise_stds : float
        The allowance below zero read as noise: ``max(noise_share / tau_s, noise_stds damping_std omega_n)`` (1/s).

    Returns
    -------
    WindowCorrection

    Raises
    ------
    ConfigError
        ``tau_s`` not finite and positive, or a mode whose corrected decay rate falls below zero by more than the
        noise allowance (the message names the mode, its frequency and by how much).
    ShapeError
        ``eigenvalues`` not finite, or not 1-D.
    """
    tau = float(tau_s)
    if not (np.isfinite(tau) and tau > 0):
        raise ConfigError(f"exponential window tau_s {tau:g} s must be finite and > 0", parameter="tau_s")
    lam = np.asarray(eigenvalues, dtype=complex)
    if lam.ndim != 1 or not np.all(np.isfinite(lam)):
        raise ShapeError(f"eigenvalues must be a finite 1-D array, got shape {lam.shape}")
    rate = 1.0 / tau
    sigma = -lam.real - rate
    w_n = np.abs(lam)
    allowance = _allowance(lam, rate, damping_std, noise_share, noise_stds)
    bad = np.nonzero(sigma < -allowance)[0]
    if bad.size:
        j = bad[np.argmin(sigma[bad] + allowance[bad])]
        raise ConfigError(
            f"exponential window tau_s {tau:.4g} s adds {rate:.4g} 1/s to every decay rate, but mode {j + 1} "
            f"({w_n[j] / (2 * np.pi):.5g} Hz" + (f", the farthest of {bad.size} such modes" if bad.size > 1 else "")
            + f") decays at {-lam.real[j]:.4g} 1/s (damping ratio {-lam.real[j] / w_n[j]:.4g}): its corrected "
            f"damping ratio would be {sigma[j] / w_n[j]:.3g}, below zero by {-sigma[j]:.3g} 1/s, more than the noise "
            f"({allowance[j]:.2g} 1/s); the window's tau is shorter than the one applied, or these FRFs were not "
            "windowed",
            parameter="tau_s")
    at_zero = sigma < 0
    corrected = np.where(at_zero, 0.0, -sigma) + 1j * lam.imag
    fn, zeta = modal_parameters(corrected)
    return WindowCorrection(corrected, fn, zeta, tau, rate, at_zero)


def _allowance(lam, rate, damping_std, noise_share, noise_stds):
    """How far below zero (1/s) a corrected decay rate may fall and be read as noise (:func:`remove_window_decay`;
    ``damping_std`` None or NaN: none of its own)."""
    std = np.zeros(lam.shape) if damping_std is None else np.broadcast_to(np.asarray(damping_std, float), lam.shape)
    return np.maximum(noise_share * rate, noise_stds * np.where(np.isfinite(std), std, 0.0) * np.abs(lam))


def slower_than_window(eigenvalues, tau_s, damping_std=None, noise_share=NOISE_SHARE,
                       noise_stds=NOISE_STDS) -> np.ndarray:
    """Which poles (shape (n_modes,)) decay slower than the window ``exp(-t / tau_s)`` alone makes every mode of
    the windowed FRFs decay, beyond the noise allowance of :func:`remove_window_decay`: no mode of the structure,
    were the window's ``tau_s`` right (a pole the fit placed in the noise)."""
    lam = np.asarray(eigenvalues, dtype=complex)
    rate = 1.0 / float(tau_s)
    return -lam.real - rate < -_allowance(lam, rate, damping_std, noise_share, noise_stds)


def remove_window_decay_modal(natural_frequencies_hz, damping_ratios, tau_s, damping_std=None,
                              noise_share=NOISE_SHARE, noise_stds=NOISE_STDS) -> WindowCorrection:
    """:func:`remove_window_decay` on identified ``(frequency_hz, damping ratio)`` pairs (vectorised).

    Parameters
    ----------
    natural_frequencies_hz, damping_ratios : array_like, shape (n_modes,)
        Identified natural frequencies (Hz, ``|lambda| / 2 pi``) and damping ratios (``0 <= zeta < 1``).
    tau_s, damping_std, noise_share, noise_stds
        As :func:`remove_window_decay`.

    Returns
    -------
    WindowCorrection
        Eigenvalues with ``Im > 0``.
    """
    fn = np.asarray(natural_frequencies_hz, float)
    zeta = np.asarray(damping_ratios, float)
    if fn.shape != zeta.shape or fn.ndim != 1:
        raise ShapeError(f"natural_frequencies_hz {fn.shape} and damping_ratios {zeta.shape} must be 1-D arrays of "
                         "one shape")
    return remove_window_decay(eigenvalues_from_modal(fn, zeta), tau_s, damping_std, noise_share, noise_stds)
