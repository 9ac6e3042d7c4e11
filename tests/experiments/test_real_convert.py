"""The real sets' converters: the registry against ``experiments/data/real/README.md``, and each converter on a tiny
synthetic copy of its repository's files (the values read back as written, the derived fields computed by hand)."""

import re
from pathlib import Path

import numpy as np
import pytest

from experiments.benches.real_convert import (BRIDGE_TESTS, DROPBEAR_STATE_PINLOC_V, DS11_BOARDS, DS11_MORE_BOARDS,
                                              SETS, convert_set, dropbear_dwells, main)
from physics.errors import FileFormatError

README = Path(__file__).resolve().parents[2] / "experiments" / "data" / "real" / "README.md"


def _sections() -> dict:
    """README section text per documented set (``## `NAME.npz` ...``)."""
    text = README.read_text(encoding="utf-8")
    parts = re.split(r"^## `(\w+)\.npz`.*$", text, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def test_every_set_of_the_registry_is_documented_and_every_documented_set_is_converted():
    sections = _sections()
    assert set(sections) == set(SETS)
    for name, spec in SETS.items():
        text = sections[name]
        assert f"python -m experiments.benches.real_convert {name} --source DIR" in text
        assert spec.commit in text and f"`{spec.repository}" in text and spec.licence.split(" (")[0] in text
        assert re.fullmatch(r"[0-9a-f]{40}", spec.commit)


def _lvm(path: Path, delta_x: float, unit: str, columns: list, data: np.ndarray, rows_per_column=None):
    """A LabVIEW text file of the form the repositories hold (``rows_per_column``: a column shorter than the
    others, as the impedance columns)."""
    k = len(columns)
    head = ["LabVIEW Measurement,", "Separator,Comma", "Date,2020/01/01", "Time,09:00:00.000000",
            "***End_of_Header***,", ",", f"Channels,{k},", "Date," + "2022/08/31," * k,
            "Time," + "13:08:32.8712248499998," * k,
            "Y_Unit_Label," + f"{unit}," * k, f"Delta_X,{delta_x!r}," + "1.0," * (k - 1), "***End_of_Header***,",
            "X_Value," + ",".join(columns) + ",Comment"]
    rows = []
    for i, row in enumerate(data):
        n = k if rows_per_column is None or i < rows_per_column[1] else rows_per_column[0]
        rows.append(",".join([f"{i * delta_x:.6f}"] + [f"{v:.6f}" for v in row[:n]] + [""] * (k - n)))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(head + rows) + "\n")


def _dropbear_text(pin: np.ndarray, seed: int) -> str:
    rng = np.random.default_rng(seed)
    acc = np.round(rng.standard_normal((pin.size, 2)), 5)
    t = np.arange(pin.size) * 2e-4
    head = ["C:\\test.txt", "Programmer - None", "Striker Velocity - 0.00179", "Sampling Frequency - 5000",
            "Tue, Jul 19, 2022 10:55 PM", "Low G Accel\tAccel\tPinLoc\tTime", "Voltage (unscaled)\t" * 3 + "Sec",
            "0.0 0.0 0\t\t0.0 0.0 0\t", ""]
    rows = [f"{a:.5E}\t{b:.5E}\t{p:.5E}\t{s:.5E}" for (a, b), p, s in zip(acc, pin, t)]
    return "\n".join(head + rows) + "\n", acc


