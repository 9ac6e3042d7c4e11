"""Multi-setup output-only identification: roving sensors merged on a fixed reference."""

import re

import numpy as np
import pytest
from oma_records import chain_record

from physics.errors import ShapeError
from physics.identification import identify_records
from physics.identification.output_only import merge_setups
from physics.io.timedata import TimeRecords
from physics.modal import mac


def _setup(channels, seed):
    y, fs, fn, zeta, phi = chain_record(seconds=300, seed=seed)
    dofs = ("1:+Z", "2:+Z", "3:+Z")
    rec = TimeRecords(1 / fs, y[channels] * (1 + seed), tuple(dofs[c] for c in channels),
                      ("displacement",) * len(channels), {"source": f"setup {seed}"})
    return identify_records(rec, "ssi", band_hz=(1, 60), max_order=30), fn, phi


def test_two_setups_sharing_a_reference_give_the_full_shapes():
    a, fn, phi = _setup([2, 0], seed=1)          # reference 3:+Z and roving 1:+Z
    b, _, _ = _setup([1, 2], seed=2)             # roving 2:+Z and the same reference (another gain)
    m = merge_setups([a, b])
    assert m.references == ("3:+Z",) and m.dofs == ("3:+Z", "1:+Z", "2:+Z") and not m.partial.any()
    np.testing.assert_allclose(m.estimate.natural_frequencies_hz, fn, rtol=2e-3)
    rows = [int(d[0]) - 1 for d in m.dofs]
    assert np.all(np.diag(mac(phi[rows], m.estimate.shapes)) > 0.999)
    assert np.all(m.estimate.frequency_std_hz > 0)
    np.testing.assert_allclose(np.linalg.norm(m.estimate.shapes, axis=0), 1.0)


def test_setups_without_a_common_dof_are_refused():
    a, _, _ = _setup([0], seed=1)
    b, _, _ = _setup([1, 2], seed=2)
    with pytest.raises(ShapeError, match="no DOF is measured in every setup"):
        merge_setups([a, b])


# --- merges of estimates with known shapes (no identification: exact numbers) ---------------------------------

def _ident(fn_hz, shapes, dofs, source, labelled=True, gain=1.0):
    """A RecordsIdentification whose estimate holds ``shapes`` (rows: ``dofs``) at ``fn_hz``, damping 1 %."""
    from physics.identification.modes import ModalEstimate, modal_phase_collinearity
    from physics.identification.output_only import RecordsIdentification
    from physics.modal import eigenvalues_from_modal

    fn = np.asarray(fn_hz, float)
    zeta = np.full(fn.size, 0.01)
    phi = gain * np.asarray(shapes, complex)
    est = ModalEstimate(fn, zeta, eigenvalues_from_modal(fn, zeta), phi, np.zeros((len(dofs), 0, fn.size), complex),
                        np.full(fn.size, 1e-3), np.full(fn.size, 1e-4), modal_phase_collinearity(phi), "ssi", False,
                        weakly_stable=np.zeros(fn.size, bool))
    meta = {"source": source} if labelled else {"source": source, "dof_labels": "by position"}
    rec = TimeRecords(0.025, np.zeros((len(dofs), 8)), tuple(dofs), ("acceleration",) * len(dofs), meta)
    return RecordsIdentification(rec, est, None)


#: A building of 8 sensors: sensors 0 and 1 stay (references), three setups rove 2 sensors each.
FN = np.array([1.23, 1.29, 1.45, 3.87])
PHI = np.random.default_rng(3).standard_normal((8, 4))
SETUPS = ([0, 1, 2, 3], [0, 1, 4, 5], [0, 1, 6, 7])


def _building(missing=None, labelled=True, order=lambda ch: ch):
    """One identification per setup; ``missing``: {setup: mode left out}; ``order`` reorders each setup's channels
    (the references move without labels)."""
    out = []
    for s, ch in enumerate(SETUPS):
        keep = [j for j in range(4) if (missing or {}).get(s) != j]
        ch = order(ch)
        dofs = [f"{c + 1}:+Z" for c in ch] if labelled else [f"{k + 1}:+Z" for k in range(len(ch))]
        out.append(_ident(FN[keep] * (1 + 1e-3 * s), PHI[np.ix_(ch, keep)], dofs, f"setup{s + 1}", labelled,
                          gain=(-2.0) ** s))
    return out


def test_a_mode_missing_from_one_setup_is_kept_with_that_setups_dofs_empty():
    m = merge_setups(_building(missing={1: 2}))            # the 1.45 Hz mode is not found in setup 2
    assert m.estimate.natural_frequencies_hz.size == 4 and m.references == ("1:+Z", "2:+Z")
    assert m.found_in == ((0, 1, 2), (0, 1, 2), (0, 2), (0, 1, 2))
    np.testing.assert_array_equal(m.partial, [False, False, True, False])
    rows = [int(d.split(":")[0]) - 1 for d in m.dofs]
    nan = np.isnan(m.estimate.shapes)
    assert [m.dofs[i] for i in np.nonzero(nan[:, 2])[0]] == ["5:+Z", "6:+Z"] and nan.sum() == 2
    for j in range(4):                                     # exact shapes on the DOFs measured, unit norm there
        ok = ~nan[:, j]
        assert mac(PHI[rows][ok][:, [j]], m.estimate.shapes[ok][:, [j]])[0, 0] == pytest.approx(1.0, abs=1e-12)
        assert np.linalg.norm(m.estimate.shapes[ok, j]) == pytest.approx(1.0)
    # frequencies: the mean over the setups holding the mode
    assert m.estimate.natural_frequencies_hz[2] == pytest.approx(1.45 * (1 + 1e-3), rel=1e-12)
    assert m.estimate.natural_frequencies_hz[0] == pytest.approx(1.23 * (1 + 1e-3), rel=1e-12)
    np.testing.assert_allclose(m.reference_mac[np.isfinite(m.reference_mac)], 1.0, atol=1e-12)
    assert np.isnan(m.reference_mac[2, 1])


