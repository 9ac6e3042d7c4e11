"""generate --beam: presets as before, beam files with shear deformation as the truth."""

import json

import numpy as np
import pytest

from experiments.cli import main

QUIET = ('[specimen]\nei_band = 0.0\nmass_band = 0.0\nroot_spring_relative = []\n[damage]\nn_slits = [0, 0]\n'
         '[output]\nshard_size = 5\n[measurement]\nlines = 32\n')


def test_beam_preset_is_the_preset_and_bad_beams_are_one_line_errors(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text(QUIET)
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "a"), "--beam", "beam6", "--config", str(cfg),
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["beam"] == "beam6"
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "b"), "--preset", "beam6", "--config", str(cfg),
                 "--json"]) == 0
    capsys.readouterr()
    a, b = (json.loads((tmp_path / d / "manifest.json").read_text()) for d in ("a", "b"))
    assert a["config"] == b["config"] and a["config"]["beam"] == {}
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "c"), "--beam", str(tmp_path / "none.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "generate" in err


def test_shear_deformation_beam_file_is_the_truth(tmp_path, capsys):
    """Baseline truth frequencies of a Timoshenko beam file: equal to the same elements assembled by
    physics.effects (20 elements) and within the mesh error of an 80-element model; far from Euler-Bernoulli."""
    beam_mod = pytest.importorskip("physics.beam")
    from datagen.store import Dataset
    from physics.modal import undamped_modes

    b = beam_mod.preset_beam("beam5").with_effects({"shear_deformation": {"kGA_N": 2.0e4}}, name="beam5-timoshenko")
    beam_mod.write_beam(tmp_path / "b.toml", b)
    cfg = tmp_path / "c.toml"
    cfg.write_text(QUIET)
    assert main(["generate", "--n", "5", "--out", str(tmp_path / "ds"), "--beam", str(tmp_path / "b.toml"),
                 "--config", str(cfg), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["beam"] == "beam5-timoshenko"
    ds = Dataset(tmp_path / "ds")
    assert ds.manifest["config"]["beam"]["effects"] == {"shear_deformation": {"kGA_N": 2.0e4}}
    f = ds.table([f"f{r}_hz_base" for r in range(1, 5)]).to_numpy()

    def freqs(model):
        return undamped_modes(model.M, model.K)[0][:4] / (2 * np.pi)

    same_mesh, fine = freqs(b.fe_model(n_elements=20)), freqs(b.fe_model(n_elements=80))
    euler = freqs(beam_mod.preset_beam("beam5").fe_model(n_elements=80))
    np.testing.assert_allclose(f, np.broadcast_to(same_mesh, f.shape), rtol=2e-5)  # damped vs undamped: zeta^2
    np.testing.assert_allclose(f, np.broadcast_to(fine, f.shape), rtol=5e-3)
    assert np.all(euler[1:] / fine[1:] - 1 > 0.04)  # shear deformation matters here: the check can fail


def test_unsupported_effects_are_refused(tmp_path, capsys):
    beam_mod = pytest.importorskip("physics.beam")
    b = beam_mod.preset_beam("beam5").with_effects({"added_mass": {"mass_kg": 0.01}}, name="with-mass")
    beam_mod.write_beam(tmp_path / "b.toml", b)
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "ds"), "--beam", str(tmp_path / "b.toml")]) == 2
    assert "added_mass" in capsys.readouterr().err