def _synthetic(name: str, src: Path) -> dict:
    """Write the set's files under ``src``; return what the converter must give for some fields."""
    rng = np.random.default_rng(1)
    spec = SETS[name]
    files = [src / p for p in spec.paths]
    for f in files:
        f.parent.mkdir(parents=True, exist_ok=True)
    if name == "pyfrf_hits":
        m = rng.standard_normal((5, 3, 64))
        m[:, 0] = np.arange(64) / 25600.0
        for f, x in zip(files, m):
            np.save(f, x)
        return {"force": m[:, 1], "response": m[:, 2], "sampling_frequency_hz": 25600.0}
    if name == "hct_setups":
        setups = [np.round(rng.standard_normal((20, 6 if i == 0 else 8)), 6) for i in range(4)]
        for f, y in zip(files, setups):
            np.savetxt(f, y, fmt="%.6e")
        return {**{f"setup{i + 1}": y.T for i, y in enumerate(setups)}, "sampling_frequency_hz": 40.0,
                "dof_labels_setup2": np.array([f"setup2:ch{c}" for c in range(1, 9)])}
    if name == "dropbear_roller_steps":
        # 0.72 s at state 0, a 0.04-s ramp, 0.72 s at state 3 (PinLoc V): two dwells (> 0.55 s) per test
        pin = np.r_[np.full(3600, 1.2259), np.linspace(1.2259, 2.5035, 200), np.full(3600, 2.5035)]
        accs = []
        for i, f in enumerate(files):
            text, acc = _dropbear_text(pin if i else np.r_[pin, 1.2259], i)   # test 0 one sample longer
            f.write_text(text)
            accs.append(acc)
        return {"records": np.stack([np.c_[a[:pin.size], np.round(pin, 5)].T for a in accs]),
                "test_number": np.arange(11), "segment_test": np.repeat(np.arange(11), 2),
                "segment_state": np.tile([0, 3], 11), "segment_pinloc_v": np.tile([1.2259, 2.5035], 11)}
    if name == "usc_bridge_a_impacts":
        recs = np.round(rng.standard_normal((len(BRIDGE_TESTS), 30, 3)), 6)
        for f, x in zip(files, recs):
            _lvm(f, 0.000156, "g", ["Acceleration_0", "Acceleration_1", "Acceleration_2"], x)
        amb = [np.round(rng.standard_normal((n, 1)), 6) for n in (25, 21, 23)]
        for f, x in zip(files[len(BRIDGE_TESTS):], amb):
            _lvm(f, 0.000605, "g", ["Acceleration"], x)
        return {"records": recs.transpose(0, 2, 1), "ambient_records": np.stack([a[:21, 0] for a in amb]),
                "test_number": [n for n, _ in BRIDGE_TESTS], "sensor_layout": [fo for _, fo in BRIDGE_TESTS],
                "start_time": ["2022/08/31 13:08:32.871"] * len(BRIDGE_TESTS),
                "sampling_frequency_hz": 1 / 0.000156, "ambient_sampling_frequency_hz": 1 / 0.000605}
    if name == "ds5_pcb_shock_impedance":
        recs = np.round(rng.standard_normal((32, 12, 2)), 6)
        zf = np.array([100000.0, 10000.0, 1000.0, 120.0, 100.0])
        mag = np.round(rng.uniform(1e3, 1e6, (32, 5)), 6)
        ph = np.round(rng.uniform(-90, -80, (32, 5)), 6)
        for k, f in enumerate(files):
            data = np.c_[recs[k], np.r_[np.c_[zf, mag[k], ph[k], np.zeros(5)], np.zeros((7, 4))]]
            _lvm(f, 1.953125e-5, "m/s^2", ["Acceleration_0", "Acceleration_1", "Untitled", "Untitled 1", "Untitled 2",
                                           "Untitled 3"], data, rows_per_column=(2, 5))
        return {"records": recs.transpose(0, 2, 1), "impedance_frequency_hz": zf, "impedance_magnitude": mag,
                "impedance_phase_deg": ph, "test_number": np.arange(1, 33), "sampling_frequency_hz": 51200.0,
                "acquisition_flagged_bad": np.isin(np.arange(1, 33), [17, 24])}
    if name == "ds5_pcb_repeated_shock":
        half = len(files) // 2
        lengths = {"pcb": [20 + (k % 2) for k in range(half)], "base": [8 + (k % 3 == 0) for k in range(half)]}
        dt = {"pcb": 2e-5, "base": 2.5e-5}
        values = {}
        for kind, fs_ in (("pcb", files[:half]), ("base", files[half:])):
            values[kind] = [np.round(rng.standard_normal(n), 6) for n in lengths[kind]]
            for f, y in zip(fs_, values[kind]):
                np.savetxt(f, np.c_[np.arange(y.size) * dt[kind], y], header="time(s), acceleration(g)")
        trials = [int(re.search(r"a(\d+)\.txt$", p).group(1)) for p in spec.paths[:half]]
        return {"pcb_records": np.stack([y[:20] for y in values["pcb"]]),
                "base_records": np.stack([y[:8] for y in values["base"]]), "trial_number": trials,
                "pcb_original_length": lengths["pcb"], "base_original_length": lengths["base"],
                "pcb_sampling_frequency_hz": np.full(half, 5e4), "base_sampling_frequency_hz": np.full(half, 4e4)}
    if name in ("ds11_pcb_impacts_to_failure", "ds11_more_boards"):
        boards = DS11_BOARDS if name == "ds11_pcb_impacts_to_failure" else DS11_MORE_BOARDS
        counts = [n for _, _, n in boards]
        recs = np.round(rng.standard_normal((len(files), 6, 2)) * 1e3, 6)
        res = np.round(rng.uniform(0.27, 0.30, len(files)), 6)
        last = np.cumsum(counts) - 1
        res[last] = 9.9e37
        board = np.repeat([b for b, _, _ in boards], counts)
        for f, x, r, b in zip(files, recs, res, board):
            _ds11_file(f, x, r, readings=b in ("4.7", "4.8", "4.9", "4.10"))
        return {"records": recs.transpose(0, 2, 1), "resistance_ohm": res,
                "open_circuit": np.isin(np.arange(len(files)), last), "board": board, "sampling_frequency_hz": 2e5,
                "impact_number": np.concatenate([np.arange(n) for n in counts])}
    raise AssertionError(name)


