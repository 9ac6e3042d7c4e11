"""The size of a damage as the network and the classical methods learn it.

A damage kind declares its ``size_transform`` (:mod:`datagen.damage`): ``"log"`` for a positive size (a slit's hinge
flexibility), ``"asinh:<scale>"`` for a signed one (a mass change's ratio). :class:`SizeTransform` turns sizes into
what a regression head predicts and back, with the spread of an estimate; :func:`fit_size_scales` scales that
spread so that each level's interval covers its share of the validation sizes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learn.network.intervals import LEVELS, Z_OF_LEVEL
from physics.errors import BeamDamageError

__all__ = ["LOG_SIZE_LIMIT", "MAX_SIZE_LOG_STD", "SizeTransform", "fit_size_scales", "lognormal_std",
           "read_size_scales"]

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


def fit_size_scales(t_true, t_mean, t_std) -> dict:
    """Factor ``k`` per level of :data:`learn.network.intervals.LEVELS` on the size head's transformed std so that the
    interval ``inverse(t_mean -+ z k t_std)`` (``z`` the level's normal quantile) holds the level's share of the
    true sizes: the level's quantile of ``|t_true - t_mean| / (z t_std)`` (all arrays (n,), transformed sizes).
    Each level has its own factor: the errors are not Gaussian (most sizes closer than the head says, a few far)."""
    r = np.abs(np.asarray(t_true, float) - np.asarray(t_mean, float)) / np.asarray(t_std, float)
    return {k: float(np.quantile(r, level) / Z_OF_LEVEL[k]) for k, level in LEVELS.items()}


def read_size_scales(saved) -> list:
    """The factors of :func:`fit_size_scales` as a model file holds them: a list (one per number of missing modes)
    of level -> factor; one such dict, or one number (every level's), read as one."""
    if isinstance(saved, list):
        return [read_size_scales(v)[0] for v in saved]
    return [{k: float(saved) for k in LEVELS} if np.isscalar(saved) else {k: float(saved[k]) for k in LEVELS}]
