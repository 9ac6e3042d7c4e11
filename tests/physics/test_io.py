"""Tests of measured-FRF I/O (UFF58 ASCII/binary, CSV, NPZ) and its validation."""

from pathlib import Path

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from physics.errors import FileFormatError, ShapeError
from physics.io import (MeasuredFRF, dof_label, parse_dof, read_frf, read_frf_csv, read_frf_npz,
                        read_uff58, write_frf_csv, write_frf_npz, write_uff58)
from systems import big_endian_58b, write_time_uff


def sdof_frf(f_hz, fn=30.0, zeta=0.02, m=0.1):
    w, wn = 2 * np.pi * f_hz, 2 * np.pi * fn
    return 1.0 / (m * (wn**2 - w**2 + 2j * zeta * wn * w))


@pytest.fixture
def frf():
    f = np.arange(1.0, 100.0, 0.5)
    h = np.stack([np.stack([sdof_frf(f, 30 + 5 * i + j) for j in range(2)]) for i in range(3)])
    return MeasuredFRF(f, h, ("1:+Y", "2:+Y", "3:-Z"), ("1:+Y", "2:+Y"), metadata={"test": 1})


def _pyuff_record(f, h, rsp=(2, 2), ref=(1, 2), func_type=4, binary=0, ordinate=8, even=1):
    return pyuff.prepare_58(binary=binary, func_type=func_type, rsp_node=rsp[0], rsp_dir=rsp[1],
                            ref_node=ref[0], ref_dir=ref[1], data=h, x=f, abscissa_spacing=even,
                            abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate,
                            orddenom_spec_data_type=13)


def _write_pyuff(path, sets):
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def test_dof_labels_round_trip():
    assert dof_label(2, 2) == "2:+Y" and dof_label(7, -6) == "7:-RZ"
    assert parse_dof("2:+Y") == (2, 2) and parse_dof("3:y") == (3, 2) and parse_dof("5:-RZ") == (5, -6)
    with pytest.raises(FileFormatError, match="NODE:"):
        parse_dof("tip")


def test_kind_conversion_is_i_omega_power(frf):
    w = frf.omega_rad_s
    mob = frf.to_kind("mobility")
    acc = frf.to_kind("accelerance")
    np.testing.assert_allclose(mob.frf, 1j * w * frf.frf, rtol=1e-14)
    np.testing.assert_allclose(acc.frf, -(w**2) * frf.frf, rtol=1e-14)
    np.testing.assert_allclose(acc.to_kind("receptance").frf, frf.frf, rtol=1e-13)
    assert acc.units == "m/s^2/N" and mob.kind == "mobility"
    with_zero = MeasuredFRF(np.r_[0.0, frf.frequency_hz], np.concatenate([frf.frf[..., :1], frf.frf], -1),
                            frf.response_dofs, frf.reference_dofs, kind="mobility")
    with pytest.raises(ShapeError, match="0 Hz"):
        with_zero.to_kind("receptance")


def test_measuredfrf_validation():
    f = np.array([1.0, 2.0, 3.0])
    with pytest.raises(ShapeError, match="expected"):
        MeasuredFRF(f, np.ones((2, 1, 3), complex), ("1:+Y",), ("1:+Y",))
    with pytest.raises(ShapeError, match="NaN"):
        MeasuredFRF(f, np.array([[[1, np.nan, 1]]], complex), ("1:+Y",), ("1:+Y",))
    with pytest.raises(ShapeError, match="increasing"):
        MeasuredFRF(f[::-1], np.ones((1, 1, 3), complex), ("1:+Y",), ("1:+Y",))
    with pytest.raises(ShapeError, match="complex"):
        MeasuredFRF(f, np.ones((1, 1, 3)), ("1:+Y",), ("1:+Y",))
    with pytest.raises(ShapeError, match="zero"):
        MeasuredFRF(f, np.full((1, 1, 3), 1e-310 + 0j), ("1:+Y",), ("1:+Y",))


