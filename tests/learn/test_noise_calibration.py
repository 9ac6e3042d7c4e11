"""The modal noise calibrated on a test: the shortcut a dataset draws then scatters as classify's identification
of that test's files does, where the thesis test's coefficients do not."""

import numpy as np
import pytest

BAR = {"name": "bar", "bc": "free-free", "length_m": 1.2, "width_m": 0.03, "thickness_m": 0.008, "EI_Nm2": 268.8,
       "mass_per_length_kg_m": 1.884, "measured_x_m": [0.0, 0.24, 0.48, 0.72, 0.96, 1.2], "drive_x_m": 0.0,
       "band_hz": [15.0, 420.0]}


def shortcut_shape_std(cfg, level, floor, specimens, seed):
    from datagen.config import merge
    from datagen.batch_inputs import draw_batch
    from datagen.pipeline import measure_modes, simulate_batch
    from datagen.setup import get_setup
    from learn.pairs.noise_calibration import robust_std

    meas = {"frf_noise": level, "frf_noise_floor": floor, "modal_noise_scale": [1.0, 1.0],
            **{f"{q}_scatter": [0.0, 0.0] for q in ("frequency", "damping", "shape", "gain")}}
    setup = get_setup(merge({"measurement": meas}, base=cfg))
    inp = draw_batch(np.random.default_rng(seed), specimens, setup)
    sim = simulate_batch(setup, inp)
    used = setup.modes_idx
    lam, psi = sim["truth_poles"][..., used], sim["truth_shapes"][..., used]
    _, psi_m = measure_modes(setup, inp, lam, psi)
    err = (psi_m - psi) / np.max(np.abs(psi), axis=-2, keepdims=True)
    return np.array([robust_std(err[..., r]) for r in range(used.size)])


@pytest.mark.slow
def test_calibrated_shape_noise_matches_the_identification_of_the_test():
    from datagen.config import load_config, merge
    from learn.pairs.noise_calibration import calibrate_test, identification_errors, robust_std

    cfg = merge({"beam": BAR}, base=load_config("training"))
    calibrated = merge({"measurement": calibrate_test(cfg, specimens=8)}, base=cfg)
    full = identification_errors(cfg, 0.01, 0.0003, 12, seed=7)[2]
    full_std = np.array([robust_std(full[..., r]) for r in range(full.shape[-1])])
    ratio_calibrated = shortcut_shape_std(calibrated, 0.01, 0.0003, 400, 3) / full_std
    ratio_shipped = shortcut_shape_std(cfg, 0.01, 0.0003, 400, 3) / full_std
    assert np.all((ratio_calibrated > 0.6) & (ratio_calibrated < 1.6)), ratio_calibrated
    assert np.min(ratio_shipped) < 0.6, ratio_shipped          # the thesis test's coefficients are too small here
