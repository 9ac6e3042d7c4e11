"""``beam-damage update``: warnings about an unstable updated model, one-line warnings on stderr."""

import json

import numpy as np
import pytest

from experiments.cli import main
from physics import modal, updating
from physics.beam import load_beam
from physics.io import format_complex, write_uff58
from physics.io.npz import write_frf_npz
from physics.thesis import simulated_beam5_test


def _beam5_mass():
    b = load_beam("beam5")
    model = b.fe_model()
    return updating.reduced_mass(model.M, model.K, model.index(b.masters), "iirs")


def _modal_file(path, zeta):
    """Complex modes of (M, C, K) on beam 5's IIRS mass with proportional damping ratios ``zeta``, the shapes the
    FE model's at the sensors made mass-orthonormal in their order (Gram-Schmidt: ``U^T M U = I``)."""
    M = _beam5_mass()
    w = 2 * np.pi * np.array([20.0, 130.0, 350.0, 650.0])
    b = load_beam("beam5")
    model = b.fe_model()
    P = modal.undamped_modes(model.M, model.K)[1][model.index(b.masters)][:, :4]
    U = P @ np.linalg.inv(np.linalg.cholesky(P.T @ M @ P)).T
    K = M @ U @ np.diag(w**2) @ U.T @ M
    C = M @ U @ np.diag(2 * np.asarray(zeta) * w) @ U.T @ M
    cm = modal.complex_modes(M, C, K)
    path.write_text(json.dumps({"eigenvalues": [format_complex(z) for z in cm.eigenvalues],
                                "eigenvectors": [[format_complex(z) for z in row] for row in cm.eigenvectors],
                                "dofs": ["2:y", "3:y", "4:y", "5:y"]}))
    return path