@pytest.mark.parametrize("binary", [False, True])
def test_uff58_round_trip(tmp_path, frf, binary):
    path = tmp_path / ("b.uff" if binary else "a.uff")
    for kind in ("receptance", "accelerance"):
        data = frf.to_kind(kind)
        write_uff58(path, data, binary=binary)
        back = read_frf(path)
        assert back.kind == kind
        assert back.response_dofs == frf.response_dofs and back.reference_dofs == frf.reference_dofs
        np.testing.assert_allclose(back.frequency_hz, frf.frequency_hz, rtol=1e-12)
        # ASCII keeps 12 significant digits (E20.11), binary is exact double
        np.testing.assert_allclose(back.frf, data.frf, rtol=0 if binary else 1e-10,
                                   atol=0 if binary else 1e-11 * np.abs(data.frf).max())
        assert back.metadata["binary"] == binary


def test_uff58_uneven_spacing_written_by_pyuff(tmp_path):
    f = np.geomspace(5.0, 200.0, 57)
    h = sdof_frf(f)
    path = tmp_path / "uneven.unv"
    _write_pyuff(path, [_pyuff_record(f, h, even=0)])
    back = read_uff58(path)
    np.testing.assert_allclose(back.frequency_hz, f, rtol=1e-5)  # E13.5 abscissa
    np.testing.assert_allclose(back.frf[0, 0], h, rtol=1e-10)
    assert back.response_dofs == ("2:+Y",) and back.reference_dofs == ("1:+Y",)


def test_uff58_mixed_binary_ascii_and_velocity(tmp_path):
    f = np.arange(1.0, 20.0, 0.25)
    h = sdof_frf(f)
    path = tmp_path / "mixed.uff"
    _write_pyuff(path, [_pyuff_record(f, h, binary=1, ordinate=11),
                        _pyuff_record(f, 2 * h, rsp=(3, 2), binary=0, ordinate=11)])
    back = read_uff58(path)
    assert back.kind == "mobility" and back.frf.shape == (2, 1, f.size)
    np.testing.assert_allclose(back.frf[1, 0], 2 * h, rtol=1e-10)


def test_uff58_skips_other_functions_and_rejects_no_frf(tmp_path):
    f = np.arange(1.0, 20.0, 0.5)
    h = sdof_frf(f)
    only_coh = tmp_path / "coh.uff"
    _write_pyuff(only_coh, [_pyuff_record(f, np.abs(h), func_type=6)])
    with pytest.raises(FileFormatError, match=r"no FRF \(function type 4\).*6 \(coherence\)"):
        read_uff58(only_coh)
    mixed = tmp_path / "mixed.uff"
    _write_pyuff(mixed, [_pyuff_record(f, np.abs(h), func_type=6), _pyuff_record(f, h)])
    with pytest.warns(UserWarning, match="not FRFs"):
        back = read_uff58(mixed)
    assert back.frf.shape == (1, 1, f.size)
    nodes = tmp_path / "nodes.uff"
    pyuff.UFF(str(nodes)).write_sets([pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0],
                                                       color=[1, 1], x=[0.0, 1.0], y=[0.0, 0.0],
                                                       z=[0.0, 0.0])], mode="add")
    with pytest.raises(FileFormatError, match="no dataset 58.*15"):
        read_uff58(nodes)


def test_uff58_duplicates_unequal_axes_missing_reference_nan(tmp_path):
    f = np.arange(1.0, 20.0, 0.5)
    h = sdof_frf(f)
    dup = tmp_path / "dup.uff"
    _write_pyuff(dup, [_pyuff_record(f, h), _pyuff_record(f, h)])
    with pytest.warns(UserWarning, match="duplicated record dropped"):
        assert read_uff58(dup).frf.shape == (1, 1, f.size)
    axes = tmp_path / "axes.uff"
    _write_pyuff(axes, [_pyuff_record(f, h), _pyuff_record(f + 0.1, h, rsp=(3, 2))])
    with pytest.raises(FileFormatError, match="record 2.*frequency axis.*differs"):
        read_uff58(axes)
    miss = tmp_path / "miss.uff"
    _write_pyuff(miss, [_pyuff_record(f, h), _pyuff_record(f, h, rsp=(3, 2), ref=(4, 2))])
    with pytest.raises(FileFormatError, match="no FRF for response .* and reference"):
        read_uff58(miss)
    bad = h.copy()
    bad[3] = 123.25  # pyuff cannot write NaN: patch the text instead
    nan = tmp_path / "nan.uff"
    _write_pyuff(nan, [_pyuff_record(f, bad)])
    text = nan.read_text()
    assert text.count("1.23250000000e+02") == 1
    nan.write_text(text.replace("1.23250000000e+02", "              NaN"))
    with pytest.raises(FileFormatError, match="NaN or inf"):
        read_uff58(nan)


