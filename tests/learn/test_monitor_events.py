"""What a monitored series reports beyond its alarms: tests not identified (counted, charted, a run of them a
change), tests beyond the baseline's conditions (extrapolated), the later tests' scatter against the baseline's,
events grouped from consecutive alarms, and identification over worker processes."""

import json
import warnings

import numpy as np
import pytest
from scipy import stats

from experiments.cli import main
from learn.monitor.coverage import _held_out_mahalanobis, baseline_scatter, coverage
from learn.monitor.events import Z_MOVED, group_events, identification_change, unidentified_p_value
from learn.monitor.identification import record_problem
from monitor_series import write_modal_series


def _row(status, z=None, baseline=False, t=0.0, change=None):
    z = [0.0] * 4 if z is None else list(z)
    return {"file": f"t{t:g}", "time": t, "time_value": t, "baseline": baseline, "status": status,
            "novelty": float(np.sum(np.square(z))) if status in ("alarm", "no alarm") else None,
            "frequencies_hz": [100.0 * (k + 1) * (1 + 1e-3 * v) for k, v in enumerate(z)]
            if status in ("alarm", "no alarm") else [None] * 4,
            "mode_z_scores": z if status in ("alarm", "no alarm") else [None] * 4,
            "change_pct": (list(change) if change is not None else [0.03 * v for v in z])
            if status in ("alarm", "no alarm") else [None] * 4}


def _baseline(n=40, seed=0):
    rng = np.random.default_rng(seed)
    return [_row("no alarm", rng.standard_normal(4), baseline=True, t=k) for k in range(n)]


def test_a_run_of_tests_not_identified_is_a_change_at_the_binomial_tail():
    rows = _baseline(40)
    later = ["no alarm"] * 5 + ["not identified"] * 4 + ["no alarm"] * 6 + ["not identified"] + ["no alarm"] * 4
    rows += [_row(s, t=40 + k) for k, s in enumerate(later)]
    events = group_events(rows, 0.01)
    assert [(e.first, e.last, e.n_not_identified) for e in events] == [(45, 48, 4), (55, 55, 1)]
    p0 = 1 / 42                                          # Laplace's rule on 0 of 40 baseline tests
    assert events[0].unidentified_p_value == pytest.approx(p0**4, rel=1e-9)
    assert events[0].change and "identification lost" in events[0].text
    assert events[1].unidentified_p_value == pytest.approx(p0, rel=1e-9)   # one failure: 2.4 % > 1 %
    assert not events[1].change and events[1].text.endswith("not a change")
    ident = identification_change(rows, 0.01)
    assert ident["later"] == {"not_identified": 5, "tests": 20} and ident["baseline"] == {"not_identified": 0,
                                                                                             "tests": 40}
    assert ident["p_value"] == pytest.approx(stats.binom.sf(4, 20, p0), rel=1e-9) and ident["change"]
    assert unidentified_p_value(0, 20, 0, 40) == 1.0


def test_tests_with_no_usable_record_are_named_but_not_counted_as_identification_lost():
    rows = _baseline(40)
    later = ["no alarm"] * 5 + ["not identified"] * 4 + ["no alarm"] * 6 + ["not identified"] + ["no alarm"] * 4
    rows += [_row(s, t=40 + k) for k, s in enumerate(later)]
    for i in range(45, 49):                             # the run of 4: records that cannot be read
        rows[i]["record_problem"] = f"t{i}: not a readable .npz"
    events = group_events(rows, 0.01)
    assert [(e.first, e.last, e.n_not_identified) for e in events] == [(45, 48, 0), (55, 55, 1)]
    assert not events[0].change and "4 with no usable record (not counted)" in events[0].text
    ident = identification_change(rows, 0.01)
    # the one test that read but was not identified, among the 16 later tests with a usable record
    assert ident["later"] == {"not_identified": 1, "tests": 16} and ident["unusable_records"] == 4
    assert ident["p_value"] == pytest.approx(stats.binom.sf(0, 16, 1 / 42), rel=1e-9) and not ident["change"]
    assert "4 tests with no usable record" in ident["text"]


