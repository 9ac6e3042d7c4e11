"""The densest window of repeated tests' poles."""

import numpy as np

from learn.densest_window import densest_window


def test_the_window_holding_most_tests_wins_over_one_holding_most_poles():
    """Test 0 holds 3 poles near 1.00 (ln f), tests 1 and 2 one each near 1.10: by poles 1.00 wins, by tests 1.10."""
    logf = np.array([0.99, 1.00, 1.01, 1.095, 1.105])
    who = np.array([0, 0, 0, 1, 2])
    assert densest_window(logf, who, 0.02) == 1.095               # both 1.095 and 1.105 hold 2 tests: the nearer


def test_among_equally_held_windows_the_one_nearest_the_prior():
    """Two clumps of 3 tests each, 10 % apart, every window holding its clump's 3 tests: the pole nearest the prior
    is the centre, whatever the order of the poles."""
    logf = np.log([10.0, 10.1, 10.2, 11.0, 11.1, 11.2])
    who = np.array([0, 1, 2, 0, 1, 2])
    half = np.log(1.025)
    assert densest_window(logf, who, half, np.log(11.3)) == np.log(11.2)
    assert densest_window(logf, who, half, np.log(9.0)) == np.log(10.0)
    assert densest_window(logf[::-1], who[::-1], half, np.log(10.12)) == np.log(10.1)
    # a fourth test at 10.15: the lower clump's windows hold 4 tests, the one nearest the poles' median (10.2) wins
    assert densest_window(np.r_[logf, np.log(10.15)], np.r_[who, 3], half) == np.log(10.2)


def test_the_window_agrees_with_a_direct_count_of_each_window_s_tests():
    rng = np.random.default_rng(3)
    for _ in range(50):
        logf, who = rng.normal(0.0, 0.05, rng.integers(1, 40)), rng.integers(0, 6, 40)
        who = who[:logf.size]
        held = np.array([np.unique(who[np.abs(logf - c) <= 0.03]).size for c in logf])
        best = logf[held == held.max()]
        assert densest_window(logf, who, 0.03, 0.01) == best[np.argmin(np.abs(best - 0.01))]
