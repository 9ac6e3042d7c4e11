"""A reference DOF where no sensor is (a hammer away from the accelerometers): the transfer FRFs of that test."""

import numpy as np

from datagen.config import load_config, merge
from datagen.batch_inputs import draw_batch
from datagen.pipeline import projected_modes, simulate_batch, truth_matrices
from datagen.setup import get_setup
from datagen.synth import measured_frf


def _setup(sensors_x_m, drive_x_m):
    cfg = load_config("training")
    cfg["beam"] = {"name": "cf", "bc": "clamped-free", "length_m": 1.0, "width_m": 0.03, "thickness_m": 0.008,
                   "EI_Nm2": 256.0, "mass_per_length_kg_m": 1.9, "measured_x_m": sensors_x_m,
                   "drive_x_m": drive_x_m, "band_hz": [3.0, 600.0]}
    return get_setup(merge(cfg))


def test_a_drive_off_the_sensors_gives_the_transfer_frfs_of_a_sensor_placed_there():
    off = _setup([0.5, 1.0], 0.2)                  # hammer at 0.2 m, accelerometers at 0.5 and 1.0 m
    on = _setup([0.2, 0.5, 1.0], 0.2)              # the same test with an accelerometer at the hammer too
    assert (off.n_meas, off.drive_row, off.drive_off_sensors) == (2, 2, True)
    assert off.n_elements == on.n_elements and off.update_drive_row == 0
    inp = draw_batch(np.random.default_rng(1), 3, off)
    sim = simulate_batch(off, inp)
    M, Mu, K, dC, _ = truth_matrices(on, inp)
    lam, psi, _ = projected_modes(on, inp, M, Mu, K, dC)
    np.testing.assert_allclose(sim["truth_shapes"][:, :, [2, 0, 1]], psi, rtol=0, atol=1e-9 * np.abs(psi).max())
    assert sim["eigenvectors_measured"].shape[2] == 2 and sim["frf_peak"].shape[2] == 2
    z = np.zeros(3)
    noise = {"noise_seed": inp.noise_seed, "noise_level": z, "noise_floor": z}
    H_off = measured_frf({**sim, "drive_row": off.drive_row, "n_responses": 2, **noise}, off.omega_rad_s,
                         np.complex128)
    H_on = measured_frf({"truth_poles": lam, "truth_shapes": psi, "drive_row": 0, **noise}, off.omega_rad_s,
                        np.complex128)
    assert H_off.shape == (3, 2, 2, off.omega_rad_s.size)
    np.testing.assert_allclose(H_off, H_on[:, :, 1:], rtol=0, atol=1e-9 * np.abs(H_on).max())
