"""Closed-form hammer-hit records with known modes: the acceleration of a linear structure under one half-sine force
pulse, sampled, with seeded white sensor noise; the truth every frequency definition is measured against.

The structure's receptance at the measured point is a sum of real modes (modal constants ``A_r``, natural
frequencies ``f_n``, damping ratios ``zeta``), impulse response ``h(t) = sum A_r exp(-sigma_r t) sin(w_d t) / w_d``,
``lambda_r = -sigma_r + i w_d = -zeta w_n + i w_n sqrt(1 - zeta^2)``. The force is the half-sine
``p(t) = P sin(pi (t - t0) / tau)`` on ``t0 <= t <= t0 + tau``. The acceleration ``a = (h * p)''`` is, with
``h(0) = 0`` and ``h'(0) = sum A_r``,

    ``a(t) = sum_r 2 Re(R_r lambda_r^2 G(lambda_r, t - t0)) + (sum_r A_r) p(t)``,  ``R_r = A_r / (2 i w_d)``,

    ``G(lambda, t) = exp(lambda t) [c - exp(-lambda u) (lambda sin(c u) + c cos(c u))] / (lambda^2 + c^2)``,
    ``c = pi / tau``, ``u = min(t, tau)`` (``G = 0`` for ``t < 0``),

the exact convolution of each pole's exponential with the pulse: no time stepping, no FFT. Its Fourier transform
over an infinite record is the accelerance ``-w^2 sum A_r / (w_n^2 - w^2 + 2 i zeta w_n w)`` times the pulse's
transform ``P c (1 + exp(-i w tau)) exp(-i w t0) / (c^2 - w^2)``: :func:`accelerance` and :func:`pulse_spectrum`
(the test of this module compares the two).

The three frequencies a mode has (``f_n = |lambda| / 2 pi``, ``f_d = Im lambda / 2 pi = f_n sqrt(1 - zeta^2)``, the
peak of one mode's ``|H|``: ``f_n / sqrt(1 - 2 zeta^2)`` for accelerance, ``f_n`` for mobility,
``f_n sqrt(1 - 2 zeta^2)`` for receptance) are :func:`frf_peak_hz`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError

__all__ = ["ImpactCase", "accelerance", "frf_peak_hz", "impact_records", "pulse_spectrum"]

#: Exponent of ``1 - 2 zeta^2`` in the peak of one mode's ``|H|`` by kind (the FRF's ``(i w)^k`` times receptance).
_PEAK_EXPONENT = {"receptance": 0.5, "mobility": 0.0, "accelerance": -0.5}


@dataclass(frozen=True)
class ImpactCase:
    """One hammer hit's record.

    Attributes
    ----------
    natural_frequencies_hz, damping_ratios : tuple of float
        The modes.
    amplitudes : tuple of float
        Each mode's acceleration amplitude just after the pulse (any sign): its modal constant is
        ``A_r = amplitude / (w_n |p(f_n)|)`` (:attr:`modal_constants`, ``p`` the pulse's transform).
    sampling_frequency_hz : float
    n_samples : int
    pretrigger_s : float
        ``t0``: the pulse's start.
    pulse_s : float
        ``tau``: the half-sine's duration.
    force_peak : float
        ``P``.
    noise_std : float
        White noise added to the acceleration (its units); the force is recorded without noise.
    """

    natural_frequencies_hz: tuple
    damping_ratios: tuple
    amplitudes: tuple
    sampling_frequency_hz: float = 25600.0
    n_samples: int = 25600
    pretrigger_s: float = 20 / 25600
    pulse_s: float = 2.5e-4
    force_peak: float = 70.0
    noise_std: float = 0.15

    @property
    def eigenvalues(self) -> np.ndarray:
        """``lambda_r`` (rad/s, ``Im > 0``), shape (n_modes,)."""
        wn = 2 * np.pi * np.asarray(self.natural_frequencies_hz, float)
        z = np.asarray(self.damping_ratios, float)
        return -z * wn + 1j * wn * np.sqrt(1 - z ** 2)

    @property
    def modal_constants(self) -> np.ndarray:
        """``A_r`` (receptance per force unit), shape (n_modes,)."""
        fn = np.asarray(self.natural_frequencies_hz, float)
        return np.asarray(self.amplitudes, float) / (2 * np.pi * fn * np.abs(pulse_spectrum(self, fn)))


def _pulse_integral(lam, t, tau):
    """``G(lambda, t)`` of the module docstring: shape ``lam.shape + t.shape``."""
    c = np.pi / tau
    lam = lam[:, None]
    u = np.clip(t, 0.0, tau)[None, :]
    inner = c - np.exp(-lam * u) * (lam * np.sin(c * u) + c * np.cos(c * u))
    g = np.exp(lam * t[None, :]) * inner / (lam ** 2 + c ** 2)
    return np.where(t[None, :] >= 0, g, 0.0)


def impact_records(case: ImpactCase, n_records: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n_records`` hits of ``case``, noise drawn from ``numpy.random.default_rng(seed)``.

    Returns
    -------
    force : ndarray, shape (n_records, n_samples)
    acceleration : ndarray, shape (n_records, n_samples)
    """
    sizes = {len(case.natural_frequencies_hz), len(case.damping_ratios), len(case.amplitudes)}
    if not (len(sizes) == 1 and np.all(np.asarray(case.damping_ratios) < 1 / np.sqrt(2))):
        raise ShapeError("ImpactCase: natural_frequencies_hz, damping_ratios and amplitudes must be of one "
                         "length, each damping ratio below 1/sqrt(2)")
    lam, a_r = case.eigenvalues, case.modal_constants
    t = np.arange(case.n_samples) / case.sampling_frequency_hz - case.pretrigger_s
    tau = case.pulse_s
    p = np.where((t >= 0) & (t <= tau), case.force_peak * np.sin(np.pi * np.clip(t, 0, tau) / tau), 0.0)
    res = a_r / (2j * lam.imag)
    a = 2 * np.real((res * lam ** 2) @ _pulse_integral(lam, t, tau)) * case.force_peak + a_r.sum() * p
    rng = np.random.default_rng(seed)
    noise = case.noise_std * rng.standard_normal((n_records, case.n_samples))
    return np.broadcast_to(p, noise.shape).copy(), a[None, :] + noise


def accelerance(case: ImpactCase, frequency_hz) -> np.ndarray:
    """The structure's accelerance ``-w^2 sum A_r / (w_n^2 - w^2 + 2 i zeta w_n w)`` at ``frequency_hz``."""
    w = 2 * np.pi * np.asarray(frequency_hz, float)[..., None]
    wn = 2 * np.pi * np.asarray(case.natural_frequencies_hz, float)
    z = np.asarray(case.damping_ratios, float)
    return np.sum(-w ** 2 * case.modal_constants / (wn ** 2 - w ** 2 + 2j * z * wn * w), axis=-1)


def pulse_spectrum(case: ImpactCase, frequency_hz) -> np.ndarray:
    """The force pulse's continuous Fourier transform ``int p(t) exp(-i w t) dt`` at ``frequency_hz``."""
    w = 2 * np.pi * np.asarray(frequency_hz, float)
    c, tau = np.pi / case.pulse_s, case.pulse_s
    at_c = np.abs(np.abs(w) - c) < 1e-9 * c                 # the removable singularity: -i tau / 2 there
    d = np.where(at_c, 1.0, c ** 2 - w ** 2)
    core = np.where(at_c, -0.5j * tau * np.sign(w), c * (1 + np.exp(-1j * w * tau)) / d)
    return case.force_peak * core * np.exp(-1j * w * case.pretrigger_s)


def frf_peak_hz(natural_frequency_hz, damping_ratio, kind="accelerance"):
    """The frequency of the peak of one mode's ``|H|`` of ``kind`` (receptance, mobility, accelerance):
    ``f_n (1 - 2 zeta^2)^(k / 2)``, ``k = 1, 0, -1`` (``zeta < 1 / sqrt(2)``)."""
    if kind not in _PEAK_EXPONENT:
        raise ShapeError(f"kind {kind!r}: expected one of {', '.join(_PEAK_EXPONENT)}")
    z = np.asarray(damping_ratio, float)
    return np.asarray(natural_frequency_hz, float) * (1 - 2 * z ** 2) ** _PEAK_EXPONENT[kind]
