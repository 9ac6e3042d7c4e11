"""The family's rate calibrated on the union of the statistics' alarms over the held-out baseline tests.

Each held-out baseline test alarms on some statistic from a family level ``s`` on (the per-statistic rates
``r_k = 1 - (1 - s)^(v_k)`` of the shares ``v_k``, :func:`~learn.monitor.statistics.joint_rates`), its *entry level*
``s_i``: the smallest level whose thresholds it exceeds; a small ``s_i`` is an extreme test of the family (the max of
its statistics, each standardised by its own threshold law). The level of the family rate ``rate`` is the entry
levels' ``rate`` quantile at the plotting position ``k / (n + 1)``, as every threshold of
:func:`~learn.monitor.alarm_threshold.threshold` reads its indices: ``t = rate (n + 1)``, between the ``floor(t)``-th
and the next smallest entry level (interpolated in ``ln s``), so that a new test exchangeable with the ``n`` held-out
ones alarms on some statistic with probability ``rate``, whatever the statistics' dependence (the tails
included, which a Gaussian copula of their ranks does not hold) and whatever the fit of each statistic's law (a law
heavier than the indices' tail sets its statistic's threshold above their quantile and leaves part of the rate
unspent; this level spends it).
"""

from __future__ import annotations

import math

import numpy as np

from learn.monitor.alarm_threshold import RESOLUTION, Threshold

__all__ = ["BISECTIONS", "LEVEL_SPAN", "entry_level", "union_level", "union_rates", "value_at"]

#: Bisection steps of an entry level in ``ln s`` (:func:`entry_level`): within ``LEVEL_SPAN`` e-folds / 2^20
#: (1e-5 relative).
BISECTIONS = 20
#: The levels searched: from ``rate e^-LEVEL_SPAN`` to 1/2.
LEVEL_SPAN = 8.0


def _bracket(count, j: int, lo: float, hi: float) -> tuple:
    """``(below, at)``: levels within one bisection step of where ``count`` (non-decreasing) reaches ``j``,
    ``count(below) < j <= count(at)`` (``(lo, lo)`` when it already does at ``lo``, ``(hi, hi)`` when it never does)."""
    if count(lo) >= j:
        return lo, lo
    if count(hi) < j:
        return hi, hi
    a, b = math.log(lo), math.log(hi)
    for _ in range(BISECTIONS):
        mid = 0.5 * (a + b)
        if count(math.exp(mid)) >= j:
            b = mid
        else:
            a = mid
    return math.exp(a), math.exp(b)


def entry_level(count, j: int, lo: float, hi: float) -> float:
    """The smallest family level ``s`` in ``[lo, hi]`` at which ``count(s)`` (held-out tests alarming at ``s``,
    non-decreasing) reaches ``j``, bisected in ``ln s`` (``hi`` when it never does, ``lo`` when it already does)."""
    return _bracket(count, j, lo, hi)[1]


def union_level(count, rate: float, n: int) -> float | None:
    """The family level ``s`` at which a test exchangeable with ``n`` held-out baseline tests alarms on some statistic
    with probability ``rate`` (module docstring): ``count(s)`` the held-out tests alarming at level ``s``
    (non-decreasing); None when ``rate (n + 1) < 1`` (the baseline holds no held-out test at the rate) or when fewer
    than ``floor(rate (n + 1)) + 1`` held-out tests alarm at any level up to 1/2. Held-out tests entering together
    (ties) keep the level below their entry: at most ``floor(rate (n + 1))`` held-out tests alarm."""
    t = rate * (n + 1)
    k = int(math.floor(t))
    lo, hi = rate * math.exp(-LEVEL_SPAN), 0.5
    if k < 1 or count(hi) < k + 1:
        return None
    below_k, s_k = _bracket(count, k, lo, hi)
    below, s_next = _bracket(count, k + 1, s_k, hi)
    if s_next <= s_k:                                   # the k-th and the next enter together
        return below_k
    s = math.exp(math.log(s_k) + (t - k) * (math.log(s_next) - math.log(s_k)))
    return min(s, below)


def union_rates(count_at_rates, weights, rate: float, n: int) -> np.ndarray | None:
    """Per-statistic rates ``r_k = 1 - (1 - s)^(v_k)`` (K,), ``v = weights / max(weights)``, at the level ``s`` of
    :func:`union_level`; ``count_at_rates(r)`` the held-out tests alarming on some statistic at the rates ``r`` (K,).
    None where :func:`union_level` is."""
    w = np.asarray(weights, float)
    v = w / w.max()

    def rates(s):
        return -np.expm1(v * math.log1p(-s))

    s = union_level(lambda s: count_at_rates(rates(s)), rate, n)
    return None if s is None else rates(s)


def value_at(t: Threshold, held, rate: float, side_share: float = 1.0) -> float:
    """The value of :func:`~learn.monitor.alarm_threshold.threshold` at another rate ``rate``, its law's scale kept:
    ``t`` the threshold of the held-out indices ``held`` (one side's, this share of the tests, with ``side_share``)
    at some rate; the scale of the law does not depend on the rate, so the level's search refits nothing."""
    s = np.asarray(held, float)
    s = s[np.isfinite(s)]
    if not s.size:
        return math.inf
    empirical = float(np.quantile(s, 1 - min(rate / max(side_share, 1e-12), 0.5), method="weibull"))
    if t.scale == 0.0:
        return max(empirical, RESOLUTION * float(np.max(np.abs(s))), np.finfo(float).tiny)
    level = 1 - min(rate / max(side_share * (1.0 - t.zero_share), 1e-12), 0.5)
    return max(t.law_at(level), empirical)
