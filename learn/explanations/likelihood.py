"""The competing explanations' likelihood of relative frequency changes: Gaussian, with a model error on each
predicted change and the temperature nuisance integrated over its flat prior (:mod:`learn.explanations.hypotheses`)."""

from __future__ import annotations

import numpy as np

__all__ = ["nuisance_loglik"]


def nuisance_loglik(g, y, s, half: float, model_error: float):
    """Log-likelihood of ``a + g`` averaged over the temperature nuisance ``a`` (uniform in +-``half``; a Gaussian
    integral in closed form), and the most likely ``a``: shapes (n, ...) for every pair's measured changes ``y``
    (n, m) and every predicted change ``g`` (..., m), relative std ``s`` (m,) and the model error on ``g``.
    ``half = 0``: no nuisance."""
    from scipy.special import log_ndtr  # scipy.special: 0.2 s to import, only where explanations are weighed

    var = s**2 + (model_error * g) ** 2                                  # (..., m)
    r = g - y.reshape(y.shape[:1] + (1,) * (g.ndim - 1) + y.shape[-1:])  # (n, ..., m)
    s0, s1, s2 = np.sum(r**2 / var, -1), np.sum(r / var, -1), np.sum(1.0 / var, -1)
    logdet = -0.5 * np.sum(np.log(var / s**2), -1)
    centre = -s1 / s2                                                    # the a that fits best
    a_best = np.clip(centre, -half, half)
    if half == 0:
        return -0.5 * s0 + logdet, a_best
    root = np.sqrt(s2)
    lo, hi = (-half - centre) * root, (half - centre) * root
    # log P(lo < z < hi), from the tail the interval lies in (no cancellation of two values near 1)
    right = lo > 0
    big = np.where(right, log_ndtr(-lo), log_ndtr(hi))
    small = np.where(right, log_ndtr(-hi), log_ndtr(lo))
    mass = big + np.log(-np.expm1(np.minimum(small - big, -1e-300)))
    return (-0.5 * (s0 - s1**2 / s2) + logdet + 0.5 * np.log(2 * np.pi) - np.log(root) + mass
            - np.log(2 * half)), a_best
