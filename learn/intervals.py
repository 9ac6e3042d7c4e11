"""The 68 % and 95 % intervals of the network's location and size, and the calibration that makes them cover.

The location head gives a distribution over ``n_bins`` equal bins of ``x / L`` (softmax of its logits); its
interval at ``level`` is the equal-tailed one, ``[Q((1 - level) / 2), Q((1 + level) / 2)]`` of the distribution's
quantile function ``Q`` (linear within a bin: each bin's probability spread evenly over it). The logits are
multiplied by a sharpness ``s`` fitted on the validation pairs (:func:`fit_location_sharpness`) so that the 68 %
interval holds 68 % of their true places: the soft location targets of training (a Gaussian of
``loc_sigma_bins``) widen the distribution beyond what the data leave uncertain, and a damage a network cannot
place should widen it. The size's interval is ``inverse(t -+ z sigma_t)`` of its transform
(:class:`learn.size.SizeTransform`, monotone), with ``z`` the normal quantile of the level; its ``sigma_t`` is
scaled on the validation pairs (:func:`learn.size.fit_size_std_scale`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LEVELS", "Z_OF_LEVEL", "distribution_interval", "fit_location_sharpness", "folded", "softmax"]

#: The intervals reported (name: level) and the standard normal quantile of each level (two-sided).
LEVELS = {"68": 0.6827, "95": 0.95}
Z_OF_LEVEL = {"68": 1.0, "95": 1.959964}


def softmax(logits, sharpness: float = 1.0) -> np.ndarray:
    """Row-wise softmax of ``sharpness * logits`` (n, B)."""
    z = np.asarray(logits, float) * sharpness
    p = np.exp(z - z.max(axis=1, keepdims=True))
    return p / p.sum(axis=1, keepdims=True)


def distribution_interval(p, level: float, span: float = 1.0) -> np.ndarray:
    """Equal-tailed interval at ``level`` of distributions over equal bins covering ``[0, span]``.

    Parameters
    ----------
    p : array, shape (n, B)     probabilities of the bins (each row sums to 1)
    level : float               e.g. 0.68
    span : float                the right edge of the last bin (1 for ``x / L``, 0.5 for a folded half)

    Returns
    -------
    ndarray, shape (n, 2)       lower and upper ends, in the bins' coordinate
    """
    p = np.atleast_2d(np.asarray(p, float))
    n, B = p.shape
    cdf = np.concatenate([np.zeros((n, 1)), np.cumsum(p, axis=1)], axis=1)     # (n, B + 1) at the bin edges
    cdf /= cdf[:, -1:]
    out = np.empty((n, 2))
    for j, q in enumerate(((1 - level) / 2, (1 + level) / 2)):
        k = np.clip(np.sum(cdf[:, 1:] < q, axis=1), 0, B - 1)                   # the bin holding quantile q
        lo, hi = cdf[np.arange(n), k], cdf[np.arange(n), k + 1]
        frac = np.where(hi > lo, (q - lo) / np.where(hi > lo, hi - lo, 1.0), 0.5)
        out[:, j] = (k + np.clip(frac, 0.0, 1.0)) * span / B
    return out


def folded(p) -> np.ndarray:
    """Distributions over equal bins of ``[0, 1]`` (n, B) folded onto ``[0, 1/2]`` (n, B // 2): the bins of ``x``
    and ``1 - x`` summed (an odd count's middle bin, which straddles 1/2, goes to the last)."""
    p = np.atleast_2d(np.asarray(p, float))
    h = p.shape[1] // 2
    half = p[:, :h] + p[:, ::-1][:, :h]
    if p.shape[1] % 2:
        half[:, -1] += p[:, h]
    return half


def fit_location_sharpness(logits, x_true, coverage: float = 0.6827, fold: bool = False) -> float:
    """Sharpness ``s`` of the location logits (n, B) whose ``coverage`` intervals hold ``coverage`` of the true places
    ``x_true`` (n,) (``x / L``); the intervals narrow as ``s`` grows, solved by bisection in ``ln s`` over
    [1/20, 20] (an end where even it does not reach the coverage). ``fold``: intervals and places on the half
    ``x <= 1/2`` (:func:`folded`), as a mirrored pair reports them."""
    logits, x_true = np.asarray(logits, float), np.asarray(x_true, float)
    if fold:
        x_true = np.minimum(x_true, 1.0 - x_true)

    def covered(log_s):
        p = softmax(logits, np.exp(log_s))
        iv = distribution_interval(folded(p), coverage, 0.5) if fold else distribution_interval(p, coverage)
        return np.mean((iv[:, 0] <= x_true) & (x_true <= iv[:, 1]))

    lo, hi = np.log(1 / 20), np.log(20.0)
    if covered(hi) >= coverage:
        return float(np.exp(hi))
    if covered(lo) < coverage:
        return float(np.exp(lo))
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if covered(mid) >= coverage else (lo, mid)
    return float(np.exp(lo))
