"""The network's 68 % / 95 % intervals (learn.network.intervals) against closed forms."""

import numpy as np
import pytest
from scipy.stats import norm

from learn.network.intervals import (
    LEVELS,
    distribution_interval,
    fit_curves,
    fit_location_sharpness,
    folded,
    level_distributions,
    level_intervals,
    read_curves,
    sharpness_at,
    softmax,
    spread,
)


def test_a_uniform_distribution_has_the_uniform_quantiles():
    p = np.full((1, 80), 1 / 80)
    assert distribution_interval(p, 0.6827)[0] == pytest.approx([0.15865, 0.84135], abs=1e-12)
    assert distribution_interval(p, 0.95, span=0.5)[0] == pytest.approx([0.0125, 0.4875], abs=1e-12)


def test_a_binned_normal_has_the_normal_quantiles_to_a_bin():
    B = 400
    c = (np.arange(B) + 0.5) / B
    mu, sd = np.array([0.3, 0.55]), np.array([0.05, 0.1])
    p = norm.cdf((c[None] + 0.5 / B - mu[:, None]) / sd[:, None]) - norm.cdf((c[None] - 0.5 / B - mu[:, None])
                                                                              / sd[:, None])
    p /= p.sum(axis=1, keepdims=True)
    for level, z in ((LEVELS["68"], 1.0), (LEVELS["95"], 1.959964)):
        iv = distribution_interval(p, level)
        assert iv[:, 0] == pytest.approx(mu - z * sd, abs=1 / B)
        assert iv[:, 1] == pytest.approx(mu + z * sd, abs=1 / B)


def test_all_mass_in_one_bin_gives_that_bin():
    p = np.zeros((1, 10))
    p[0, 3] = 1.0
    lo, hi = distribution_interval(p, 0.95)[0]
    assert 0.3 <= lo < hi <= 0.4


def test_the_sharpness_undoes_a_distribution_too_wide_by_a_known_factor():
    """Logits of a normal k times wider than the scatter of the true places: the fitted sharpness is k^2 (logits
    scale as 1 / sigma^2), within the sampling of 3000 places."""
    rng = np.random.default_rng(0)
    B, n, sd, k = 200, 3000, 0.04, 2.5
    c = (np.arange(B) + 0.5) / B
    mu = rng.uniform(0.25, 0.75, n)
    x = mu + sd * rng.standard_normal(n)
    logits = -0.5 * ((c[None] - mu[:, None]) / (k * sd)) ** 2
    s = fit_location_sharpness(logits, x)
    assert s == pytest.approx(k**2, rel=0.1)
    iv = distribution_interval(softmax(logits, s), LEVELS["95"])
    assert np.mean((iv[:, 0] <= x) & (x <= iv[:, 1])) == pytest.approx(0.95, abs=0.015)


def test_a_mirrored_network_is_calibrated_on_the_folded_half():
    """Distributions with two equal peaks at x and 1 - x, each twice as wide as the places' scatter (a symmetric
    beam read on frequencies): folded onto x <= 1/2, the fitted sharpness undoes the width and the folded
    intervals hold 68 % of the folded places."""
    rng = np.random.default_rng(1)
    B, n, sd = 200, 3000, 0.03
    c = (np.arange(B) + 0.5) / B
    mu = rng.uniform(0.1, 0.4, n)
    x = np.where(rng.random(n) < 0.5, mu, 1 - mu) + sd * rng.standard_normal(n)
    logits = np.logaddexp(-0.5 * ((c[None] - mu[:, None]) / (2 * sd)) ** 2,
                          -0.5 * ((c[None] - 1 + mu[:, None]) / (2 * sd)) ** 2)
    s = fit_location_sharpness(logits, x, fold=True)
    assert s == pytest.approx(4.0, rel=0.15)                  # the peaks twice too wide: k^2 = 4
    iv = distribution_interval(folded(softmax(logits, s)), LEVELS["68"], 0.5)
    xf = np.minimum(x, 1 - x)
    assert np.mean((iv[:, 0] <= xf) & (xf <= iv[:, 1])) == pytest.approx(0.6827, abs=0.01)
    assert np.all(iv[:, 1] <= 0.5)
    assert folded(np.full((1, 5), 0.2))[0] == pytest.approx([0.4, 0.6])


