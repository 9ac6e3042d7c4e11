"""The half-power (-3 dB) bandwidth of a spectrum's peaks."""

from __future__ import annotations

import numpy as np

__all__ = ["half_power_bandwidth_hz"]


def half_power_bandwidth_hz(frequency_hz, values, idx, *, ratio: float = np.sqrt(2.0),
                            one_side: str = "double") -> np.ndarray:
    """Half-power bandwidth (Hz) of each peak line ``idx`` of ``values``: the distance between the first lines either
    side at which the values fall below the peak's over ``ratio``, each crossing interpolated linearly between its
    two lines (``2 zeta f_n`` for a lone lightly damped mode).

    A side has no crossing where the band ends, or a line higher than the peak comes, before it (the line is then no
    peak's top on that side).

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
        Increasing; any spacing.
    values : ndarray, shape (n_lines,)
        A magnitude (``ratio`` ``sqrt(2)``) or a power (``ratio`` 2).
    idx : sequence of int, shape (n,)
    ratio : float
        The peak's value over the half-power level.
    one_side : {"double", "nan"}
        A peak with a crossing on one side only: ``"double"`` counts the other side as wide as that one (no crossing
        on either side: ``inf``); ``"nan"``: NaN (no crossing on either side: NaN).

    Returns
    -------
    ndarray, shape (n,)
    """
    f = np.asarray(frequency_hz, float)
    v = np.asarray(values, float)
    idx = np.atleast_1d(np.asarray(idx, int))
    out = np.full(idx.size, np.inf if one_side == "double" else np.nan)
    for k, p in enumerate(idx):                          # per peak: each side read up to its first crossing
        level = v[p] / ratio
        half = []
        for step, side in ((-1, v[p - 1::-1] if p > 0 else v[:0]), (1, v[p + 1:])):
            below = np.flatnonzero(side < level)
            if not below.size or np.any(side[:below[0]] > v[p]):
                continue
            j = p + step * (below[0] + 1)                # first line below, and the line before it
            i = j - step
            frac = (v[i] - level) / (v[i] - v[j])
            half.append(abs(f[i] + frac * (f[j] - f[i]) - f[p]))
        if len(half) == 2:
            out[k] = half[0] + half[1]
        elif half and one_side == "double":
            out[k] = 2 * half[0]
    return out
