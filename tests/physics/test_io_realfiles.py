"""Readers against universal files written by real test systems (tests/data, pyuff's MIT-licensed samples).

Units and geometry: the Test.Lab file's header, units (164), coordinate systems (18) and nodes (15) are
combined with FRF records whose axis labels name their units, so the SI values are known independently.
"""

from pathlib import Path

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from physics.errors import FileFormatError
from physics.io import (match_dofs_by_position, measured_positions, read_frf, read_uff58, read_uff_geometry,
                        write_uff58)
from physics.io.types import MeasuredFRF

DATA = Path(__file__).resolve().parents[1] / "data"
G = 9.80665
LBF = 4.4482216152605


def sdof(f_hz, fn=30.0, zeta=0.02):
    w, wn = 2 * np.pi * f_hz, 2 * np.pi * fn
    return 1.0 / (wn**2 - w**2 + 2j * zeta * wn * w)


def _frf_records(h_by_node, f, ordinate_label, denominator_label, ordinate_type=12):
    return [pyuff.prepare_58(binary=0, func_type=4, rsp_node=n, rsp_dir=3, ref_node=1, ref_dir=3, data=h, x=f,
                             abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate_type,
                             orddenom_spec_data_type=13, abscissa_axis_units_lab="Hz",
                             ordinate_axis_units_lab=ordinate_label, orddenom_axis_units_lab=denominator_label)
            for n, h in h_by_node.items()]


def _testlab_with_frfs(tmp_path, name, records):
    """Test.Lab's own header/units/coordinate systems/nodes, then FRF records appended by pyuff."""
    path = tmp_path / name
    path.write_bytes((DATA / "TestLab_161_164_18_15_82.uff").read_bytes())
    pyuff.UFF(str(path)).write_sets(records, mode="add")
    return path


def test_testlab_geometry_and_units_are_read_and_labels_converted_to_si(tmp_path):
    f = np.arange(5.0, 60.0, 0.5)
    h_g = {1: 0.5 * sdof(f), 2: 0.25 * sdof(f, 41.0)}  # accelerance in g/lbf as a test system wrote it
    path = _testlab_with_frfs(tmp_path, "g_per_lbf.uff", _frf_records(h_g, f, "g", "lbf"))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # header, units, systems, nodes and trace lines are context, not noise
        frf = read_uff58(path)
    assert frf.kind == "accelerance" and frf.units == "m/s^2/N"
    np.testing.assert_allclose(frf.frf[0, 0], h_g[1] * G / LBF, rtol=1e-10)
    assert frf.metadata["units"]["file"] == ["g/lbf (axis labels)"]
    assert frf.metadata["units"]["factor_to_si"] == [pytest.approx(G / LBF)]
    assert "dataset 164" in frf.metadata["units"]["unit_system"]
    nodes = frf.metadata["geometry"]["nodes_m"]
    assert len(nodes) == 36 and nodes["1"] == [-2.4, -0.95, 0.0] and nodes["5"] == [-1.2, 8.35, 0.0]


@pytest.mark.parametrize("label, factor, kind", [("mm/s^2", 1e-3, "accelerance"), ("m/s2", 1.0, "accelerance"),
                                                 ("in/s", 0.0254, "mobility"), ("(m/s^2)/N", 1.0, "accelerance"),
                                                 ("mm", 1e-3, "receptance")])
def test_unit_labels(tmp_path, label, factor, kind):
    f = np.arange(5.0, 60.0, 0.5)
    path = tmp_path / "x.uff"
    code = {"receptance": 8, "mobility": 11, "accelerance": 12}[kind]
    pyuff.UFF(str(path)).write_sets(_frf_records({2: sdof(f)}, f, label, "N", code), mode="add")
    frf = read_uff58(path)
    assert frf.kind == kind
    np.testing.assert_allclose(frf.frf[0, 0], sdof(f) * factor, rtol=1e-10)