def test_unlabelled_setups_are_refused_when_the_channels_by_position_are_other_sensors():
    """Without DOF labels the references are assumed by position: each setup's channels are 2 roving sensors, then
    the 2 references, so positions 1-2 are other sensors in each setup: the MAC of each mode's reference part is
    far below 1, and the two positions that agree are named."""
    idents = _building(labelled=False, order=lambda ch: ch[2:] + ch[:2])
    expected = np.diag(mac(PHI[[2, 3, 0, 1]], PHI[[4, 5, 0, 1]]))       # setup 1's channels against setup 2's
    assert np.median(expected) < 0.9                     # refused on the median over the common modes
    with pytest.warns(UserWarning, match="assumed by position"), pytest.raises(ShapeError) as err:
        merge_setups(idents)
    msg = str(err.value)
    assert msg.startswith("setup2: the reference DOFs 1:+Z, 2:+Z, 3:+Z, 4:+Z (assumed by position")
    got = [float(x) for x in re.findall(r"([0-9.]+(?:e-?[0-9]+)?) at [0-9.]+ Hz", msg)]
    np.testing.assert_allclose(got, expected, atol=5e-4)            # 3 significant digits
    assert "only 3:+Z, 4:+Z agree (MAC >= 1 on every mode)" in msg        # the two references
    m = merge_setups(_building(labelled=True, order=lambda ch: ch[2:] + ch[:2]))   # labelled: merged on them
    assert m.references == ("1:+Z", "2:+Z") and not m.by_position
    np.testing.assert_allclose(m.reference_mac, 1.0, atol=1e-12)


def test_labelled_setups_merge_on_their_true_references():
    idents = _building(labelled=True, order=lambda ch: ch if ch[2] == 2 else ch[2:] + ch[:2])
    m = merge_setups(idents)
    assert m.references == ("1:+Z", "2:+Z") and not m.by_position and not m.partial.any()
    np.testing.assert_allclose(m.reference_mac, 1.0, atol=1e-12)


def test_one_mode_whose_reference_part_disagrees_is_named_in_a_warning():
    idents = _building()
    bad = idents[2].estimate.shapes.copy()
    bad[:2, 3] = bad[[1, 0], 3]                               # mode 4's reference part in setup 3: swapped
    idents[2] = _ident(idents[2].estimate.natural_frequencies_hz, bad, idents[2].records.dofs, "setup3")
    expected = mac(PHI[:2, [3]], bad[:2, [3]])[0, 0]
    assert expected < 0.9
    with pytest.warns(UserWarning, match=r"setup3: the reference part of the mode\(s\) at 3.874 Hz \(MAC ") as w:
        m = merge_setups(idents)
    assert f"MAC {expected:.3g})" in str(w[0].message)
    assert m.reference_mac[3, 2] == pytest.approx(expected)


def test_finite_mac_compares_partial_modes_on_the_rows_both_hold():
    from physics.identification.setups import finite_mac

    phi = PHI[:, :3].astype(complex)
    phi[[2, 5], 1] = np.nan
    got = finite_mac(phi)
    ok = [0, 1, 3, 4, 6, 7]
    assert got[0, 1] == pytest.approx(mac(PHI[ok][:, [0]], PHI[ok][:, [1]])[0, 0], rel=1e-12)
    assert got[0, 2] == pytest.approx(mac(PHI[:, [0]], PHI[:, [2]])[0, 0], rel=1e-12)
    np.testing.assert_allclose(np.diag(got), 1.0)


def test_modal_json_writes_a_missing_entry_as_null_and_refuses_it_on_reading(tmp_path):
    import json

    from physics.errors import FileFormatError
    from physics.io import write_modal_json
    from physics.io.modal_json import read_modal_json

    m = merge_setups(_building(missing={1: 2}))
    write_modal_json(tmp_path / "modal.json", m.modal_data)
    obj = json.loads((tmp_path / "modal.json").read_text())
    rows = [k for k, row in enumerate(obj["eigenvectors"]) if row[2] is None]
    assert [obj["dofs"][k] for k in rows] == ["5:+Z", "6:+Z"]
    assert sum(v is None for row in obj["eigenvectors"] for v in row) == 2
    with pytest.raises(FileFormatError, match=r"field 'eigenvectors' row 5, column 3 is null: a DOF not measured"):
        read_modal_json(tmp_path / "modal.json")
