"""The trained network's forward pass in NumPy: what ``classify`` runs on a loaded model.

Training needs torch (:class:`learn.network.models.DamageNet`, :mod:`learn.network.estimator`); answering does not: a
model directory's ``weights-<input>.npz`` holds the same state dict, and :func:`forward` evaluates it as the torch
module does in evaluation mode (dropout off): ``depth`` layers ``h <- GELU(h W^T + b)`` (the exact, erf-based GELU),
then the four heads. In float64: the answers agree with torch's float32 ones to about 1e-6.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf, expit

__all__ = ["LOG_STD_MAX", "LOG_STD_MIN", "check_weights", "forward"]

#: Range of the size head's log standard deviation. A smooth bound: a hard clamp has no gradient beyond it, and
#: the large size errors of the first epochs would push the head there for good (a constant spread).
LOG_STD_MIN, LOG_STD_MAX = -6.0, 1.0


def forward(weights: dict, x) -> dict:
    """Outputs of the network ``weights`` (a state dict of :class:`learn.network.models.DamageNet` as arrays) for inputs
    ``x`` (n, d): ``detect`` (n,), ``support`` (n,; 0 without a support head), ``locate`` (n, n_bins),
    ``size_mean`` and ``size_log_std`` (n,)."""
    h = np.asarray(x, float)
    k = 0
    while f"trunk.{k}.weight" in weights:              # Linear, GELU, Dropout per layer: Linear at 0, 3, 6, ...
        h = h @ weights[f"trunk.{k}.weight"].T + weights[f"trunk.{k}.bias"]
        h = 0.5 * h * (1.0 + erf(h / np.sqrt(2.0)))
        k += 3

    def head(name):
        return h @ weights[f"{name}.weight"].T + weights[f"{name}.bias"]

    s = head("size")
    return {"detect": head("detect")[:, 0],
            "support": head("support")[:, 0] if "support.weight" in weights else np.zeros(len(h)),
            "locate": head("locate"), "size_mean": s[:, 0],
            "size_log_std": LOG_STD_MIN + (LOG_STD_MAX - LOG_STD_MIN) * expit(s[:, 1])}


def check_weights(weights: dict, n_inputs: int, n_bins: int, hidden: int, depth: int) -> None:
    """Raise ``ValueError`` naming the first array whose shape is not that of the network described."""
    want = {}
    d = n_inputs
    for k in range(depth):
        want[f"trunk.{3 * k}.weight"], want[f"trunk.{3 * k}.bias"] = (hidden, d), (hidden,)
        d = hidden
    for name, n in (("detect", 1), ("locate", n_bins), ("size", 2)):
        want[f"{name}.weight"], want[f"{name}.bias"] = (n, hidden), (n,)
    for name, shape in want.items():
        got = np.shape(weights[name]) if name in weights else None
        if got != shape:
            raise ValueError(f"network array {name!r} has shape {got}, expected {shape}")
