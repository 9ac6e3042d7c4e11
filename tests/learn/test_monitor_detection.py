"""The detector's statistics (learn.monitor.statistics) and memory charts (learn.monitor.charts) against closed
forms: Hotelling's law of T^2, the family-wise rate of the combination, the stationary variance of an EWMA of
AR(1) data, and the onset of a step."""

import math

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from learn.monitor import IdentificationSettings, read_conditions
from learn.monitor.alarms import monitor_series
from learn.monitor.charts import chart_limit, ewma_chart, onset, run_charts
from learn.monitor.alarm_threshold import threshold
from learn.monitor.normal_models import PCARemoval
from learn.monitor.statistics import SHARES, detect, shift_fraction, shift_weights, sidak_rate, statistics_of
from physics.errors import ConfigError
from monitor_series import write_modal_series


def _gaussian(rng, n, sd=(3.0, 2.0, 1.0, 0.5)):
    return rng.standard_normal((n, len(sd))) * np.asarray(sd)


def test_environmental_t2_of_new_gaussian_tests_follows_hotelling():
    """A new test's T^2 in k components of n baseline tests: k (n+1)(n-1) / (n (n-k)) F(k, n-k)."""
    rng = np.random.default_rng(11)
    n, k = 200, 2
    rates = []
    for _ in range(10):
        model = PCARemoval(k).fit(_gaussian(rng, n))
        t2 = statistics_of(model, _gaussian(rng, 5000))["environment"][0]
        law = k * (n + 1) * (n - 1) / (n * (n - k)) * stats.f(k, n - k).ppf(0.95)
        rates.append(np.mean(t2 > law))
    assert 0.04 < np.mean(rates) < 0.06


def _detected(X, nb, rate, make=lambda: PCARemoval(2)):
    model = make().fit(X[:nb])
    return detect(model, make, X, None, np.arange(nb), np.arange(nb, len(X)), rate)


def test_the_combination_holds_the_family_wise_rate_on_null_data():
    rng = np.random.default_rng(12)
    rates, alone, each = [], [], []
    for _ in range(6):
        det = _detected(_gaussian(rng, 2300), 300, 0.05)
        assert det.names == ("residual", "environment", "shift", "mode")
        v = np.array([SHARES[nm] for nm in det.names]) / max(SHARES[nm] for nm in det.names)
        s = -np.expm1(np.log1p(-det.rate_each) / v)             # r_k = 1 - (1 - s)^(v_k): one s for all
        assert np.ptp(s) < 1e-12
        assert det.calibration == "union" and det.alarm[:300].sum() == 15   # the union's level: floor(5 % of 301)
        assert 1 - 0.95 ** (1 / v.sum()) < 1.5 * s[0] and s[0] < 1.5 * 0.05    # about the weighted Sidak split
        rates.append(det.alarm[300:].mean())
        alone.append((det.ratios[300:] > 1).mean(axis=0))
        each.append(det.rate_each)
    assert 0.025 < np.mean(rates) <= 0.06                       # any of four: 5 %
    np.testing.assert_array_less(np.mean(alone, axis=0), 1.3 * np.mean(each, axis=0))


def test_a_shift_along_the_top_environmental_component_is_seen_by_the_combination_not_the_residual():
    rng = np.random.default_rng(13)
    X = _gaussian(rng, 600)
    X[300:, 0] += 6 * 3.0                                       # 6 sd along the first (removed) component
    det = _detected(X, 300, 0.01)
    residual = det.values[300:, 0] > det.thresholds[0].value
    assert det.alarm[300:].mean() > 0.9
    assert residual.mean() < 0.03


def _factor_cov(a, d):
    """``a 1 1^T + diag(d)``: a common factor (the temperature) plus each mode's own scatter."""
    return a * np.ones((len(d), len(d))) + np.diag(d)


