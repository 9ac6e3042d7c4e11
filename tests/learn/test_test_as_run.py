"""A test run otherwise than the beam file says: the force where no sensor is, at a node of some modes, one
accelerometer; the poles of a file paired with the model's modes."""

import json

import numpy as np
import pytest

from experiments.cli import main
from learn.network.features import BeamSpec
from learn.pairs.measured import on_model_dofs, pair_modes_by_frequency, differences_from_model, unexcited_modes
from physics.beam import beam_from_dict
from physics.io import MeasuredFRF
from physics.layout import layout_of

#: A cantilever's modes 1-5 with a mass on it (Hz), as the simulator's impact beam has them.
CANTILEVER_HZ = np.array([22.8, 136.2, 407.2, 753.0, 1319.2])


def test_a_spurious_pole_beside_a_true_mode_is_left_unpaired():
    # a 600 Hz line between modes 3 and 4, a 1235 Hz pole beside the true mode 5 at 1295 Hz
    found = np.array([22.1, 133.0, 398.0, 600.0, 741.0, 1235.0, 1295.0])
    np.testing.assert_array_equal(pair_modes_by_frequency(found, CANTILEVER_HZ), [0, 1, 2, -1, 3, -1, 4])


def test_a_pole_far_from_every_nominal_mode_is_never_paired():
    # 260 Hz lies a factor 1.57 below mode 3 and 1.91 above mode 2: beyond the tolerance even when both are missing
    np.testing.assert_array_equal(pair_modes_by_frequency([22.5, 260.0, 745.0], CANTILEVER_HZ), [0, -1, 3])
    # closely spaced high modes narrow the tolerance: mode 6 of a free-free beam lies 1.40 times above mode 5, so a
    # pole 25 % above mode 5 (beyond the midpoint, 18 %) is not taken for it
    free = np.array([1.0, 2.757, 5.404, 8.933, 13.345, 18.638])
    assert pair_modes_by_frequency([13.345 * 1.25], free[:5])[0] == -1
    assert pair_modes_by_frequency([13.345 * 1.15], free[:5])[0] == 4


def test_with_two_sensors_a_pole_is_paired_by_its_shape_too():
    mac = np.array([[0.99, 0.01], [0.02, 0.1]])          # the second pole's shape is none of the nominal ones
    np.testing.assert_array_equal(pair_modes_by_frequency([10.0, 27.0], [10.0, 27.6], shape_mac=mac), [0, -1])
    np.testing.assert_array_equal(pair_modes_by_frequency([10.0, 27.0], [10.0, 27.6]), [0, 1])


def _pinned(drive=None):
    d = {"name": "pp", "bc": "pinned-pinned", "length_m": 1.2, "width_m": 0.05, "thickness_m": 0.01,
         "EI_Nm2": 875.0, "mass_per_length_kg_m": 3.925, "measured_x_m": [0.15, 0.3, 0.6, 0.9, 1.05],
         "band_hz": [9.7, 650.0]}
    if drive is not None:
        d["drive_x_m"] = drive
    test = layout_of(beam_from_dict(d, "pp.toml"))
    return BeamSpec("pp", 1.2, tuple(f"{k}:y" for k in range(1, 6)), "iirs", test)


def _frf(x_sensors, x_ref, geometry=True, fmax_hz=650.0):
    f = np.linspace(10.0, fmax_hz, 800)
    resp = tuple(f"{k + 1}:+Y" for k in range(len(x_sensors)))
    ref = f"{len(x_sensors) + 1}:+Y"
    meta = {"format": "uff", "source": "t.uff"}
    if geometry:
        xs = [*x_sensors, x_ref]
        meta["geometry"] = {"nodes_m": {str(k + 1): [x, 0.0, 0.0] for k, x in enumerate(xs)}, "source": "uff 15"}
    H = (1.0 / (1.0 + 1j * f))[None, None, :] * np.ones((len(resp), 1, 1))
    return MeasuredFRF(f, H, resp, (ref,), metadata=meta)


