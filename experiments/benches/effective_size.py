"""The effective number of independent tests of an autocorrelated series, what it does to the spread of false
alarms, and the finite-sample correction of the held-out statistics it implies.

A monitoring series tested every day or every 30 min is autocorrelated (the weather of a few days, the week of one
mounting): its ``n`` tests carry fewer independent draws. For an AR(1) series of lag-1 autocorrelation ``rho`` the
variance of their mean is that of ``n_eff = n (1 - rho) / (1 + rho)`` independent tests (:func:`effective_size`).

* The spread of the false alarms: a detector whose alarms are the exceedances of the ``1 - rate`` quantile of a
  Gaussian AR(1) series alarms on a share of ``n`` tests whose mean is ``rate`` and whose variance grows with
  ``rho`` (:func:`alarm_count_variance`, exact: the indicators' covariances from the bivariate normal law);
  :func:`false_alarm_spread` draws it, with the threshold exact or read from a baseline of the same series.
  Without a model of the series: the alarms come in episodes (:func:`alarm_episodes`), and a detector at the rate
  alarms on a Poisson number of episodes of the sizes seen (:func:`episode_spread`, a compound Poisson count whose
  variance is the binomial's times ``E[S^2] / E[S]``).
* The held-out statistics: a baseline test held out by a model fitted on its neighbours (interleaved folds,
  leave-one-out) is partly in-sample: its deviation from the training centre has the variance
  ``sigma^2 (1 - 1 / n_eff + 2 / n)`` (its neighbours' share of the centre moves with it), a test of a later period
  ``sigma^2 (1 + 1 / n_eff)``; :func:`prediction_inflation` is their ratio (Hotelling's prediction factor with
  ``n_eff`` for ``n``), 1 for an independent series, and :func:`inflate_held` scales each held-out statistic's
  coordinates by it, each coordinate by its own ``n_eff``.
"""

from __future__ import annotations

import math

import numpy as np

from learn.monitor.per_mode import per_mode_index

__all__ = ["alarm_count_variance", "alarm_episodes", "effective_size", "episode_spread", "false_alarm_spread",
           "inflate_held", "lag1_autocorrelation", "prediction_inflation"]