def test_unit_system_of_dataset_164_applies_without_labels_and_maps_nodes_to_beam_positions(tmp_path):
    # a file in millimetres (user system: length factor 1000, force factor 1): receptance in mm/N,
    # nodes along x at 0, 152.4, ..., 609.6 mm (beam 5's quarter points)
    f = np.arange(5.0, 60.0, 0.5)
    x_mm = np.array([0.0, 152.375, 304.75, 457.125, 609.5])
    path = tmp_path / "mm.uff"
    sets = [pyuff.prepare_164(units_code=9, units_description="mm user", temp_mode=1, length=1000.0, force=1.0,
                              temp=1.0, temp_offset=273.15),
            pyuff.prepare_15(node_nums=[1, 2, 3, 4, 5], def_cs=[0] * 5, disp_cs=[0] * 5, color=[1] * 5,
                             x=x_mm.tolist(), y=[20.0] * 5, z=[5.0] * 5)]
    sets += _frf_records({3: sdof(f), 5: 2 * sdof(f)}, f, "NONE", "NONE", ordinate_type=8)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    frf = read_uff58(path)
    np.testing.assert_allclose(frf.frf[0, 0], sdof(f) * 1e-3, rtol=1e-10)  # mm/N -> m/N
    assert frf.metadata["units"]["file"] == ["file units of dataset 164 (dataset 164 user defined, length "
                                             "factor 1000, force factor 1)"]
    geometry = read_uff_geometry(path)
    pos, source = measured_positions(frf.response_dofs, geometry)
    np.testing.assert_allclose(pos, [0.30475, 0.6095], rtol=1e-12)
    assert "geometry" in source
    # the model of beam 5 (4 elements, 0.6095 m): nodes 3 and 5
    model_x = np.linspace(0, 0.6095, 5)
    np.testing.assert_array_equal(match_dofs_by_position(pos, model_x, tol_m=1e-3), [2, 4])
    # without geometry the quarter-point convention holds, and says so
    pos2, source2 = measured_positions(frf.response_dofs, None, length_m=0.6095)
    np.testing.assert_allclose(pos2, pos, rtol=1e-12)
    assert "quarter points" in source2


@pytest.mark.parametrize("label, message", [("furlong/s", "unit label 'furlong/s'"),
                                            ("g", "accelerance unit but the ordinate type says receptance")])
def test_uninterpretable_or_contradictory_units_are_refused(tmp_path, label, message):
    f = np.arange(5.0, 60.0, 0.5)
    path = tmp_path / "bad.uff"
    pyuff.UFF(str(path)).write_sets(_frf_records({2: sdof(f)}, f, label, "N", ordinate_type=8), mode="add")
    with pytest.raises(FileFormatError, match=message):
        read_uff58(path)


def test_geometry_of_oros_and_artemis_files():
    oros = read_uff_geometry(DATA / "mesh_Oros-modal_uff15_uff2412.uff")
    raw = pyuff.UFF(str(DATA / "mesh_Oros-modal_uff15_uff2412.uff")).read_sets(1)  # nodes in system 1
    local = np.column_stack([raw["x"], raw["y"], raw["z"]])
    assert oros.node_ids.size == 96 and "m assumed" in oros.source
    # system 1 is a rigid placement: every distance between nodes is kept
    d_local = np.linalg.norm(local[:, None] - local[None], axis=-1)
    d_global = np.linalg.norm(oros.xyz_m[:, None] - oros.xyz_m[None], axis=-1)
    np.testing.assert_allclose(d_global, d_local, atol=1e-9)
    art = read_uff_geometry(DATA / "Artemis_export_-_Geometry_RPBC_setup_05_14102016_105117.uff")
    assert art.node_ids.size == 74 and np.ptp(art.xyz_m[:, 0]) == pytest.approx(9.856)


@pytest.mark.parametrize("name, message", [
    ("sample_dataset58_psd.uff", r"no FRF \(function type 4\); function types found: 9 \(power spectral density\)"),
    ("Sample_UFF58b_bin.uff", r"1 \(time response\) x1; time records need a force channel"),
    ("MPSTD_Set001_2024_10_08_10_27_07.uff", r"1 \(time response\) x4; time records need a force channel"),
    ("TestLab_161_164_18_15_82.uff", r"no dataset 58 .* 15 \(nodes\)"),
])
def test_real_files_without_frfs_say_what_they_hold(name, message):
    with pytest.raises(FileFormatError, match=message):
        read_frf(DATA / name)


def test_written_uff_keeps_units_label_and_round_trips(tmp_path):
    f = np.arange(5.0, 60.0, 0.5)
    frf = MeasuredFRF(f, sdof(f), ("2:+Z",), ("1:+Z",), kind="mobility")
    write_uff58(tmp_path / "m.uff", frf)
    back = read_uff58(tmp_path / "m.uff")
    assert back.metadata["units"]["file"] == ["m/s/N (axis labels)"]
    np.testing.assert_array_equal(back.frequency_hz, f)


def test_a_geometry_of_one_node_places_it_at_its_distance_from_the_origin():
    """One accelerometer (a file whose geometry holds its node alone): its position along the beam is its
    distance from the origin, the end x = 0, wherever the beam's axis points."""
    from physics.io.geometry import NodeGeometry, positions_along_beam

    g = NodeGeometry(np.array([7]), np.array([[0.0, -0.3, 0.4]]), "test")
    np.testing.assert_allclose(positions_along_beam(g, [7]), [0.5])