def test_the_files_reference_dof_is_named_with_the_modes_it_cannot_excite():
    beam = _pinned()                                  # the beam file names no drive point: the first sensor's
    assert beam.test.drive_x_m == 0.15 and unexcited_modes(beam.test, 0.4) == (3, 6)
    lines = differences_from_model({"b.uff": _frf(beam.test.sensors_x_m, 0.4)}, beam, 0.625)
    drive = [x for x in lines if "reference DOF 6:+Y lies at 0.4 m" in x]
    assert len(drive) == 1 and "trained for a drive point at 0.15 m" in drive[0] and "modes 3, 6" in drive[0]
    assert not differences_from_model({"b.uff": _frf(beam.test.sensors_x_m, 0.4)}, _pinned(0.4), 0.625)
    spacing = differences_from_model({"b.uff": _frf(beam.test.sensors_x_m, 0.4)}, _pinned(0.4), 0.1)
    assert len(spacing) == 1 and "line spacing 0.801 Hz, coarser than the training data's 0.1 Hz" in spacing[0]
    short = _frf(beam.test.sensors_x_m, 0.4)
    short = MeasuredFRF(short.frequency_hz[:300], short.frf[..., :300], short.response_dofs, short.reference_dofs,
                        metadata=short.metadata)                # 10-250 Hz: modes 4 and 5 (261, 407 Hz) are not
    band = differences_from_model({"s.uff": short}, _pinned(0.4), 0.625)
    assert len(band) == 1 and "modes 4, 5 of the model lie outside" in band[0]


def test_one_accelerometer_and_a_hammer_elsewhere_is_one_sensor():
    """No node geometry: the beam file's one measured_x_m places the response; the hammer's DOF is the force's."""
    d = {"name": "cf", "bc": "clamped-free", "length_m": 0.6, "width_m": 0.03, "thickness_m": 0.01,
         "EI_Nm2": 525.0, "mass_per_length_kg_m": 2.355, "measured_x_m": [0.6], "drive_x_m": 0.06,
         "band_hz": [10.0, 1600.0]}
    beam = BeamSpec("cf", 0.6, ("1:y",), "iirs", layout_of(beam_from_dict(d, "cf.toml")))
    frf = _frf([0.6], 0.06, geometry=False, fmax_hz=1600.0)
    frf = MeasuredFRF(frf.frequency_hz, frf.frf, ("6:+Y",), ("5:+Y",), metadata=frf.metadata)
    data, dof_map = on_model_dofs(frf, beam, [0.6], "t.uff")
    assert data.response_dofs == ("1:y",) and data.reference_dofs == ("5:+Y",)
    assert dof_map.dofs == ("6:+Y",) and dof_map.positions_m.tolist() == [0.6]
    lines = differences_from_model({"t.uff": frf}, beam)
    assert lines == ["the files carry no node geometry of their reference DOF: the force is taken at the model's "
                     "drive point 0.06 m"]


@pytest.fixture(scope="module")
def impact(tmp_path_factory):
    """One pair of the independent simulator's impact test: one accelerometer at the tip, the hammer at 0.09 m."""
    from experiments.second_sim.beams import TEST_AS_RUN, simulate_beam_pairs, write_beam_pairs

    cb = next(c for c in TEST_AS_RUN if c.name == "steel-cf-1acc-impact")
    tmp = tmp_path_factory.mktemp("impact")
    write_beam_pairs(cb, simulate_beam_pairs(cb, 1, 7), tmp, 7)
    return tmp