def test_record_problem_names_unusable_records_and_leaves_identification_failures_and_modal_data(tmp_path):
    fs = 2000.0
    t = np.arange(4000) / fs
    good = tmp_path / "good.npz"
    np.savez(good, signals=(np.exp(-t) * np.sin(2 * np.pi * 50 * t))[None], sampling_frequency_hz=fs,
             dofs=np.array(["1:+Z"]))
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[:300])
    nan = tmp_path / "nan.npz"
    np.savez(nan, signals=np.full((1, 4000), np.nan), sampling_frequency_hz=fs, dofs=np.array(["1:+Z"]))
    dead = tmp_path / "dead.npz"
    np.savez(dead, signals=np.zeros((1, 4000)), sampling_frequency_hz=fs, dofs=np.array(["1:+Z"]))
    modal = tmp_path / "modal.json"
    modal.write_text("{ not json")
    assert record_problem(good) is None
    assert "not a readable .npz" in record_problem(cut) and str(cut) in record_problem(cut)
    assert "NaN" in record_problem(nan) and "constant" in record_problem(dead)
    missing = "file not found; expected an .npz of FRFs (frequency_hz, frf, ...) or of time series (signals, ...)"
    assert record_problem(tmp_path / "missing.npz").endswith(missing)
    assert record_problem(modal) is None                # modal data: an outside identification's failure counts


def test_events_group_consecutive_alarms_and_split_at_a_new_state():
    rows = _baseline(40, seed=1)
    one, two = np.array([-10.0, -5, 0, 0]), np.array([-20.0, -10, 0, 0])
    seq = [("no alarm", None), ("alarm", one), ("alarm", one + 0.5), ("no alarm", None), ("alarm", one - 0.5),
           ("no alarm", None), ("no alarm", None), ("no alarm", None), ("alarm", one), ("alarm", two),
           ("alarm", two + 0.3), ("no alarm", None)]
    rows += [_row(s, z, t=40 + k) for k, (s, z) in enumerate(seq)]
    events = group_events(rows, 0.01)
    assert [list(e.members) for e in events] == [[41, 42, 44], [48], [49, 50]]
    first, _, third = events
    assert first.n_tests == 4 and first.n_alarms == 3                    # one quiet test inside
    assert first.moved == [1, 2] and first.direction == "down"
    np.testing.assert_allclose([first.modes[0]["z"], first.modes[1]["z"]], [-10.0, -5.0])
    # size: the root mean square over the modes of the mean change (change = 0.03 z here)
    rms = lambda *v: 0.03 * np.sqrt(np.mean(np.square(v)))                         # noqa: E731
    assert first.size_pct == pytest.approx(rms(10, 5, 0, 0))
    assert third.size_pct == pytest.approx(rms(19.85, 9.85, 0.15, 0.15))
    assert third.size_first_pct == pytest.approx(rms(20, 10, 0, 0))
    assert third.size_last_pct == pytest.approx(rms(19.7, 9.7, 0.3, 0.3))
    assert all(abs(d["z"]) < Z_MOVED for d in third.modes[2:])
    assert "modes 1, 2 down" in third.text
    up = group_events(rows[:40] + [_row("alarm", [8.0, -6, 0, 0], t=40)], 0.01)[0]
    assert up.direction == "mixed" and up.moved == [1, 2]


def test_one_stray_alarm_splits_no_event_and_tests_beyond_the_conditions_belong_to_it():
    """An alarm beyond the event's mean whose next alarm lies back within it is one stray reading, not a new state;
    tests of status 'change or unseen conditions' are flagged members of the event, not quiet tests between."""
    rows = _baseline(40, seed=3)
    one, far = np.array([-10.0, -5, 0, 0]), np.array([-10.0, 15, 9, 0])
    unseen = {**_row("no alarm", [0.5, 0, 0, 0], t=43), "status": "change or unseen conditions"}
    seq = [_row("alarm", one, t=40), _row("alarm", far, t=41), _row("alarm", one + 0.3, t=42), unseen,
           _row("no alarm", None, t=44), _row("no alarm", None, t=45), _row("alarm", one - 0.3, t=46),
           _row("alarm", far, t=47)]
    events = group_events(rows + seq, 0.01)
    # the stray alarm 41 stays; 43-45 are one flagged and two quiet tests (a gap of 2); the last alarm, far from the
    # event and with none after it to confirm, starts its own event
    assert [list(e.members) for e in events] == [[40, 41, 42, 43, 46], [47]]
    assert events[0].n_alarms == 4 and events[0].n_tests == 7
    assert "1 change or unseen conditions" in events[0].text
    alone = group_events(rows + [unseen], 0.01)[0]
    assert not alone.change and alone.text.endswith("; change or unseen conditions")