def test_the_shift_weights_are_the_inverse_variances_within_a_percent_of_the_gls_bound():
    """For a change common to the modes the generalised least squares' signal-to-noise ratio is
    ``sqrt(1^T cov^-1 1)``, on ``cov = a 1 1^T + D`` (Sherman-Morrison) ``sqrt(s / (1 + a s))``, ``s = sum 1 / D_ii``,
    its weights ``D^-1 1``; the shift's inverse variances ``1 / (a + D_ii)`` give ``1 / sqrt(w^T cov w)``: the bound
    itself without the common factor, within 1 % with a dominant one (the series' temperature), and equal weights
    fall 30 % short when one mode scatters 30 times more than the others."""
    d = np.array([1.0, 2.0, 4.0, 30.0]) * 1e-8
    s = np.sum(1.0 / d)
    for a in (0.0, 1e-6, 1e-5):
        cov = _factor_cov(a, d)
        w = shift_weights(cov)
        np.testing.assert_allclose(w, (1 / (a + d)) / np.sum(1 / (a + d)), rtol=1e-12)
        gls = np.linalg.solve(cov, np.ones(4))
        np.testing.assert_allclose(gls / gls.sum(), (1 / d) / s, rtol=1e-9)          # the direction D^-1 1
        bound = math.sqrt(s / (1 + a * s))
        assert math.sqrt(np.ones(4) @ np.linalg.solve(cov, np.ones(4))) == pytest.approx(bound, rel=1e-9)
        snr = 1.0 / math.sqrt(w @ cov @ w)
        assert snr <= bound * (1 + 1e-12)
        assert snr == pytest.approx(bound, rel=1e-12 if a == 0 else 0.01)
    e = np.full(4, 0.25)
    assert 1.0 / math.sqrt(e @ np.diag(d) @ e) < 0.7 * math.sqrt(s)


