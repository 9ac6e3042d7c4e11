"""``beam-damage estimate`` and ``identify`` on time records (universal file dataset 58, function type 1)."""

import json
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run_cli
from systems import write_time_uff

from physics.io import read_frf

pyuff = pytest.importorskip("pyuff")
DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def impact_file(tmp_path_factory):
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "physics"))
    from test_time_records import _impact_test

    rec, model, scale = _impact_test()
    path = tmp_path_factory.mktemp("t") / "impact.uff"
    codes = {"force": 13, "displacement": 8, "acceleration": 12}
    write_time_uff(path, np.arange(rec.signals[0].size) * rec.time_step_s,
                   [(d.split(":")[0], sig, codes[q], lab)
                    for sig, d, q, lab in zip(rec.signals, rec.dofs, rec.quantities, ["N", "m"])])
    return path, rec, model, scale


def test_estimate_impact_file_flags_hits_and_writes_frf(capsys, impact_file, tmp_path):
    path, rec, (m, c, k), scale = impact_file
    code, out, err = run_cli(capsys, ["estimate", str(path), "--excitation", "impact", "--averages", "6",
                                      "--out", str(tmp_path / "frf.uff"), "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["double_hits"] == [2] and res["overloads"] == [{"block": 4, "dof": "2:+Z"}]
    assert res["n_averages"] == 4 and res["reference"] == "1:+Z" and res["kind"] == "receptance"
    frf = read_frf(tmp_path / "frf.uff")
    f = frf.frequency_hz
    band = (f > 5) & (f < 300)
    s = 2j * np.pi * f[band] + res["added_decay_rate_1_s"]
    np.testing.assert_allclose(frf.frf[0, 0, band], scale / (m * s**2 + c * s + k), rtol=0.1)


def test_identify_estimates_an_impact_record_one_block_per_hit_and_removes_the_window(capsys, impact_file):
    path, rec, (m, c, k), scale = impact_file
    code, out, err = run_cli(capsys, ["identify", str(path), "--band", "20", "200", "--json"])
    assert code == 0, err
    res = json.loads(out)
    # the force is 7 hits in 6 s (one a double hit) and near zero between them: an impact test, estimated one block
    # per hit (the double hit and the clipped block left out), not as random excitation cut across the hits
    said = [w for w in res["warnings"] if "holds time records, not FRFs" in w]
    assert said and "H1 of 4 impact blocks" in said[0], said
    assert res["exponential_window"]["added_decay_rate_1_s"] > 0
    wn = np.sqrt(k / m)
    assert res["modes"][0]["frequency_hz"] == pytest.approx(wn / (2 * np.pi), rel=2e-4)
    assert res["modes"][0]["damping_ratio"] == pytest.approx(c / (2 * m * wn), rel=0.05)


def test_estimate_cuts_one_impact_block_per_hit_by_default(capsys, impact_file):
    path, *_ = impact_file
    code, out, err = run_cli(capsys, ["estimate", str(path), "--excitation", "impact", "--json"])
    assert code == 0, err
    res = json.loads(out)
    # 6 hits 1 s apart and a bounce 0.3 s after the third: 6 blocks, the bounce's and the clipped one left out
    assert res["double_hits"] == [2] and res["n_averages"] == 4 and "of 2048 samples" in res["description"]


def test_estimate_warns_when_an_impact_record_is_estimated_as_random_excitation(capsys, impact_file):
    path, *_ = impact_file
    code, out, err = run_cli(capsys, ["estimate", str(path), "--json"])
    assert code == 0, err
    assert "holds 6 hits and is near zero between them" in err and "'impact' cuts one block per hit" in err


@pytest.mark.parametrize("command", ["estimate"])   # identify runs them output-only (test_cmd_identify_output_only)
def test_real_time_records_without_force_give_one_line(capsys, command, tmp_path):
    code, out, err = run_cli(capsys, [command, str(DATA / "MPSTD_Set001_2024_10_08_10_27_07.uff"),
                                      *(["--out", str(tmp_path / "x.uff")] if command == "estimate" else [])])
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "MPSTD_Set001" in err and "4 time records" in err and "no force channel" in err
    assert not (tmp_path / "x.uff").exists()


@pytest.mark.parametrize("window", ["bogus", "kaiser", "kaiser,x"])
def test_a_window_scipy_cannot_make_is_one_line_naming_the_form(capsys, impact_file, window, tmp_path):
    path, *_ = impact_file
    out_file = tmp_path / "frf.uff"
    code, out, err = run_cli(capsys, ["estimate", str(path), "--window", window, "--out", str(out_file)])
    assert code == 2 and out == "" and not out_file.exists()
    assert err.count("\n") == 1 and f"window {window!r}" in err and "kaiser,8.6" in err


def test_a_window_with_its_parameter_is_the_scipy_window():
    from scipy.signal import get_window

    from physics.time_records import segment_window

    assert segment_window("kaiser,8.6") == ("kaiser", 8.6)
    np.testing.assert_array_equal(get_window(segment_window("tukey, 0.25"), 64), get_window(("tukey", 0.25), 64))
    assert segment_window("hann") == "hann"