def test_a_test_beyond_the_baselines_conditions_is_flagged_extrapolated():
    rng = np.random.default_rng(2)
    temp = rng.uniform(0.0, 10.0, 30)
    humid = 50 + 2.0 * temp + rng.normal(0, 0.5, 30)              # the baseline saw them together
    E = np.c_[np.r_[temp, 12.0, 5.0, 5.0], np.r_[humid, 74.0, 60.0, 58.0]]
    cov = coverage(("temperature_c", "humidity"), E, np.arange(30), np.arange(30, 33))
    assert cov.extrapolated.tolist() == [False] * 30 + [True, False, True]
    assert cov.reasons[30].startswith(f"temperature_c 12 beyond the baseline's {temp.min():.4g} to {temp.max():.4g}")
    assert cov.reasons[32] and "combination" in cov.reasons[32]    # in both ranges, off the line they move on
    assert cov.mahalanobis[31] < cov.mahalanobis_max < cov.mahalanobis[32]
    # the held-out distance in closed form is the one of a fit without the row
    Eb = E[:30]
    P = np.linalg.inv(np.cov(Eb[1:], rowvar=False))
    r = Eb[0] - Eb[1:].mean(axis=0)
    assert _held_out_mahalanobis(Eb)[0] == pytest.approx(r @ P @ r, rel=1e-10)


def test_the_later_tests_scatter_is_compared_with_the_baselines():
    rng = np.random.default_rng(4)
    rows = [_row("no alarm", rng.standard_normal(4), baseline=True, t=k) for k in range(40)]
    wide = 2.0 * rng.standard_normal((60, 4))
    later = [_row("no alarm", z, t=40 + k) for k, z in enumerate(wide)]
    zb = np.array([r["mode_z_scores"] for r in rows])
    sc = baseline_scatter(rows + later, has_times=True)
    # the root of the ratio of the mean indices (here the sums of the squared z-scores)
    assert sc.ratio == pytest.approx(np.sqrt(np.mean(wide**2) / np.mean(zb**2)), rel=1e-12)
    np.testing.assert_allclose(sc.per_mode, np.sqrt(np.mean(wide**2, axis=0) / np.mean(zb**2, axis=0)), rtol=1e-12)
    assert 1.7 < sc.ratio < 2.3 and "scatter" in sc.warning and f"{sc.ratio:.2f} times" in sc.warning
    assert "spans 39 of the series' 99 days" in sc.warning
    same = [_row("no alarm", z, t=40 + k) for k, z in enumerate(rng.standard_normal((60, 4)))]
    sc = baseline_scatter(rows + same)
    assert 0.8 < sc.ratio < 1.2 and sc.warning is None
    assert baseline_scatter(rows + same[:4]).ratio is None          # too few later tests


@pytest.fixture(scope="module")
def slit_series(tmp_path_factory):
    return write_modal_series(tmp_path_factory.mktemp("events"), 36, slit_day=30, seed=12)


