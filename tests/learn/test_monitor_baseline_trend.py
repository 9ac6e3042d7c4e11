"""The trend test of the baseline period (learn.monitor.baseline_trend)."""

import numpy as np
import pytest
from scipy.stats import binom

from learn.monitor.baseline_trend import MIN_TESTS, TREND_RATE, baseline_trend, series_baseline_trend


def test_a_linear_drift_of_one_mode_is_named_with_its_size():
    rng = np.random.default_rng(0)
    n = 15
    X = np.log([740.0, 4400.0, 5300.0]) + 1e-4 * rng.standard_normal((n, 3))
    X[:, 0] += np.linspace(0.0, -0.0075, n)            # mode 1 falls 0.75 % over the period, 1e-4 noise
    t = baseline_trend(X)
    assert t.drifting == [1]
    # noise-free: the medians of the first and last five tests are tests 2 and 12 of 0..14: 10/14 of the fall
    assert t.change_pct[0] == pytest.approx(100 * np.expm1(-0.0075 * 10 / 14), abs=0.03)
    assert t.rho[0] < -0.9 and t.p_value[0] < TREND_RATE / 3
    assert "mode 1 falls" in t.warning and "mode 2" not in t.warning


def test_gaussian_baselines_warn_at_most_at_the_family_rate():
    rng = np.random.default_rng(1)
    draws = 200
    warned = sum(bool(baseline_trend(rng.standard_normal((20, 4))).drifting) for _ in range(draws))
    assert warned <= binom.ppf(0.999, draws, TREND_RATE)


def test_a_season_that_closes_in_the_period_or_a_small_trend_is_no_drift():
    n = 365
    day = np.arange(n)
    rng = np.random.default_rng(2)
    season = -0.004 * np.cos(2 * np.pi * day / n)          # a year beginning in winter
    assert not baseline_trend((season + 1e-4 * rng.standard_normal(n))[:, None]).drifting
    # significant (Spearman) but smaller than a standard deviation between the thirds
    small = np.linspace(0.0, 1.0, 2000) + 2.0 * rng.standard_normal(2000)
    t = baseline_trend(small[:, None])
    assert t.p_value[0] < TREND_RATE and abs(t.size_sd[0]) < 1 and not t.drifting


def test_too_few_tests_of_a_mode_are_not_tested():
    X = np.log(np.c_[np.linspace(700, 690, MIN_TESTS - 1), np.linspace(700, 690, MIN_TESTS - 1)])
    X[0, 1] = np.nan
    t = baseline_trend(X)
    assert t.rho == [None, None] and not t.drifting and t.warning is None


def _rows(freqs, change=None):
    return [{"baseline": True, "identified": True, "frequencies_hz": list(f),
             "change_pct": list(change[i]) if change is not None else [0.0] * len(f)}
            for i, f in enumerate(freqs)]


def test_the_series_rows_are_tested_on_frequencies_or_on_residuals_about_the_conditions():
    f = np.c_[np.linspace(740, 733, 15), np.full(15, 4400.0)]
    assert series_baseline_trend(_rows(f), "pca").drifting == [1]
    # the conditions explain the course: residuals about their prediction are flat
    flat = 1e-3 * np.sin(np.arange(15))[:, None] * np.ones((1, 2))
    assert series_baseline_trend(_rows(f, flat), "regression").drifting == []
    t = series_baseline_trend(_rows(f), "pca", covers_seasons=True)
    assert t.drifting == [] and t.about.startswith("not tested")
