"""bench_choice_rules' residual-based estimator choice on a baseline with a closed-form residual scatter."""

import numpy as np
import pytest

from experiments.benches.bench_choice_rules import held_out_residuals, rule_choice, short_term_scatter
from learn.pairs.noise_calibration import robust_std

N = 60
SIG_A, SIG_B = 1e-4, 3e-4
U = np.full(4, 0.5)                         # the environment's direction: every mode alike
V = np.array([0.5, -0.5, 0.5, -0.5])        # estimator A's common error (a glide shared by its modes)


def _baseline(seed=0):
    """``ln f`` (N, 4) by two estimators: A with a large error common to its modes (sd 6e-3 along V) and small
    independent ones (SIG_A), B with independent errors (SIG_B) alone; both see the environment (sd 4e-3 along U)."""
    rng = np.random.default_rng(seed)
    env = rng.normal(0, 4e-3, N)[:, None] * U
    XA = 4.0 + env + rng.normal(0, 6e-3, N)[:, None] * V + rng.normal(0, SIG_A, (N, 4))
    XB = 4.0 + env + rng.normal(0, SIG_B, (N, 4))
    return XA, XB


def test_the_held_out_residual_scatter_is_the_independent_error_left_by_the_removed_components():
    XA, XB = _baseline()
    RA, kA = held_out_residuals(XA)
    RB, kB = held_out_residuals(XB)
    assert (kA, kB) == (2, 1)               # A: environment and glide removed; B: the environment
    # per mode, (I - U U') of independent noise: sigma^2 (1 - sum_k U_rk^2), each U_rk^2 = 1/4
    sA = np.exp(np.mean(np.log([robust_std(r) for r in RA.T])))
    sB = np.exp(np.mean(np.log([robust_std(r) for r in RB.T])))
    np.testing.assert_allclose(sA, SIG_A * np.sqrt(0.5), rtol=0.3)
    np.testing.assert_allclose(sB, SIG_B * np.sqrt(0.75), rtol=0.3)


def test_the_common_error_loses_the_raw_comparison_and_wins_on_the_residual():
    XA, XB = _baseline()
    raw = np.array([[robust_std(XA[:, r]), robust_std(XB[:, r])] for r in range(4)])
    assert np.all(raw[:, 1] < raw[:, 0])    # per mode by raw scatter: B everywhere
    eligible = np.ones(4, bool)
    for rule in ("one-residual", "one-volume", "mode-residual"):
        chosen, _ = rule_choice(rule, XA, XB, eligible)
        assert not chosen.any(), rule       # on what the normal model leaves: A everywhere
    chosen, _ = rule_choice("one-residual", XB, XA, eligible)   # the roles swapped: the FFT peak is A
    assert chosen.all()
    chosen, _ = rule_choice("one-residual", XB, XA, np.zeros(4, bool))
    assert not chosen.any()                 # nothing eligible: nothing chosen


def test_a_common_drift_hides_the_more_precise_estimator_from_the_raw_scatter_but_not_from_the_short_term_one():
    """Three sessions of 10 baseline tests moving both estimators' ``ln f`` by 0, +6e-3 and -4e-3 and a slow common
    drift of 2e-3 (the structure's variation, 0.4 % in all); A's own error 1e-4, B's 3e-4 (standard deviations).
    The robust scatter over the baseline is the environment's (4.3e-3 and 3.8e-3: B the smaller) and takes B; the
    short-term scatter cancels the environment (9.6e-5 and 4.3e-4, near the errors' 1e-4 and 3e-4; the session steps
    are 2 of the 29 differences, which the MAD passes over) and keeps A. With the roles swapped, B is kept."""
    rng = np.random.default_rng(5)
    n = 30
    env = np.repeat([0.0, 6e-3, -4e-3], 10) + 2e-3 * np.sin(np.arange(n) / 30)
    XA = (4.6 + env + 1e-4 * rng.standard_normal(n))[:, None]
    XB = (4.6 + env + 3e-4 * rng.standard_normal(n))[:, None]
    np.testing.assert_allclose([robust_std(XA[:, 0]), robust_std(XB[:, 0])], [4.336e-3, 3.777e-3], atol=1e-6)
    d = np.diff(np.stack([XA[:, 0], XB[:, 0]], axis=1), axis=0)                 # by hand: 1.4826 MAD / sqrt 2
    by_hand = 1.4826 * np.median(np.abs(d - np.median(d, axis=0)), axis=0) / np.sqrt(2.0)
    np.testing.assert_allclose([short_term_scatter(XA[:, 0]), short_term_scatter(XB[:, 0])], by_hand, rtol=1e-12)
    np.testing.assert_allclose(by_hand, [0.96e-4, 4.33e-4], atol=0.01e-4)
    chosen, text = rule_choice("short-term", XA, XB, np.ones(1, bool))
    assert not chosen[0] and text.startswith("short-term scatter ")
    assert rule_choice("short-term", XB, XA, np.ones(1, bool))[0][0]
    assert not rule_choice("short-term", XB, XA, np.zeros(1, bool))[0][0]    # not eligible: not chosen
    assert short_term_scatter([4.6, np.nan, 4.6, 4.61]) == pytest.approx(1.4826 * 0.005 / np.sqrt(2.0))
    assert np.isnan(short_term_scatter([4.6, np.nan]))