def test_the_shift_statistic_is_the_weighted_change_over_its_closed_form_sd():
    """New Gaussian tests of ``cov`` about the baseline's mean: the shift's ``z`` is ``w . (x - mean)`` over
    ``sqrt(w^T cov w)`` exactly (:func:`shift_fraction` its numerator), so its standard deviation is 1 within the
    sampling error of 20 000 tests, and a common change ``delta`` of every ``ln f`` moves it by
    ``delta / sqrt(w^T cov w)``."""
    rng = np.random.default_rng(21)
    cov = _factor_cov(4e-6, np.array([1.0, 2.0, 4.0, 30.0]) * 1e-8)
    L = np.linalg.cholesky(cov)
    model = PCARemoval().fit(rng.standard_normal((20000, 4)) @ L.T)
    X = rng.standard_normal((20000, 4)) @ L.T
    w = shift_weights(model.cov_)
    sd = math.sqrt(w @ model.cov_ @ w)
    z = statistics_of(model, X)["shift"][1][:, 0]
    np.testing.assert_allclose(z, (X - model.mean_) @ w / sd, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(shift_fraction(model, X), (X - model.mean_) @ w, rtol=1e-10, atol=1e-15)
    assert np.std(z) == pytest.approx(1.0, abs=0.02)                 # 20 000 draws: standard error 0.005
    assert sd == pytest.approx(math.sqrt(shift_weights(cov) @ cov @ shift_weights(cov)), rel=0.03)
    moved = statistics_of(model, X - 1e-3)["shift"][1][:, 0]
    np.testing.assert_allclose(z - moved, 1e-3 / sd, rtol=1e-9)


def test_the_shift_sides_share_its_rate_between_a_drop_and_a_rise():
    """The shift alone at 4 % on Gaussian data, its rate split 3 : 1: new tests fall beyond the drop's threshold
    with 3 % and beyond the rise's with 1 % (5000 held-out baseline tests: the side's quantile within 10 %; 100 000
    new ones), and the two thresholds are the normal law's ``z`` of those rates; half each (the default) gives 2 % per
    side. A split that is not two shares above 0 summing to 1 is refused."""
    rng = np.random.default_rng(22)
    X = rng.standard_normal((105000, 2)) * np.array([1e-3, 2e-3])
    nb, rest = np.arange(5000), np.arange(5000, len(X))
    model = PCARemoval().fit(X[nb])
    for sides in ((0.75, 0.25), (0.5, 0.5)):
        det = detect(model, model.with_choices, X, None, nb, rest, 0.04, 0, ("shift",), shift_sides=sides)
        z = det.vectors["shift"][rest, 0]
        assert np.mean(det.alarm[rest] & (z < 0)) == pytest.approx(0.04 * sides[0], rel=0.2)
        assert np.mean(det.alarm[rest] & (z > 0)) == pytest.approx(0.04 * sides[1], rel=0.2)
        assert math.sqrt(det.thresholds[0].value) == pytest.approx(stats.norm.isf(0.04 * sides[0]), rel=0.05)
        assert math.sqrt(det.shift_rise.value) == pytest.approx(stats.norm.isf(0.04 * sides[1]), rel=0.05)
        assert det.shift_sides == sides
    for bad in ((1.0, 0.0), (0.6, 0.6), (1.0,)):
        with pytest.raises(ConfigError, match="shift_sides"):
            detect(model, model.with_choices, X, None, nb, rest, 0.04, 0, ("shift",), shift_sides=bad)


def test_the_ewma_limit_is_the_closed_form_of_ar1_data_and_gives_its_rate_and_run_length():
    """EWMA of a stationary AR(1) of unit variance: var e = lam/(2-lam) (1 + phi(1-lam)) / (1 - phi(1-lam))."""
    rng = np.random.default_rng(14)
    phi, lam, rate = 0.6, 0.1, 0.01

    def ar1(n):
        return lfilter([math.sqrt(1 - phi**2)], [1, -phi], rng.standard_normal(n))

    limit, phis, run_length = chart_limit(ar1(3000)[:, None], rate, lam, seed=1)
    inflation = (1 + phi * (1 - lam)) / (1 - phi * (1 - lam))
    assert phis[0] == pytest.approx(phi, abs=0.05)
    assert limit == pytest.approx(inflation * stats.chi2(1).ppf(1 - rate), rel=0.12)
    fresh = ewma_chart(ar1(400_000), lam)[200:]
    assert 0.6 * rate < np.mean(fresh > limit) < 1.5 * rate
    above = np.flatnonzero(fresh > limit)
    starts = above[np.r_[True, np.diff(above) > 1]]            # the first test of each excursion
    measured = np.mean(np.diff(starts))                         # in-control tests between excursions
    assert 0.6 * run_length < measured < 1.6 * run_length


def test_the_onset_of_a_lasting_shift_is_dated_within_a_few_tests():
    rng = np.random.default_rng(15)
    errors = []
    for _ in range(10):
        Z = rng.standard_normal((900, 3))
        Z[600:, 1] += 1.0                                       # one sd from test 600 on
        charts = run_charts({"residual": Z}, np.arange(400), 0.01, lam=0.1)
        first = 600 + int(np.argmax(charts.alarm[600:]))
        assert charts.alarm[first]
        errors.append(charts.onset[first] - 600)
        assert onset(Z, first, 60) == charts.onset[first]
    assert np.median(np.abs(errors)) <= 3
    assert sidak_rate(0.01, 1) == pytest.approx(0.01)


def test_monitor_rows_carry_the_statistics_the_chart_and_the_onset(tmp_path):
    csv_path, _, _ = write_modal_series(tmp_path, 50, slit_day=35, seed=4)
    res = monitor_series(read_conditions(csv_path), 30, IdentificationSettings(), progress=False)
    assert res.detection.names == ("residual", "shift")       # regression on the temperature: no removed components
    row = res.rows[40]
    assert row["alarm"] and "residual" in row["alarmed_by"] and row["chart_alarm"]
    assert abs(row["onset"] - 35) <= 2
    assert row["statistics"]["residual"] == pytest.approx(row["novelty"])
    assert not any(r["chart_alarm"] for r in res.rows[30:35])


def test_environmental_statistics_on_a_baseline_shorter_than_the_seasons_are_warned_of():
    from learn.monitor.seasons import season_warning

    days = np.arange(400.0)
    dates = ["2026-01-01T10:00"] * 400                     # dated tests (only the first is parsed)
    why = season_warning(dates, days, 120, ("residual", "environment", "shift"))
    assert "spans 119 days" in why and "--statistics residual" in why
    assert season_warning(dates, days, 360, ("residual", "environment", "shift")) is None   # a year covered
    assert season_warning(dates, days, 120, ("residual",)) is None
    assert season_warning(["1", "2"] * 200, days, 120, ("residual", "shift")) is None     # test numbers, no dates


def test_the_charts_share_the_rate_by_their_joint_baseline_distribution():
    """Two charts of one statistic cost nothing (each at the rate), of two independent ones Sidak's split; the
    ``sidak`` combination always the split."""
    rng = np.random.default_rng(16)
    Z = rng.standard_normal((1500, 1))
    b_idx = np.arange(1000)
    same = run_charts({"a": Z, "b": Z.copy()}, b_idx, 0.01, lam=0.1)
    apart = run_charts({"a": Z, "b": rng.standard_normal((1500, 1))}, b_idx, 0.01, lam=0.1)
    split = run_charts({"a": Z, "b": Z.copy()}, b_idx, 0.01, lam=0.1, combination="sidak")
    assert [c.rate for c in same.charts] == pytest.approx([0.01, 0.01])
    assert apart.charts[0].rate == pytest.approx(sidak_rate(0.01, 2), rel=0.15)
    assert split.charts[0].rate == pytest.approx(sidak_rate(0.01, 2))
    assert split.charts[0].limit > same.charts[0].limit


def test_the_empirical_threshold_is_the_order_statistic_whose_exceedance_is_the_rate():
    """Of ``n`` held-out indices the ``k``-th smallest is exceeded by a new exchangeable test with probability
    ``(n + 1 - k) / (n + 1)``: at rate 0.05 of 39 indices the threshold's empirical part is the 38th smallest (2 of
    40), not the linear interpolation between the 37th and 38th (exceeded with ``(1 + (n - 1) rate) / (n + 1)`` =
    7.4 %); on uniform indices its exceedance averages the rate."""
    rng = np.random.default_rng(3)
    exceed = []
    for _ in range(60):
        s = rng.random(39)
        t = threshold(s, 0.05, 1, 38)
        assert t.empirical_quantile == pytest.approx(np.sort(s)[37], rel=1e-12)
        exceed.append(1.0 - t.empirical_quantile)
    assert np.mean(exceed) == pytest.approx(0.05, abs=0.012)               # linear interpolation: 0.074
    s = rng.random(39)                                                      # beyond the largest's 1 / 40: the largest
    assert threshold(s, 0.01, 1, 38).empirical_quantile == s.max()


@pytest.mark.slow
def test_a_three_sigma_drift_of_one_mode_is_detected_at_the_closed_form_rate():
    """One mode, 30 Gaussian baseline tests, 1 % false alarms: the detector (the residual and the signed shift, the
    same statistic with one mode) alarms on a new test with ``z = (x - mean) / s`` beyond its thresholds; for a new
    test of ``N(mu, sigma^2)`` that probability is ``Phi((mean - a s - mu) / sigma) + Phi((mu - mean - b s) / sigma)``
    given the baseline. Averaged over baselines the exact prediction interval (the law known, its scale Hotelling's)
    would give 1 % on intact tests and, on a 3-sigma drop, the noncentral t law's ``P(T(n - 1, -3 / sqrt(1 + 1/n)) <
    -t(n - 1; 0.995))`` = 58.2 %. The detector holds the rate (1.02 %) and finds 49.6 %: its thresholds are read from
    the 30 held-out tests (each statistic's scale fitted, a one-sided tail's scale uncertainty integrated out, the
    law's degrees of freedom fitted: 50.8 % with the formula's; 57.1 % at 1.6 % false alarms with the plug-in
    scale)."""
    rng = np.random.default_rng(17)
    n, sigma, rate = 30, 2e-3, 0.01
    found, false = [], []
    for _ in range(40):
        X = np.r_[rng.standard_normal((n, 1)), [[0.0]]] * sigma
        model = PCARemoval().fit(X[:n])
        det = detect(model, model.with_choices, X, None, np.arange(n), np.array([n]), rate)
        th = dict(zip(det.names, det.thresholds))
        a = math.sqrt(min(th["residual"].value, th["shift"].value))
        b = math.sqrt(min(th["residual"].value, det.shift_rise.value))
        m, s = X[:n, 0].mean(), X[:n, 0].std(ddof=1)
        p = lambda mu: stats.norm.cdf((m - a * s - mu) / sigma) + stats.norm.sf((m + b * s - mu) / sigma)  # noqa: E731
        found.append(p(-3 * sigma))
        false.append(p(0.0))
    t = stats.t(n - 1).isf(rate / 2)
    closed = stats.nct(n - 1, -3 / math.sqrt(1 + 1 / n)).cdf(-t)
    assert closed == pytest.approx(0.582, abs=0.001)
    assert closed - 0.12 < np.mean(found) < closed + 0.03       # 40 baselines: standard error 0.03
    assert 0.005 < np.mean(false) < 0.015
