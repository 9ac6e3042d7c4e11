"""The 68 % and 95 % intervals of the network's location and size, and the calibration that makes them cover.

The location head gives a distribution over ``n_bins`` equal bins of ``x / L`` (softmax of its logits); its
interval at ``level`` is the equal-tailed one, ``[Q((1 - level) / 2), Q((1 + level) / 2)]`` of the distribution's
quantile function ``Q`` (linear within a bin: each bin's probability spread evenly over it).

Each level has its own sharpness ``s``, the logits' factor that makes its interval hold that share of the true
places on the validation pairs: the soft location targets of training (a Gaussian of ``loc_sigma_bins``) widen the
distribution beyond what the data leave uncertain, and the errors are not Gaussian (most pairs placed far better
than the distribution says, a few on a wrong peak), so one factor cannot make both levels cover. The sharpness also
depends on how hard a pair is to place: the validation pairs are split into :data:`SHARPNESS_GROUPS` groups by the
spread (std) of their raw distribution, a sharpness is fitted per group, and a pair's sharpness is interpolated in
``ln`` between the groups' median spreads (:func:`fit_sharpness_curve`, :func:`sharpness_at`); one factor for all
leaves the well-placed pairs' intervals too wide and the hard ones' too narrow.

The size's interval is ``inverse(t -+ z sigma_t)`` of its transform
(:class:`learn.network.size.SizeTransform`, monotone), with ``z`` the normal quantile of the level; its ``sigma_t`` is
scaled on the validation pairs (:func:`learn.network.size.fit_size_std_scale`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LEVELS", "SHARPNESS_GROUPS", "Z_OF_LEVEL", "constant_curve", "distribution_interval", "fit_curves",
           "fit_location_sharpness", "fit_sharpness_curve", "folded", "level_distributions", "level_intervals",
           "read_curves",
           "sharpness_at", "softmax", "spread"]

#: The intervals reported (name: level) and the standard normal quantile of each level (two-sided).
LEVELS = {"68": 0.6827, "95": 0.95}
Z_OF_LEVEL = {"68": 1.0, "95": 1.959964}

#: Groups of validation pairs, by the spread of their raw distribution, each with its own sharpness, and the
#: fewest pairs a group holds (fewer groups where the pairs are fewer).
SHARPNESS_GROUPS, MIN_GROUP_PAIRS = 3, 40


def softmax(logits, sharpness=1.0) -> np.ndarray:
    """Row-wise softmax of ``sharpness * logits`` (n, B); ``sharpness`` a scalar or one per row (n,)."""
    s = np.asarray(sharpness, float)
    z = np.asarray(logits, float) * (s[:, None] if s.ndim == 1 else s)
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


def spread(logits, fold: bool = False) -> np.ndarray:
    """Std (n,) of the raw distributions ``softmax(logits)`` over ``x / L`` (folded onto ``x <= 1/2`` with
    ``fold``), a bin's width included: how hard the network finds each pair to place."""
    p = softmax(logits)
    p = folded(p) if fold else p
    c = (np.arange(p.shape[1]) + 0.5) / p.shape[1] * (0.5 if fold else 1.0)
    mean = p @ c
    return np.sqrt(np.maximum(p @ c**2 - mean**2, 0.0) + (c[0] * 2) ** 2 / 12)


def fit_sharpness_curve(logits, x_true, coverage: float = 0.6827, fold: bool = False,
                        groups: int = SHARPNESS_GROUPS) -> dict:
    """The sharpness of the location logits (n, B) as a function of their raw :func:`spread`, fitted so that the
    ``coverage`` intervals of each group of pairs (equal counts by spread, at least :data:`MIN_GROUP_PAIRS` each)
    hold ``coverage`` of its true places ``x_true`` (n,).

    Returns
    -------
    dict: ``ln_spread`` (G,), the median log spread of each group (increasing), and ``ln_sharpness`` (G,), its
    fitted log sharpness; :func:`sharpness_at` interpolates between them.
    """
    logits, x_true = np.asarray(logits, float), np.asarray(x_true, float)
    g = int(max(1, min(groups, len(x_true) // MIN_GROUP_PAIRS)))
    ln_w = np.log(spread(logits, fold))
    order = np.argsort(ln_w, kind="stable")
    parts = np.array_split(order, g)
    return {"ln_spread": [float(np.median(ln_w[i])) for i in parts],
            "ln_sharpness": [float(np.log(fit_location_sharpness(logits[i], x_true[i], coverage, fold)))
                             for i in parts]}


def constant_curve(sharpness: float) -> dict:
    """A sharpness curve that gives every pair ``sharpness``."""
    return {"ln_spread": [0.0], "ln_sharpness": [float(np.log(sharpness))]}


def sharpness_at(curve: dict, logits, fold: bool = False) -> np.ndarray:
    """Each row's sharpness (n,) from a curve of :func:`fit_sharpness_curve`: ``ln s`` interpolated linearly in the
    log spread between the groups, constant beyond the first and last."""
    return np.exp(np.interp(np.log(spread(logits, fold)), curve["ln_spread"], curve["ln_sharpness"]))


def fit_curves(logits, x_true, fold: bool = False) -> dict:
    """One sharpness curve per level of :data:`LEVELS` (:func:`fit_sharpness_curve`)."""
    return {k: fit_sharpness_curve(logits, x_true, level, fold) for k, level in LEVELS.items()}


def read_curves(saved) -> list:
    """The curves of :func:`fit_curves` as a model file holds them: a list (one per number of missing modes) of
    level -> curve; one such dict, or a single number (one sharpness for every pair and level), read as one."""
    if isinstance(saved, list):
        return [read_curves(v)[0] for v in saved]
    if np.isscalar(saved):
        return [{k: constant_curve(float(saved)) for k in LEVELS}]
    return [{k: {"ln_spread": [float(v) for v in saved[k]["ln_spread"]],
                 "ln_sharpness": [float(v) for v in saved[k]["ln_sharpness"]]} for k in LEVELS}]


def level_distributions(curves: list, logits, fold: bool = False, group=None) -> dict:
    """Each level's distributions (n, B): ``softmax`` of the logits (n, B) at each row's sharpness of that level,
    from the curves (level -> curve) ``curves[group[i]]`` of row ``i`` (``group`` (n,) int; default all 0)."""
    logits = np.atleast_2d(np.asarray(logits, float))
    group = np.zeros(len(logits), int) if group is None else np.asarray(group, int)
    s = {k: np.ones(len(logits)) for k in LEVELS}
    for g in np.unique(group):
        rows = group == g
        for k in LEVELS:
            s[k][rows] = sharpness_at(curves[g][k], logits[rows], fold)
    return {k: softmax(logits, s[k]) for k in LEVELS}


def level_intervals(distributions: dict, fold: bool = False) -> dict:
    """Each level's interval (n, 2) of ``x / L`` from its own distributions (level -> (n, B)), on the half
    ``x <= 1/2`` with ``fold`` (:func:`folded`); a wider level's interval holds every narrower one's (each level's
    sharpness is its own, so nesting is not given otherwise)."""
    out = {}
    for k, level in sorted(LEVELS.items(), key=lambda kv: kv[1]):
        p = folded(distributions[k]) if fold else np.atleast_2d(np.asarray(distributions[k], float))
        iv = distribution_interval(p, level, 0.5 if fold else 1.0)
        if out:
            inner = out[max(out, key=LEVELS.get)]
            iv = np.stack([np.minimum(iv[:, 0], inner[:, 0]), np.maximum(iv[:, 1], inner[:, 1])], axis=1)
        out[k] = iv
    return out
