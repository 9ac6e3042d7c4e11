"""Tests of ``beam-damage identify`` (and ``update`` fed by an FRF file)."""

import json

import numpy as np
import pytest
from cli_runs import run_cli

from experiments.cli import build_parser
from physics.identification import METHODS
from physics.io import MeasuredFRF, read_modal_json, write_frf_csv, write_frf_npz, write_uff58
from physics.thesis import beam5_reduced_model, simulated_beam5_test


@pytest.fixture(scope="module")
def beam5_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("frf")
    frf, exact = simulated_beam5_test(noise=0.01, seed=3, damping="heavy")
    write_uff58(d / "beam5.uff", frf, binary=True)
    write_frf_csv(d / "beam5.csv", frf.to_kind("accelerance"))
    write_frf_npz(d / "beam5.npz", frf)
    return d, exact


@pytest.mark.parametrize("name", ["beam5.uff", "beam5.csv", "beam5.npz"])
def test_identify_json_recovers_exact_modes(capsys, beam5_files, name):
    d, exact = beam5_files
    code, out, err = run_cli(capsys, ["identify", str(d / name), "--modes", "4", "--json"])
    assert code == 0, err
    res = json.loads(out)
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    z = np.array([m["damping_ratio"] for m in res["modes"]])
    np.testing.assert_allclose(f, exact.natural_frequencies_hz, rtol=5e-4)
    np.testing.assert_allclose(z, exact.damping_ratios, rtol=0.02)
    shape = np.array([complex(s) for s in res["modes"][1]["shape"]])
    psi = exact.eigenvectors[:, 1]
    assert abs(np.vdot(shape, psi)) ** 2 / (np.vdot(shape, shape).real * np.vdot(psi, psi).real) > 0.999
    assert np.linalg.norm(shape) == pytest.approx(np.linalg.norm(psi), rel=0.01)  # unit modal A
    assert res["dofs"] == ["2:+Y", "3:+Y", "4:+Y", "5:+Y"] and res["scaling"] == "unit modal A"
    assert all(0.99 < m["mpc"] <= 1.0 for m in res["modes"])


@pytest.mark.parametrize("method", [n for n, spec in METHODS.items() if spec.data == "frf"])
def test_identify_every_method_in_a_band(capsys, beam5_files, method):
    d, exact = beam5_files
    code, out, err = run_cli(capsys, ["identify", str(d / "beam5.uff"), "--method", method, "--band", "80", "500",
                                      "--json"])
    assert code == 0, err
    res = json.loads(out)
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    np.testing.assert_allclose(f, exact.natural_frequencies_hz[1:3], rtol=2e-3)
    assert res["method"] == method and res["uncertainty"] == dict(METHODS[method].uncertainty)


def test_identify_method_choices_and_help_are_the_method_table():
    sub = next(a for a in build_parser(["identify"])._actions if a.dest == "command")
    parser = sub.choices["identify"]
    actions = {a.dest: a for a in parser._actions}
    assert list(actions["method"].choices) == list(METHODS)
    assert actions["method"].default is None          # lscf for FRFs, ssi for response records
    for name, spec in METHODS.items():
        assert f"{name}: {spec.help}" in parser.description
    with_order = [name for name, spec in METHODS.items() if "max_order" in spec.options]
    assert actions["max_order"].help.endswith(f"used by {', '.join(with_order)})")


def test_identify_out_dir_feeds_update(capsys, beam5_files, tmp_path):
    d, exact = beam5_files
    code, out, err = run_cli(capsys, ["identify", str(d / "beam5.uff"), "--out", str(tmp_path / "id")])
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "id").iterdir()) == ["modal.json", "overlay.png",
                                                                   "stabilisation.png", "synthesised.uff"]
    assert (tmp_path / "id" / "overlay.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    modal = read_modal_json(tmp_path / "id" / "modal.json")
    np.testing.assert_allclose(modal.natural_frequencies_hz, exact.natural_frequencies_hz, rtol=5e-4)
    assert "4 modes by lscf" in out


def test_identify_bad_files_one_line_exit_2(capsys, tmp_path, beam5_files):
    d, _ = beam5_files
    raw = (d / "beam5.uff").read_bytes()
    (tmp_path / "cut.uff").write_bytes(raw[: len(raw) // 2 + 5])
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "cut.uff")])
    assert code == 2 and err.count("\n") == 1 and "truncated universal file" in err
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "missing.csv")])
    assert code == 2 and "not found" in err
    code, out, err = run_cli(capsys, ["identify", str(d / "beam5.uff"), "--band", "500", "100"])
    assert code == 2 and "FMIN" in err
    assert not (tmp_path / "out").exists()


def test_identify_without_driving_point_warns_unscaled(capsys, tmp_path):
    frf, _ = simulated_beam5_test(noise=0.0, seed=0, damping="heavy")
    other = MeasuredFRF(frf.frequency_hz, frf.frf[:3], frf.response_dofs[:3], frf.reference_dofs)
    write_frf_npz(tmp_path / "x.npz", other)
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "x.npz"), "--modes", "4", "--json"])
    res = json.loads(out)
    assert code == 0 and res["scaling"].startswith("unscaled") and "driving point" in res["warnings"][0]


