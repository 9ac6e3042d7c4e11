"""A reference mode missing from its band: moved (a pole beyond the band that no other mode claims, within the
mode's reach) or lost, weighed by the baseline period's chance of that reading, flagged beside the alarms."""

import json

import numpy as np
import pytest
from scipy import stats

from experiments.cli import main
from experiments.cli.cmd_monitor import chart
from learn.monitor import (IdentificationSettings, IdentifiedModes, SeriesInput, monitor_series, reference_modes,
                           track_modes)
from learn.monitor.alarms import FLAGGED_STATUSES, readings_text
from learn.monitor.events import group_events, lost_modes_change
from learn.monitor.beyond_band import beyond_bands
from learn.monitor.tracking import MODE_LOST, MODE_MOVED, REACH_FACTOR, reach_bands_hz
from modal_files import write_modal_series

F0 = np.array([10.0, 31.0, 62.0])


def _modes(f):
    f = np.sort(np.asarray(f, float))
    return IdentifiedModes("modal", "file", f, np.full(f.size, 0.01), None)


def _baseline(n=12, seed=0, drop=None):
    """``n`` tests of the three modes at 0.3 % scatter; ``drop``: (mode, tests) left without that mode."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        f = F0 * (1 + 0.003 * rng.standard_normal(3))
        if drop is not None and k in drop[1]:
            f = np.delete(f, drop[0])
        out.append(_modes(f))
    return out


def _read(tests, n_baseline, rate=0.01):
    ref = reference_modes(tests[:n_baseline])
    cols = track_modes(tests, ref)[3]
    return ref, beyond_bands(tests, ref, cols, range(n_baseline), rate)


def test_the_reach_ends_at_half_the_log_gap_to_the_neighbours_and_at_the_factor():
    ref = reference_modes(_baseline())
    got = reach_bands_hz(ref)
    f = ref.frequencies_hz
    half = 0.5 * np.log(f[1:] / f[:-1])                  # 0.566 and 0.347, both below ln 2
    np.testing.assert_allclose(got[0], f[0] * np.array([1 / REACH_FACTOR, np.exp(half[0])]))   # the open side: 2
    np.testing.assert_allclose(got[1], f[1] * np.exp([-half[0], half[1]]))
    np.testing.assert_allclose(got[2], f[2] * np.array([np.exp(-half[1]), REACH_FACTOR]))
    lone = reference_modes([_modes([F0[0] * (1 + 0.003 * k)]) for k in range(10)])
    np.testing.assert_allclose(reach_bands_hz(lone)[0], lone.frequencies_hz[0] * np.array([1 / REACH_FACTOR,
                                                                                          REACH_FACTOR]))


def test_a_mode_that_jumps_40_percent_is_moved_by_plus_40_percent_and_flagged():
    tests = _baseline() + [_modes(F0 * [1.40, 1.0, 1.0])]
    ref, bb = _read(tests, 12)
    assert np.isnan(track_modes(tests, ref)[0][12, 0])          # beyond its band: not tracked
    (d,) = bb.readings(12, ref)
    assert d["reading"] == "moved" and d["mode"] == 1 and d["flagged"]
    assert d["frequency_hz"] == pytest.approx(14.0)
    assert d["change_pct"] == pytest.approx(100 * (14.0 / ref.frequencies_hz[0] - 1))
    assert abs(d["change_pct"] - 40.0) < 0.5
    assert bb.status(12) == MODE_MOVED and bb.chance[12, 0] == 0.0


def test_a_mode_the_baseline_found_in_every_test_missing_is_lost_and_flagged_on_a_baseline_that_can_tell():
    """Laplace's rule: 0 of n baseline tests lacking the mode gives a lost one chance 1 / (n + 2); at 1 % shared
    among 3 modes a single loss is flagged from n = 298 baseline tests, not on 12 (chance 1/14)."""
    tests = _baseline(300) + [_modes([F0[0], F0[2]])]
    ref, bb = _read(tests, 300)
    assert bb.lost[300, 1] and bb.chance[300, 1] == pytest.approx(1 / 302)
    assert bb.flagged[300, 1] and bb.status(300) == MODE_LOST and bb.missing_share[1] == 0.0
    tests = _baseline(12) + [_modes([F0[0], F0[2]])]
    ref, bb = _read(tests, 12)
    assert bb.lost[12, 1] and bb.chance[12, 1] == pytest.approx(1 / 14) and bb.status(12) is None


def test_a_mode_the_baseline_found_in_half_its_tests_missing_is_not_flagged():
    tests = _baseline(drop=(1, range(0, 12, 2))) + [_modes([F0[0], F0[2]])]
    ref, bb = _read(tests, 12)
    assert ref.presence[1] == pytest.approx(0.5)
    assert bb.lost[12, 1] and not bb.flagged[12, 1] and bb.status(12) is None
    assert bb.chance[12, 1] == pytest.approx(7 / 14)
    # a baseline test is read against the other baseline tests: 5 of 11 lack it
    assert bb.chance[0, 1] == pytest.approx(6 / 13) and not bb.flagged[0, 1]
    big = _baseline(300, drop=(1, range(0, 300, 2))) + [_modes([F0[0], F0[2]])]
    ref, bb = _read(big, 300)
    assert bb.chance[300, 1] == pytest.approx(151 / 302) and bb.status(300) is None


def test_a_moved_reading_the_baseline_makes_ordinary_is_not_flagged():
    """A mode lacking in half the baseline tests: a pole beyond its band in a test lacking it has chance 1/2 times
    Laplace's chance of such a pole, (w + 1) / (n + 2): not flagged, whether the baseline held such poles (w = 4)
    or none (a lone pole in a quiet record is no evidence on 12 tests)."""
    tests = _baseline(drop=(1, range(0, 12, 2)))
    for k in range(0, 12, 3):
        tests[k] = _modes(np.r_[tests[k].frequencies_hz, 38.0])
    tests.append(_modes([F0[0], 38.5, F0[2]]))
    ref, bb = _read(tests, 12)
    assert bb.moved_hz[12, 1] == pytest.approx(38.5) and not bb.flagged[12, 1]
    assert bb.chance[12, 1] == pytest.approx(0.5 * 5 / 14)
    tests = _baseline(drop=(1, range(0, 12, 2))) + [_modes([F0[0], 38.5, F0[2]])]
    ref, bb = _read(tests, 12)
    assert bb.chance[12, 1] == pytest.approx(0.5 / 14) and not bb.flagged[12, 1] and bb.status(12) is None


def test_a_run_of_moved_readings_settled_at_one_frequency_is_flagged_by_its_chance():
    """Mode 2 lacking in half of 12 baseline tests: one pole beyond its band has chance 0.5 x 1/14 = 0.036 (the share
    lacking it times Laplace's chance of a pole beyond its band), above 0.01 / 3. A second test in a row read moved
    to the same frequency adds the pole's chance alone (the mode's absence may persist over tests, the poles of a
    healthy structure's tests lie beyond the band independently): 0.036 / 14 = 0.0026, flagged. A reading to the
    other side, a test not identified or the mode back in its band start a new run."""
    down = _modes([F0[0], 28.0, F0[2]])
    up = _modes([F0[0], 35.0, F0[2]])
    tests = _baseline(drop=(1, range(0, 12, 2))) + [down, down, down, up, None, down, _modes(F0), down, down]
    ref, bb = _read(tests, 12)
    c, p = 0.5 / 14, 1 / 14
    np.testing.assert_allclose(bb.chance[12:, 1], [c, c, c, c, np.nan, c, np.nan, c, c])
    np.testing.assert_array_equal(bb.run_tests[12:, 1], [1, 2, 3, 1, 0, 1, 0, 1, 2])
    np.testing.assert_allclose(bb.run_chance[12:, 1], [c, c * p, c * p**2, c, np.nan, c, np.nan, c, c * p])
    np.testing.assert_array_equal(bb.flagged[12:, 1], [False, True, True, False, False, False, False, False, True])
    assert [bb.status(i) for i in (12, 13, 15, 20)] == [None, MODE_MOVED, None, MODE_MOVED]
    (d,) = bb.readings(13, ref)
    assert d["run_tests"] == 2 and d["run_chance"] == pytest.approx(c * p)
    assert "; 2 tests in a row read so, chance 0.0026 at the baseline's share" in readings_text([d], ref)
    # a run holds the mode settled: a reading further than the band's half-width from the one before starts a new
    # run; a lost mode makes none (a mode's absence persists over quiet tests)
    tol = ref.tolerance[1]
    assert np.log(28.0 / 27.6) < tol < np.log(27.6 / 26.0)
    tests = _baseline(drop=(1, range(0, 12, 2))) + [_modes([F0[0], f, F0[2]]) for f in (28.0, 27.6, 26.0)]
    tests += [_modes([F0[0], F0[2]])] * 3 + [down, down]
    ref, bb = _read(tests, 12)
    np.testing.assert_array_equal(bb.run_tests[12:, 1], [1, 2, 1, 0, 0, 0, 1, 2])
    assert bb.lost[15:18, 1].all() and not bb.flagged[15:18, 1].any()
    # below the lowest mode the reach runs to the factor 2, a run only to half the gap to mode 2 mirrored (5.67 Hz):
    # beyond it a mode the reference modes lack would run
    low = _modes([5.2, F0[1], F0[2]])
    ref, bb = _read(_baseline(drop=(0, range(0, 12, 2))) + [low] * 3, 12)
    assert reach_bands_hz(ref)[0, 0] < 5.2 < reach_bands_hz(ref, open_factor=False)[0, 0]
    np.testing.assert_allclose(bb.moved_hz[12:, 0], 5.2)
    np.testing.assert_array_equal(bb.run_tests[12:, 0], [1, 1, 1])
    np.testing.assert_allclose(bb.run_chance[12:, 0], bb.chance[12:, 0])
    assert not bb.flagged[12:, 0].any()


def test_a_run_as_long_as_one_the_baseline_ended_is_judged_by_the_baseline_s_runs():
    """Mode 2 lacking in 7 of 20 baseline tests, two of them in a row holding a pole at 28 Hz (so 3/22 is Laplace's
    chance of such a pole): the baseline ended one run of two, so a later run of two has chance at least 2/22
    (Laplace's rule on the baseline's runs) instead of 7/20 x (3/22)^2 = 0.0065, and is not flagged; a run of
    three, longer than any the baseline ended, is judged as independent tests: 7/20 x (3/22)^3 = 8.9e-4, flagged."""
    down = _modes([F0[0], 28.0, F0[2]])
    base = _baseline(20, drop=(1, [0, 2, 6, 8, 10]))
    base[3] = _modes([F0[0], 28.2, F0[2]])
    base[4] = _modes([F0[0], 28.1, F0[2]])
    ref, bb = _read(base + [down, down, down], 20)
    np.testing.assert_array_equal(bb.run_tests[:, 1], [0, 0, 0, 1, 2] + [0] * 15 + [1, 2, 3])
    c, p = 7 / 20 * 3 / 22, 3 / 22
    np.testing.assert_allclose(bb.run_chance[20:, 1], [c, 2 / 22, c * p * p])
    np.testing.assert_array_equal(bb.flagged[20:, 1], [False, False, True])
    # the baseline's own run, held out: none among the other baseline tests, so as independent tests
    assert bb.run_chance[4, 1] == pytest.approx(6 / 19 * 2 / 21 * 2 / 21)


def test_two_missing_modes_never_share_a_pole_and_a_pole_beyond_the_reach_is_no_mode():
    tests = _baseline() + [_modes([13.5, F0[2]]), _modes([F0[0], 45.0, F0[2]])]
    ref, bb = _read(tests, 12)
    # test 12: modes 1 and 2 missing, one pole 13.5 Hz: mode 1 moved (+35 %), mode 2 lost, not both on it
    assert bb.moved_hz[12, 0] == pytest.approx(13.5) and bb.lost[12, 1] and np.isnan(bb.moved_hz[12, 1])
    # test 13: 45 Hz lies beyond mode 2's reach (half the log gap to 62 Hz, 43.8 Hz): mode 2 lost, mode 3 kept
    assert reach_bands_hz(ref)[1, 1] < 45.0
    assert bb.lost[13, 1] and np.isnan(bb.moved_hz[13]).all()
    assert track_modes(tests, ref)[0][13, 2] == pytest.approx(F0[2], rel=0.02)


def test_the_events_of_moved_modes_are_changes_that_name_the_mode_and_its_change():
    rows = [{"file": f"t{k}", "time": None, "baseline": k < 12, "status": "no alarm", "mode_z_scores": [0.0] * 3,
             "change_pct": [0.0] * 3, "frequencies_hz": list(F0), "beyond_band": []} for k in range(15)]
    for k in (12, 13, 14):
        rows[k].update(status=MODE_MOVED, mode_z_scores=[None, 0.0, 0.0], change_pct=[None, 0.0, 0.0],
                       frequencies_hz=[None, 31.0, 62.0],
                       beyond_band=[{"mode": 1, "reading": "moved", "frequency_hz": 14.0, "change_pct": 40.0 + k - 13,
                                     "chance": 0.0, "flagged": True}])
    (ev,) = group_events(rows, 0.01)
    assert ev.change and ev.n_beyond == 3 and ev.moved == [1] and ev.direction == "up"
    assert ev.beyond_band == [{"mode": 1, "moved": 3, "change_pct": 40.0, "lost": 0}]
    assert "mode 1 moved in 3 (median +40 %)" in ev.text


@pytest.fixture(scope="module")
def jump_series(tmp_path_factory):
    """Modal JSON files: 21 baseline tests (each mode's scatter symmetric about ``F0``: its median), 6 intact, 6
    with mode 1 at exactly 1.4 ``F0``."""
    root = tmp_path_factory.mktemp("jump")
    rng = np.random.default_rng(4)
    steps = np.linspace(-1.6, 1.6, 21)
    base = F0 * (1 + 0.003 * np.stack([rng.permutation(steps) for _ in F0], axis=1))
    later = F0 * (1 + 0.003 * rng.standard_normal((12, 3)))
    later[6:, 0] = 1.4 * F0[0]
    return write_modal_series(root, np.r_[base, later])


def test_monitor_flags_a_mode_moved_40_percent_beside_the_alarms(jump_series, capsys):
    assert main(["monitor", *jump_series, "--baseline-tests", "21", "--json"]) == 0
    res = json.loads(capsys.readouterr()[0])
    rows = res["tests"]
    assert all(r["status"] in ("alarm", "no alarm") and not r["beyond_band"] for r in rows[:27])
    assert sum(r["status"] == "alarm" for r in rows[21:27]) <= 1
    for r in rows[27:]:
        assert r["status"] in ("alarm", MODE_MOVED)
        (d,) = r["beyond_band"]
        assert d["reading"] == "moved" and d["flagged"] and d["change_pct"] == pytest.approx(40.0)
        assert "mode 1 moved +40.0 % (14 Hz, beyond its band" in r["verdict"]["summary"]
        assert "not found" not in r["verdict"]["summary"]
    assert res["counts"][MODE_MOVED] + res["counts"]["alarm"] - sum(r["alarm"] for r in rows[21:27]) == 6
    ev = [e for e in res["events"] if e["first"] >= 27]
    assert ev and all(e["change"] and 1 in e["moved"] and e["direction"] == "up" for e in ev)
    assert any("mode 1 moved in" in e["text"] and "(median +40 %)" in e["text"] for e in ev)


def test_a_run_of_lost_modes_after_a_short_baseline_is_a_change_a_pair_is_not():
    def row(baseline, lost=False):
        return {"baseline": baseline, "status": "no alarm", "mode_z_scores": [0.0] * 3,
                "missing_modes": [2] if lost else [],
                "beyond_band": [{"mode": 2, "reading": "lost", "frequency_hz": None, "change_pct": None,
                                 "chance": 1 / 14, "flagged": False}] if lost else []}

    rows = [row(True) for _ in range(12)] + [row(False, lost=k % 2 == 0) for k in range(16)]
    res = lost_modes_change(rows, 0.01)
    d = res["modes"][1]
    assert d["baseline"] == {"lacking": 0, "tests": 12} and d["later"] == {"lost": 8, "tests": 16}
    assert d["p_value"] == pytest.approx(stats.binom.sf(7, 16, 1 / 14), rel=1e-9) and d["change"] and res["change"]
    assert "mode 2 lost in 8 of 16 later tests" in res["text"] and "reported as a change" in res["text"]
    pair = [row(True) for _ in range(8)] + [row(False), row(False), row(False, True), row(False, True)]
    d = lost_modes_change(pair, 0.01)["modes"][1]
    assert d["p_value"] == pytest.approx(stats.binom.sf(1, 4, 1 / 10), rel=1e-9) and not d["change"]


def test_the_chart_marks_the_tests_whose_mode_moved_and_draws_it_at_its_moved_frequency(jump_series):
    import matplotlib.pyplot as plt  # matplotlib: heavy, only where a chart is drawn

    res = monitor_series(SeriesInput.from_files(jump_series), 21, IdentificationSettings(), progress=False)
    for r in res.rows:
        r["extrapolated"] = False
    fig = chart(res)
    moved = [i + 1 for i, r in enumerate(res.rows) if r["status"] == MODE_MOVED]          # tests counted from 1
    line = next(ln for ln in fig.axes[1].get_lines() if ln.get_label().startswith(MODE_MOVED))
    assert line.get_label() == f"{MODE_MOVED} beyond its band ({len(moved)})" and line.get_marker() == "^"
    np.testing.assert_array_equal(line.get_xdata(), moved)
    hollow = [ln for ln in fig.axes[0].get_lines() if ln.get_marker() == "o"]
    (pts,) = hollow
    np.testing.assert_allclose(np.asarray(pts.get_ydata())[27:], 40.0)
    assert np.isnan(np.asarray(pts.get_ydata())[:27]).all()
    plt.close(fig)


def test_a_test_whose_poles_all_lie_beyond_the_bands_is_moved_or_lost_and_flagged_never_unidentified(tmp_path):
    """Mode 3 lacking in 2 of 12 baseline tests: alone, a pole 24 % below it is no evidence (chance 2/12 * 1/14 =
    0.012 > 0.01 / 3). In a test whose poles all lie beyond the bands the detector has nothing to judge: each mode is
    read moved (nearest in ln f, one pole per mode) or lost, and every reading is flagged when every baseline test
    held a mode in its band."""
    base = _baseline(drop=(2, [0, 6]))
    tests = base + [_modes([47.0]), _modes([47.0, 49.0]), _modes([3.0]), _modes([F0[0], 47.0])]
    ref, bb = _read(tests, 12)
    np.testing.assert_array_equal(track_modes(tests, ref)[3][12:15], -1)
    assert reach_bands_hz(ref)[1, 1] < 47.0 < ref.frequencies_hz[2] * np.exp(-ref.tolerance[2])
    # one pole: mode 3 moved -24 % (the nearest in ln f: ln(62/47) = 0.28 against ln(47/31) = 0.42), modes 1-2 lost
    assert bb.moved_hz[12, 2] == 47.0 and bb.lost[12, :2].all()
    assert bb.chance[12, 2] == pytest.approx(2 / 12 / 14) and bb.chance[12, 2] > 0.01 / 3
    assert bb.unplaced[12] and bb.unplaced_chance[12] == 0.0 and bb.flagged[12].all() and bb.status(12) == MODE_MOVED
    d = bb.readings(12, ref)[2]
    assert d["change_pct"] == pytest.approx(100 * (47.0 / ref.frequencies_hz[2] - 1)) and d["change_pct"] < -23
    assert readings_text(bb.readings(12, ref), ref).startswith("no mode in its band: mode 1 lost")
    assert "mode 3 moved -24." in readings_text(bb.readings(12, ref), ref)
    # two poles within mode 3's reach: it takes the nearer (49 Hz); no other mode takes the other
    assert bb.moved_hz[13, 2] == 49.0 and np.isnan(bb.moved_hz[13, :2]).all() and bb.status(13) == MODE_MOVED
    # a pole within no mode's reach: every mode lost, flagged
    assert reach_bands_hz(ref)[0, 0] > 3.0 and bb.lost[14].all() and bb.flagged[14].all()
    assert bb.status(14) == MODE_LOST
    # mode 1 in its band: the same pole is weighed by the baseline's odds alone, not flagged (the test before lost
    # mode 3: no run)
    assert not bb.unplaced[15] and bb.moved_hz[15, 2] == 47.0 and not bb.flagged[15].any() and bb.status(15) is None
    assert bb.run_tests[15, 2] == 1
    assert not bb.unplaced[:12].any() and not bb.flagged[:12].any()
    # a baseline with 2 of 12 tests lacking every mode (a lone pole at 3 Hz) makes it ordinary: each mode alone
    odd = list(base)
    odd[3] = odd[7] = _modes([3.0])
    ref2, bb2 = _read(odd + [_modes([47.0])], 12)
    np.testing.assert_allclose(ref2.frequencies_hz, ref.frequencies_hz, rtol=0.01)
    assert bb2.unplaced[12] and bb2.unplaced_chance[12] == pytest.approx(2 / 12) and not bb2.flagged[12].any()
    assert bb2.unplaced_chance[3] == pytest.approx(1 / 11) and bb2.status(3) is None and bb2.status(12) is None
    files = []
    for k, t in enumerate(tests[:13]):
        path = tmp_path / f"t{k:02d}.json"
        path.write_text(json.dumps({"natural_frequencies_hz": t.frequencies_hz.tolist()}))
        files.append(str(path))
    res = monitor_series(SeriesInput.from_files(files), 12, IdentificationSettings(), progress=False, chart="none")
    row = res.rows[12]
    assert not row["identified"] and row["status"] == MODE_MOVED and MODE_MOVED in FLAGGED_STATUSES
    assert row["beyond_band_text"].startswith("no mode in its band:") and "mode 3 moved -24." in row["beyond_band_text"]
