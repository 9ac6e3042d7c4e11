"""The detector's family-wise calibration (learn.monitor.statistics): the per-statistic rate from the statistics'
joint held-out distribution against the closed form of the largest of two correlated normals, the family-wise
rate and the power against Šidák's on dependent null data, the signed shift's two sides, the thresholds per set
of modes found, and the status of an environmental alarm on an extrapolated test."""

import math
import warnings
from datetime import date, timedelta

import numpy as np
import pytest
from scipy import optimize, stats

from learn.monitor import IdentificationSettings, read_conditions
from learn.monitor.alarms import EXTRAPOLATED, monitor_series
from learn.monitor.normal_models import PCARemoval
from learn.monitor.statistics import SHARES, STATISTICS, detect, joint_rate, joint_rates, sidak_rate
from monitor_series import write_modal_series


def _closed_form_rate(rho, rate):
    """Per-statistic rate ``a`` with ``P(max(Z1, Z2) > Phi^-1(1 - a)) = rate``, ``corr(Z1, Z2) = rho``."""
    def union(t):
        return 1 - stats.multivariate_normal([0, 0], [[1, rho], [rho, 1]]).cdf([t, t]) - rate
    return stats.norm.sf(optimize.brentq(union, 0.5, 6.0))


@pytest.mark.parametrize("rho", [0.0, 0.6, 0.9])
def test_the_joint_rate_is_the_closed_form_of_two_correlated_normals(rho):
    rng = np.random.default_rng(21)
    z = rng.multivariate_normal([0, 0], [[1, rho], [rho, 1]], 20_000)
    held = np.c_[np.exp(z[:, 0]), z[:, 1] ** 3]                 # monotone maps: the same ranks, the same copula
    a = joint_rate(held, 0.01)
    assert a == pytest.approx(_closed_form_rate(rho, 0.01), rel=0.06)
    assert sidak_rate(0.01, 2) <= a <= 0.01
    assert joint_rate(np.c_[held[:, 0], held[:, 0]], 0.01) == pytest.approx(0.01)    # one statistic twice


def _closed_form_shares(rho, rate, v):
    """``s`` with ``P(Z1 > Phi^-1(1 - r1) or Z2 > Phi^-1(1 - r2)) = rate``, ``r_k = 1 - (1 - s)^(v_k)``."""
    def union(s):
        t = stats.norm.isf(-np.expm1(np.asarray(v) * np.log1p(-s)))
        return 1 - stats.multivariate_normal([0, 0], [[1, rho], [rho, 1]]).cdf(t) - rate
    return optimize.brentq(union, 1e-4, rate)


@pytest.mark.parametrize("rho", [0.0, 0.7])
def test_unequal_shares_are_the_closed_form_of_two_correlated_normals(rho):
    """Shares 1 : 2: the second statistic's rate about twice the first's, the union at the rate; independent
    statistics give the weighted Sidak split (1 - r1)(1 - r2) = 1 - rate exactly."""
    rng = np.random.default_rng(24)
    z = rng.multivariate_normal([0, 0], [[1, rho], [rho, 1]], 20_000)
    r = joint_rates(np.c_[np.exp(z[:, 0]), z[:, 1] ** 3], 0.01, [1.0, 2.0])
    s = _closed_form_shares(rho, 0.01, [0.5, 1.0])
    np.testing.assert_allclose(r, -np.expm1(np.array([0.5, 1.0]) * np.log1p(-s)), rtol=0.06)
    assert 1.99 < r[1] / r[0] < 2.01
    if rho == 0.0:
        assert (1 - r[0]) * (1 - r[1]) == pytest.approx(0.99, abs=3e-4)
    assert joint_rates(np.c_[z[:, 0], z[:, 0]], 0.01, [1.0, 2.0])[1] == pytest.approx(0.01)   # one statistic twice


def _dependent(rng, n):
    """Four features, one common factor dominating (sd 3 against 0.5-1): its removed component's ``T^2`` and the
    common shift are nearly one statistic."""
    return 3.0 * rng.standard_normal((n, 1)) + rng.standard_normal((n, 4)) * np.array([1.0, 0.8, 0.6, 0.5])


def test_the_joint_calibration_holds_the_rate_on_dependent_null_data_and_beats_sidak():
    rng = np.random.default_rng(22)
    rate, nb = 0.05, 300
    fam, shares, each, drop, rise = [], [], [], [], []
    for _ in range(4):
        X = _dependent(rng, nb + 4000)
        model = PCARemoval(1).fit(X[:nb])
        kw = dict(b_idx=np.arange(nb), rest=np.arange(nb, len(X)), rate=rate)
        joint = detect(model, lambda: PCARemoval(1), X, None, **kw, combination="equal")
        sidak = detect(model, lambda: PCARemoval(1), X, None, **kw, combination="sidak")
        assert np.all(joint.rate_each > 1.1 * sidak.rate_each)
        fam.append(joint.alarm[nb:].mean())
        shares.append(detect(model, lambda: PCARemoval(1), X, None, **kw).alarm[nb:].mean())
        each.append(joint.rate_each[0])
        shifted = X + 2.5 * 3.0                                 # every feature up along the common factor
        on = detect(model, lambda: PCARemoval(1), shifted, None, **kw, combination="equal")
        off = detect(model, lambda: PCARemoval(1), shifted, None, **kw, combination="sidak")
        assert np.all(on.alarm[nb:] >= off.alarm[nb:]) and on.alarm[nb:].sum() > off.alarm[nb:].sum()
        alone = detect(model, lambda: PCARemoval(1), X, None, **kw, statistics=("shift",))
        z = alone.vectors["shift"][nb:, 0]
        drop.append(np.mean(alone.alarm[nb:] & (z < 0)))
        rise.append(np.mean(alone.alarm[nb:] & (z > 0)))
    assert 0.6 * rate < np.mean(fam) < 1.3 * rate              # the family-wise rate, not Sidak's ~3.6 %
    assert 0.6 * rate < np.mean(shares) < 1.3 * rate           # so with unequal shares
    assert np.mean(each) > 1.2 * sidak_rate(rate, 3)
    assert 0.35 * rate < np.mean(drop) < 0.7 * rate and 0.35 * rate < np.mean(rise) < 0.7 * rate


