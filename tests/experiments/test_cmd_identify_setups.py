"""``beam-damage identify FILE --setup FILE``: partial modes, references checked by MAC, warnings on stderr."""

import json
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run_cli
from oma_records import modal_record
from scipy import linalg

from physics.modal import mac

#: The closed-form 3-mass chain of tests/oma_records.chain_record.
K = 1e4 * np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]])
W2, PHI = linalg.eigh(K)
FN, ZETA = np.sqrt(W2) / (2 * np.pi), np.array([0.01, 0.015, 0.02])


def _npz(path, channels, seed, labelled=True, amplitudes=None):
    y = modal_record(FN, ZETA, PHI[channels], seconds=300, fs_hz=200.0, amplitudes=amplitudes, seed=seed)
    extra = {"dofs": np.array([f"{c + 1}:+Z" for c in channels])} if labelled else {}
    np.savez(path, signals=y, sampling_frequency_hz=np.array(200.0), quantity=np.array("displacement"), **extra)
    return str(path)


@pytest.fixture(scope="module")
def setups(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("setups")
    return {"s1": _npz(tmp / "s1.npz", [2, 0], 1),                               # reference 3:+Z, roving 1:+Z
            "s2": _npz(tmp / "s2.npz", [1, 2], 2, amplitudes=[1.0, 1.0, 0.0]),   # roving 2:+Z; mode 3 not excited
            "u1": _npz(tmp / "u1.npz", [0, 2], 3, labelled=False),                # no labels: roving, reference
            "u2": _npz(tmp / "u2.npz", [2, 1], 4, labelled=False),                # no labels: reference, roving
            "tmp": tmp}


def test_a_mode_missing_from_a_setup_is_kept_partial_with_its_dofs_empty(capsys, setups):
    argv = ["identify", setups["s1"], "--setup", setups["s2"], "--band", "1", "60", "--max-order", "30"]
    code, out, err = run_cli(capsys, [*argv, "--json", "--out", str(setups["tmp"] / "out")])
    assert code == 0, err
    res = json.loads(out)
    assert res["dofs"] == ["3:+Z", "1:+Z", "2:+Z"] and res["setup_references"] == ["3:+Z"]
    assert len(res["modes"]) == 3
    np.testing.assert_allclose([m["frequency_hz"] for m in res["modes"]], FN, rtol=3e-3)
    assert [p["mode"] for p in res["partial_modes"]] == [3] and res["partial_modes"][0]["setups"] == [setups["s1"]]
    assert res["modes"][2]["shape"][2] is None and None not in res["modes"][2]["shape"][:2]
    assert res["reference_mac"][2][1] is None and res["reference_mac"][0] == pytest.approx([1, 1])   # 1 reference
    shapes = np.array([[complex(z) if z is not None else np.nan for z in m["shape"]] for m in res["modes"]]).T
    assert mac(PHI[[2, 0, 1]][:, :2], shapes[:, :2]).diagonal().min() > 0.999
    assert mac(PHI[[2, 0]][:, [2]], shapes[:2, [2]])[0, 0] > 0.999                       # on the DOFs measured
    modal = json.loads((setups["tmp"] / "out" / "modal.json").read_text())
    assert modal["eigenvectors"][2][2] is None and modal["partial_modes"][0]["mode"] == 3
    # the modes' file is refused by the reader, in one line naming the empty entry
    from physics.errors import FileFormatError
    from physics.io.modal_json import read_modal_json

    with pytest.raises(FileFormatError, match="field 'eigenvectors' row 3, column 3 is null"):
        read_modal_json(setups["tmp"] / "out" / "modal.json")
    # text: the merge line names the partial mode; warnings (none expected here) would be on stderr only
    code, out, err = run_cli(capsys, argv)
    assert code == 0 and "partial modes (found in some setups only, the others' DOFs empty): " in out
    assert out.count("  partial") == 1 and "warning:" not in out


def test_unlabelled_setups_whose_positions_hold_other_sensors_are_refused(capsys, setups):
    argv = ["identify", setups["u1"], "--setup", setups["u2"], "--band", "1", "60", "--max-order", "30"]
    code, out, err = run_cli(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "the reference DOFs 1:+Z, 2:+Z (assumed by position" in err
    # the MAC of each mode's reference part: setup 1's channels (sensors 1, 3) against setup 2's (3, 2)
    expected = np.diag(mac(PHI[[0, 2]], PHI[[2, 1]]))
    assert np.median(expected) < 0.9
    import re
    got = np.array([float(x) for x in re.findall(r"([0-9.]+(?:e-?[0-9]+)?) at [0-9.]+ Hz", err)])
    assert got.size >= 2 and np.median(got) < 0.9
    assert all(np.min(np.abs(expected - g)) < 0.05 for g in got)


def test_warnings_go_to_stderr_in_text_mode_and_into_the_json(capsys, setups, tmp_path):
    """Two unlabelled setups whose first two channels are the same sensors, the second setup with a third channel:
    merged on the first two positions, with a warning (on stderr, and in 'warnings' with --json) that the
    references were assumed by position."""
    a = _npz(tmp_path / "a.npz", [2, 0], 5, labelled=False)
    b = _npz(tmp_path / "b.npz", [2, 0, 1], 6, labelled=False)
    argv = ["identify", a, "--setup", b, "--band", "1", "60", "--max-order", "30"]
    code, out, err = run_cli(capsys, argv)
    assert code == 0, err
    assert "warning:" not in out and "beam-damage identify: warning: " in err and "assumed by position" in err
    assert "(assumed by position: no DOF labels)" in out
    code, out, err = run_cli(capsys, [*argv, "--json"])
    res = json.loads(out)
    assert any("assumed by position" in w for w in res["warnings"]) and "assumed by position" in err
    assert res["setup_references"] == ["1:+Z", "2:+Z"] and res["references_by_position"]
    assert np.nanmin(np.array(res["reference_mac"], float)) > 0.99
    shapes = np.array([[complex(z) for z in m["shape"]] for m in res["modes"]]).T
    assert mac(PHI[[2, 0, 1]], shapes).diagonal().min() > 0.999


def test_a_setup_given_twice_is_refused_naming_it(capsys, setups):
    for argv in (["identify", setups["s1"], "--setup", setups["s1"]],
                 ["identify", setups["s1"], "--setup", setups["s2"], "--setup", setups["s2"]]):
        code, out, err = run_cli(capsys, argv)
        assert (code, out) == (2, "") and err.count("\n") == 1
        assert f"--setup {argv[-1]}: given twice" in err
    copy = setups["tmp"] / "s2-copy.npz"
    copy.write_bytes(Path(setups["s2"]).read_bytes())
    code, out, err = run_cli(capsys, ["identify", setups["s1"], "--setup", setups["s2"], "--setup", str(copy)])
    assert (code, out) == (2, "") and f"--setup {copy}: the same bytes as {setups['s2']}" in err
