"""The shipped training configuration: label ranges, intact pairs, day-to-day changes, noise per sample."""

import numpy as np
import pytest

from datagen.config import load_config, merge
from datagen.generation import generate
from datagen.batch_inputs import draw_batch
from datagen.pipeline import simulate_batch
from datagen.setup import get_setup
from datagen.dataset import Dataset
from physics.errors import ConfigError


@pytest.fixture(scope="module")
def training(tmp_path_factory):
    cfg = load_config("training")
    cfg["measurement"]["lines"] = 64
    cfg["output"]["shard_size"] = 100
    root = tmp_path_factory.mktemp("tr") / "ds"
    generate(root, merge(cfg), n=200, seed=3, workers=1, progress=False)
    return Dataset(root)


def test_training_labels_span_the_configured_ranges(training):
    t = training.samples
    assert 0.15 < 1 - t["damaged"].mean() < 0.35                      # about a quarter intact
    d, i = t[t.damaged], t[~t.damaged]
    assert d["damage0_ei_loss"].between(0.05 - 1e-6, 0.9 + 1e-6).all()
    assert d["damage0_ei_loss"].min() < 0.15 and d["damage0_ei_loss"].max() > 0.8
    assert d["damage0_width_m"].between(0.001, 0.01).all()
    assert d["damage0_x_m"].min() < 0.05 and d["damage0_x_m"].max() > 0.55  # whole length (L = 0.6095 m)
    assert t["noise_level"].between(0.001, 0.03).all() and t["noise_level"].max() / t["noise_level"].min() > 10
    assert t["noise_floor"].between(1e-4, 1e-3).all()
    assert t["temperature_stiffness_change"].between(-0.004, 0.004).all()
    day = t["root_spring_change"][~t["support_changed"]]
    assert day.between(-0.08, 0.08).all() and day.abs().max() > 0.05
    moved = 1 + t["root_spring_change"][t["support_changed"]]       # supports 2-5x softer or stiffer
    assert len(moved) > 0 and np.all((moved >= 2) & (moved <= 5) | (moved >= 0.2) & (moved <= 0.5))
    assert not (t["support_changed"] & t["damaged"]).any()
    # stiffness loss dEI * w (N m^3) and the slit-alone frequency drop
    np.testing.assert_allclose(d["stiffness_loss_Nm3"], d["damage0_ei_loss"] * d["ei_Nm2"] * d["damage0_width_m"])
    assert (i["stiffness_loss_Nm3"] == 0).all() and (i["max_frequency_drop_rel"] == 0).all()
    assert (d["max_frequency_drop_rel"] > 0).all()
    # intact pairs still differ between the days (temperature, re-clamping)
    assert (i["df1_rel"].abs() > 1e-5).mean() > 0.8


def test_temperature_change_scales_frequencies_by_its_square_root():
    """Intact, rigid clamp: K_current = (1 + t) K_baseline, so f_cur / f_base = sqrt(1 + t) (closed form)."""
    cfg = load_config("training")
    cfg["specimen"].update(root_spring_relative=[], root_spring_change=[0.0, 0.0], support_change_fraction=0.0)
    cfg["damage"]["intact_fraction"] = 1.0
    cfg["specimen"]["temperature_stiffness_change"] = [-0.01, 0.01]
    setup = get_setup(merge(cfg))
    inp = draw_batch(np.random.default_rng(1), 20, setup)
    out = simulate_batch(setup, inp)
    w = np.abs(out["truth_poles"][..., :4])
    np.testing.assert_allclose(w[:, 1] / w[:, 0], np.sqrt(1 + inp.temperature_stiffness_change)[:, None]
                               * np.ones((1, 4)), rtol=1e-6)


def test_slit_drop_label_ignores_day_to_day_changes():
    """With and without temperature/re-clamping the slit-alone drop is the same number."""
    cfg = load_config("training")
    cfg["damage"]["intact_fraction"] = 0.0
    quiet = {**cfg, "specimen": {**cfg["specimen"], "temperature_stiffness_change": [0.0, 0.0],
                                 "root_spring_change": [0.0, 0.0]}}
    a = get_setup(merge(cfg))
    b = get_setup(merge(quiet))
    ia = draw_batch(np.random.default_rng(2), 12, a)
    ib = draw_batch(np.random.default_rng(2), 12, b)
    assert not np.allclose(ia.temperature_stiffness_change, 0)
    da = simulate_batch(a, ia)["damage_frequency_drop"]
    db = simulate_batch(b, ib)["damage_frequency_drop"]
    np.testing.assert_allclose(da, db, rtol=1e-4, atol=1e-8)
    assert (da > 0).all()


