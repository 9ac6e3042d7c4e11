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
    order = np.argsort(x, kind="stable")
    xs = x[order]
    test = np.unique(np.asarray(who), return_inverse=True)[1].reshape(-1)[order]
    lo, hi = np.searchsorted(xs, xs - half, "left"), np.searchsorted(xs, xs + half, "right")
    upto = np.zeros((test.max() + 1, x.size + 1), np.int32)                 # (tests, p + 1) poles of each test so far
    upto[:, 1:] = np.cumsum(test[None] == np.arange(test.max() + 1)[:, None], axis=1)
    held = np.empty(x.size, int)
    held[order] = np.count_nonzero(upto[:, hi] - upto[:, lo], axis=0)      # tests in each pole's window
    best = np.flatnonzero(held == held.max())
    k = best[np.argmin(np.abs(x[best] - (np.median(x) if prior is None else prior)))]
    return float(x[k])