def _ds11_file(path: Path, x: np.ndarray, resistance: float, dt: float = 5e-6, readings: bool = False) -> None:
    """A Dataset-11 impact file: tab-separated time, two channels; the resistance on the first line, the later
    lines ending in a tab (as the repository's); ``readings``: a fifth column, resistance readings, on the first
    three lines (the second and third with an empty fourth), as boards 4.7-4.10's files."""
    t = np.arange(x.shape[0]) * dt
    fifth = [f"\t{resistance + 1e-5 * k:.6f}" if readings and k < 3 else "" for k in range(x.shape[0])]
    lines = [f"{t[0]:.6f}\t{x[0, 0]:.6f}\t{x[0, 1]:.6f}\t{resistance:.6E}{fifth[0]}"]
    lines += [f"{ti:.6E}\t{a:.6f}\t{b:.6f}\t{e}" for ti, (a, b), e in zip(t[1:], x[1:], fifth[1:])]
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("name", list(SETS))
def test_each_converter_reads_its_repositorys_files_as_written(tmp_path, name):
    expected = _synthetic(name, tmp_path / "src")
    path = convert_set(name, tmp_path / "src", tmp_path / "out")
    assert path == tmp_path / "out" / f"{name}.npz"
    with np.load(path, allow_pickle=False) as z:
        for key, want in expected.items():
            got = z[key]
            if got.dtype.kind in "US":
                np.testing.assert_array_equal(got, np.asarray(want))
            else:
                np.testing.assert_allclose(got, np.asarray(want, float), rtol=1e-12, atol=0, err_msg=key)
        assert all(z[k].dtype != object for k in z.files)