def test_tests_not_identified_are_counted_charted_and_a_run_of_them_is_a_change(tmp_path, capsys, slit_series):
    csv_path, files, _ = slit_series
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    tests = [str(f) for f in files[:22]] + [str(bad)] * 5 + [str(f) for f in files[27:]]
    assert main(["monitor", *tests, "--baseline-tests", "18", "--json"]) == 0
    out, err = capsys.readouterr()
    res = json.loads(out)
    status = [r["status"] for r in res["tests"]]
    assert status[22:27] == ["not identified"] * 5 and status[30:] == ["alarm"] * 6
    assert res["counts"]["not identified"] == 5 and res["counts"]["alarm"] == 6
    assert res["identification_change"]["change"] and "identification lost" in err
    ev = res["events"]
    assert [(e["first"], e["last"], e["n_not_identified"], e["n_alarms"], e["change"]) for e in ev] == [
        (22, 26, 5, 0, True), (30, 35, 0, 6, True)]
    assert ev[0]["unidentified_p_value"] == pytest.approx((1 / 20) ** 5, rel=1e-9)   # 0 of 18 baseline tests
    # pca: against the 10 tests before the first change (the lost identification); the slit lowers modes 1, 3, 4
    assert ev[1]["against"] == "the 10 tests without an alarm before the first change (test 23)"
    assert ev[1]["before"] == list(range(12, 22))
    assert all(ev[1]["modes"][k]["change_pct"] < -0.15 for k in (0, 2, 3))
    assert all(r["verdict"]["event"] == 1 for r in res["tests"][30:])

    from experiments.cli.cmd_monitor import chart
    from learn.monitor import IdentificationSettings, SeriesInput, monitor_series

    result = monitor_series(SeriesInput.from_files(tests), 18, IdentificationSettings(), progress=False)
    for i, r in enumerate(result.rows):
        r["extrapolated"] = False
    fig = chart(result)
    ax = fig.axes[1]
    line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("not identified"))
    assert line.get_label() == "not identified (5)"
    np.testing.assert_array_equal(line.get_xdata(), np.arange(23, 28))          # tests counted from 1
    assert line.get_marker() == "x"
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_the_regressions_event_says_which_modes_fell_and_by_the_simulators_drop(capsys, slit_series):
    csv_path, _, _ = slit_series
    assert main(["monitor", "--conditions", str(csv_path), "--baseline-tests", "18", "--json"]) == 0
    res = json.loads(capsys.readouterr()[0])
    # the slit's drop in the simulator: modes 1, 4, 3 by 0.85, 0.84, 0.67 %; mode 2 by 0.03 %
    (ev,) = res["events"]
    assert (ev["first"], ev["last"], ev["n_alarms"]) == (30, 35, 6)
    assert ev["moved"] == [1, 4, 3] and ev["direction"] == "down"
    assert ev["against"] == "the normal model's prediction"
    from monitor_series import simulate

    _, slit = simulate(36, 30, seed=12)
    _, intact = simulate(36, None, seed=12)
    drop = 100 * (1 - np.array([s[2].frequencies_hz[:4] / i[2].frequencies_hz[:4] for s, i in zip(slit, intact)]))
    assert ev["size_pct"] == pytest.approx(np.sqrt(np.mean(drop[30:].mean(axis=0) ** 2)), rel=0.05)


@pytest.mark.slow
def test_two_workers_give_the_json_of_one(tmp_path, capsys, slit_series):
    csv_path, _, _ = slit_series
    outs = []
    for w in ("1", "2"):
        assert main(["monitor", "--conditions", str(csv_path), "--baseline-tests", "18", "--workers", w,
                     "--out", str(tmp_path / w), "--json"]) == 0
        outs.append(capsys.readouterr()[0].replace(str(tmp_path / w), "OUT"))
    assert outs[0] == outs[1]
    assert json.loads(outs[0])["counts"]["alarm"] == 6
    assert sorted(p.name for p in (tmp_path / "1" / "cache").iterdir()) == sorted(
        p.name for p in (tmp_path / "2" / "cache").iterdir())
    assert main(["monitor", "--conditions", str(csv_path), "--baseline-tests", "18", "--workers", "0",
                 "--json"]) == 2
    assert "--workers 0" in capsys.readouterr()[1]


