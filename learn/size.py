"""The size of a damage as the network and the classical methods learn it.

A damage kind declares its ``size_transform`` (:mod:`datagen.damage`): ``"log"`` for a positive size (a slit's hinge
flexibility), ``"asinh:<scale>"`` for a signed one (a mass change's ratio). :class:`SizeTransform` turns sizes into
what a regression head predicts and back, with the spread of an estimate; :func:`fit_size_std_scale` scales that
spread so that one standard deviation covers 68 % of validation sizes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import BeamDamageError

__all__ = ["LOG_SIZE_LIMIT", "MAX_SIZE_LOG_STD", "SizeTransform", "fit_size_std_scale", "lognormal_std"]

#: Bound of the log of the size (from e^-30 to e^30) and of its log-std (a factor e^5).
LOG_SIZE_LIMIT = 30.0
MAX_SIZE_LOG_STD = 5.0


def lognormal_std(median, log_std):
    """Standard deviation of a log-normal variable from its median and the std of its logarithm."""
    return median * np.sqrt(np.expm1(log_std**2) * np.exp(log_std**2))


@dataclass(frozen=True)
class SizeTransform:
    """How the size head learns a size: ``t = forward(size)`` is what it predicts (a mean and a log-std of ``t``).

    ``"log"``: ``t = ln(size)`` (a positive size, a slit's hinge flexibility; the estimate is log-normal);
    ``"asinh:<scale>"``: ``t = asinh(size / scale)`` (a signed size, a mass change's ratio: linear below the
    scale, logarithmic above). Each damage kind declares its own (:mod:`datagen.damage`, ``size_transform``).
    """

    kind: str
    scale: float = 1.0

    @classmethod
    def parse(cls, spec: str) -> "SizeTransform":
        name, _, scale = str(spec).partition(":")
        try:
            if name == "log" and not scale:
                return cls("log")
            if name == "asinh" and float(scale) > 0:
                return cls("asinh", float(scale))
        except ValueError:
            pass
        raise BeamDamageError(f"size_transform {spec!r} unknown; expected 'log' or 'asinh:<scale>' (scale > 0)")

    def forward(self, size):
        size = np.asarray(size, float)
        if self.kind == "log":
            return np.log(np.maximum(size, 1e-9))
        return np.arcsinh(size / self.scale)

    def inverse(self, t):
        t = np.clip(np.asarray(t, float), -LOG_SIZE_LIMIT, LOG_SIZE_LIMIT)
        return np.exp(t) if self.kind == "log" else self.scale * np.sinh(t)

    def std(self, t, t_std):
        """Standard deviation of the size from the transformed mean ``t`` and std ``t_std``: log-normal for
        ``log``, half the width of the one-sigma interval ``inverse(t +- t_std)`` for ``asinh``."""
        t = np.clip(np.asarray(t, float), -LOG_SIZE_LIMIT, LOG_SIZE_LIMIT)
        if self.kind == "log":
            return lognormal_std(np.exp(t), t_std)
        return self.scale * np.cosh(t) * np.sinh(t_std)


def fit_size_std_scale(truth, median, log_std, coverage: float = 0.6827, spread=None) -> float:
    """Factor ``k`` on the size head's log-std so that ``|truth - median| <= std(k log_std)`` holds for
    ``coverage`` of the pairs (one sigma: 68.3 %); the std grows with ``k``, solved by bisection in log k.
    ``spread(t_std)`` gives the std of each pair from its transformed std (default: log-normal about ``median``)."""
    truth, median, log_std = (np.asarray(a, float) for a in (truth, median, log_std))
    spread = spread or (lambda t_std: lognormal_std(median, t_std))

    def covered(log_k):
        with np.errstate(over="ignore", invalid="ignore"):   # an infinite std covers every truth
            return np.mean(np.abs(truth - median) <= spread(np.exp(log_k) * log_std))

    lo, hi = np.log(1e-3), np.log(1e2)
    if covered(hi) < coverage:
        return float(np.exp(hi))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if covered(mid) < coverage else (lo, mid)
    return float(np.exp(hi))