@pytest.mark.slow
def test_identify_writes_one_sensor_modal_data_that_discrepancy_takes(impact, capsys):
    f = impact / "pair-000_baseline.uff"
    assert main(["identify", str(f), "--band", "10", "1600", "--out", str(impact / "id"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    truth = json.loads((impact / "truth.json").read_text())["pairs"][0]["baseline_frequencies_hz"]
    np.testing.assert_allclose([m["frequency_hz"] for m in out["modes"]], truth, rtol=0.01)
    assert main(["discrepancy", "--beam", str(impact / "beam.toml"), "--measured", str(impact / "id" / "modal.json"),
                 "--max-effects", "0", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["gap_before"]["max_abs_frequency_error_pct"] < 8.0


@pytest.mark.slow
def test_the_one_accelerometer_transfer_test_is_generated_classified_and_discrepancyd(impact, capsys):
    """generate simulates the test as run (the hammer at 0.09 m, no sensor there); classify takes its files (two
    DOFs, one of them the force's) and finds the modes 'identify --band' finds; discrepancy takes the FRF."""
    fast = impact / "fast.toml"
    fast.write_text('base = "training"\n[output]\nshard_size = 200\n[measurement]\nlines = 512\n')
    assert main(["generate", "--beam", str(impact / "beam.toml"), "--config", str(fast), "--n", "600",
                 "--seed", "2", "--modal-noise", "shipped", "--out", str(impact / "data"), "--json"]) == 0
    manifest = json.loads((impact / "data" / "manifest.json").read_text())
    assert manifest["schema"]["frf_reference_row"] == 1 and len(manifest["schema"]["measured_dofs"]) == 1
    capsys.readouterr()
    assert main(["train", "--data", str(impact / "data"), "--out", str(impact / "model"), "--epochs", "5",
                 "--json"]) == 0
    capsys.readouterr()
    base, cur = impact / "pair-000_baseline.uff", impact / "pair-000_current.uff"
    assert main(["classify", "--model", str(impact / "model"), "--baseline", str(base), str(cur), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    ident = res["identification"]
    assert ident["as"] == "identify --band 10 1600" and [p["mode"] for p in ident["baseline_poles"]] == [1, 2, 3, 4, 5]
    assert any("no node geometry of their reference DOF" in w for w in res["warnings"])
    for name, f in (("baseline", base), ("measured", cur)):
        assert main(["identify", str(f), "--band", "10", "1600", "--json"]) == 0
        found = [m["frequency_hz"] for m in json.loads(capsys.readouterr().out)["modes"]]
        np.testing.assert_allclose([p["frequency_hz"] for p in ident[f"{name}_poles"]], found, rtol=1e-9)
    assert main(["discrepancy", "--beam", str(impact / "beam.toml"), "--measured", str(base), "--max-effects", "0",
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert any("one sensor" in n for n in res["notes"]) and res["drive_x_m_from_file"] is None


def test_discrepancy_takes_the_drive_point_a_beam_file_leaves_out_from_the_file():
    from physics.discrepancy import measurement_mesh, measured_test_notes
    from physics.discrepancy import Measurement

    d = {"name": "pp", "bc": "pinned-pinned", "length_m": 1.2, "width_m": 0.05, "thickness_m": 0.01,
         "EI_Nm2": 875.0, "mass_per_length_kg_m": 3.925, "measured_x_m": [0.15, 0.3, 0.6, 0.9, 1.05]}
    beam = beam_from_dict(d, "pp.toml")
    assert measurement_mesh(beam).n_elements == 8                     # nodes at 0.15 m steps
    f = np.linspace(10.0, 20.0, 8)
    meas = Measurement(np.array([16.3, 65.1]), frf=np.ones((1, 1, 8)), frf_frequency_hz=f,
                       frf_response_x_m=(0.6,), frf_reference_x_m=(0.4,))
    notes, drive = measured_test_notes(beam, meas, "b.uff")
    assert drive == 0.4 and len(notes) == 2 and "one sensor" in notes[0]
    assert "drive_x_m = 0.4 m from b.uff: its reference DOF" in notes[1]
    assert measured_test_notes(beam_from_dict({**d, "drive_x_m": 0.15}, "pp.toml"), meas, "b.uff")[1] is None
