"""The effective sample size of an autocorrelated series, the spread of its false alarms and the held-out
statistics' prediction factor (experiments.benches.effective_size) against closed forms."""

import numpy as np
import pytest
from scipy import signal, stats

from experiments.benches.effective_size import (alarm_count_variance, alarm_episodes, effective_size, episode_spread,
                                          false_alarm_spread, inflate_held, lag1_autocorrelation,
                                          prediction_inflation)


def _ar1(rho, n, seed):
    e = np.random.default_rng(seed).standard_normal(n)
    return signal.lfilter([np.sqrt(1 - rho**2)], [1.0, -rho], e)


def test_ar1_effective_size_is_the_closed_form():
    n, rho = 200_000, 0.6
    x = _ar1(rho, n, 3)
    assert lag1_autocorrelation(x) == pytest.approx(rho, abs=0.01)
    assert effective_size(x) == pytest.approx(n * (1 - rho) / (1 + rho), rel=0.03)      # 50 000


def test_independent_series_is_unchanged():
    x = np.tile([1.0, -1.0], 500) + 0.01 * np.random.default_rng(0).standard_normal(1000)   # rho < 0
    assert effective_size(x) == 1000.0
    assert prediction_inflation(1000, effective_size(x)) == 1.0
    w = np.random.default_rng(1).standard_normal(5000)                                   # white noise
    assert prediction_inflation(5000, effective_size(w)) == pytest.approx(1.0, abs=2e-5)


def test_nan_gaps_are_skipped():
    x = _ar1(0.8, 20_000, 4)
    x[::7] = np.nan
    assert lag1_autocorrelation(x) == pytest.approx(0.8, abs=0.02)


def test_prediction_inflation_closed_form():
    assert prediction_inflation(100, 10) == pytest.approx(1.1 / (0.9 + 0.02))
    assert prediction_inflation(100, 100) == 1.0
    assert prediction_inflation(100, 0.5) == pytest.approx(1.5 / (0.5 + 0.02))          # n_eff at least 2


def test_inflate_held_scales_each_coordinate_by_its_own_factor():
    n = 400
    a, b = _ar1(0.9, n, 5), np.tile([1.0, -1.0], n // 2)
    V = np.column_stack([a, b])
    held = {"residual": (np.sum(V**2, axis=1) + 0.5, V), "shift": (a**2, a[:, None]),
            "mode": (np.max(V**2, axis=1), V), "plain": (np.ones(n), None)}
    out = inflate_held(held)
    c = prediction_inflation(n, n * (1 - lag1_autocorrelation(a)) / (1 + lag1_autocorrelation(a)))
    assert c > 1.05
    np.testing.assert_allclose(out["shift"][0], c * a**2)
    np.testing.assert_allclose(out["residual"][0], c * a**2 + b**2 + 0.5)               # b alternates: unchanged
    np.testing.assert_allclose(out["mode"][0], np.maximum(c * a**2, b**2))
    np.testing.assert_allclose(out["residual"][1], np.column_stack([np.sqrt(c) * a, b]))
    assert out["plain"][0] is held["plain"][0]


def test_alarm_count_variance():
    assert alarm_count_variance(365, 0.01, 0.0) == pytest.approx(365 * 0.01 * 0.99)
    shares = false_alarm_spread(500, 0.01, 0.8, draws=6000, seed=7)
    assert np.mean(shares) == pytest.approx(0.01, abs=0.0008)
    assert np.var(shares * 500) == pytest.approx(alarm_count_variance(500, 0.01, 0.8), rel=0.1)


def test_false_alarm_spread_independent_is_binomial_and_beta_binomial():
    exact = false_alarm_spread(365, 0.01, 0.0, draws=10_000, seed=1)
    assert np.mean(exact > 0.02) == pytest.approx(stats.binom.sf(7, 365, 0.01), abs=0.006)     # 3.2 %
    # a baseline of 399: the threshold is its 4th largest, exceeded with a Beta(4, 396) share
    base = false_alarm_spread(200, 0.01, 0.0, n_baseline=399, draws=10_000, seed=2)
    assert np.mean(base > 0.02) == pytest.approx(stats.betabinom.sf(4, 200, 4, 396), abs=0.012)


def test_alarm_episodes():
    a = np.zeros(20, bool)
    a[[2, 3, 5, 9, 10, 11, 19]] = True
    np.testing.assert_array_equal(alarm_episodes(a, 1), [2, 1, 3, 1])
    np.testing.assert_array_equal(alarm_episodes(a, 2), [3, 3, 1])
    assert alarm_episodes(np.zeros(5, bool)).size == 0


def test_episode_spread_single_tests_is_poisson_and_pairs_double_the_variance():
    single = episode_spread(365, 0.01, [1], draws=40_000, seed=3)
    assert np.mean(single > 0.02) == pytest.approx(stats.poisson.sf(7, 3.65), abs=0.004)
    pairs = episode_spread(365, 0.01, [2], draws=40_000, seed=4)                 # 2 x Poisson(1.825)
    assert np.mean(pairs) == pytest.approx(0.01, abs=2e-4)
    assert np.var(pairs * 365) == pytest.approx(2 * 3.65, rel=0.03)
    assert np.mean(pairs > 0.02) == pytest.approx(stats.poisson.sf(3, 1.825), abs=0.005)
