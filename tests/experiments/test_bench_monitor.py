"""The monitoring benchmark's scoring: rates at the method's threshold and at 1 % false alarms, the delay."""

import numpy as np

from experiments.benches.bench_monitor import frequency_shift, paired_frequencies, score_series
from experiments.benches.plain_tests import plain_alarms


def test_rates_and_delay_of_a_hand_made_series():
    day = np.arange(20.0)
    damaged = day >= 12                       # tests 12..19 damaged, 4..11 the intact monitoring tests
    alarm = np.zeros(20)
    alarm[[2, 6, 13, 15, 16, 17, 18, 19]] = 1  # test 2 lies in the baseline period: not scored
    alarm[8] = np.nan                          # not answered
    score = np.where(damaged, 2.0, 1.0) + 0.01 * day
    r = score_series(day, damaged, alarm, score, n_baseline=4, damage_day=11.5, stay=3)
    assert r["intact_tests"] == 8 and r["damaged_tests"] == 8 and r["answered"] == 15
    assert r["false_alarm_rate"] == 1 / 7     # test 6 of the 7 answered intact tests
    assert r["true_positive_rate"] == 6 / 8
    assert r["tpr_at_1pct"] == 1.0            # every damaged score lies above every intact one
    assert r["delay_days"] == 15 - 11.5       # tests 15, 16, 17 are the first three alarms in a row


def test_no_detection_gives_no_delay_and_the_frequency_shift_alarms_on_a_drop():
    day = np.arange(10.0)
    r = score_series(day, day >= 5, np.zeros(10), np.zeros(10), 2, 4.5)
    assert r["delay_days"] is None and r["true_positive_rate"] == 0.0
    F = np.array([[10.0, 60.0]] * 6 + [[9.9, 59.0]] * 2)
    F[1:6] *= 1 + 1e-4 * np.array([1, -1, 2, -2, 0])[:, None]
    drop, alarm = frequency_shift(F, 6)
    assert alarm[6:].all() and alarm[1:6].tolist() == [False, False, False, True, False]  # the baseline's largest
    np.testing.assert_allclose(drop[6], 0.5 * (0.01 + 1 / 60))


def test_a_tests_frequencies_are_paired_to_the_first_tests_modes_not_by_position():
    """A split mode 1 (two poles near 10 Hz) and a mode missing: each reference mode takes its nearest reading
    within half the smaller (log) gap to its neighbours, the extra pole none."""
    ref = np.array([10.0, 64.0, 179.0, 350.0])
    got = paired_frequencies([9.95, 10.08, 64.5, 178.0, 352.0], ref)
    np.testing.assert_allclose(got, [9.95, 64.5, 178.0, 352.0])
    got = paired_frequencies([10.1, 178.0, 900.0], ref)        # 900 Hz: beyond mode 4's window (up to 489 Hz)
    np.testing.assert_allclose(got, [10.1, np.nan, 178.0, np.nan])
    assert np.isnan(paired_frequencies([], ref)).all()


def test_the_plainest_tests_alarm_below_the_baselines_own_quantiles():
    rng = np.random.default_rng(0)
    F = np.array([10.0, 60.0]) * (1 + 1e-3 * rng.standard_normal((1001, 2)))
    F[1000] = [10.0 * 0.99, 60.0]                           # mode 1 down 1 % (10 sd), the mean 0.5 %
    a = plain_alarms(F, 1000, 0.01, sides=1, method="weibull")
    assert a["plain shift"][1000] and a["plain per mode"][1000]
    rise = plain_alarms(F, 1000, 0.01, sides=1, method="weibull", sign=-1.0)   # told of a rise: the drop not seen
    assert not rise["plain shift"][1000] and not rise["plain per mode"][1000]
    assert 0.005 <= a["plain shift"][:1000].mean() <= 0.011   # the baseline's own 1 % quantile, one-sided
    assert 0.005 <= a["plain per mode"][:1000].mean() <= 0.011  # each mode at 0.5 %: at most 1 % together
