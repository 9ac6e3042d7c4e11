"""Measured DOFs placed by position in ``update`` and ``discrepancy`` (issue 11, units and geometry).

A test system numbers its nodes as it likes (101..104 here), writes the records in its own order and its
coordinates in millimetres; the file of the same test with the thesis numbering (nodes 2..5 at the quarter
points, file order = node order, SI) is the independent reference: both must give the same numbers.
"""

import json

import numpy as np
import pytest
from systems import write_renumbered_uff

from experiments.cli import main
from physics.io import write_uff58
from physics.thesis import simulated_beam5_test

L = 0.6095
NODES = {2: 101, 3: 102, 4: 103, 5: 104}
QUARTER_MM = {101: 152.375, 102: 304.75, 103: 457.125, 104: 609.5}
SHUFFLE = [2, 0, 3, 1]  # records of nodes 4, 2, 5, 3


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("positions")
    frf, exact = simulated_beam5_test(noise=0.005, seed=11, df_hz=2.0, damping="heavy")
    write_uff58(d / "canonical.uff", frf, binary=True)
    write_renumbered_uff(d / "renumbered.uff", frf, NODES, QUARTER_MM, SHUFFLE)
    write_renumbered_uff(d / "offgrid.uff", frf, NODES, {**QUARTER_MM, 103: 400.0}, SHUFFLE)
    write_renumbered_uff(d / "nogeometry.uff", frf, NODES, None, SHUFFLE)
    return d, exact


def _run(capsys, *argv):
    code = main(list(argv))
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def test_update_maps_renumbered_shuffled_mm_file_by_geometry(capsys, files):
    d, exact = files
    code, out, err = _run(capsys, "update", "--modal", str(d / "canonical.uff"), "--json")
    assert code == 0, err
    ref = json.loads(out)
    assert ref["dof_positions"]["source"] == "quarter-point convention"
    code, out, err = _run(capsys, "update", "--modal", str(d / "renumbered.uff"), "--json")
    assert code == 0, err
    res = json.loads(out)
    pos = res["dof_positions"]
    assert pos["source"] == "uff geometry"
    assert pos["dofs"] == ["103:+Y", "101:+Y", "104:+Y", "102:+Y"]          # the file's record order
    np.testing.assert_allclose(pos["positions_m"], [3 * L / 4, L / 4, L, L / 2], rtol=1e-12)
    assert pos["model_dofs"] == ["4:y", "2:y", "5:y", "3:y"]
    # the same updated model as the canonical file's (rows in the beam's DOF order 2..5)
    for key in ("C", "K"):
        np.testing.assert_allclose(res[key], ref[key], rtol=0, atol=1e-6 * np.abs(ref[key]).max())
    np.testing.assert_allclose(res["natural_frequencies_hz"], ref["natural_frequencies_hz"], rtol=1e-7)
    # and both reproduce the exact modes of the simulated test
    np.testing.assert_allclose(res["natural_frequencies_hz"], exact.natural_frequencies_hz, rtol=2e-3)
    assert res["eigenvalue_check"]["reproduces_measured"] and res["eigenvalue_check"]["max_relative_error"] < 1e-3


def test_update_refuses_a_measured_point_off_the_model_grid_in_one_line(capsys, files):
    d, _ = files
    code, out, err = _run(capsys, "update", "--modal", str(d / "offgrid.uff"))
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "offgrid.uff" in err and "measured DOF 103:+Y at x = 0.4 m is not at a model DOF" in err
    assert "uff geometry" in err
    # no geometry and nodes 101..104: the quarter-point convention puts node 101 at 25 m, refused
    code, out, err = _run(capsys, "update", "--modal", str(d / "nogeometry.uff"))
    assert code == 2 and err.count("\n") == 1 and "nogeometry.uff" in err and "quarter-point convention" in err


def test_update_without_geometry_says_quarter_point_convention(capsys, files, tmp_path):
    d, _ = files
    code, out, err = _run(capsys, "update", "--modal", str(d / "canonical.uff"))
    assert code == 0, err
    assert "measured DOFs placed by the quarter-point convention" in out and "5:+Y at 0.6095 m -> 5:y" in out