def test_calibrated_modal_noise_scales_with_each_samples_frf_noise_level():
    cfg = load_config("training")
    cfg["measurement"].update(frequency_noise=[0.02, 0.01, 0.01, 0.01], damping_noise=[3.0, 2.0, 1.0, 1.0],
                              shape_noise=[0.5, 0.5, 0.5, 0.5], frequency_noise_floor=[0.0] * 4,
                              damping_noise_floor=[0.0] * 4, shape_noise_floor=[0.0] * 4,
                              frequency_noise_per_floor=[0.0] * 4, damping_noise_per_floor=[0.0] * 4,
                              shape_noise_per_floor=[0.0] * 4, modal_noise_scale=[1.0, 1.0],
                              frequency_scatter=[0.0, 0.0], damping_scatter=[0.0, 0.0], shape_scatter=[0.0, 0.0],
                              gain_scatter=[0.0, 0.0])
    setup = get_setup(merge(cfg))
    inp = draw_batch(np.random.default_rng(5), 4000, setup)
    from datagen.pipeline import measure_modes

    lam = -0.002 * np.full((4000, 2, 4), 100.0) + 100j
    psi = np.ones((4000, 2, 4, 4), complex)
    lam_m, psi_m = measure_modes(setup, inp, lam, psi)
    level = inp.noise_level[:, None]
    ef = (np.abs(lam_m) / np.abs(lam) - 1)[:, :, 0] / level          # mode 1: std 0.02 per unit level
    ez = (-lam_m.real / np.abs(lam_m) / 0.002 - 1)[:, :, 2] / level  # mode 3: std 1.0 per unit level
    es = (psi_m - psi)[:, :, :, 1] / level[..., None]                # mode 2 shapes: complex std 0.5
    assert np.std(ef) == pytest.approx(0.02, rel=0.05)
    assert np.std(ez) == pytest.approx(1.0, rel=0.05)
    assert np.sqrt(np.mean(np.abs(es) ** 2)) == pytest.approx(0.5, rel=0.05)
    # std = sqrt((c level)^2 + floor^2): a floor alone gives the same std at every level
    cfg["measurement"].update(frequency_noise=[0.0] * 4, frequency_noise_floor=[1e-3, 0.0, 0.0, 0.0])
    setup = get_setup(merge(cfg))
    lam_m, _ = measure_modes(setup, inp, lam, psi)
    ef = (np.abs(lam_m) / np.abs(lam) - 1)[:, :, 0]
    low = inp.noise_level < np.median(inp.noise_level)
    assert np.std(ef[low]) == pytest.approx(1e-3, rel=0.07) and np.std(ef[~low]) == pytest.approx(1e-3, rel=0.07)
    assert np.abs(np.abs(lam_m) / np.abs(lam) - 1)[:, :, 1].max() < 1e-12  # mode 2: no coefficient, no floor
    # + (g floor)^2: errors proportional to each sample's FRF noise floor
    cfg["measurement"].update(frequency_noise_floor=[0.0] * 4, frequency_noise_per_floor=[0.0, 5.0, 0.0, 0.0])
    lam_m, _ = measure_modes(get_setup(merge(cfg)), inp, lam, psi)
    ef = (np.abs(lam_m) / np.abs(lam) - 1)[:, :, 1] / inp.noise_floor[:, None]
    assert np.std(ef) == pytest.approx(5.0, rel=0.05)
    # the per-sample modal_noise_scale multiplies every std: log-uniform in [0.5, 4] scales the errors by it
    cfg["measurement"].update(modal_noise_scale=[0.5, 4.0])
    setup = get_setup(merge(cfg))
    inp = draw_batch(np.random.default_rng(5), 4000, setup)
    assert inp.modal_noise_scale.min() >= 0.5 and inp.modal_noise_scale.max() <= 4.0
    lam_m, _ = measure_modes(setup, inp, lam, psi)
    ef = (np.abs(lam_m) / np.abs(lam) - 1)[:, :, 1] / (inp.noise_floor * inp.modal_noise_scale)[:, None]
    assert np.std(ef) == pytest.approx(5.0, rel=0.05)
    # frequency_scatter (log-uniform per sample) adds in quadrature on every mode's frequency, not on shapes
    cfg["measurement"].update(frequency_noise_per_floor=[0.0] * 4, modal_noise_scale=[1.0, 1.0],
                              frequency_scatter=[1e-5, 1e-3])
    setup = get_setup(merge(cfg))
    inp = draw_batch(np.random.default_rng(6), 4000, setup)
    assert 1e-5 <= inp.frequency_scatter.min() and inp.frequency_scatter.max() <= 1e-3
    assert np.median(inp.frequency_scatter) == pytest.approx(1e-4, rel=0.1)          # log-uniform
    lam_m, psi_m = measure_modes(setup, inp, lam, psi)
    ef = (np.abs(lam_m) / np.abs(lam) - 1)[:, :, 1:] / inp.frequency_scatter[:, None, None]
    assert np.std(ef) == pytest.approx(1.0, rel=0.05)
    from dataclasses import replace

    lam_0, psi_0 = measure_modes(setup, replace(inp, frequency_scatter=np.zeros(4000)), lam, psi)
    np.testing.assert_array_equal(psi_0, psi_m)
    assert np.abs(np.abs(lam_0) / np.abs(lam) - 1)[:, :, 1:].max() < 1e-12


