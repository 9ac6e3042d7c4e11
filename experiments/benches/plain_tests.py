"""The plainest tests the monitoring benches set beside ``monitor``: each test's relative change of the modal
frequencies from their baseline medians, alarmed beyond the baseline's own quantiles.

* ``plain shift``: the mean relative change of the modes beyond the baseline's ``rate`` quantile;
* ``plain per mode``: any mode's relative change beyond that mode's baseline ``rate / m`` quantile (``m`` modes).

One side (``sides=1``): below the quantile, the change's sign told (``sign=-1``: a rise, above the ``1 - rate``
quantile). Both sides (``sides=2``): the rate split between the tails, below the ``rate / 2`` or above the
``1 - rate / 2`` quantile (per mode ``rate / (2 m)``). ``method`` is :func:`numpy.nanquantile`'s rule: ``"linear"``,
or ``"weibull"``, the ``k``-th smallest of ``n`` values at level ``k / (n + 1)`` as
:func:`~learn.monitor.alarm_threshold.threshold` reads its empirical quantile.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plain_alarms"]


def plain_alarms(F, n_baseline: int, rate: float, *, sides: int, method: str, sign: float = 1.0) -> dict:
    """The plainest tests' alarms on frequencies ``F`` (n, m) (NaN: not found), the baseline its first
    ``n_baseline`` rows.

    Parameters
    ----------
    F : array_like (n, m)
        Each test's frequency (Hz) of each mode.
    n_baseline : int
        The first tests, the baseline period.
    rate : float
        The false-alarm rate of each test on the baseline.
    sides : {1, 2}
        1: alarm below the quantile; 2: below the lower or above the upper, the rate split between them.
    method : str
        The quantile rule of :func:`numpy.nanquantile` (``"linear"``, ``"weibull"``).
    sign : float
        The relative changes are multiplied by it first (``-1``: one side reads a rise).

    Returns
    -------
    dict
        ``"plain shift"`` and ``"plain per mode"``: bool (n,). A test without any frequency found alarms neither.
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
