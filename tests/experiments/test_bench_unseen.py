"""bench_unseen's bookkeeping: the FRF peak, the plain tests' alarms, the loss marks and the drawn series."""

import numpy as np

from experiments.benches.bench_unseen import (Series, frf_peaks, plain_flags, score_series, scope_series,
                                              write_tests)


def test_frf_peak_is_the_vertex_of_a_log_parabola():
    """A log magnitude that is a parabola about 41.3 Hz: the vertex through three lines is exact."""
    f = np.arange(0.0, 100.0, 0.5)
    H = np.exp(-((f - 41.3) / 3.0) ** 2)[None] * (1 + 1j)
    got = frf_peaks(H, f, np.array([[30.0, 50.0], [60.0, 90.0]]))
    assert abs(got[0] - 41.3) < 1e-9
    assert np.isnan(got[1])                     # the largest line of 60-90 Hz is its edge: no peak there


def test_plain_flags_at_the_rate():
    """A 1 % drop of one mode of three against 40 baseline tests of 0.05 % scatter: both plain tests flag it; a test
    within the scatter is flagged by neither; a test with no mode found by neither."""
    rng = np.random.default_rng(3)
    F = np.array([10.0, 30.0, 70.0]) * (1 + 5e-4 * rng.standard_normal((43, 3)))
    F[40] = [10.0, 30.0, 70.0]
    F[41, 1] *= 0.99
    F[42] = np.nan
    flags = plain_flags(F, 40, 0.01)
    assert not flags["plain shift"][40] and not flags["plain per mode"][40]
    assert flags["plain shift"][41] and flags["plain per mode"][41]
    assert not flags["plain shift"][42] and not flags["plain per mode"][42]
    assert flags["plain shift"][:40].sum() <= 2                 # held out, at 1 %: about 0.4 of 40


def test_loss_marks_a_smaller_detection_and_more_false_alarms():
    truth = np.tile([10.0, 20.0], (8, 1))
    s = Series("t", "", [None] * 8, truth, ("baseline",) * 2 + ("intact",) * 2 + ("d",) * 4, 2, (1.0, 30.0), 100.0,
               np.full(2, np.nan))
    flags = {"monitor": np.array([0, 0, 1, 0, 1, 1, 0, 0], bool),
             "plain shift": np.array([0, 0, 0, 0, 1, 1, 1, 0], bool),
             "plain per mode": np.array([0, 0, 1, 0, 1, 0, 0, 0], bool)}
    mon = truth.copy()
    mon[5, 1] = np.nan                                           # one mode lost in one damaged test
    fft = truth * 1.05                                           # beyond the 3 % match: found in none
    rows = {r["group"]: r for r in score_series(s, flags, mon, fft, 0.01)}
    assert rows["intact"]["loss"] == ["plain shift"]            # 1 of 4 healthy tests flagged against 0 and 1
    assert rows["intact"]["healthy flagged"]["monitor"] == 0.25
    assert score_series(s, flags, mon, fft, 0.2)[1]["loss"] == []   # 25 % is within twice a rate of 20 %
    assert rows["d"]["loss"] == ["plain shift"]                 # 50 % detected against 75 % and 25 %
    assert (rows["d"]["monitor found"], rows["d"]["fft found"]) == (3, 0)
    assert rows["baseline"]["loss"] == []


def test_scope_series_is_seeded_quantised_and_written_as_csv(tmp_path):
    a = scope_series(5, {"baseline": 20, "intact": 10, "damaged": 10})
    b = scope_series(5, {"baseline": 20, "intact": 10, "damaged": 10})
    assert a.how == b.how and all(np.array_equal(x, y) for x, y in zip(a.data, b.data))
    levels = np.concatenate([d[0] for d in a.data]) * 128
    assert np.array_equal(levels, np.round(levels)) and levels.min() >= -128 and levels.max() <= 127
    assert a.groups.count("baseline") == 20 and len(a.groups) == 50
    dropped = [g for g in dict.fromkeys(a.groups) if g.startswith("mode")]
    mode = int(dropped[0].split()[1]) - 1
    g = np.asarray(a.groups)
    ratio = a.truth_hz[g == dropped[1], mode].mean() / a.truth_hz[g == "intact", mode].mean()
    assert 0.96 < ratio < 0.99                                   # 1.5-3 % down, within the sessions' 1 %
    files = write_tests(Series(**{**a.__dict__, "data": a.data[:2]}), tmp_path)
    head = open(files[0]).read().splitlines()[:3]
    assert head[:2] == ["# quantity: acceleration", "time_s,1:+Y"] and head[2].startswith("0.000000,")


def test_a_scope_mode_above_the_band_is_no_true_mode_of_the_series():
    """Seed 4 draws 3 modes (33.0, 207.1, 579.8 Hz) at 1250 Hz: the band ends at 0.4 fs = 500 Hz, below the third
    mode; the truth (what "all modes found" and the scatter count) holds the two in the band."""
    a = scope_series(4, {"baseline": 10, "intact": 10, "damaged": 10})
    assert a.sampling_frequency_hz == 1250.0 and a.band_hz[1] == 500.0 and "579.8" in a.how
    assert a.truth_hz.shape == (40, 2) and a.crb_rel.shape == (2,)
    assert np.all(a.truth_hz < a.band_hz[1]) and np.all(a.truth_hz > a.band_hz[0])


def test_a_rerun_replaces_a_test_file_whose_bytes_differ_and_keeps_the_others(tmp_path):
    """A series written again into its folder: a file another simulator version left (other bytes) is replaced, an
    identical one is left as it is (the identification cache reads it by its bytes)."""
    import os

    series = scope_series(0, {"baseline": 10, "intact": 10, "damaged": 10})
    files = write_tests(series, tmp_path)
    first = open(files[0], "rb").read()
    with open(files[1], "a") as f:
        f.write("0.0,0.0\n")
    os.utime(files[0], (1.0, 1.0))
    again = write_tests(series, tmp_path)
    assert again == files and open(files[0], "rb").read() == first and os.stat(files[0]).st_mtime == 1.0
    assert not open(files[1]).read().endswith("0.0,0.0\n")
    assert not list(tmp_path.glob(".test_*"))