def test_thresholds_per_set_of_modes_found_give_each_set_its_rate():
    """Mode 1 found in 30 % of the baseline tests: a threshold pooled over them lets the tests holding it alarm
    several times the rate; one per set of modes found gives each set about the rate."""
    rng = np.random.default_rng(23)
    rate, nb = 0.05, 200
    holding, lacking = [], []
    for _ in range(3):
        X = 0.01 * rng.standard_normal((nb + 3000, 1)) + 0.001 * rng.standard_normal((nb + 3000, 4))
        X[rng.random(len(X)) > 0.3, 0] = np.nan
        model = PCARemoval(None).fit(X[:nb])
        det = detect(model, model.with_choices, X, None, np.arange(nb), np.arange(nb, len(X)), rate,
                     statistics=("residual",))
        has = np.isfinite(X[nb:, 0])
        holding.append(det.alarm[nb:][has].mean())
        lacking.append(det.alarm[nb:][~has].mean())
        assert set(det.patterns) == {"none", "1"}
    assert 0.5 * rate < np.mean(holding) < 1.6 * rate
    assert 0.5 * rate < np.mean(lacking) < 1.6 * rate


def test_an_environmental_alarm_on_an_extrapolated_test_has_its_own_status(tmp_path):
    """A baseline of the warm half of the temperature cycle, then the cold half, no conditions (pca): the tests
    alarmed only by the environment or the shift and beyond the baseline's environment are reported apart
    (``separate``; ``auto`` unless dated tests show a baseline period of the seasons), kept alarms otherwise."""
    csv_path, _, _ = write_modal_series(tmp_path, 60, seed=5)
    series = read_conditions(csv_path)

    def run(how, s=series):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return monitor_series(s, 30, IdentificationSettings(), normal_model="pca", progress=False,
                                  extrapolated_alarms=how)

    kept, apart = run("alarm"), run("separate")
    moved = [i for i, r in enumerate(kept.rows) if r["alarm"] and r["extrapolated"]
             and set(r["alarmed_by"]) <= {"environment", "shift"}]
    assert moved
    for i, (a, b) in enumerate(zip(kept.rows, apart.rows)):
        if i in moved:
            assert b["status"] == EXTRAPOLATED and not b["alarm"] and b["alarmed_by"] == a["alarmed_by"]
        else:
            assert b["status"] == a["status"] and b["alarm"] == a["alarm"]
    assert [r["status"] for r in run("auto").rows] == [r["status"] for r in apart.rows]     # undated: separated
    lines = csv_path.read_text().splitlines()

    def dated(days_per_test):
        rows = [",".join([f, (date(2026, 1, 1) + timedelta(days=days_per_test * int(t))).isoformat(), c])
                for f, t, c in (line.split(",") for line in lines[1:])]
        csv_path.write_text("\n".join([lines[0], *rows]) + "\n")
        return [r["status"] for r in run("auto", read_conditions(csv_path)).rows]

    assert dated(1) == [r["status"] for r in apart.rows]        # 29 days of baseline: separated
    assert dated(13) == [r["status"] for r in kept.rows]        # 377 days: the seasons covered, kept alarms


def test_the_shares_give_the_family_rate_on_a_large_new_gaussian_sample():
    """Three statistics (residual independent, environment and shift correlated 0.7) at SHARES: thresholds from
    5000 held-out draws put 200 000 new draws of the same law beyond any of them at the rate, within binomial
    tolerance, each at its own rate, the shift at twice the residual's."""
    rng = np.random.default_rng(25)
    cov = np.array([[1, 0, 0], [0, 1, 0.7], [0, 0.7, 1]])
    held = rng.multivariate_normal(np.zeros(3), cov, 5000)
    r = joint_rates(np.c_[held[:, 0] ** 3, np.exp(held[:, 1]), held[:, 2]], 0.01,
                    [SHARES[nm] for nm in STATISTICS[:3]])
    new = rng.multivariate_normal(np.zeros(3), cov, 200_000)
    beyond = new > stats.norm.isf(r)
    sd = math.sqrt(0.01 * 0.99 / len(new))
    assert abs(beyond.any(axis=1).mean() - 0.01) < 4 * sd + 5e-4          # 5e-4: the copula's 200 000 draws
    np.testing.assert_allclose(beyond.mean(axis=0), r, rtol=0.1)
    assert r[2] == pytest.approx(2 * r[0], rel=0.01) and r[1] == pytest.approx(r[0] / 4, rel=0.01)
