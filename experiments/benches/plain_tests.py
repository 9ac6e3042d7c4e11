"""The plainest tests the monitoring benches set beside ``monitor``: alarms on the modal frequencies' relative change
from their baseline medians, beyond the baseline's own quantiles."""

from __future__ import annotations

import numpy as np

__all__ = ["plain_alarms"]


def plain_alarms(F, n_baseline: int, rate: float, *, sides: int, method: str, sign: float = 1.0) -> dict:
    """``"plain shift"``: the mean relative change of the modes beyond the baseline's ``rate`` quantile; ``"plain per
    mode"``: any mode's relative change beyond its baseline ``rate / m`` quantile. Each bool (n,); a test without any
    frequency found alarms neither.

    ``F`` (n, m): each test's frequency (Hz) of each mode, NaN where not found; the baseline its first ``n_baseline``
    rows. The changes are multiplied by ``sign`` first (``-1``: a rise is the alarmed side). ``sides=1``: below the
    quantile; ``sides=2``: the rate split between the tails, below the ``rate / 2`` or above the ``1 - rate / 2``
    quantile (per mode ``rate / (2 m)``). ``method``: :func:`numpy.nanquantile`'s rule, ``"linear"`` or ``"weibull"``
    (the ``k``-th smallest of ``n`` at level ``k / (n + 1)``, as :func:`~learn.monitor.alarm_threshold.threshold`).
    """
    if sides not in (1, 2):
        raise ValueError(f"sides must be 1 or 2, not {sides!r}")
    F = np.asarray(F, float)
    rel = sign * (F / np.nanmedian(F[:n_baseline], axis=0) - 1.0)
    found = np.isfinite(rel).any(axis=1)
    mean = np.nanmean(np.where(found[:, None], rel, 0.0), axis=1)
    q = rate / sides
    lo, hi = np.nanquantile(mean[:n_baseline], [q, 1 - q], method=method)
    plo, phi = np.nanquantile(rel[:n_baseline], [q / F.shape[1], 1 - q / F.shape[1]], axis=0, method=method)
    with np.errstate(invalid="ignore"):
        shift, per = mean < lo, (rel < plo).any(axis=1)
        if sides == 2:
            shift |= mean > hi
            per |= (rel > phi).any(axis=1)
    return {"plain shift": found & shift, "plain per mode": found & per}