def _normal_logits(mu, width, B=200):
    c = (np.arange(B) + 0.5) / B
    return -0.5 * ((c[None] - mu[:, None]) / width[:, None]) ** 2


def test_the_sharpness_follows_the_spread_where_one_factor_cannot_cover_both_kinds_of_pair():
    """Two kinds of pair: distributions 3 times too wide for places scattered 0.01 (sharpness 9 undoes them) and
    distributions as wide as the scatter of 0.06 (sharpness 1). One sharpness for all over-covers one kind and
    under-covers the other; the curve over the spread covers each about as the level says."""
    rng = np.random.default_rng(2)
    n = 4000
    hard = rng.random(n) < 0.5
    sd = np.where(hard, 0.06, 0.01)
    mu = rng.uniform(0.3, 0.7, n)
    x = mu + sd * rng.standard_normal(n)
    logits = _normal_logits(mu, np.where(hard, 1.0, 3.0) * sd)

    def coverage(p, level):
        iv = distribution_interval(p, level)
        inside = (iv[:, 0] <= x) & (x <= iv[:, 1])
        return inside[~hard].mean(), inside[hard].mean()

    one = coverage(softmax(logits, fit_location_sharpness(logits, x)), LEVELS["68"])
    assert one[0] > 0.8 and one[1] < 0.6
    curves = fit_curves(logits, x)
    assert np.exp(curves["68"]["ln_sharpness"][0]) == pytest.approx(9.0, rel=0.15)
    assert np.exp(curves["68"]["ln_sharpness"][-1]) == pytest.approx(1.0, rel=0.15)
    dists = level_distributions([curves], logits)
    for k, level in LEVELS.items():
        assert coverage(dists[k], level) == pytest.approx((level, level), abs=0.035)


def test_each_level_has_its_own_sharpness_when_the_errors_have_heavy_tails():
    """Places 0.01 from the distribution's centre for 90 % of the pairs and anywhere on the beam for 10 %: the
    68 % level needs a sharper distribution than the 95 %, and each level's interval covers as it says; the 95 %
    interval holds the 68 % one."""
    rng = np.random.default_rng(3)
    n = 3000
    mu = rng.uniform(0.2, 0.8, n)
    x = np.where(rng.random(n) < 0.9, mu + 0.01 * rng.standard_normal(n), rng.uniform(0, 1, n))
    logits = _normal_logits(mu, np.full(n, 0.05))
    curves = fit_curves(logits, x)
    assert curves["68"]["ln_sharpness"][0] > curves["95"]["ln_sharpness"][0] + 1.0
    iv = level_intervals(level_distributions([curves], logits))
    for k, level in LEVELS.items():
        assert np.mean((iv[k][:, 0] <= x) & (x <= iv[k][:, 1])) == pytest.approx(level, abs=0.02)
    assert np.all(iv["95"][:, 0] <= iv["68"][:, 0]) and np.all(iv["68"][:, 1] <= iv["95"][:, 1])


def test_a_saved_single_sharpness_reads_as_constant_curves():
    (curves,) = read_curves(2.5)
    logits = _normal_logits(np.array([0.3, 0.5]), np.array([0.01, 0.2]))
    for k in LEVELS:
        assert sharpness_at(curves[k], logits) == pytest.approx([2.5, 2.5])
    one = {k: {"ln_spread": [0.0, 1.0], "ln_sharpness": [1.0, 0.0]} for k in LEVELS}
    assert read_curves(one) == [one] and read_curves([one, one]) == [one, one]
    # a row answers on the curves of its group (its number of missing modes)
    d = level_distributions(read_curves([1.0, 4.0]), np.vstack([logits[:1], logits[:1]]), group=[0, 1])
    assert d["68"][1] == pytest.approx(softmax(logits[:1], 4.0)[0])
    assert d["95"][0] == pytest.approx(softmax(logits[:1], 1.0)[0])
    assert spread(np.zeros((1, 80)))[0] == pytest.approx(np.sqrt(1 / 12), rel=1e-9)      # a uniform one
