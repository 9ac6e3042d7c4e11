"""Batched pipeline against the per-sample path, the light-damping shortcut against the full solution."""

import numpy as np
import pytest

from datagen.config import merge
from datagen.naive import simulate_naive
from datagen.batch_inputs import draw_batch
from datagen.pipeline import simulate_batch
from datagen.setup import get_setup
from datagen.synth import measured_frf, updated_frf
from physics.frf import pole_residue, poles_and_residues, receptance
from physics.modal import complex_modes, modal_parameters
from physics.updating import pilkey


@pytest.fixture(scope="module")
def setup():
    return get_setup(merge({"damage": {"n_slits": [0, 3]}, "measurement": {"lines": 256}}))


@pytest.fixture(scope="module")
def batch(setup):
    inp = draw_batch(np.random.default_rng(7), 12, setup)
    return inp, simulate_batch(setup, inp, chunk=5)


def _rel(a, b):
    return np.nanmax(np.abs(a - b)) / np.nanmax(np.abs(b))


def _stored(inp, out):
    return {**out, "noise_seed": inp.noise_seed, "noise_level": inp.noise_level, "noise_floor": inp.noise_floor}


def test_batched_equals_per_sample(setup, batch):
    inp, out = batch
    ref = simulate_naive(setup, inp, solution="projection")
    for k in ("truth_poles", "truth_shapes", "eigenvalues_measured", "eigenvectors_measured", "M_updated",
              "C_updated", "K_updated", "updated_poles", "updated_residues", "damage_frequency_drop"):
        assert _rel(out[k], ref[k]) < 1e-8, k
    # FRFs synthesised on read (compiled pair kernel, fused noise) against eager per-sample FRFs
    # (modal superposition, direct inversion, the same noise applied afterwards)
    w = setup.omega_rad_s
    a = _stored(inp, out)
    assert _rel(measured_frf(a, w, np.complex128), ref["frf_measured"]) < 1e-8
    assert _rel(updated_frf(a, w, np.complex128), ref["frf_updated"]) < 1e-8
    assert np.array_equal(out["converged"], ref["converged"])
    assert np.array_equal(out["iterations"], ref["iterations"])


def test_projection_shortcut_matches_full_state_space(setup, batch):
    """Stated tolerance: f 1e-4, zeta 1e-3 (relative), MAC > 1 - 1e-6, FRF 1e-3 of its peak."""
    inp, out = batch
    full = simulate_naive(setup, inp, solution="full")
    f_s, z_s = modal_parameters(out["truth_poles"][..., :4])
    f_f, z_f = modal_parameters(full["truth_poles"][..., :4])
    np.testing.assert_allclose(f_s, f_f, rtol=1e-4)
    np.testing.assert_allclose(z_s, z_f, rtol=1e-3)
    a, b = out["truth_shapes"][..., :4], full["truth_shapes"][..., :4]
    mac = np.abs(np.sum(np.conj(a) * b, axis=-2)) ** 2 / (np.sum(np.abs(a) ** 2, -2) * np.sum(np.abs(b) ** 2, -2))
    assert mac.min() > 1 - 1e-6
    h_s, h_f = measured_frf(_stored(inp, out), setup.omega_rad_s, np.complex128), full["frf_measured"]
    assert np.max(np.abs(h_s - h_f) / np.abs(h_f).max(axis=-1, keepdims=True)) < 1e-3


def test_baseline_state_has_prescribed_damping(setup, batch):
    inp, out = batch
    _, z = modal_parameters(out["truth_poles"][:, 0, :4])
    want = np.array(setup.cfg["specimen"]["damping_ratios"]) * inp.damping_scale[:, None]
    np.testing.assert_allclose(z, want, rtol=1e-6)


def test_batched_updating_equals_per_sample_pilkey(setup, batch):
    _, out = batch
    M = np.repeat(out["M_updated"][:, None], 2, 1).reshape(-1, 4, 4)
    lam = out["eigenvalues_measured"].reshape(-1, 4)
    phi = out["eigenvectors_measured"].reshape(-1, 4, 4)
    C, K, conv = (out[k].reshape((-1,) + out[k].shape[2:]) for k in ("C_updated", "K_updated", "converged"))
    it = out["iterations"].reshape(-1)
    for i in range(0, M.shape[0], 5):
        r = pilkey(M[i], lam[i], phi[i], raise_on_failure=False)
        assert conv[i] == r.converged and it[i] == r.iterations
        if r.converged:
            assert _rel(C[i], r.C) < 1e-12 and _rel(K[i], r.K) < 1e-12


def test_updated_poles_and_residues_give_the_direct_inversion_frf(setup, batch):
    """Stored poles/residues of the updated models -> pole-residue FRF = (K - w^2 M + i w C)^-1 (eq. 3.16)."""
    _, out = batch
    w = setup.omega_rad_s
    M, C, K = out["M_updated"][:3], out["C_updated"][:3, 1], out["K_updated"][:3, 1]
    pr = poles_and_residues(M, C, K, np.arange(4), [0])
    lam, R = pr.eigenvalues, pr.residues[..., 0, :]
    direct = receptance(M, C, K, w, np.arange(4), [0])[..., 0, :]
    assert _rel(pole_residue(lam, R, w), direct) < 1e-9
    # an overdamped model has real poles: NaN poles, and the reader takes the state-space route
    Co = C * 2000.0
    pr = poles_and_residues(M, Co, K, np.arange(4), [0])
    lam_o, R_o = pr.eigenvalues, pr.residues[..., 0, :]
    assert np.isnan(lam_o).all()
    a = {"updated_poles": lam_o[:, None].repeat(2, 1), "updated_residues": R_o[:, None].repeat(2, 1),
         "M_updated": M, "C_updated": Co[:, None].repeat(2, 1), "K_updated": K[:, None].repeat(2, 1)}
    got = updated_frf(a, w, np.complex128)[:, 0]
    assert _rel(got, receptance(M, Co, K, w, np.arange(4), [0])[..., 0, :]) < 1e-9