@pytest.mark.parametrize("binary", [False, True])
def test_uff58_truncated_file_is_a_clear_error(tmp_path, frf, binary):
    path = tmp_path / "full.uff"
    write_uff58(path, frf, binary=binary)
    raw = path.read_bytes()
    for cut in (50, len(raw) // 2 + 11, len(raw) - 3):
        (tmp_path / "cut.uff").write_bytes(raw[:cut])
        with pytest.raises(FileFormatError, match="cut.uff: truncated universal file"):
            read_frf(tmp_path / "cut.uff")
    (tmp_path / "empty.uff").write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty"):
        read_frf(tmp_path / "empty.uff")


def test_csv_round_trip_and_layout(tmp_path, frf):
    path = tmp_path / "frf.csv"
    write_frf_csv(path, frf.to_kind("mobility"))
    text = path.read_text().splitlines()
    assert text[1] == "# kind: mobility"
    assert text[3].startswith("frequency_hz,re(1:+Y/1:+Y),im(1:+Y/1:+Y),re(1:+Y/2:+Y)")
    back = read_frf_csv(path)
    np.testing.assert_array_equal(back.frf, frf.to_kind("mobility").frf)  # 17 digits: exact
    assert back.kind == "mobility"


def test_csv_hand_written_single_reference_and_errors(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text("frequency_hz,re(2:+Y),im(2:+Y)\n1.0,1.5,-2.0\n2.0,0.5,0.25\n")
    back = read_frf(path)
    np.testing.assert_array_equal(back.frf[0, 0], [1.5 - 2j, 0.5 + 0.25j])
    assert back.reference_dofs == ("ref",) and back.kind == "receptance"
    path.write_text("frequency_hz,re(2:+Y),im(2:+Y)\n1.0,1.5,-2.0\n2.0,0.5\n")
    with pytest.raises(FileFormatError, match="line 3: 2 fields, expected 3"):
        read_frf(path)
    path.write_text("frequency_hz,re(2:+Y),im(3:+Y)\n1.0,1.5,-2.0\n")
    with pytest.raises(FileFormatError, match="must be 're"):
        read_frf(path)
    path.write_text("frequency_hz,re(2:+Y),im(2:+Y)\n1.0,1.5,nan\n2.0,1,1\n")
    with pytest.raises(FileFormatError, match="line 2: NaN"):
        read_frf(path)
    path.write_text("frequency_hz,re(2:+Y/1:+Y),im(2:+Y/1:+Y),re(3:+Y/5:+Y),im(3:+Y/5:+Y)\n1.0,1,1,1,1\n2.0,1,1,1,1\n")
    with pytest.raises(FileFormatError, match=r"hand.csv: line 1: no FRF for response 2:\+Y and reference 5:\+Y "
                                              r"\(2 missing of 2x2\)"):
        read_frf(path)
    for head in ("re(ref),im(ref)", "re(ref/5:+Y),im(ref/5:+Y)"):   # "ref" names only an unnamed reference
        path.write_text(f"frequency_hz,{head}\n1.0,1.5,-2.0\n2.0,0.5,0.25\n")
        with pytest.raises(FileFormatError, match=r"hand.csv: line 1: column 2 're\(ref.*DOF label 'ref' must look"):
            read_frf(path)


def test_npz_round_trip_without_pickle(tmp_path, frf):
    path = tmp_path / "frf.npz"
    write_frf_npz(path, frf)
    back = read_frf_npz(path)
    np.testing.assert_array_equal(back.frf, frf.frf)
    assert back.response_dofs == frf.response_dofs and back.metadata["test"] == 1
    np.savez(tmp_path / "bad.npz", frf=frf.frf)
    with pytest.raises(FileFormatError, match="missing array"):
        read_frf(tmp_path / "bad.npz")
    np.savez(tmp_path / "obj.npz", frequency_hz=np.array([object()]), frf=frf.frf,
             response_dofs=np.array(["a"]), reference_dofs=np.array(["b"]))
    with pytest.raises(FileFormatError, match="not a readable"):
        read_frf(tmp_path / "obj.npz")


def test_read_frf_sniffs_content_and_missing_file(tmp_path, frf):
    write_uff58(tmp_path / "data.dat", frf)
    assert read_frf(tmp_path / "data.dat").frf.shape == frf.frf.shape
    write_frf_npz(tmp_path / "x.npz", frf)
    (tmp_path / "x.npz").rename(tmp_path / "x.bin")
    assert read_frf(tmp_path / "x.bin").frf.shape == frf.frf.shape
    with pytest.raises(FileFormatError, match="not found"):
        read_frf(tmp_path / "nope.uff")


def test_writes_are_atomic_no_temp_left(tmp_path, frf):
    for writer, name in ((write_uff58, "a.uff"), (write_frf_csv, "a.csv"), (write_frf_npz, "a.npz")):
        writer(tmp_path / name, frf)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.npz", "a.uff"]


def test_atomic_path_renames_on_success_and_leaves_target_on_failure(tmp_path):
    import physics.io as pio

    target = tmp_path / "sub" / "t.txt"
    pio.atomic_write_text(target, "first")
    with pytest.raises(RuntimeError):
        with pio.atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("writer died")
    assert target.read_text() == "first" and sorted(p.name for p in target.parent.iterdir()) == ["t.txt"]
    with pytest.raises(FileNotFoundError):
        with pio.atomic_path(target):
            pass  # the writer wrote nothing: the target must not be replaced by an empty file
    assert target.read_text() == "first"
    with pio.atomic_path(target) as tmp:
        tmp.write_bytes(b"second")
    assert target.read_bytes() == b"second" and len(list(target.parent.iterdir())) == 1


def test_physics_io_keeps_every_public_name_of_the_module_it_replaced():
    import physics.io as pio

    names = {"MeasuredFRF", "ModalData", "FRF_KINDS", "DEFAULT_UNITS", "atomic_write_bytes", "atomic_write_text",
             "atomic_path", "dof_label", "parse_dof", "format_complex", "modal_data_from_dict",
             "modal_data_to_dict", "read_modal_json", "write_modal_json", "read_frf", "read_frf_csv",
             "read_frf_npz", "read_uff58", "write_frf_csv", "write_frf_npz", "write_uff58"}
    assert names <= set(pio.__all__) and all(hasattr(pio, n) for n in names)


def test_uff58b_big_endian_reads_like_little_endian(tmp_path, frf):
    write_uff58(tmp_path / "le.uff", frf, binary=True)
    (tmp_path / "be.uff").write_bytes(big_endian_58b((tmp_path / "le.uff").read_bytes()))
    assert b"    58b     2     2" in (tmp_path / "be.uff").read_bytes()
    le, be = read_uff58(tmp_path / "le.uff"), read_uff58(tmp_path / "be.uff")
    np.testing.assert_array_equal(be.frf, frf.frf)
    np.testing.assert_array_equal(be.frequency_hz, le.frequency_hz)


def test_uff58b_big_endian_time_records_read_like_little_endian(tmp_path):
    from physics.io import TIME, read

    t = np.arange(512) / 256.0
    write_time_uff(tmp_path / "le.uff", t, [(1, np.exp(-t), 13), (2, np.sin(2 * np.pi * 7 * t), 12)])
    (tmp_path / "be.uff").write_bytes(big_endian_58b((tmp_path / "le.uff").read_bytes()))
    assert (tmp_path / "be.uff").read_bytes().count(b"    58b     2     2") == 2
    be = read(tmp_path / "be.uff", TIME)
    np.testing.assert_array_equal(be.signals, [np.exp(-t), np.sin(2 * np.pi * 7 * t)])
    assert be.quantities == ("force", "acceleration") and be.time_step_s == pytest.approx(1 / 256.0, rel=1e-5)


def test_measured_frf_of_time_records_reads_the_universal_file_once(tmp_path, monkeypatch):
    import pyuff

    from physics.identification import read_measured_frf
    from physics.io import TIME, read
    from physics.time_records import estimate_from_records

    t = np.arange(4096) / 512.0
    force = np.random.default_rng(3).standard_normal(t.size)
    write_time_uff(tmp_path / "t.uff", t, [(1, force, 13), (2, np.convolve(force, np.exp(-t[:200] * 20), "same"), 12)])
    expected = estimate_from_records(read(tmp_path / "t.uff", TIME)).frf
    reads, read_sets = [], pyuff.UFF.read_sets
    monkeypatch.setattr(pyuff.UFF, "read_sets", lambda self, *a, **k: reads.append(a) or read_sets(self, *a, **k))
    with pytest.warns(UserWarning, match="holds time records, not FRFs"):
        got = read_measured_frf(tmp_path / "t.uff")
    assert len(reads) == 1
    np.testing.assert_array_equal(got.frf, expected.frf)
    assert got.response_dofs == ("2:+Z",) and got.reference_dofs == ("1:+Z",)


@pytest.mark.parametrize("field, value, message", [(slice(7, 13), b"     3", "byte ordering field '3'"),
                                                   (slice(13, 19), b"     1", "floating-point format field '1'")])
def test_uff58b_byte_order_and_float_format_codes_outside_the_standard_are_refused(tmp_path, frf, field, value,
                                                                                   message):
    write_uff58(tmp_path / "x.uff", frf, binary=True)
    raw = bytearray((tmp_path / "x.uff").read_bytes())
    at = raw.index(b"    58b")
    raw[at + field.start:at + field.stop] = value
    (tmp_path / "x.uff").write_bytes(bytes(raw))
    with pytest.raises(FileFormatError, match=message):
        read_uff58(tmp_path / "x.uff")


def test_binary_uff58_writer_leaves_no_open_file(tmp_path):
    """pyuff's binary 58 writer leaves a file handle behind: the writer closes it before the rename (no
    ResourceWarning reaches the caller, whose CLI would print it) and the file reads back whole."""
    import warnings as _w

    frf = MeasuredFRF(np.linspace(1, 100, 50), (np.arange(100).reshape(2, 1, 50) + 1j).astype(complex),
                      ("2:+Y", "3:+Y"), ("2:+Y",))
    with _w.catch_warnings(record=True) as caught:
        _w.simplefilter("always")
        write_uff58(tmp_path / "b.uff", frf, binary=True)
    assert not [w for w in caught if issubclass(w.category, ResourceWarning)]
    np.testing.assert_allclose(read_frf(tmp_path / "b.uff").frf, frf.frf)


def test_positive_directions_and_reciprocity_of_measured_frfs():
    """'3:-Y' rows and '2:-Y' columns are negated and relabelled (twice negated: unchanged), modal data rows too;
    reciprocal() swaps responses and references and is its own inverse."""
    from physics.io import MeasuredFRF, ModalData

    rng = np.random.default_rng(0)
    h = rng.standard_normal((3, 2, 5)) + 1j * rng.standard_normal((3, 2, 5))
    f = MeasuredFRF(np.arange(1.0, 6.0), h, ("2:+Y", "3:-Y", "4:+Y"), ("2:-Y", "4:+Y"))
    g = f.with_positive_directions()
    assert g.response_dofs == ("2:+Y", "3:+Y", "4:+Y") and g.reference_dofs == ("2:+Y", "4:+Y")
    np.testing.assert_array_equal(g.frf[1, 1], -h[1, 1])
    np.testing.assert_array_equal(g.frf[1, 0], h[1, 0])          # -Y response, -Y reference: signs cancel
    np.testing.assert_array_equal(g.frf[0, 0], -h[0, 0])
    np.testing.assert_array_equal(g.frf[2, 1], h[2, 1])
    assert g.with_positive_directions() is g
    r = f.reciprocal()
    assert r.response_dofs == f.reference_dofs and r.reference_dofs == f.response_dofs
    np.testing.assert_array_equal(r.frf[1, 2], h[2, 1])
    np.testing.assert_array_equal(r.reciprocal().frf, h)
    md = ModalData(np.array([-1 + 10j, -2 + 30j]), np.arange(6.0).reshape(3, 2) + 0j, ("2:+Y", "3:-Y", "4:+Y"))
    p = md.with_positive_directions()
    assert p.dofs == ("2:+Y", "3:+Y", "4:+Y")
    np.testing.assert_array_equal(p.eigenvectors, md.eigenvectors * np.array([1, -1, 1])[:, None])


def test_npz_and_csv_time_series_with_a_force_channel_are_estimated_as_the_universal_file(tmp_path):
    from physics.identification import read_measured_frf
    from physics.io import TIME, read
    from physics.time_records import estimate_from_records

    t = np.arange(4096) / 512.0
    force = np.random.default_rng(3).standard_normal(t.size)
    resp = np.convolve(force, np.exp(-t[:200] * 20), "same")
    write_time_uff(tmp_path / "t.uff", t, [(1, force, 13), (2, resp, 12)])
    expected = estimate_from_records(read(tmp_path / "t.uff", TIME)).frf
    np.savez(tmp_path / "t.npz", signals=np.vstack([force, resp]), sampling_frequency_hz=512.0,
             dofs=np.array(["1:+Z", "2:+Z"]), quantity=np.array(["force", "acceleration"]))
    rows = "\n".join(",".join(repr(float(v)) for v in row) for row in zip(t, force, resp))
    (tmp_path / "t.csv").write_text(f"# quantity: force, acceleration\ntime_s,1:+Z,2:+Z\n{rows}\n")
    for name in ("t.npz", "t.csv"):
        rec = read(tmp_path / name, TIME)
        assert rec.forces == [0] and rec.quantities == ("force", "acceleration")
        with pytest.warns(UserWarning, match="holds time records, not FRFs"):
            got = read_measured_frf(tmp_path / name)
        np.testing.assert_allclose(got.frf, expected.frf, rtol=1e-9, atol=1e-12 * np.abs(expected.frf).max())
        assert got.response_dofs == ("2:+Z",) and got.reference_dofs == ("1:+Z",) and got.kind == expected.kind


@pytest.mark.parametrize("quantity, message", [(["force", "force"], "'force' for every channel"),
                                               (["force", "strain"], r"one of them per channel \(2\)"),
                                               (["force", "acceleration", "velocity"], "one of them per channel")])
def test_time_series_quantities_other_than_one_or_one_per_channel_are_refused(tmp_path, quantity, message):
    from physics.errors import FileFormatError
    from physics.io import TIME, read

    q = quantity[0] if quantity == ["force", "force"] else np.array(quantity)
    np.savez(tmp_path / "q.npz", signals=np.zeros((2, 64)), sampling_frequency_hz=100.0, quantity=q)
    with pytest.raises(FileFormatError, match=message):
        read(tmp_path / "q.npz", TIME)


def test_a_cut_crlf_binary_universal_file_names_the_byte_its_last_record_starts_at(tmp_path):
    raw = (Path(__file__).resolve().parents[1] / "data" / "MPSTD_Set001_2024_10_08_10_27_07.uff").read_bytes()
    cut = int(0.4 * len(raw))
    start = raw[:cut].rfind(b"    -1\r\n    58b")           # the opening delimiter of the record cut
    assert start > 0
    (tmp_path / "cut.uff").write_bytes(raw[:cut])
    with pytest.raises(FileFormatError, match=f"the last record \\(from byte {start}\\)"):
        read_frf(tmp_path / "cut.uff")


def test_frequencies_and_damping_beside_the_eigenvalues_must_be_finite_and_the_same_modes():
    from physics.io.modal_json import modal_data_from_dict

    lam = np.array([-0.5 + 100j, -2.0 + 800j])
    w = np.abs(lam)
    good = {"eigenvalues": [str(z) for z in lam], "natural_frequencies_hz": list(w / (2 * np.pi)),
            "damping_ratios": list(-lam.real / w)}
    np.testing.assert_array_equal(modal_data_from_dict(good).eigenvalues, lam)
    damped = {**good, "natural_frequencies_hz": list(lam.imag / (2 * np.pi))}     # tools write either
    np.testing.assert_array_equal(modal_data_from_dict(damped).eigenvalues, lam)
    for key, value, message in (("natural_frequencies_hz", [float("nan"), 127.3], "must hold finite numbers"),
                                ("damping_ratios", [0.005], "has 1 entries for 2 eigenvalues"),
                                ("natural_frequencies_hz", [20.0, 127.3], "entry 1 is 20, but eigenvalue 1"),
                                ("damping_ratios", [0.005, 0.05], "entry 2 is 0.05, but eigenvalue 2")):
        with pytest.raises(FileFormatError, match=message):
            modal_data_from_dict({**good, key: value}, "m.json")


def test_a_value_no_number_names_the_unreadable_record(tmp_path):
    f = np.linspace(1.0, 100.0, 50)
    h = (1.0 + 0.5j) / (1.0 + 1j * f)
    bad = h.copy()
    bad[7] = 123.25
    path = tmp_path / "stars.uff"
    _write_pyuff(path, [_pyuff_record(f, h), _pyuff_record(f, bad, rsp=(3, 2))])
    text = path.read_text()
    assert text.count("1.23250000000e+02") == 1
    path.write_text(text.replace("1.23250000000e+02", "*" * 17))
    with pytest.raises(FileFormatError, match=r"stars.uff: cannot read dataset 58 records .*the first unreadable: "
                                              r"dataset 58 record 2 \(block 2 of the file"):
        read_frf(path)


def test_csv_and_npz_units_are_converted_to_si_and_a_unit_of_another_kind_is_refused(tmp_path, frf):
    """The same accelerance written in g/N (CSV ``# units:``) and in mm/s^2/N (NPZ ``units``) reads as the SI one
    (1 g = 9.80665 m/s^2); a receptance stated in g/N, or a unit this reader does not know, names the field."""
    acc = frf.to_kind("accelerance")
    path = tmp_path / "g.csv"
    write_frf_csv(path, acc)
    lines = path.read_text().splitlines()
    assert lines[2] == "# units: m/s^2/N"
    table = np.loadtxt(lines[4:], delimiter=",")
    table[:, 1:] /= 9.80665
    path.write_text("\n".join([*lines[:2], "# units: g/N", lines[3]]) + "\n"
                    + "\n".join(",".join(f"{v:.17g}" for v in row) for row in table) + "\n")
    back = read_frf(path)
    np.testing.assert_allclose(back.frf, acc.frf, rtol=1e-14)
    assert back.units == "m/s^2/N"
    npz = tmp_path / "mm.npz"
    np.savez(npz, frequency_hz=acc.frequency_hz, frf=acc.frf * 1e3, response_dofs=np.array(acc.response_dofs),
             reference_dofs=np.array(acc.reference_dofs), kind=np.array("accelerance"), units=np.array("mm/s^2/N"))
    np.testing.assert_allclose(read_frf(npz).frf, acc.frf, rtol=1e-14)
    path.write_text(path.read_text().replace("# kind: accelerance", "# kind: receptance"))
    with pytest.raises(FileFormatError, match=r"g.csv: '# units: g/N': 'g/N' is a unit of accelerance, but the FRFs "
                                              "are receptance"):
        read_frf(path)
    np.savez(npz, frequency_hz=acc.frequency_hz, frf=acc.frf, response_dofs=np.array(acc.response_dofs),
             reference_dofs=np.array(acc.reference_dofs), kind=np.array("accelerance"), units=np.array("furlong/N"))
    with pytest.raises(FileFormatError, match=r"mm.npz: array 'units' \('furlong/N'\): unit label 'furlong'"):
        read_frf(npz)


def test_a_csv_time_series_off_its_step_names_the_line():
    """A time series whose samples 5 and 6 are swapped (a double step, then a step back): the line of the first row
    off the first step (line 7: two comment and header lines first) is named with both times."""
    import tempfile

    from physics.io import TIME, read

    t = np.arange(10) * 0.001
    t[[4, 5]] = t[[5, 4]]
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "ts.csv"
        rows = "".join(f"{float(x)!r},{k}\n" for k, x in enumerate(t))
        path.write_text("# quantity: acceleration\ntime_s,2:+Y\n" + rows)
        with pytest.raises(FileFormatError, match=r"ts.csv: line 7: column 'time_s' must increase by one uniform step "
                                                  r"\(the sampling rate\): 0.005 s after 0.003 s, where the first step "
                                                  r"is 0.001 s"):
            read(path, TIME)