def test_update_takes_positions_from_a_beam_file(capsys, files, tmp_path):
    """Nodes 101..104 without geometry, placed by a beam file's measured_x_m in ascending node number."""
    d, _ = files
    beam = tmp_path / "b.toml"
    beam.write_text(f'preset = "beam5"\nmeasured_x_m = [{L / 4!r}, {L / 2!r}, {3 * L / 4!r}, {L!r}]\n')
    ref = json.loads(_run(capsys, "update", "--modal", str(d / "canonical.uff"), "--json")[1])
    code, out, err = _run(capsys, "update", "--beam", str(beam), "--modal", str(d / "nogeometry.uff"), "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["dof_positions"]["source"] == "beam file"
    assert res["dof_positions"]["model_dofs"] == ["4:y", "2:y", "5:y", "3:y"]
    np.testing.assert_allclose(res["K"], ref["K"], rtol=0, atol=1e-6 * np.abs(ref["K"]).max())
    # a beam file giving the wrong number of positions is refused naming both
    beam.write_text(f'preset = "beam5"\nmeasured_x_m = [{L / 2!r}, {L!r}]\n')
    code, out, err = _run(capsys, "update", "--beam", str(beam), "--modal", str(d / "nogeometry.uff"))
    assert code == 2 and err.count("\n") == 1 and "nogeometry.uff" in err


DISCREPANCY = ("--max-effects", "1", "--elements", "6", "--candidates", "root_flexibility",
               "--json")


def test_discrepancy_maps_renumbered_shuffled_mm_file_by_geometry(capsys, files):
    d, _ = files
    code, out, err = _run(capsys, "discrepancy", "--measured", str(d / "canonical.uff"), *DISCREPANCY)
    assert code == 0, err
    ref = json.loads(out)
    assert ref["dof_positions"]["source"] == "quarter-point convention"
    code, out, err = _run(capsys, "discrepancy", "--measured", str(d / "renumbered.uff"), *DISCREPANCY)
    assert code == 0, err
    res = json.loads(out)
    assert res["dof_positions"]["source"] == "uff geometry"
    assert res["dof_positions"]["model_dofs"] == ["4:y", "2:y", "5:y", "3:y"]   # reference 104 = the tip, 5:y
    assert res["named_effect"] == ref["named_effect"]
    # the same fit: the residuals to 1e-4, the parameters to a fifth of their one-sigma (the bounded
    # multi-start fit stops at a tolerance: the identical inputs, up to 1e-9, land 0.1 sigma apart at most)
    for key, v in ref["parameters"].items():
        assert abs(res["parameters"][key] - v) < 0.2 * ref["parameter_std"][key], key
    for gap in ("gap_before", "gap_after"):
        for key, v in ref[gap].items():
            assert res[gap][key] == pytest.approx(v, rel=1e-4), (gap, key)
    code, out, err = _run(capsys, "discrepancy", "--measured", str(d / "offgrid.uff"), *DISCREPANCY)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "offgrid.uff" in err and "103:+Y at x = 0.4 m is not at a model DOF" in err


def test_rotations_and_axial_translations_are_no_measured_dofs_of_the_beam(capsys, tmp_path):
    """The same FRFs labelled as rotations (RZ) or, without node geometry, along the beam's axis (X) are refused in
    one line naming them; as Z they are transverse and update as the Y file does. Told to leave such DOFs out
    (``classify``'s pairs), the mapping names them as not used."""
    from physics.io.geometry import map_measured_dofs
    from physics.io.types import MeasuredFRF

    frf, _ = simulated_beam5_test(noise=0.0, seed=11, df_hz=2.0, damping="heavy")
    results = {}
    for direction in ("+Y", "+Z", "+RZ", "+X"):
        relabel = tuple(d.replace("+Y", direction) for d in frf.response_dofs)
        ref = tuple(d.replace("+Y", direction) for d in frf.reference_dofs)
        path = tmp_path / f"{direction[1:]}.uff"
        write_uff58(path, MeasuredFRF(frf.frequency_hz, frf.frf, relabel, ref))
        code, out, err = _run(capsys, "update", "--modal", str(path), "--json")
        results[direction] = (code, out, err)
    assert results["+Y"][0] == 0 and results["+Z"][0] == 0
    assert json.loads(results["+Y"][1])["K"] == json.loads(results["+Z"][1])["K"]
    for direction, named in (("+RZ", "2:+RZ, 3:+RZ, 4:+RZ, 5:+RZ"), ("+X", "2:+X, 3:+X, 4:+X, 5:+X")):
        code, out, err = results[direction]
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
        assert f"measured DOFs {named} are no transverse translation" in err
    mapped = map_measured_dofs(["2:+Y", "2:+RZ", "3:+Y"], [0.0, 0.152375, 0.30475], ["1:y", "2:y", "3:y"],
                               length_m=0.6095, off_grid="ignore")
    assert mapped.model_dofs == ("2:y", "", "3:y") and mapped.detail.endswith("not used: 2:+RZ")


@pytest.mark.parametrize(("text", "message"), [
    ('bc = "pinned-pinned"\n', "'measured_x_m': measured position 0.6095 m is on the pinned-pinned support at "
                              "x = 0.6095 m, which holds the translation (the quarter points, the default sensors): "
                              "give 'measured_x_m' off the supports"),
    ("measured_x_m = [0.1, 0.3, 0.45, 0.6095]\n", "'measured_x_m': measured position 0.1 m is not a node of the "
                                                  "4-element mesh: give 'measured_x_m' on its nodes, or 'n_elements' "
                                                  "that put nodes there"),
])
def test_sensors_on_a_support_or_off_the_nodes_are_refused_naming_the_beam_file(capsys, tmp_path, text, message):
    beam = tmp_path / "b.toml"
    beam.write_text('preset = "beam5"\n' + text)
    code, out, err = _run(capsys, "update", "--beam", str(beam), "--modal", str(_thesis_table()))
    assert code == 2 and out == "" and err.strip() == f"beam-damage update: error: {beam}: {message}"


def _thesis_table():
    from pathlib import Path

    import physics

    return Path(physics.__file__).parent / "data" / "thesis" / "beam5_table_4_5.json"
