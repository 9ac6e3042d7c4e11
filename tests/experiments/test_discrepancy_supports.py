"""``discrepancy`` on a free-free beam file: the suspension named from modal JSON of an independent model, the
calibrated beam file drives ``generate``; a candidate that does not fit the supports is refused in one line."""

import json

import numpy as np
import pytest
from experiments.studies.plain_beam import plain_fe

from experiments.cli import main

L, EI, M = 0.6095, 22.674, 0.12955
N_EL = 8
BEAM = (f'preset = "beam5"\nname = "bar"\nbc = "free-free"\nn_elements = {N_EL}\n'
        f"measured_x_m = [{', '.join(repr(L * k / N_EL) for k in range(N_EL + 1))}]\n")
W1 = 22.3733 / L**2 * np.sqrt(1.02 * EI / M)
K_Y = 0.5 * M * L * (0.15 * W1) ** 2          # bounce at 15 % of the first bending mode
QUIET = ('[specimen]\nei_band = 0.0\nmass_band = 0.0\ndamping_band = 0.0\nroot_spring_relative = []\n'
         '[damage]\nn_slits = [0, 0]\n[output]\nshard_size = 5\n[measurement]\nlines = 32\n')


def _run(capsys, *argv):
    code = main(list(argv))
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _modal_json(path, seed=4):
    """Five bending modes of the plain FE bar (EI 2 % above the file's) on its suspension, with noise."""
    rng = np.random.default_rng(seed)
    xs = [L * k / N_EL for k in range(N_EL + 1)]
    f, sh = plain_fe("free-free", L, 1.02 * EI, M, k_y=K_Y, x_sensors=xs)
    f = f * (1 + 0.002 * rng.standard_normal(f.size))
    sh = sh / np.max(np.abs(sh), axis=0) + 0.01 * rng.standard_normal(sh.shape)
    path.write_text(json.dumps({"natural_frequencies_hz": f.tolist(), "damping_ratios": [0.004] * f.size,
                                "eigenvectors": [[str(complex(v)) for v in row] for row in sh],
                                "dofs": [f"{k + 1}:y" for k in range(N_EL + 1)]}))


def test_free_free_suspension_is_named_and_the_calibrated_file_drives_generate(tmp_path, capsys):
    from datagen.dataset import Dataset
    from physics.beam import load_beam

    (tmp_path / "bar.toml").write_text(BEAM)
    _modal_json(tmp_path / "modal.json")
    code, out, err = _run(capsys, "discrepancy", "--beam", str(tmp_path / "bar.toml"), "--measured",
                          str(tmp_path / "modal.json"), "--max-effects", "1", "--elements", "24",
                          "--out", str(tmp_path / "cal"), "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["named_effect"] == "suspension"
    assert abs(res["parameters"]["suspension.k_y_N_m"] / K_Y - 1) < 0.1
    assert res["gap_after"]["max_abs_frequency_error_pct"] < 0.5 < res["gap_before"]["max_abs_frequency_error_pct"]
    cal = load_beam(tmp_path / "cal" / "beam.toml")
    assert cal.bc == "free-free" and "suspension" in cal.effects
    cfg = tmp_path / "c.toml"
    cfg.write_text(QUIET)
    code, out, err = _run(capsys, "generate", "--n", "3", "--out", str(tmp_path / "ds"), "--beam",
                          str(tmp_path / "cal" / "beam.toml"), "--config", str(cfg), "--json")
    assert code == 0, err
    ds = Dataset(tmp_path / "ds")
    f = ds.table([f"f{r}_hz_base" for r in range(1, 4)]).to_numpy()
    measured = json.loads((tmp_path / "modal.json").read_text())["natural_frequencies_hz"][:3]
    # the calibrated truth reproduces the measured bending modes (the nominal specimen: no variability)
    np.testing.assert_allclose(f, np.broadcast_to(measured, f.shape), rtol=5e-3)


def test_a_candidate_that_does_not_fit_the_supports_is_refused(tmp_path, capsys):
    (tmp_path / "bar.toml").write_text(BEAM)
    _modal_json(tmp_path / "modal.json")
    code, out, err = _run(capsys, "discrepancy", "--beam", str(tmp_path / "bar.toml"), "--measured",
                          str(tmp_path / "modal.json"), "--candidates", "root_flexibility")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "root_flexibility" in err and "free-free" in err and "suspension" in err
    (tmp_path / "bad.toml").write_text(BEAM + "[effects.bearing_flexibility]\nk_theta_Nm_rad = 5.0\n")
    with pytest.raises(SystemExit) as exit_:      # the beam file is read as the argument is parsed
        main(["discrepancy", "--beam", str(tmp_path / "bad.toml"), "--measured", str(tmp_path / "modal.json")])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1
    assert "bad.toml" in err and "'bearing_flexibility'" in err and "'suspension'" in err
