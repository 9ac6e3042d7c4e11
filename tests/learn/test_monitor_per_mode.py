"""The detector's per-mode statistic (learn.monitor.per_mode): on Gaussian baselines its threshold is the closed
form of a per-mode prediction interval read family-wise (Bonferroni), and new Gaussian tests exceed it at that
closed form's rate; the detector combines it when chosen."""

import math

import numpy as np
import pytest
from scipy import stats

from learn.monitor.normal_models import PCARemoval
from learn.monitor.per_mode import per_mode_index, per_mode_threshold, per_mode_z
from learn.monitor.statistics import DEFAULT_STATISTICS, STATISTICS, detect, held_out_statistics


def _held_z(X):
    return held_out_statistics(lambda: PCARemoval(0), X)["mode"][1]


@pytest.mark.parametrize("n, m", [(10, 1), (15, 3), (40, 5)])
def test_the_law_is_the_per_mode_prediction_interval_of_the_held_out_baseline(n, m):
    """Leave-one-out ``z`` of Gaussian tests: the scaled ``F(1, n_train - 1)`` law fitted to their squares has the
    scale ``(n_train + 1) / n_train`` of a new test's ``t^2`` (an identity of the held-out ``t``), so the threshold
    is the prediction interval ``(1 + 1/n_train) F(1, n_train - 1; 1 - rate / m)``."""
    X = np.random.default_rng(n + m).standard_normal((n, m)) * np.geomspace(1e-4, 1e-2, m)
    t = per_mode_threshold(_held_z(X), 0.05, n - 1)
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


def test_the_detector_combines_it_when_chosen_and_it_alarms_on_one_mode_alone():
    """``detect`` leaves ``mode`` out by default (:data:`DEFAULT_STATISTICS`); chosen, a jump of one of three
    independent modes by 8 of its standard deviations is alarmed by it, and a test of the baseline's law is not."""
    rng = np.random.default_rng(4)
    n, sd = 30, np.array([1e-3, 3e-3, 2e-4])
    X = np.r_[rng.standard_normal((n, 3)), [[0.0, 0.0, 0.0], [0.0, 0.0, 8.0]]] * sd
    model = PCARemoval(0).fit(X[:n])
    rest = np.array([n, n + 1])
    assert detect(model, model.with_choices, X, None, np.arange(n), rest, 0.01).names == ("residual", "shift")
    assert "mode" in STATISTICS and "mode" not in DEFAULT_STATISTICS
    det = detect(model, model.with_choices, X, None, np.arange(n), rest, 0.01, statistics=STATISTICS)
    assert det.names == ("residual", "shift", "mode")                 # no removed component: no environment
    assert not det.alarm[n] and det.alarm[n + 1] and "mode" in det.alarmed_by(n + 1)
    assert det.rate_each[2] == pytest.approx(det.rate_each[0], rel=1e-9)     # one share each