@pytest.mark.parametrize("method", ["pilkey", "direct"])
def test_negative_damping_gives_an_unstable_model_and_a_warning_naming_the_mode(tmp_path, capsys, method):
    path = _modal_file(tmp_path / "m.json", [-0.01, 0.002, 0.003, -0.004])
    assert main(["update", "--modal", str(path), "--method", method, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(out["damping_ratios"], [-0.01, 0.002, 0.003, -0.004], rtol=1e-6)
    unstable = [w for w in out["warnings"] if "unstable" in w]
    assert len(unstable) == 2 and "mode 1 at 20 Hz" in unstable[0] and "damping ratio -0.01 " in unstable[0]
    assert "mode 4 at 650 Hz" in unstable[1] and "damping ratio -0.004 " in unstable[1]


def test_stable_model_has_no_warning_and_text_output_prints_them(tmp_path, capsys):
    assert main(["update", "--modal", str(_modal_file(tmp_path / "ok.json", [0.01, 0.002, 0.003, 0.004])),
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []
    assert main(["update", "--modal", str(_modal_file(tmp_path / "bad.json", [0.01, -0.002, 0.003, 0.004]))]) == 0
    cap = capsys.readouterr()
    lines = [ln for ln in cap.err.splitlines() if ln.startswith("beam-damage update: warning:")]
    assert len(lines) == 1 and "mode 2 at 130 Hz has damping ratio -0.002" in lines[0] and "warning:" not in cap.out


def test_a_warning_of_a_successful_command_is_one_stderr_line(tmp_path, capsys):
    frf, _ = simulated_beam5_test(noise=0.0, seed=0, damping="heavy", df_hz=2.0)
    write_uff58(tmp_path / "g.uff", frf)
    path = tmp_path / "x.uff"
    path.write_bytes(b"    -1\n   999\nfoo\n    -1\n" + (tmp_path / "g.uff").read_bytes())
    assert main(["update", "--modal", str(path), "--json"]) == 0
    err = capsys.readouterr().err
    assert err == f"beam-damage update: warning: {path}: skipped 1 record(s) of dataset type(s) 999\n"


def test_an_unstable_model_with_real_eigenvalues_is_a_warning_not_an_error(tmp_path, capsys):
    """Real-valued shapes inconsistent with the mass, the refusal lifted: the direct update has a real eigenvalue
    > 0 and complex pairs with Re > 0; each is one warning (no error about real eigenvalues)."""
    path = tmp_path / "real.json"
    path.write_text(json.dumps({"eigenvalues": ["-0.21962+135.31j", "-2.0222+815.06j", "-6.7531+2174.9j",
                                                "-16.773+3984j"],
                                "eigenvectors": [[1.5, 2.5, 3.5, 4.5], [0.5, -1, 2, 3], [1, 1, -2, 0.3],
                                                 [2, -3, 1, 1]]}))
    assert main(["update", "--modal", str(path), "--method", "direct", "--max-eigenvalue-error", "1e9",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lam = np.linalg.eigvals(modal.state_matrix(np.array(out["M"]), np.array(out["C"]), np.array(out["K"])))
    real = lam[lam.imag == 0].real
    assert real.size and real.max() > 0
    growing = [w for w in out["warnings"] if "grows without oscillating" in w]
    assert len(growing) == np.sum(real >= 0) and f"{real.max():.6g} 1/s" in growing[-1]
    oscillating = [w for w in out["warnings"] if "unstable: mode" in w]
    assert len(oscillating) == np.sum((lam.imag > 0) & (lam.real >= 0))
    assert any("real eigenvalue(s)" in w for w in out["warnings"])


def test_frequencies_out_of_order_against_their_shapes_are_warned_of(tmp_path, capsys):
    """Modal JSON whose first two eigenvalues are swapped (each no longer beside its own shape) is updated, as
    the file asks, but with a warning naming the order; the file in order gets none."""
    path = _modal_file(tmp_path / "m.json", [0.01, 0.002, 0.003, 0.004])
    obj = json.loads(path.read_text())
    obj["eigenvalues"][0], obj["eigenvalues"][1] = obj["eigenvalues"][1], obj["eigenvalues"][0]
    swapped = tmp_path / "swapped.json"
    swapped.write_text(json.dumps(obj))
    assert main(["update", "--modal", str(swapped), "--json"]) == 0
    cap = capsys.readouterr()
    order = [w for w in json.loads(cap.out)["warnings"] if "ascending order" in w]
    assert len(order) == 1 and "(130, 20, 350, 650 Hz)" in order[0], order


def test_the_model_pairs_the_lowest_identified_modes_and_names_those_left_out(tmp_path):
    """FRFs of beam 5 hold 4 modes; a model of 3 DOFs pairs the 3 lowest (their exact frequencies to 1e-4, their
    shapes from the one fit of all 4), and the 4th is named as left out. (LSCF asked for 3 modes keeps those stable
    over most orders, which on an accelerance or a fine band are the highest.)"""
    from physics import beam_updating

    frf, modes = simulated_beam5_test(noise=0.0, seed=0, damping="heavy", df_hz=2.0)
    path = tmp_path / "t.npz"
    write_frf_npz(path, frf)
    with pytest.warns(UserWarning, match=r"t.npz: 4 modes identified in the FRFs' band, the model pairs the lowest 3: "
                                         r"6\d\d(\.\d)? Hz left out of the update"):
        data, _ = beam_updating.load_modal(path, 3)
    np.testing.assert_allclose(data.natural_frequencies_hz, modes.natural_frequencies_hz[:3], rtol=1e-4)


def test_shapes_beside_another_modes_frequency_are_named_by_their_mac_with_the_model(tmp_path, capsys):
    """Table 4.5 updates without a shape warning; with its shape columns 1 and 2 swapped, Lancaster's construction
    still reproduces the eigenvalues (the check passes), and the MAC with the model's modes names both columns."""
    from pathlib import Path

    import physics

    table = Path(physics.__file__).parent / "data" / "thesis" / "beam5_table_4_5.json"
    assert main(["update", "--modal", str(table), "--json"]) == 0
    assert not [w for w in json.loads(capsys.readouterr().out)["warnings"] if "MAC" in w]
    obj = json.loads(table.read_text())
    for row in obj["eigenvectors"]:
        row[0], row[1] = row[1], row[0]
    swapped = tmp_path / "swapped.json"
    swapped.write_text(json.dumps(obj))
    assert main(["update", "--modal", str(swapped), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["eigenvalue_check"]["max_relative_error"] < 0.05
    named = [w for w in out["warnings"] if "does not pair the model's mode" in w]
    assert len(named) == 2
    assert "measured mode 1's shape" in named[0] and "most like the model's mode 2" in named[0]
    assert "measured mode 2's shape" in named[1] and "most like the model's mode 1" in named[1]


def test_the_update_does_not_depend_on_each_modes_shape_scale(tmp_path, capsys):
    """Each mode's shape is scaled against the trusted mass: Table 4.5 with its columns multiplied by complex
    factors (shapes of no driving point, of another normalisation) gives the same K and C to the file's 5 digits."""
    from pathlib import Path

    import physics

    table = Path(physics.__file__).parent / "data" / "thesis" / "beam5_table_4_5.json"
    obj = json.loads(table.read_text())
    V = np.array([[complex(z.replace(" ", "")) for z in row] for row in obj["eigenvectors"]])
    V *= np.array([2.0 * np.exp(0.3j), 0.5 * np.exp(-1j), 3.0, 1j])
    obj["eigenvectors"] = [[format_complex(z) for z in row] for row in V]
    scaled = tmp_path / "scaled.json"
    scaled.write_text(json.dumps(obj))
    out = []
    for path in (table, scaled):
        assert main(["update", "--modal", str(path), "--json"]) == 0
        out.append(json.loads(capsys.readouterr().out))
    for key in ("K", "C"):
        a, b = (np.array(o[key]) for o in out)
        assert np.max(np.abs(a - b)) < 1e-5 * np.max(np.abs(a))