def test_update_accepts_frf_file_and_recovers_model(capsys, beam5_files):
    d, exact = beam5_files
    code, out, err = run_cli(capsys, ["update", "--modal", str(d / "beam5.uff"), "--json"])
    assert code == 0, err
    res = json.loads(out)
    np.testing.assert_allclose(res["measured_natural_frequencies_hz"], exact.natural_frequencies_hz, rtol=5e-4)
    _, C, K = beam5_reduced_model("heavy")
    # the IIRS-reduced mass of the package equals the fixture's M to its printed digits,
    # so Pilkey's updated K is close to the K that made the FRFs
    np.testing.assert_allclose(np.diag(res["K"]), np.diag(K), rtol=0.02)


def test_identify_writes_synthesised_uff_in_the_input_kind_and_reports_db_error(capsys, tmp_path):
    from experiments.benches.bench_identification import simulate_free_free
    from physics.identification import reconstruction_error_db
    from physics.io import read_frf

    frf, truth = simulate_free_free(seed=2)
    write_uff58(tmp_path / "ff.uff", frf, binary=True)
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "ff.uff"), "--json", "--out", str(tmp_path / "o")])
    assert code == 0, err
    res = json.loads(out)
    synth = read_frf(tmp_path / "o" / "synthesised.uff")
    assert synth.kind == "accelerance" and synth.units == "m/s^2/N"
    np.testing.assert_array_equal(synth.frequency_hz, frf.frequency_hz)
    assert synth.response_dofs == frf.response_dofs and synth.reference_dofs == frf.reference_dofs
    med, p90 = reconstruction_error_db(frf.frf, synth.frf)  # recomputed from the written file
    assert res["fit_error_db"]["median"] == pytest.approx(med, rel=1e-6) and med < 0.1
    assert res["fit_error_db"]["p90"] == pytest.approx(p90, rel=1e-6) and p90 < 0.3
    assert res["kind"] == "accelerance" and res["out_of_band_poles_hz"] == [pytest.approx(1005.0, abs=0.5)]
    m = res["modes"][0]
    assert m["frequency_fit_std_hz"] > 0 and m["damping_fit_std"] > 0 and "model orders" in \
        res["uncertainty"]["frequency_std_hz, damping_std"]


def test_identify_json_reports_units_and_positions_from_the_file(capsys, tmp_path):
    import pyuff

    frf, _ = simulated_beam5_test(noise=0.0, seed=0, damping="heavy")
    # the same test written by a system in millimetres: dataset 164 (length factor 1000), nodes in mm,
    # receptances in mm/N with no unit labels
    x_mm = [0.0, 152.375, 304.75, 457.125, 609.5]
    sets = [pyuff.prepare_164(units_code=9, units_description="mm user", temp_mode=1, length=1000.0, force=1.0,
                              temp=1.0, temp_offset=273.15),
            pyuff.prepare_15(node_nums=[1, 2, 3, 4, 5], def_cs=[0] * 5, disp_cs=[0] * 5, color=[1] * 5,
                             x=x_mm, y=[0.0] * 5, z=[0.0] * 5)]
    for i, dof in enumerate(frf.response_dofs):
        sets.append(pyuff.prepare_58(binary=1, func_type=4, rsp_node=int(dof[0]), rsp_dir=2, ref_node=5, ref_dir=2,
                                     data=np.ascontiguousarray(frf.frf[i, 0] * 1000.0), x=frf.frequency_hz,
                                     abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=8,
                                     orddenom_spec_data_type=13))
    pyuff.UFF(str(tmp_path / "mm.uff")).write_sets(sets, mode="add")
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "mm.uff"), "--modes", "4", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["units"]["si"] == "m/N" and res["units"]["factor_to_si"] == [pytest.approx(1e-3)]
    assert res["positions_m"] == {"2:+Y": pytest.approx(0.152375), "3:+Y": pytest.approx(0.30475),
                                  "4:+Y": pytest.approx(0.457125), "5:+Y": pytest.approx(0.6095)}
    assert "geometry" in res["positions_source"]
    # the CSV of the same FRFs has no geometry: the quarter-point convention is named
    write_frf_csv(tmp_path / "b.csv", frf)
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "b.csv"), "--modes", "4", "--json"])
    res = json.loads(out)
    assert res["positions_m"] is None and "quarter points" in res["positions_source"]
    assert res["units"]["si"] == "m/N"


def test_a_narrow_band_fits_the_highest_order_its_lines_carry(capsys, tmp_path):
    """41 lines of one FRF carry LSCF order 19 at most: by default the order is capped there and the 50 Hz, 2 %
    mode is found; --max-order 40 is refused naming the file and the highest order."""
    f = np.arange(1, 801) * 0.25
    w, wn = 2 * np.pi * f, 2 * np.pi * 50.0
    h = 1.0 / (wn ** 2 - w ** 2 + 2j * 0.02 * wn * w)
    path = tmp_path / "sdof.csv"
    write_frf_csv(path, MeasuredFRF(f, h[None, None], ("1:+Z",), ("1:+Z",)))
    code, out, err = run_cli(capsys, ["identify", str(path), "--band", "45", "55", "--json"])
    assert code == 0, err
    (mode,) = json.loads(out)["modes"]
    assert mode["frequency_hz"] == pytest.approx(50.0, rel=1e-4)
    assert mode["damping_ratio"] == pytest.approx(0.02, rel=1e-2)
    code, out, err = run_cli(capsys, ["identify", str(path), "--band", "45", "55", "--max-order", "40"])
    assert code == 2 and err.count("\n") == 1
    assert f"{path}: lscf: 41 lines x 1 responses are too few for model order 40 (at most 19" in err
