"""The family's level calibrated on the union of the held-out alarms (learn.monitor.union_calibration): the entry
levels' quantile at the plotting position against its closed form, the weighted Šidák split of independent
statistics, and the family-wise rate of the detector on new Gaussian draws within the binomial limits of a
conformal quantile."""

import math

import numpy as np
import pytest
from scipy import stats

from learn.monitor.normal_models import PCARemoval
from learn.monitor.statistics import DEFAULT_STATISTICS, SHARES, detect
from learn.monitor.alarm_threshold import threshold
from learn.monitor.union_calibration import entry_level, union_level, union_rates, value_at


def test_the_level_is_the_plotting_position_quantile_of_the_entry_levels():
    """Entry levels known: ``count(s) = #{s_i <= s}``; with ``t = rate (n + 1) = 3.5`` the level lies halfway in
    ``ln s`` between the third and the fourth smallest."""
    levels = np.sort(np.random.default_rng(3).uniform(1e-3, 0.4, 349))
    count = lambda s: int(np.sum(levels <= s))                                  # noqa: E731
    assert entry_level(count, 3, 1e-5, 0.5) == pytest.approx(levels[2], rel=2e-5)       # 20 bisections
    s = union_level(count, 0.01, 349)
    assert s == pytest.approx(math.sqrt(levels[2] * levels[3]), rel=2e-5)
    assert union_level(count, 0.01, 80) is None                               # rate (n + 1) < 1: no quantile


def test_independent_statistics_give_the_weighted_sidak_split():
    """Four independent uniform p-values per held-out test at shares 1 : 0.25 : 2 : 0.25: the union alarms on a test
    when some ``p_k < r_k``; the level's rates satisfy ``prod (1 - r_k) = 1 - rate`` within the binomial error of
    ``rate`` from 40 000 tests, each rate ``1 - (1 - s)^(v_k)`` of its share."""
    n, rate = 40_000, 0.01
    P = np.random.default_rng(4).uniform(size=(n, 4))
    w = [SHARES[nm] for nm in DEFAULT_STATISTICS]
    assert w == [1.0, 0.25, 2.0, 0.25]
    r = union_rates(lambda r: int((P < r).any(axis=1).sum()), w, rate, n)
    union = 1 - np.prod(1 - r)
    assert abs(union - rate) < 4 * math.sqrt(rate * (1 - rate) / n)
    np.testing.assert_allclose(np.log1p(-r) / np.log1p(-r[2]), [0.5, 0.125, 1.0, 0.125], rtol=1e-9)  # 1 - (1 - s)^v_k


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_detector_holds_the_family_rate_on_new_gaussian_draws(seed):
    """iid Gaussian baseline (four features, one removed component) of 1000 tests: the union's level puts new
    draws of the same law beyond some statistic at the rate within the limits of a conformal quantile (its
    exceedance Beta(k, n + 1 - k) with ``k = rate (n + 1)``, 4 standard deviations, plus the binomial error of
    the 40 000 new draws), and its held-out union at ``floor(rate (n + 1))`` tests."""
    rng = np.random.default_rng(40 + seed)
    nb, rate = 1000, 0.05
    X = rng.standard_normal((nb + 40_000, 4)) * np.array([3.0, 1.0, 0.8, 0.6])
    model = PCARemoval(1).fit(X[:nb])
    det = detect(model, lambda: PCARemoval(1), X, None, np.arange(nb), np.arange(nb, len(X)), rate)
    assert det.calibration == "union" and det.names == DEFAULT_STATISTICS
    k = rate * (nb + 1)
    sd = math.sqrt(stats.beta(k, nb + 1 - k).var() + rate * (1 - rate) / (len(X) - nb))
    assert abs(det.alarm[nb:].mean() - rate) < 4 * sd
    assert det.alarm[:nb].sum() == math.floor(k)


@pytest.mark.parametrize("tail_share, side_share", [(1.0, 1.0), (0.25, 1.0), (1.0, 0.4)])
def test_value_at_another_rate_is_the_threshold_refitted_at_it(tail_share, side_share):
    """The law's scale does not depend on the rate: the value read at another rate equals the threshold fitted at
    it, in the law's range and in the empirical quantile's (with a point mass of zeros)."""
    rng = np.random.default_rng(5)
    held = np.r_[3.0 * rng.f(2, 60, 400), np.zeros(20)]
    t = threshold(held, 0.01, 2, 60, tail_share=tail_share, side_share=side_share)
    for rate in (0.001, 0.004, 0.02, 0.08):
        refit = threshold(held, rate, 2, 60, tail_share=tail_share, side_share=side_share)
        assert value_at(t, held, rate, side_share) == pytest.approx(refit.value, rel=1e-6)


def test_tests_entering_together_keep_the_level_below_them():
    """The third and the fourth held-out tests enter at one level: ``t = 3.5`` would put the level there, where
    four alarm; it stays below, where two do."""
    levels = np.sort(np.r_[np.random.default_rng(6).uniform(0.05, 0.4, 345), [0.002, 0.004, 0.01, 0.01]])
    count = lambda s: int(np.sum(levels <= s))                                  # noqa: E731
    s = union_level(count, 0.01, 349)
    assert count(s) == 2 and s == pytest.approx(0.01, rel=2e-5)
