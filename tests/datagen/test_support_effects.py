"""generate --beam with the support effects of free-free, pinned-pinned and clamped-clamped beams as the truth."""

import json

import numpy as np
import pytest

from experiments.cli import main

QUIET = ('[specimen]\nei_band = 0.0\nmass_band = 0.0\ndamping_band = 0.0\nroot_spring_relative = []\n'
         '[damage]\nn_slits = [0, 0]\n[output]\nshard_size = 5\n[measurement]\nlines = 32\n')

L = 0.6095
SENSORS = [L / 8, 3 * L / 8, 5 * L / 8, 7 * L / 8]
EI, M = 22.674, 0.12955
W1_FREE = 22.3733 / L**2 * np.sqrt(EI / M)       # first free-free bending mode (rad/s)
SUPPORTS = {
    "free-free": ("suspension", {"k_y_N_m": 0.5 * M * L * (0.2 * W1_FREE) ** 2}),
    "pinned-pinned": ("bearing_flexibility", {"k_theta_Nm_rad": 2.0 * EI / L}),
    "clamped-clamped": ("clamp_flexibility", {"k_theta_Nm_rad": 10.0 * EI / L, "k_y_N_m": 1.0e4 * EI / L**3}),
}


@pytest.mark.parametrize("bc", list(SUPPORTS))
def test_support_effect_of_a_beam_file_is_the_truth(bc, tmp_path, capsys):
    """Nominal specimen of a beam file with its supports' effect: its baseline frequencies are the modes of
    physics.effects' model on the truth mesh (bending modes), and differ from the beam without the effect."""
    from datagen.dataset import Dataset
    from datagen.setup import get_setup
    from physics.beam import preset_beam, write_beam
    from physics.discrepancy import bending_modes

    effect, params = SUPPORTS[bc]
    b = preset_beam("beam5").with_effects({effect: params}, name=f"beam5-{bc}", bc=bc, measured_x_m=SENSORS)
    write_beam(tmp_path / "b.toml", b)
    cfg = tmp_path / "c.toml"
    cfg.write_text(QUIET)
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "ds"), "--beam", str(tmp_path / "b.toml"),
                 "--config", str(cfg), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["beam"] == f"beam5-{bc}"
    ds = Dataset(tmp_path / "ds")
    assert ds.manifest["config"]["beam"]["effects"] == {effect: params}
    setup = get_setup(ds.manifest["config"])
    n = setup.n_modes
    f = ds.table([f"f{r}_hz_base" for r in range(1, n + 1)]).to_numpy()

    def freqs(beam):
        model = beam.fe_model(setup.n_elements)
        return np.sqrt(bending_modes(beam, model, n)[0]) / (2 * np.pi)

    f_fx = freqs(b)
    np.testing.assert_allclose(f, np.broadcast_to(f_fx, f.shape), rtol=2e-5)
    f_without = freqs(b.with_effects({}))
    assert np.max(np.abs(f_without / f_fx - 1)) > 1e-2     # the effect moves the truth: the check can fail


@pytest.mark.parametrize("bc", ["pinned-pinned", "free-free"])
def test_the_bearing_or_suspension_spring_changes_between_the_test_days(bc, tmp_path):
    """``specimen.root_spring_change`` changes a pinned beam's bearing springs (a free-free beam's suspension)
    between the two test days: each intact specimen's current frequencies are the beam file's model with the
    spring times ``1 + c``."""
    from datagen.dataset import Dataset
    from datagen.setup import get_setup
    from physics.beam import preset_beam, write_beam
    from physics.discrepancy import bending_modes

    effect, params = SUPPORTS[bc]
    key = next(iter(params))
    b = preset_beam("beam5").with_effects({effect: params}, name=f"beam5-{bc}", bc=bc, measured_x_m=SENSORS)
    write_beam(tmp_path / "b.toml", b)
    (tmp_path / "c.toml").write_text(QUIET.replace("root_spring_relative = []\n",
                                                   "root_spring_relative = []\nroot_spring_change = [-0.5, 0.5]\n"))
    assert main(["generate", "--n", "4", "--seed", "2", "--out", str(tmp_path / "ds"), "--beam",
                 str(tmp_path / "b.toml"), "--config", str(tmp_path / "c.toml")]) == 0
    ds = Dataset(tmp_path / "ds")
    setup = get_setup(ds.manifest["config"])
    n = setup.n_modes
    t = ds.table(["root_spring_change"] + [f"f{r}_hz_{s}" for s in ("base", "cur") for r in range(1, n + 1)])
    c = t["root_spring_change"].to_numpy()
    assert np.ptp(c) > 0.2
    ratio = t[[f"f{r}_hz_cur" for r in range(1, n + 1)]].to_numpy() / t[[f"f{r}_hz_base"
                                                                         for r in range(1, n + 1)]].to_numpy()

    def freqs(beam):
        return np.sqrt(bending_modes(beam, beam.fe_model(setup.n_elements), n)[0])

    expected = np.array([freqs(b.with_effects({effect: {key: params[key] * (1 + ci)}})) / freqs(b) for ci in c])
    np.testing.assert_allclose(ratio, expected, rtol=2e-6)
    assert np.max(np.abs(expected - 1)) > (1e-3 if bc == "pinned-pinned" else 1e-6)    # the change shows