def test_a_test_appended_is_judged_with_the_saved_baseline_state(tmp_path, monkeypatch, slit_series):
    """The baseline's held-out statistics are saved beside the cache; a rerun with a test appended reuses them (no
    held-out fit), a changed baseline refits."""
    import learn.monitor.baseline_state as state
    from learn.monitor import IdentificationSettings, SeriesInput, monitor_series, read_conditions

    full = read_conditions(slit_series[0])

    def part(n):
        return SeriesInput(full.files[:n], full.times[:n], full.time_values[:n], full.conditions[:n],
                           full.condition_names)

    first = monitor_series(part(34), 18, IdentificationSettings(), tmp_path, progress=False)
    assert len(list((tmp_path / "baseline").glob("*.json"))) == 1
    monkeypatch.setattr(state, "held_out_statistics", lambda *a: pytest.fail("refitted"))
    again = monitor_series(part(36), 18, IdentificationSettings(), tmp_path, progress=False)
    assert [r["novelty"] for r in again.rows[:34]] == [r["novelty"] for r in first.rows]
    assert again.threshold.value == first.threshold.value and again.rows[35]["alarm"]
    with pytest.raises(pytest.fail.Exception, match="refitted"):
        monitor_series(part(36), 20, IdentificationSettings(), tmp_path, progress=False)


def test_alarms_missing_a_mode_group_without_a_numpy_warning_and_an_unscaled_change_says_so():
    """A mode absent from every alarm of an event (its z NaN) splits nothing and warns nothing; an alarm whose
    z-scores are all NaN names its largest change without a 'nan sd'."""
    rows = _baseline(40, seed=2)
    a = _row("alarm", [np.nan, -9.0, 0, 0], t=40)
    b = _row("alarm", [np.nan, -9.5, 0, 0], t=41)
    c = {**_row("alarm", [0.0] * 4, t=42), "mode_z_scores": [np.nan] * 4, "change_pct": [3.0, np.nan, -1.0, np.nan]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        events = group_events(rows + [a, b], 0.01)
        lone = group_events(rows + [c], 0.01)[0]
    assert [list(e.members) for e in events] == [[40, 41]]
    assert "(the most: mode 1 +3 %, no baseline scatter to scale it by)" in lone.text


def test_a_test_not_identified_is_read_once_and_its_record_problem_comes_from_the_cache(tmp_path, monkeypatch,
                                                                                        slit_series):
    """A truncated .npz and response records clipped late (a run held at their highest value from sample 3000 of
    4000) among the modal tests: each file read once by the series' identification, its row's ``record_problem``
    that of :func:`record_problem` (which reads the file again), and the same from the cache without reading it."""
    import pickle

    import learn.monitor.identification as ident
    from learn.monitor import IdentificationSettings, SeriesInput, monitor_series

    _, files, _ = slit_series
    clipped, cut = tmp_path / "clipped.npz", tmp_path / "cut.npz"
    y = np.round(20 * np.random.default_rng(3).standard_normal(4000))
    y[3000:3050] = y.max() + 1
    np.savez(clipped, signals=y[None], sampling_frequency_hz=np.array(1000.0), dofs=np.array(["3:+Y"]))
    cut.write_bytes(clipped.read_bytes()[:300])
    expected = [record_problem(cut), record_problem(clipped)]
    assert "not a readable .npz" in expected[0] and "channel 0 is clipped: samples 3000-3049" in expected[1]
    tests = [str(f) for f in files[:22]] + [str(cut), str(clipped)] + [str(f) for f in files[24:]]
    reads = []
    real = ident.read_test
    monkeypatch.setattr(ident, "read_test", lambda path: reads.append(str(path)) or real(path))
    for _ in range(2):                                  # identified, then from the cache
        reads.clear()
        res = monitor_series(SeriesInput.from_files(tests), 18, IdentificationSettings(), tmp_path / "cache",
                             progress=False)
        assert [r["status"] for r in res.rows[22:24]] == ["not identified"] * 2
        assert [r["record_problem"] for r in res.rows[22:24]] == expected
        assert sorted(r for r in reads if r.endswith(".npz")) == ([str(clipped), str(cut)] if _ == 0 else [])
    error = res.rows[23]["error"]
    assert error.startswith(str(clipped)) and error.record_problem == expected[1]
    assert pickle.loads(pickle.dumps(error)).record_problem == expected[1]          # across worker processes
