"""The real-series bench's pure functions on a synthetic series: the FFT peaks in each mode's window, the plain
tests' quantile thresholds, the per-group scores; the Dataset-11 series cut from a synthetic converted file."""

import numpy as np

from experiments.benches.bench_real_series import (DS11_LENGTH, DS11_SKIP, LOADERS, fft_frequencies, group_scores,
                                                   mode_windows_hz, reference_fft_modes)
from experiments.benches.plain_tests import held_out_plain_alarms, matched_alarms, plain_alarms, plain_p_values
from experiments.benches.real_convert import DS11_BOARDS, DS11_MORE_BOARDS


def _decays(freqs_hz, fs=1000.0, n=4000, zeta=0.01, seed=0):
    """Free decays of two modes, one per row of ``freqs_hz`` (Hz), a little noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    out = []
    for f in freqs_hz:
        y = sum(np.exp(-zeta * 2 * np.pi * fk * t) * np.cos(2 * np.pi * fk * np.sqrt(1 - zeta ** 2) * t)
                for fk in f)
        out.append((y + 1e-4 * rng.standard_normal(n))[None])
    return out


def test_the_fft_modes_of_a_series_of_decays_are_its_frequencies_and_a_moved_mode_is_followed_in_its_window():
    base = [(20.0 * (1 + 1e-3 * k), 90.0) for k in range(8)]
    moved = [(24.0, 90.0), (20.0, 70.0)]                   # mode 1 +20 %, mode 2 -22 %: within their windows
    recs = _decays(base + moved)
    fs = np.full(len(recs), 1000.0)
    ref = reference_fft_modes(recs[:8], fs[:8], (5.0, 200.0))
    np.testing.assert_allclose(ref, [20.0 * 1.0035, 90.0], rtol=3e-3)
    w = mode_windows_hz(ref, (5.0, 200.0))
    g = np.sqrt(ref[1] / ref[0])                            # half the log gap, either side of each mode
    np.testing.assert_allclose(w, [[ref[0] / g, ref[0] * g], [ref[1] / g, ref[1] * g]])
    np.testing.assert_allclose(mode_windows_hz([50.0], (5.0, 200.0)), [[5.0, 200.0]])     # one mode: the band
    F = fft_frequencies(recs, fs, w)
    # the peak of a decay lies at the damped frequency, within a fraction of the 0.25 Hz resolution
    np.testing.assert_allclose(F, np.sqrt(1 - 0.01 ** 2) * np.array(base + moved), rtol=2e-3)


def test_the_plain_tests_alarm_beyond_the_baselines_own_quantiles_on_either_side():
    rng = np.random.default_rng(1)
    F = np.array([10.0, 60.0]) * (1 + 1e-3 * rng.standard_normal((2003, 2)))
    F[2000] = [10.0 * 1.01, 60.0]       # mode 1 up 1 % (10 sd): the mean shift 0.5 % (7 sd), both tests see it
    F[2001] = [10.0 * 0.997, 60.0]      # mode 1 down 0.3 % (3 sd): beyond the per-mode 0.25 % quantile only
    F[2002] = [np.nan, np.nan]          # nothing found: no alarm
    a = plain_alarms(F, 2000, 0.01, sides=2, method="linear")
    rel = F / np.median(F[:2000], axis=0) - 1
    mean = rel.mean(axis=1)
    lo, hi = np.quantile(mean[:2000], [0.005, 0.995])
    np.testing.assert_array_equal(a["plain shift"][:2000], (mean[:2000] < lo) | (mean[:2000] > hi))
    assert a["plain shift"][:2000].mean() == 0.01           # the baseline's own quantiles: 1 % of its tests
    assert 0.01 <= a["plain per mode"][:2000].mean() <= 0.011
    assert a["plain shift"][2000] and a["plain per mode"][2000]
    assert not a["plain shift"][2001] and a["plain per mode"][2001]
    assert not a["plain shift"][2002] and not a["plain per mode"][2002]


def test_group_scores_count_each_groups_flags_and_split_the_first_methods_misses():
    groups = ["baseline"] * 4 + ["intact"] * 2 + ["change"] * 4
    mon = np.array([0, 1, 0, 0, 0, 0, 1, 0, 0, 0], bool)
    plain = np.array([0, 0, 0, 0, 1, 0, 1, 1, 1, 0], bool)
    ident = np.array([1, 1, 1, 1, 1, 1, 1, 0, 1, 1], bool)
    rows = group_scores(groups, {"monitor": mon, "plain": plain}, ident, 4, known=False)
    by = {r["group"]: r for r in rows}
    assert by["baseline"]["monitor"] == 0.25 and by["intact"]["plain"] == 0.5 and by["change"]["plain"] == 0.75
    assert by["intact"]["missed, below threshold"] == 1 and by["intact"]["missed, not identified"] == 0
    assert by["change"]["missed, not identified"] == 1 and by["change"]["missed, below threshold"] == 1
    assert by["change"]["identified"] == 3
    assert by["first flagged later test"] == {"group": "first flagged later test", "monitor": 6, "plain": 4}


def test_the_held_out_plain_tests_judge_each_baseline_test_against_the_others_extremes():
    F = np.array([[10.0], [10.2], [10.3], [10.4], [11.0], [9.0], [10.25]])
    a = held_out_plain_alarms(F, 5, 0.01, sides=2, method="linear")
    # held out, 10.0 lies below the 0.5 % quantile of the other four (10.2 + 0.015 * 0.1) and 11.0 above theirs;
    # the inner three within: the baseline's extremes alarm, as a new test beyond the baseline's range would
    np.testing.assert_array_equal(a["plain shift"], [True, False, False, False, True, True, False])
    np.testing.assert_array_equal(a["plain per mode"], a["plain shift"])
    whole = plain_alarms(F, 5, 0.01, sides=2, method="linear")
    # in sample the extremes pass their own linear quantiles too (10.004 and 10.988)
    np.testing.assert_array_equal(whole["plain shift"][:5], [True, False, False, False, True])
    np.testing.assert_array_equal(whole["plain shift"][5:], a["plain shift"][5:])


def test_the_plain_p_values_are_the_gaussian_prediction_intervals_and_hold_their_rate():
    x = np.exp(np.array([[-1.0], [0.0], [1.0], [2.0], [np.nan]]))
    p = plain_p_values(x, 3)
    t = 2.0 / np.sqrt(4.0 / 3.0)            # mean 0, s 1 of 3 tests; on t(2) P(T > t) = (1 - t / sqrt(t^2 + 2)) / 2
    np.testing.assert_allclose(p["plain shift"][3], 1 - t / np.sqrt(t ** 2 + 2), rtol=1e-12)
    np.testing.assert_allclose(p["plain per mode"][3], p["plain shift"][3], rtol=1e-12)   # one mode: one test
    assert np.isnan(p["plain shift"][4]) and np.isnan(p["plain per mode"][4])             # nothing found
    # held out: -1 against (0, 1): mean 0.5, s 0.707, t = -1.5 / (0.707 sqrt(1.5)) on t(1)
    t0 = 1.5 / (np.sqrt(0.5) * np.sqrt(1.5))
    np.testing.assert_allclose(p["plain shift"][0], 1 - 2 / np.pi * np.arctan(t0), rtol=1e-12)
    # exchangeable Gaussian tests: a held-out baseline test and a new one each below 0.1 in 10 % of 800 series
    rng = np.random.default_rng(2)
    hits = np.zeros((2, 2))
    for _ in range(800):
        F = np.exp(1e-3 * rng.standard_normal((9, 2)) + np.log([10.0, 60.0]))
        q = plain_p_values(F, 8)
        hits += [[q["plain shift"][0] < 0.1, q["plain shift"][8] < 0.1],
                 [q["plain per mode"][0] < 0.1, q["plain per mode"][8] < 0.1]]
    shares, sd = hits / 800, np.sqrt(0.1 * 0.9 / 800)
    assert np.all(np.abs(shares[0] - 0.1) < 3 * sd)                      # the shift: exactly the rate
    assert np.all((shares[1] > 0.1 - 0.02 - 3 * sd) & (shares[1] < 0.1 + 3 * sd))    # Bonferroni: at most, near it


def test_the_matched_threshold_flags_as_many_healthy_tests_as_allowed():
    p = np.array([0.5, 0.02, 0.3, np.nan, 0.01, 0.025, 0.2, np.nan])
    healthy = np.array([1, 1, 1, 1, 0, 0, 0, 0], bool)
    np.testing.assert_array_equal(matched_alarms(p, healthy, 0), [0, 0, 0, 0, 1, 0, 0, 0])
    np.testing.assert_array_equal(matched_alarms(p, healthy, 1), [0, 1, 0, 0, 1, 1, 1, 0])
    np.testing.assert_array_equal(matched_alarms(p, healthy, 4), [1, 1, 1, 0, 1, 1, 1, 0])    # every finite p


def test_the_dataset_11_series_cuts_each_impact_after_its_hit_and_leaves_out_a_record_without_room(tmp_path):
    """One board of 9 files (``_00`` its hit at 0.09 s, too late for 70 ms after it) and another board's file; the
    board channel's hit (largest deviation from the first sample) at a known sample of each."""
    n = 20000
    hit = {0: 18000, **{k: 300 + 40 * k for k in range(1, 9)}}
    recs = np.zeros((10, 2, n))
    for k, a in hit.items():
        recs[k, 1] = 5.0 + np.arange(n) * 1e-6                 # an offset: the deviation is from the first sample
        recs[k, 1, a] = -900.0 - k
    recs[9, 1, 100] = 1e4                                       # board 4.4's: not read
    z = {"records": recs, "sampling_frequency_hz": np.float64(2e5), "board": np.array(["4.6"] * 9 + ["4.4"]),
         "impact_number": np.r_[np.arange(9), 0], "open_circuit": np.arange(10) == 8}
    path = tmp_path / "ds11.npz"
    np.savez(path, **z)
    file, load = LOADERS["ds11-b4.6"]
    assert file == "ds11_pcb_impacts_to_failure.npz"
    s = load.func(path, False, board="4.6", n_baseline=3, block=2)
    q = load.func(path, True, board="4.6", n_baseline=3, block=2)
    assert s.n_baseline == 3 and s.known is False and s.band_hz == (400.0, 6000.0)
    assert s.labels == tuple(f"board 4.6 impact {k}" for k in range(1, 9))
    assert s.groups == ("baseline",) * 3 + ("impacts 4-5", "impacts 4-5", "impacts 6-7", "impacts 6-7",
                                            "impact 8 (circuit open)")
    for k, y in zip(range(1, 9), s.records):
        a = hit[k] + DS11_SKIP
        np.testing.assert_array_equal(y, recs[k, 1:2, a:a + DS11_LENGTH])
    np.testing.assert_array_equal(s.sampling_frequency_hz, np.full(8, 2e5))
    assert q.labels == tuple(f"board 4.6 impact {k}" for k in (1, 2, 3, 4, 6, 8))   # later tests halved, the last kept


def test_every_dataset_11_board_is_one_series_by_the_same_rules_its_file_the_converters():
    for boards, file in ((DS11_BOARDS, "ds11_pcb_impacts_to_failure.npz"), (DS11_MORE_BOARDS, "ds11_more_boards.npz")):
        for b, _, _ in boards:
            f, load = LOADERS[f"ds11-b{b}"]
            assert f == file and load.keywords == {"board": b} and load.func is LOADERS["ds11-b4.6"][1].func