def test_updated_model_with_consistent_data_reproduces_measured_modes(setup):
    """Noise-free data of a 4-DOF model consistent with M: Pilkey recovers C and K exactly."""
    M = np.array([[2.0, 0.3, 0, 0], [0.3, 2.0, 0.3, 0], [0, 0.3, 2.0, 0.3], [0, 0, 0.3, 1.0]])
    K = 1e4 * (np.diag([2.0, 2, 2, 1]) - np.eye(4, k=1) - np.eye(4, k=-1))
    C = 1e-4 * K + 0.05 * M
    cm = complex_modes(M, C, K)
    r = pilkey(M[None], cm.eigenvalues[None], cm.eigenvectors[None] * 3.0)
    assert r.converged[0]
    np.testing.assert_allclose(r.C[0], C, atol=1e-9 * np.abs(C).max())
    np.testing.assert_allclose(r.K[0], K, rtol=1e-8, atol=1e-8 * np.abs(K).max())


def test_tabulated_box_muller_matches_the_exact_transform_and_is_gaussian():
    from datagen.noise_kernels import box_muller  # the transform the noise streams go through

    rng = np.random.default_rng(3)
    # z = sqrt(-ln(1 - u1)) exp(2 pi i u2), including the exact branch near u1 = 0 and 1
    u = np.concatenate([rng.random((20000, 2)), [[1e-7, 0.3], [1 - 1e-7, 0.7], [0.0, 0.0]]])
    z = np.array([box_muller(*x) for x in u])
    r = np.sqrt(-np.log1p(-u[:, 0]))
    a = 2 * np.pi * u[:, 1]
    assert np.abs(z - np.c_[r * np.cos(a), r * np.sin(a)]).max() < 1e-5
    assert abs(np.mean(z[:, 0] ** 2 + z[:, 1] ** 2) - 1.0) < 0.03  # E|z|^2 = 1
    assert abs(np.mean(z[:, 0] * z[:, 1])) < 0.02


def test_counter_based_noise_stream_is_unit_circular_gaussian_and_independent():
    from scipy import stats

    from datagen.noise_kernels import hashed_normal

    seed = np.uint64(12345)
    z = np.array([hashed_normal(seed, k) for k in range(40000)])
    zc = z[:, 0] + 1j * z[:, 1]
    assert abs(np.mean(np.abs(zc) ** 2) - 1.0) < 0.03 and abs(zc.mean()) < 0.02
    assert stats.kstest(z[:, 0] * np.sqrt(2), "norm").pvalue > 1e-3  # each part N(0, 1/2)
    assert abs(np.corrcoef(z[:-1, 0], z[1:, 0])[0, 1]) < 0.02      # consecutive counters uncorrelated
    other = np.array([hashed_normal(seed + np.uint64(1), k) for k in range(2000)])
    assert abs(np.corrcoef(z[:2000, 0], other[:, 0])[0, 1]) < 0.07  # neighbouring seeds: unrelated streams


def test_band_cholesky_solve_equals_dense_solve(setup):
    from datagen.band_cholesky import band_cholesky, band_cholesky_solve

    rng = np.random.default_rng(4)
    K = np.stack([setup.K0 * f for f in (1.0, 2.5)])
    K[:, 0, 0] += 50.0  # the root spring makes the free-rotation mesh definite
    B = rng.standard_normal((2, K.shape[1], 5))
    X = band_cholesky_solve(band_cholesky(K, 3), B)
    np.testing.assert_allclose(X, np.linalg.solve(K, B), rtol=1e-9, atol=1e-12 * np.abs(X).max())
    with pytest.raises(ValueError, match="positive definite"):
        band_cholesky(-K, 3)


def test_projection_shortcut_with_a_shear_flexibility_per_specimen_matches_full_state_space():
    """Specimens with shear flexibility 0-0.006 (Timoshenko truth elements per sample, slits on them, the
    nominal basis of the band's centre as the subspace start): the shortcut's modes are the full solution's."""
    from datagen.config import load_config

    cfg = merge({"specimen": {"shear_flexibility": [0.0, 0.006]}, "measurement": {"lines": 128}},
                base=load_config("training"))
    st = get_setup(cfg)
    inp = draw_batch(np.random.default_rng(3), 10, st)
    assert np.ptp(inp.shear_flexibility) > 0.003
    out, full = simulate_batch(st, inp, chunk=4), simulate_naive(st, inp, solution="full")
    f_s, z_s = modal_parameters(out["truth_poles"][..., :4])
    f_f, z_f = modal_parameters(full["truth_poles"][..., :4])
    np.testing.assert_allclose(f_s, f_f, rtol=1e-4)
    np.testing.assert_allclose(z_s, z_f, rtol=1e-3)
