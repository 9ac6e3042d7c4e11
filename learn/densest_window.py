"""The densest window of repeated tests' poles: where a mode sits among the poles of many tests of one structure,
found in a few of them, scattered, and mixed with spurious poles."""

from __future__ import annotations

import numpy as np

__all__ = ["densest_window"]


def densest_window(logf, who, half: float, prior: float | None = None) -> float:
    """The centre (``ln f``, a pole's) of the window ``+-half`` centred on a pole that holds poles of the most tests.

    Parameters
    ----------
    logf : array (p,)     the poles' ``ln f`` (f in Hz), any order; at least one
    who : int array (p,)  each pole's test; a test's several poles in one window count once
    half : float          half-width of the window in ``ln f``
    prior : float         ``ln f``; among windows holding equally many tests, the one whose centre lies nearest it
                          (default: the median of ``logf``)
    """
    x = np.asarray(logf, float)
    inside = (np.abs(x[:, None] - x[None]) <= half).astype(np.int64)                 # (p, p)
    test = np.unique(np.asarray(who), return_inverse=True)[1].reshape(-1)
    held = np.count_nonzero(inside @ np.eye(test.max() + 1, dtype=np.int64)[test], axis=1)     # tests per window
    best = np.flatnonzero(held == held.max())
    k = best[np.argmin(np.abs(x[best] - (np.median(x) if prior is None else prior)))]
    return float(x[k])
