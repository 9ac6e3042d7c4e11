"""``beam-damage update``: warnings about an unstable updated model, one-line warnings on stderr."""

import json

import numpy as np
import pytest

from experiments.cli import main
from physics import modal, updating
from physics.beam import load_beam
from physics.io import format_complex, write_uff58
from physics.thesis import simulated_beam5_test


def _beam5_mass():
    b = load_beam("beam5")
    model = b.fe_model()
    return updating.reduced_mass(model.M, model.K, model.index(b.masters), "iirs")


def _modal_file(path, zeta):
    """Complex modes of (M, C, K) on beam 5's IIRS mass with proportional damping ratios ``zeta``."""
    M = _beam5_mass()
    w = 2 * np.pi * np.array([20.0, 130.0, 350.0, 650.0])
    Q, _ = np.linalg.qr(np.arange(1.0, 17.0).reshape(4, 4) ** 0.5)
    U = np.linalg.solve(np.linalg.cholesky(M).T, Q)  # U^T M U = I
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


def test_modes_the_model_cannot_pair_are_named_as_left_out(tmp_path, monkeypatch):
    """``update`` identifies as many modes as the model pairs; modes beyond them in the FRFs' band are named."""
    from types import SimpleNamespace

    from physics import beam_updating

    def ident(f_hz):
        return SimpleNamespace(modal_data=SimpleNamespace(natural_frequencies_hz=np.array(f_hz)))

    monkeypatch.setattr(beam_updating, "identify_file", lambda path, n_modes=None: ident([10.2, 64.8, 179.0, 352.4]))
    with pytest.warns(UserWarning, match=r"t.uff: 4 modes identified in the FRFs' band, the model pairs 3: 352.4 Hz "
                                         "left out of the update"):
        beam_updating._warn_modes_left_out("t.uff", ident([10.2, 64.8, 179.0]), 3)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        beam_updating._warn_modes_left_out("t.uff", ident([10.2, 64.8, 179.0, 352.4]), 4)
