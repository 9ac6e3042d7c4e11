"""The detector's per-mode statistic (learn.monitor.per_mode): on Gaussian baselines its threshold is the closed
form of a per-mode prediction interval read family-wise (Bonferroni), and new Gaussian tests exceed it at that
closed form's rate; each mode is read about the PCA's removed components' part over its scatter about them (the
closed form of one common factor); the detector combines it where the PCA removes components."""

import math

import numpy as np
import pytest
from scipy import stats

from learn.monitor.normal_models import PCARemoval, Regression
from learn.monitor.per_mode import per_mode_index, per_mode_threshold, per_mode_z, residual_covariance
from learn.monitor.statistics import DEFAULT_STATISTICS, STATISTICS, detect


def _held_z(X):
    """Each test's per-mode ``z`` by the model of the other tests (no component removed: about their mean)."""
    rows = np.arange(len(X))
    return np.vstack([per_mode_z(PCARemoval(0).fit(X[rows != i]), X[i:i + 1]) for i in rows])


@pytest.mark.parametrize("n, m", [(10, 1), (15, 3), (40, 5)])
def test_the_law_is_the_per_mode_prediction_interval_of_the_held_out_baseline(n, m):
    """Leave-one-out ``z`` of Gaussian tests: the scaled ``F(1, n_train - 1)`` law fitted to their squares has the
    scale ``(n_train + 1) / n_train`` of a new test's ``t^2`` (an identity of the held-out ``t``), so the threshold
    is the prediction interval ``(1 + 1/n_train) F(1, n_train - 1; 1 - rate / m)`` (the law's degrees of freedom
    those of the formula: ``heavy_tails`` off)."""
    X = np.random.default_rng(n + m).standard_normal((n, m)) * np.geomspace(1e-4, 1e-2, m)
    t = per_mode_threshold(_held_z(X), 0.05, n - 1, heavy_tails=False)
    assert t.scale == pytest.approx(n / (n - 1), rel=1e-5)
    assert t.law_value == pytest.approx(n / (n - 1) * stats.f(1, n - 2).isf(0.05 / m), rel=1e-5)
    assert t.value >= t.law_value and t.rate == 0.05


def test_new_gaussian_tests_exceed_it_at_the_closed_form_rate():
    """15 baseline tests of 3 independent modes, 5 %: a new test of a baseline's law against the model of that
    baseline exceeds the law's threshold on some mode with probability ``1 - (1 - p)^3``, ``p = 2 P(|T_14| >
    sqrt(thr / (1 + 1/15)))`` (below 5 %: the threshold is that of a model on the 14 tests a held-out fit sees)."""
    rng = np.random.default_rng(8)
    n, m, rate = 15, 3, 0.05
    sd = np.array([1e-3, 3e-3, 2e-4])
    thr = per_mode_threshold(_held_z(rng.standard_normal((n, m)) * sd), rate, n - 1).law_value
    p = 2 * stats.t(n - 1).sf(math.sqrt(thr / (1 + 1 / n)))
    closed = 1 - (1 - p) ** m
    exceed = []
    for _ in range(400):
        model = PCARemoval(0).fit(rng.standard_normal((n, m)) * sd)
        exceed.append(np.mean(per_mode_index(per_mode_z(model, rng.standard_normal((200, m)) * sd)) > thr))
    assert 0.04 < closed < rate
    assert np.mean(exceed) == pytest.approx(closed, abs=0.005)      # 80 000 draws over 400 baselines


def test_modes_not_found_are_not_judged():
    """The index is the largest square over the modes found (0 with none); a mode no held-out test holds is left
    out of the family (``rate / (m - 1)``)."""
    Z = np.array([[1.0, np.nan, -3.0], [np.nan, np.nan, np.nan]])
    np.testing.assert_array_equal(per_mode_index(Z), [9.0, 0.0])
    n = 20
    X = np.random.default_rng(2).standard_normal((n, 3))
    Zh = _held_z(X)
    Zh[:, 1] = np.nan
    t = per_mode_threshold(Zh, 0.01, n - 1)
    assert t.law_value == pytest.approx(n / (n - 1) * stats.f(1, n - 2).isf(0.01 / 2), rel=1e-5)


