"""The real-series miss diagnosis' pure functions: the per-group summary of flags, the closest statistic, the
one-sided thresholds of a signed environmental score, the variants and their patches (restored after)."""

import numpy as np
import pytest

import learn.monitor.alarms as alarms
import learn.monitor.statistics as statistics
from experiments.benches.diag_real_misses import (closest, environment_sides, flag_summary, parse_variant,
                                                  patched)


def test_the_summary_names_the_baseline_tests_flagged_and_each_later_group_s_share_and_misses():
    groups = ["baseline"] * 3 + ["a"] * 4 + ["b"] * 2
    labels = [f"t{i}" for i in range(9)]
    flags = [False, True, False, True, False, True, True, False, False]
    s = flag_summary(groups, labels, flags, 3)
    assert s["baseline"] == ["t1"]
    assert s["a"] == (0.75, ["t4"])
    assert s["b"] == (0.0, ["t7", "t8"])
    assert list(s) == ["baseline", "a", "b"]


def test_the_closest_statistic_is_the_largest_finite_ratio():
    assert closest([0.59, 0.08, np.nan, 0.61], ("residual", "environment", "shift", "mode")) == "mode"
    assert closest([np.nan, np.nan], ("residual", "shift")) == "-"


def test_a_one_sided_threshold_below_a_rate_of_one_over_n_plus_one_lies_at_or_beyond_the_side_s_largest_score():
    # 8 held-out scores on the + side, 6 on the - side (board 4.6's environmental scores): below a rate of
    # 1 / (n + 1) per side the empirical quantile is the side's largest, and the threshold is at least that
    scores = np.array([-2.45, -1.63, -1.20, -0.67, -0.46, -0.20, 0.13, 0.34, 0.51, 0.72, 0.84, 1.05, 1.33, 1.28])
    (s1, n1, t1, m1), (s2, n2, t2, m2) = environment_sides(scores, 0.01, 13)
    assert (s1, n1, m1) == (-1.0, 6, 2.45) and (s2, n2, m2) == (1.0, 8, 1.33)
    assert t1 >= 2.45 and t2 >= 1.33
    # the same scores scaled by 3: the law's scale by 9, each side's threshold by 3 (the law is fitted in squares)
    (_, _, u1, _), (_, _, u2, _) = environment_sides(3.0 * scores, 0.01, 13)
    np.testing.assert_allclose([u1, u2], [3.0 * t1, 3.0 * t2], rtol=1e-4)
    # a side with a single score has no threshold
    (_, n, t, m), _ = environment_sides(np.array([-1.0, 0.5, 0.7, 0.9]), 0.01, 3)
    assert n == 1 and np.isnan(t) and m == 1.0


def test_variants_parse_to_monitor_keywords_or_a_patch_and_another_is_refused():
    assert parse_variant("rate=0.0625") == ({"false_alarm_rate": 0.0625}, None)
    assert parse_variant("statistics=residual+mode") == ({"statistics": ("residual", "mode")}, None)
    assert parse_variant("model=pca0") == ({"normal_model": "pca0"}, None)
    assert parse_variant("keep-outliers") == ({"keep_baseline_outliers": True}, None)
    assert parse_variant("fft=1+3") == ({}, ("fft", frozenset({0, 2})))
    with pytest.raises(ValueError, match="variant 'rate'"):
        parse_variant("rate")


def test_the_patches_hold_within_the_block_and_are_restored_after_it_even_on_an_error():
    saved = alarms.choose_frequencies, alarms.held_out_cached, statistics.shift_weights
    cov = np.diag([4.0, 1.0, 0.25])
    np.testing.assert_allclose(statistics.shift_weights(cov), np.array([0.25, 1.0, 4.0]) / 5.25)
    with pytest.raises(RuntimeError):
        with patched(("equal", None)):
            np.testing.assert_allclose(statistics.shift_weights(cov), [1 / 3] * 3)
            assert alarms.held_out_cached is not saved[1]
            raise RuntimeError
    with patched(("fft", frozenset({0}))):
        assert alarms.choose_frequencies is not saved[0]
    assert (alarms.choose_frequencies, alarms.held_out_cached, statistics.shift_weights) == saved