def test_the_dropbear_dwells_are_the_still_runs_of_the_roller_and_cut_short_runs():
    fs = 5000.0
    pin = np.r_[np.full(4000, 1.2259), np.linspace(1.2259, 2.5035, 500), np.full(4000, 2.5035),
                np.linspace(2.5035, 1.2259, 500), np.full(2000, 1.2259)]   # the last dwell 0.4 s: too short
    d = dropbear_dwells(pin, fs)
    assert len(d) == 2
    (a0, b0, m0), (a1, b1, m1) = d
    # A sample moves when the 250-sample average (half width 125) changes by > 0.03 V within 250 samples either way.
    # The start: the zero-padded average lies within 0.03 V of the level 250 * 0.03 / 1.2259 samples before its
    # half width ends. At a ramp of slope s (V/sample) the average rises quadratically, s x^2 / 500 after x samples,
    # reaching 0.03 V at x = sqrt(500 * 0.03 / s).
    slope = (2.5035 - 1.2259) / 499
    x = np.sqrt(500 * 0.03 / slope)
    assert abs(a0 - (125 + 250 - 250 * 0.03 / 1.2259)) <= 1.5
    assert abs(b0 - (4000 - 125 - 250 + x)) <= 1.5
    assert abs(a1 - (4500 + 125 + 250 - x)) <= 1.5
    assert abs(b1 - (8500 - 125 - 250 + x)) <= 1.5
    assert (m0, m1) == (1.2259, 2.5035)
    assert np.argmin(np.abs(np.array([m0, m1])[:, None] - DROPBEAR_STATE_PINLOC_V), axis=1).tolist() == [0, 3]


def test_a_missing_file_stops_with_one_line_naming_it_and_the_commit_and_writes_nothing(tmp_path, capsys):
    with pytest.raises(FileFormatError, match=r"measurements_1\.npy: absent \(5 of the 5 files of pyfrf_hits\); "
                                              r"expected a checkout of github.com/ladisk/pyFRF at commit 55431fd"):
        convert_set("pyfrf_hits", tmp_path, tmp_path / "out")
    assert main(["hct_setups", "--source", str(tmp_path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "dherita1.asc: absent" in err
    assert not (tmp_path / "out").exists()


def test_a_malformed_file_is_named(tmp_path):
    _synthetic("usc_bridge_a_impacts", tmp_path)
    bad = tmp_path / SETS["usc_bridge_a_impacts"].paths[3]
    bad.write_text(bad.read_text().replace("Delta_X,0.000156", "Delta_X,0.0002"))
    with pytest.raises(FileFormatError, match=re.escape(f"{bad}: Delta_X 0.0002; expected 0.000156")):
        convert_set("usc_bridge_a_impacts", tmp_path, tmp_path / "out")
    lines = bad.read_text().replace("Delta_X,0.0002", "Delta_X,0.000156").splitlines()
    lines[-1] = lines[-1].rsplit(",", 1)[0] + ",0.1x"            # a text cell in channel 2
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=re.escape(f"{bad}: column(s) Acceleration_2 hold text")):
        convert_set("usc_bridge_a_impacts", tmp_path, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_dataset_11_file_without_its_resistance_or_off_the_time_step_is_named(tmp_path):
    _synthetic("ds11_pcb_impacts_to_failure", tmp_path)
    bad = tmp_path / SETS["ds11_pcb_impacts_to_failure"].paths[60]
    good = bad.read_text()
    bad.write_text(good.split("\n", 1)[0].rsplit("\t", 1)[0] + "\n" + good.split("\n", 1)[1])
    with pytest.raises(FileFormatError, match=re.escape(f"{bad}: first line '0.000000\\t") + r".*expected 4 "
                                              r"tab-separated numbers: time, two channels, resistance"):
        convert_set("ds11_pcb_impacts_to_failure", tmp_path, tmp_path / "out")
    _ds11_file(bad, np.zeros((6, 2)), 0.28, dt=1e-5)
    with pytest.raises(FileFormatError, match=re.escape(f"{bad}: time column not on a 5e-06 s step")):
        convert_set("ds11_pcb_impacts_to_failure", tmp_path, tmp_path / "out")
    assert not (tmp_path / "out").exists()