def _one_factor(rng, n, loading, noise):
    """``n`` tests of ``m`` log frequencies: one common factor (unit variance) along ``loading`` plus independent
    noise of standard deviation ``noise``."""
    return rng.standard_normal((n, 1)) * loading + rng.standard_normal((n, loading.size)) * noise


def test_each_mode_is_read_about_the_removed_components_over_its_scatter_about_them():
    """One common factor (the environment, 0.1-0.3 % per mode) over independent noise of 0.002 %: the PCA removes
    it, the residual covariance is ``sigma^2 (I - u u^T)`` (``u`` the factor's direction) and a jump ``d`` of mode
    ``j`` alone reads ``z_j = d sqrt(1 - u_j^2) / sigma`` (and each other mode ``-d u_j u_k / (sigma sqrt(1 -
    u_k^2))``); about the baseline mean over the whole scatter it would
    read ``d / sqrt(a_j^2 + sigma^2)``, 100 times less."""
    rng = np.random.default_rng(6)
    a, sigma = np.array([1e-3, 2e-3, 3e-3, 1.5e-3]), 2e-5
    X = _one_factor(rng, 4000, a, sigma)
    model = PCARemoval(1).fit(X)
    u = a / np.linalg.norm(a)
    R = np.cov((X - X.mean(axis=0)) @ (np.eye(4) - np.outer(u, u)), rowvar=False)        # an independent residual
    np.testing.assert_allclose(residual_covariance(model), R, rtol=0.02, atol=1e-3 * sigma**2)
    np.testing.assert_allclose(np.diag(residual_covariance(model)), sigma**2 * (1 - u**2), rtol=0.06)
    d = 8 * sigma
    x = model.mean_ + 0.7 * a                                   # the environment 0.7 of its sd away
    x[1] += d
    z = per_mode_z(model, x[None])[0]
    closed = -d * u[1] * u / (sigma * np.sqrt(1 - u**2))        # the others: -u_k u_j d over sigma sqrt(1 - u_k^2)
    closed[1] = d * math.sqrt(1 - u[1] ** 2) / sigma
    np.testing.assert_allclose(z, closed, rtol=0.05)
    assert abs((x[1] - model.mean_[1]) / math.sqrt(model.cov_[1, 1])) < 1.0       # within the environment's range


def test_the_detector_combines_it_where_the_pca_removes_components_and_it_alarms_on_one_mode_alone():
    """``mode`` is a default statistic (:data:`DEFAULT_STATISTICS`) of a PCA that removes components, not of the
    regression nor of a PCA that removes none; on 30 baseline tests of one common factor, a jump of one mode by 8
    of its noise standard deviations, inside the environment's range, is alarmed by it, a test of the baseline's
    law is not."""
    rng = np.random.default_rng(4)
    n, a, sigma = 30, np.array([1e-3, 2e-3, 3e-3, 1.5e-3]), 2e-5
    X = _one_factor(rng, n + 2, a, sigma)
    X[n + 1, 0] += 8 * sigma
    model = PCARemoval(1).fit(X[:n])
    rest = np.array([n, n + 1])
    assert "mode" in STATISTICS and "mode" in DEFAULT_STATISTICS
    det = detect(model, model.with_choices, X, None, np.arange(n), rest, 0.01)
    assert det.names == ("residual", "environment", "shift", "mode")
    assert not det.alarm[n] and det.alarm[n + 1] and "mode" in det.alarmed_by(n + 1)
    assert det.rate_each[3] == pytest.approx(det.rate_each[1], rel=1e-9)     # a quarter share, as the environment
    assert math.log1p(-det.rate_each[3]) / math.log1p(-det.rate_each[0]) == pytest.approx(0.25, rel=1e-9)
    none = PCARemoval(0).fit(X[:n])
    assert detect(none, none.with_choices, X, None, np.arange(n), rest, 0.01, statistics=STATISTICS).names == (
        "residual", "shift")
    C = rng.standard_normal((n + 2, 1))
    reg = Regression().fit(X[:n], C[:n])
    assert detect(reg, Regression, X, C, np.arange(n), rest, 0.01, 1).names == ("residual", "shift")