def lag1_autocorrelation(x) -> float:
    """The lag-1 autocorrelation of the series ``x`` (n,): the products of consecutive finite values about the finite
    values' mean over their sum of squares (0 with fewer than 3 finite values or no spread)."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    if ok.sum() < 3:
        return 0.0
    d = np.where(ok, x - x[ok].mean(), 0.0)
    ss = float(d[ok] @ d[ok])
    pair = ok[1:] & ok[:-1]
    if ss <= 0.0 or not pair.any():
        return 0.0
    return float(np.sum(d[1:][pair] * d[:-1][pair]) / ss * ok.sum() / pair.sum())


def effective_size(x) -> float:
    """``n_eff = n (1 - rho) / (1 + rho)`` of the finite values of ``x`` (n,), ``rho`` their
    :func:`lag1_autocorrelation` (the variance of the mean of an AR(1) series is that of ``n_eff`` independent
    values): ``n`` for ``rho <= 0`` (an independent series is unchanged), at least 1."""
    x = np.asarray(x, float)
    n = int(np.isfinite(x).sum())
    rho = lag1_autocorrelation(x)
    if rho <= 0.0:
        return float(n)
    return float(max(n * (1.0 - rho) / (1.0 + rho), 1.0))


def prediction_inflation(n: int, n_eff: float) -> float:
    """``(1 + 1 / n_eff) / (1 - 1 / n_eff + 2 / n)``: the variance of a later test's deviation from the centre of
    ``n`` autocorrelated baseline tests (``n_eff`` effective) over that of a baseline test held out from a model
    fitted on its neighbours (module docstring); 1 when ``n_eff >= n`` (independent tests: a held-out test is a
    new test), ``n_eff`` taken at least 2."""
    if n_eff >= n:
        return 1.0
    m = max(float(n_eff), 2.0)
    return (1.0 + 1.0 / m) / (1.0 - 1.0 / m + 2.0 / n)


def inflate_held(held: dict) -> dict:
    """The held-out statistics ``held`` (:func:`~learn.monitor.statistics.held_out_statistics`: ``{name: (index
    (n,), vectors (n, d) or None)}``) with each coordinate ``j`` of the vectors scaled by ``sqrt(c_j)``,
    ``c_j = prediction_inflation(n, effective_size(coordinate j))``: the index grows by ``sum (c_j - 1) v_j^2`` (the
    residual's missing-mode evidence kept), the per-mode index is the largest scaled square; a statistic without
    vectors is kept."""
    out = {}
    for name, (index, vec) in held.items():
        if vec is None:
            out[name] = (index, vec)
            continue
        n = int(np.isfinite(vec).all(axis=1).sum())
        c = np.array([prediction_inflation(n, effective_size(vec[:, j])) for j in range(vec.shape[1])])
        scaled = vec * np.sqrt(c)
        if name == "mode":
            new = np.where(np.isfinite(index), per_mode_index(scaled), index)
        else:
            new = index + np.nansum((c - 1.0) * vec**2, axis=1)
        out[name] = (new, scaled)
    return out


def alarm_count_variance(n: int, rate: float, rho: float) -> float:
    """The variance of the number of exceedances among ``n`` consecutive values of a stationary Gaussian AR(1)
    series of lag-1 autocorrelation ``rho`` (lag ``k``: ``rho^k``) beyond its ``1 - rate`` quantile:
    ``n p (1 - p) + 2 sum_k (n - k) (P2(rho^k) - p^2)``, ``P2(r)`` the bivariate normal probability of both values
    beyond the quantile at correlation ``r`` (``n p (1 - p)``, the binomial's, for ``rho = 0``). The lags are summed
    until ``rho^k`` falls below 1e-6."""
    from scipy import stats  # scipy.stats: the bivariate normal law, only where the spread is computed

    p = float(rate)
    var = n * p * (1.0 - p)
    if rho <= 0.0 or n < 2:
        return var
    z = stats.norm.isf(p)
    k_max = min(n - 1, int(math.ceil(math.log(1e-6) / math.log(rho))) if rho < 1.0 else n - 1)
    ks = np.arange(1, k_max + 1)
    both = np.array([stats.multivariate_normal(cov=[[1.0, r], [r, 1.0]]).cdf([-z, -z]) for r in rho ** ks])
    return float(var + 2.0 * np.sum((n - ks) * (both - p * p)))


def false_alarm_spread(n_tests: int, rate: float, rho: float, n_baseline: int = 0, draws: int = 2000,
                       seed: int = 0, chunk: int = 100) -> np.ndarray:
    """``draws`` shares of false alarms (draws,) of a detector on ``n_tests`` later tests of a stationary Gaussian
    AR(1) series (lag-1 autocorrelation ``rho``): alarms beyond the exact ``1 - rate`` quantile
    (``n_baseline = 0``), or beyond the ``1 - rate`` quantile at the plotting position ``k / (n + 1)`` of the
    ``n_baseline`` values before them (the threshold read from a baseline of the same series). Seeded."""
    from scipy import signal, stats  # scipy.signal/stats: the AR(1) filter, only where the spread is drawn

    rng = np.random.default_rng(seed)
    n = n_baseline + n_tests
    out = np.empty(draws)
    innovation = math.sqrt(max(1.0 - rho * rho, 0.0))
    exact = float(stats.norm.isf(rate))
    for start in range(0, draws, chunk):
        m = min(chunk, draws - start)
        e = rng.standard_normal((m, n))
        start_state = rho * rng.standard_normal((m, 1))          # x_0 of unit variance: the stationary law
        x = signal.lfilter([innovation], [1.0, -rho], e, axis=1, zi=start_state)[0]
        if n_baseline:
            q = np.quantile(x[:, :n_baseline], 1.0 - rate, axis=1, method="weibull")
        else:
            q = np.full(m, exact)
        out[start:start + m] = np.mean(x[:, n_baseline:] > q[:, None], axis=1)
    return out


def alarm_episodes(alarm, gap: int = 1) -> np.ndarray:
    """The sizes (number of alarmed tests) of the episodes of ``alarm`` (bool (n,)): alarmed tests at most ``gap``
    tests after the previous alarmed one belong to its episode."""
    idx = np.flatnonzero(np.asarray(alarm, bool))
    if not idx.size:
        return np.zeros(0, int)
    starts = np.r_[0, np.flatnonzero(np.diff(idx) > gap) + 1]
    return np.diff(np.r_[starts, idx.size])


def episode_spread(n_tests: int, rate: float, sizes, draws: int = 20000, seed: int = 0) -> np.ndarray:
    """``draws`` shares of false alarms (draws,) over ``n_tests`` tests of a detector exact at ``rate`` whose alarms
    come in episodes of the sizes ``sizes`` (drawn with replacement): a Poisson number of episodes of mean
    ``rate n_tests / mean(sizes)``. Seeded."""
    sizes = np.asarray(sizes, float)
    rng = np.random.default_rng(seed)
    counts = rng.poisson(rate * n_tests / sizes.mean(), draws)
    picks = rng.choice(sizes, counts.sum())
    totals = np.bincount(np.repeat(np.arange(draws), counts), weights=picks, minlength=draws)
    return totals / n_tests
