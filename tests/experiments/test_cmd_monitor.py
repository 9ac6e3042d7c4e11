"""``beam-damage monitor`` through the CLI on series of the independent simulator (tests/monitor_series.py)."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from experiments.cli import main
from monitor_series import write_frf_series, write_modal_series


@pytest.fixture(scope="module")
def frf_series(tmp_path_factory):
    """16 daily UFF tests (receptances at 4 points, 1 % noise), a slit from day 13 on."""
    return write_frf_series(tmp_path_factory.mktemp("frf"), 16, slit_day=13, seed=11)


@pytest.fixture(scope="module")
def modal_series(tmp_path_factory):
    return write_modal_series(tmp_path_factory.mktemp("modal"), 30, slit_day=24, seed=12)


def run_json(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, (json.loads(out) if code == 0 else None), err


@pytest.mark.slow
def test_an_frf_series_is_identified_once_and_the_slit_alarmed(tmp_path, capsys, monkeypatch, frf_series):
    csv_path, _ = frf_series
    out = tmp_path / "mon"
    code, res, err = run_json(capsys, ["monitor", "--conditions", str(csv_path), "--baseline-tests", "12",
                                       "--out", str(out), "--json"])
    assert code == 0, err
    assert res["baseline_tests"] == 12 and res["false_alarm_rate"] == 0.01
    assert res["normal_variation"]["model"] == "regression"
    f = np.array([r["frequencies_hz"] for r in res["tests"]])
    assert f.shape == (16, 4) and np.isfinite(f).all()
    np.testing.assert_allclose(np.median(f[:12], axis=0), [21.7, 136, 381, 746], rtol=0.02)   # 12-element mesh
    alarms = [r["alarm"] for r in res["tests"]]
    assert alarms[13:] == [True] * 3 and not any(alarms[12:13])
    assert res["first_alarm"]["index"] == 13
    v = res["tests"][13]["verdict"]
    assert v["what_changed"][0]["z"] < -5 and v["what_changed"][0]["change_pct"] < -0.3
    for name in ("monitor.png", "monitor.csv", "monitor.json", "report.html"):
        assert (out / name).is_file()
    assert "data:image/png;base64," in (out / "report.html").read_text()
    rows = list(csv.DictReader(open(out / "monitor.csv")))
    assert len(rows) == 16 and rows[13]["alarm"] == "True"
    memory = [r["chart_alarm"] == "True" for r in rows]
    assert memory == [bool(r["chart_alarm"]) for r in res["tests"]]
    assert res["counts"]["chart_alarms"] == sum(memory[12:])
    from experiments.cli.cmd_monitor import chart_text

    words = chart_text(res)
    assert words in (out / "report.md").read_text()
    assert words.startswith(f"memory chart (EWMA): {sum(memory[12:])} later test" if any(memory[12:]) else
                            "memory chart (EWMA): no later test above its limit")
    entries = [json.loads(p.read_text()) for p in (out / "cache").glob("*.json")]
    # one entry per test, and one per narrow-band re-identification (the far-pole check of the damaged tests)
    assert sum(e["narrow_band_hz"] is None for e in entries) == 16
    assert ({e["file"] for e in entries if e["narrow_band_hz"] is not None}
            <= {e["file"] for e in entries if e["narrow_band_hz"] is None})
    import learn.monitor.identification

    monkeypatch.setattr(learn.monitor.identification, "identify_test", lambda *a: pytest.fail("identified again"))
    code, again, err = run_json(capsys, ["monitor", "--conditions", str(csv_path), "--baseline-tests", "12",
                                         "--out", str(out), "--json"])
    assert code == 0, err
    assert [r["novelty"] for r in again["tests"]] == [r["novelty"] for r in res["tests"]]


def test_a_modal_series_writes_its_chart_table_and_report_and_reruns_from_the_cache(tmp_path, capsys, monkeypatch,
                                                                                   modal_series):
    csv_path, files, _ = modal_series
    out = tmp_path / "mon"
    argv = ["monitor", "--conditions", str(csv_path), "--baseline-tests", "18", "--out", str(out), "--json"]
    code, res, err = run_json(capsys, argv)
    assert code == 0, err
    assert [r["alarm"] for r in res["tests"][18:]] == [False] * 6 + [True] * 6
    assert res["first_alarm"]["index"] == 24 and res["n_alarms_after_baseline"] == 6
    assert res["tests"][24]["verdict"]["summary"].startswith("mode ")
    saved = json.loads((out / "monitor.json").read_text())
    assert saved["tests"][24]["novelty"] == res["tests"][24]["novelty"]
    assert "data:image/png;base64," in (out / "report.html").read_text()
    rows = list(csv.DictReader(open(out / "monitor.csv")))
    assert len(rows) == 30 and rows[24]["alarm"] == "True" and float(rows[0]["temperature_c"]) == pytest.approx(
        res["tests"][0]["conditions"]["temperature_c"])
    assert [row["alarmed_by"] for row in rows] == ["+".join(r["alarmed_by"]) for r in res["tests"]]
    assert rows[24]["alarmed_by"] != "" and rows[17]["alarmed_by"] == ""
    assert float(rows[24]["shift_pct"]) == pytest.approx(res["tests"][24]["shift_pct"])
    assert len(list((out / "cache").glob("*.json"))) == 30
    import learn.monitor.identification

    monkeypatch.setattr(learn.monitor.identification, "identify_test", lambda *a: pytest.fail("identified again"))
    code, again, err = run_json(capsys, argv)
    assert code == 0, err
    assert [r["novelty"] for r in again["tests"]] == [r["novelty"] for r in res["tests"]]


def test_too_few_baseline_tests_is_one_line_and_nothing_written(tmp_path, capsys, modal_series):
    csv_path, _, _ = modal_series
    out = tmp_path / "never"
    code, _, err = run_json(capsys, ["monitor", "--conditions", str(csv_path), "--baseline-tests", "9",
                                     "--out", str(out), "--json"])
    assert code == 2
    assert err.count("\n") == 1 and "at least 11" in err and "--baseline-tests" in err
    assert not out.exists()


def test_a_bad_file_is_its_rows_error_and_mixed_kinds_are_named(tmp_path, capsys, modal_series, frf_series):
    _, files, _ = modal_series
    bad = tmp_path / "bad.json"
    bad.write_text('{"natural_frequencies_hz": "many"}')
    series = [str(f) for f in files[:26]] + [str(bad), str(frf_series[1][0])] + [str(f) for f in files[26:]]
    code, res, err = run_json(capsys, ["monitor", *series, "--baseline-tests", "15", "--json"])
    assert code == 0, err
    rows = res["tests"]
    assert rows[26]["identified"] is False and "bad.json" in rows[26]["error"]
    assert rows[27]["identified"] is False and rows[27]["error"].startswith("mixed kinds")
    assert all(r["alarm"] for r in rows[28:])                        # the slit, after both bad rows
    assert res["normal_variation"]["model"] == "pca"
    code, _, err = run_json(capsys, ["monitor", str(frf_series[1][0]), *series[:20], "--baseline-tests", "15",
                                     "--json"])
    assert code == 2 and "mixed kinds" in err and err.count("\n") == 1


@pytest.mark.slow
def test_an_alarm_gets_the_explanations_with_the_measured_scatter_and_the_networks_verdict(tmp_path, capsys,
                                                                                          modal_series):
    from datagen.config import load_config, merge
    from datagen.generation import generate

    cfg = merge({"measurement": {"lines": 256}, "output": {"shard_size": 100}}, base=load_config("training"))
    generate(tmp_path / "data", cfg, n=200, seed=5, progress=False)
    assert main(["train", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "model"), "--epochs", "2",
                 "--json"]) == 0
    capsys.readouterr()
    csv_path, _, _ = modal_series
    code, res, err = run_json(capsys, ["monitor", "--conditions", str(csv_path), "--baseline-tests", "18",
                                       "--model", str(tmp_path / "model"), "--json"])
    assert code == 0, err
    (k, ev), = [(k, e) for k, e in enumerate(res["events"]) if 24 in e["members"]]
    assert res["tests"][24]["verdict"]["event"] == k and ev["first"] == 24 and ev["n_alarms"] == 6
    v = ev["verdict"]                                   # one explanation per event, on its alarms' mean change
    assert v["representative"] in [res["tests"][i]["file"] for i in ev["members"]]
    sigma = v["frequency_change_std"]
    np.testing.assert_allclose(sigma, res["normal_variation"]["per_mode_std"], rtol=1e-12)
    assert [h["name"] for h in v["hypotheses"]][0] != "intact"
    assert v["network"]["probability_damaged"] is not None and v["network_baselines"] == 18
    assert not any("may be of another beam" in w for w in res["warnings"])
    # tests measured at a DOF the model's beam does not have: said up front
    _, files, _ = modal_series
    other = []
    for f in files[:20]:
        d = json.loads(Path(f).read_text())
        other.append(tmp_path / Path(f).name)
        other[-1].write_text(json.dumps({**d, "dofs": [*d["dofs"][:3], "6:y"]}))
    code, res, err = run_json(capsys, ["monitor", *map(str, other), "--baseline-tests", "18",
                                       "--model", str(tmp_path / "model"), "--json"])
    assert code == 0, err
    assert any(w.startswith(f"--model {tmp_path / 'model'}: the tests may be of another beam: ") and
               "no measured DOF at model DOF(s) 5:y" in w for w in res["warnings"])


def test_a_baseline_of_sessions_is_named_and_a_later_session_like_them_is_no_alarm(tmp_path, capsys):
    """Four baseline sessions of 10 tests (every mode moved alike per session), then a session beyond their range
    and one with mode 3 moved 0.2 % within it: the sessions named in monitor.json and the report, the later session
    no alarm, the change alarmed."""
    rng = np.random.default_rng(7)
    offsets = [0.002, 0.005, -0.001, -0.004, 0.009, 0.009]
    files = []
    for j, o in enumerate(offsets):
        for k in range(10):
            f = np.array([20.0, 130.0, 370.0]) * np.exp(o + 1e-5 * rng.standard_normal(3))
            f[2] *= 1 - 0.002 * (j == 5)
            path = tmp_path / f"test_{10 * j + k:03d}.json"
            path.write_text(json.dumps({"natural_frequencies_hz": f.tolist()}))
            files.append(str(path))
    out = tmp_path / "mon"
    code, res, err = run_json(capsys, ["monitor", *files, "--baseline-tests", "40", "--out", str(out), "--json"])
    assert code == 0, err
    sessions = res["normal_variation"]["baseline_sessions"]
    assert sessions["sizes"] == [10] * 4 and sessions["first_tests"] == files[0:40:10]
    status = [r["status"] for r in res["tests"]]
    assert status[40:50] == ["no alarm"] * 10 and status[50:] == ["alarm"] * 10
    assert "The baseline period holds 4 sessions of 10/10/10/10 tests" in (out / "report.md").read_text()


def test_a_baseline_condition_missing_names_the_csv_line_and_the_condition(tmp_path, capsys, modal_series):
    csv_path, _, _ = modal_series
    lines = csv_path.read_text().splitlines()
    head, row = lines[0], lines[4].split(",")                   # line 5: the fourth test (time 3)
    lines[4] = ",".join([*row[:2], "nan"])
    bad = tmp_path / "c_nan.csv"
    bad.write_text("\n".join(lines).replace("day0", str(csv_path.parent / "day0")) + "\n")
    assert head == "file,time,temperature_c"
    code, _, err = run_json(capsys, ["monitor", "--conditions", str(bad), "--baseline-tests", "20",
                                     "--out", str(tmp_path / "m"), "--json"])
    assert code == 2 and err.count("\n") == 1 and not (tmp_path / "m").exists()
    assert f"{bad} line 5: baseline test " in err and "day003.json lacks a measured condition (temperature_c" in err


def test_a_baseline_none_of_whose_tests_is_identified_says_why_the_first_is_not(tmp_path, capsys):
    t = np.arange(2000) / 2000.0
    for k in range(8):
        np.savez(tmp_path / f"t{k}.npz", signals=np.vstack([np.sin(2 * np.pi * 50 * t) * np.exp(-t)] * 2),
                 sampling_frequency_hz=2000.0)
    code, _, err = run_json(capsys, ["monitor", *sorted(map(str, tmp_path.glob("t*.npz"))), "--baseline-tests", "7",
                                     "--band", "1500", "2000", "--out", str(tmp_path / "m"), "--json"])
    assert code == 2 and err.count("\n") == 1 and not (tmp_path / "m").exists()
    assert "none of the 7 baseline tests could be identified; the first: " in err
    assert "t0.npz: band up to 2000 Hz is above the Nyquist frequency 1000 Hz" in err


def test_a_conditions_csv_with_a_byte_order_mark_reads_as_without(tmp_path, modal_series):
    from learn.monitor.series import read_conditions

    csv_path, _, _ = modal_series
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + csv_path.read_bytes().replace(b"day0", str(csv_path.parent / "day0").encode()))
    a, b = read_conditions(bom), read_conditions(csv_path)
    assert a.files == b.files and a.condition_names == ("temperature_c",)
    np.testing.assert_array_equal(a.conditions, b.conditions)


def test_a_repeated_test_is_named_in_a_warning(tmp_path, capsys, modal_series):
    from physics.io.inputs import repeated_files

    _, files, _ = modal_series
    files = [str(f) for f in files]
    copy = tmp_path / "copy.json"
    copy.write_bytes(Path(files[10]).read_bytes())
    series = [*files[:25], files[3], str(copy)]
    assert repeated_files(series) == [(3, 25), (10, 26)]
    assert repeated_files(files) == []
    big = [tmp_path / f"big{k}.bin" for k in range(3)]     # equal in their first 64 KiB, the last differs after
    for k, b in enumerate(big):
        b.write_bytes(bytes(70_000) + (b"b" if k == 2 else b"a"))
    assert repeated_files([str(b) for b in big]) == [(0, 1)]
    code, res, err = run_json(capsys, ["monitor", *series, "--baseline-tests", "20", "--json"])
    assert code == 0, err
    assert res["warnings"][0] == (f"2 test(s) repeat an earlier one (the same file, or the same bytes): test 26 "
                                  f"({files[3]}) is test 4 listed again; test 27 ({copy}) repeats test 11 "
                                  f"({files[10]}); a repeated test is no new test")


def test_a_pca_asked_to_remove_more_components_than_the_modes_leave_says_so(tmp_path, capsys, modal_series):
    from learn.monitor import SeriesInput, monitor_series
    from learn.monitor.identification import IdentificationSettings

    _, files, _ = modal_series
    two = []
    for f in files:                                             # the first two modes of each test
        d = json.loads(Path(f).read_text())
        two.append(tmp_path / Path(f).name)
        two[-1].write_text(json.dumps({"eigenvalues": d["eigenvalues"][:2], "dofs": d["dofs"],
                                       "eigenvectors": [row[:2] for row in d["eigenvectors"]]}))
    with pytest.warns(UserWarning, match=r"--normal-model pca2: 2 tracked modes leave at most 1 component\(s\)"):
        res = monitor_series(SeriesInput.from_files(two), 20, IdentificationSettings(), None, 0.01, "pca2",
                             progress=False, chart="none")
    assert res.normal_variation["factors_removed"] == 1