def test_repeatability_scatter_of_damping_shapes_and_channel_gains():
    """damping_scatter and shape_scatter add in quadrature per mode; gain_scatter multiplies a sensor's entries of
    every mode by one factor per test (the same for all modes of that sensor); a range of 0 draws nothing."""
    from datagen.pipeline import measure_modes

    cfg = load_config("training")
    zero = [0.0] * 4
    cfg["measurement"].update({f"{q}_{s}": zero for q in ("frequency", "damping", "shape")
                               for s in ("noise", "noise_floor", "noise_per_floor")})
    cfg["measurement"].update(modal_noise_scale=[1.0, 1.0], frequency_scatter=[0.0, 0.0],
                              damping_scatter=[0.05, 0.3], shape_scatter=[0.01, 0.01], gain_scatter=[0.02, 0.02])
    setup = get_setup(merge(cfg))
    inp = draw_batch(np.random.default_rng(7), 4000, setup)
    assert 0.05 <= inp.damping_scatter.min() and inp.damping_scatter.max() <= 0.3
    assert np.median(inp.damping_scatter) == pytest.approx(np.sqrt(0.05 * 0.3), rel=0.1)     # log-uniform
    lam = -0.002 * np.full((4000, 2, 4), 100.0) + 100j
    psi = np.ones((4000, 2, 4, 4), complex)
    lam_m, psi_m = measure_modes(setup, inp, lam, psi)
    ez = (-lam_m.real / np.abs(lam_m) / 0.002 - 1) / inp.damping_scatter[:, None, None]
    assert np.std(ez) == pytest.approx(1.0, rel=0.05)
    assert np.abs(np.abs(lam_m) / np.abs(lam) - 1).max() < 1e-12                       # frequencies untouched
    # shapes: psi (1 + 0.02 n_gain) + 0.01 (1 + 0.02 n_gain) noise; the gain is common to the modes of a sensor
    ratio = psi_m / psi_m.mean(axis=-1, keepdims=True)          # the sensor's gain divides out
    np.testing.assert_allclose(np.sqrt(np.mean(np.abs(ratio - 1) ** 2)), 0.01 * np.sqrt(3 / 4), rtol=0.05)
    gain = psi_m.mean(axis=-1).real - 1                         # (B, 2, S): gain error plus the mean of 4 noises
    assert np.std(gain) == pytest.approx(np.hypot(0.02, 0.01 / np.sqrt(8)), rel=0.05)
    cfg["measurement"].update(gain_scatter=[0.0, 0.0])
    assert not draw_batch(np.random.default_rng(7), 10, get_setup(merge(cfg))).n_gain.any()


def test_support_changes_are_drawn_for_intact_specimens_only_beyond_re_clamping():
    cfg = load_config("training")
    cfg["specimen"].update(support_change_fraction=0.5, support_change_factor=[2.0, 5.0])
    inp = draw_batch(np.random.default_rng(8), 4000, get_setup(merge(cfg)))
    s = inp.support_changed
    assert not (s & (inp.n_damages > 0)).any()
    assert np.mean(s[inp.n_damages == 0]) == pytest.approx(0.5, abs=0.05)
    factor = 1 + inp.root_spring_change[s]
    stiffer = factor > 1
    assert np.mean(stiffer) == pytest.approx(0.5, abs=0.05)
    assert factor[stiffer].min() >= 2 and factor[stiffer].max() <= 5
    assert (1 / factor[~stiffer]).min() >= 2 and (1 / factor[~stiffer]).max() <= 5
    assert np.abs(inp.root_spring_change[~s]).max() <= 0.08                      # the config's re-clamping
    cfg["specimen"].update(root_spring_relative=[], root_spring_change=[0.0, 0.0])
    with pytest.raises(ConfigError, match="specimen.support_change_fraction"):
        get_setup(merge(cfg))


def test_a_beam_without_support_springs_draws_no_support_change(tmp_path):
    """Pinned ends without bearing springs hold no spring that could change: no sample is labelled
    support_changed, and the other draws are those of a config without support changes."""
    cfg = load_config("training")
    cfg["beam"] = {"name": "pp", "bc": "pinned-pinned", "length_m": 1.0, "width_m": 0.03, "thickness_m": 0.008,
                   "EI_Nm2": 256.0, "mass_per_length_kg_m": 1.9, "measured_x_m": [0.2, 0.5, 0.8],
                   "drive_x_m": 0.2, "band_hz": [5.0, 600.0]}
    cfg["specimen"]["root_spring_change"] = [0.0, 0.0]
    inp = draw_batch(np.random.default_rng(3), 200, get_setup(merge(cfg)))
    cfg["specimen"]["support_change_fraction"] = 0.0
    ref = draw_batch(np.random.default_rng(3), 200, get_setup(merge(cfg)))
    assert not inp.support_changed.any()
    np.testing.assert_array_equal(inp.root_spring_change, ref.root_spring_change)
    np.testing.assert_array_equal(inp.noise_seed, ref.noise_seed)
