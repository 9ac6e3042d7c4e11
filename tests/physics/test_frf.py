import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import frf, modal
from physics.errors import BeamDamageError
from systems import random_system


def test_sdof_receptance_is_eq_3_11():
    m, c, k = 1.5, 0.4, 900.0
    w = np.linspace(1, 60, 500)
    h = frf.receptance([[m]], [[c]], [[k]], w)[0, 0]
    np.testing.assert_allclose(h, 1 / ((k - m * w**2) + 1j * c * w), rtol=1e-13)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(2, 10), seed=st.integers(0, 2**31))
def test_direct_modal_and_state_space_routes_agree(n, seed):
    M, C, K = random_system(n, seed)
    cm = modal.complex_modes(M, C, K)
    w = np.linspace(0.1, 1.5, 300) * np.abs(cm.eigenvalues).max()
    out, inp = [0, n - 1], [n // 2]
    a = frf.receptance(M, C, K, w, out, inp)
    b = frf.receptance_modal(cm.eigenvalues, cm.eigenvectors, w, out, inp)
    c = frf.receptance_state_space(M, C, K, w, out, inp)
    assert a.shape == (2, 1, 300)
    scale = np.abs(a).max()
    assert np.abs(a - b).max() < 1e-8 * scale
    assert np.abs(a - c).max() < 1e-8 * scale


def test_batched_frf_and_reciprocity():
    systems = [random_system(3, seed=s) for s in range(4)]
    M, C, K = (np.stack(x) for x in zip(*systems))
    w = np.linspace(1, 30, 50)
    h = frf.receptance(M, C, K, w)
    assert h.shape == (4, 3, 3, 50)
    np.testing.assert_allclose(h, np.swapaxes(h, 1, 2), rtol=1e-10)  # H_sr = H_rs
    np.testing.assert_allclose(h[2], frf.receptance(*systems[2], w), rtol=1e-12)


def test_kind_conversion_and_db():
    w = np.array([2.0, 10.0])
    h = np.array([1e-3 + 1e-3j, -2e-4j])
    mob = frf.convert_frf(h, w, "receptance", "mobility")
    np.testing.assert_allclose(mob, 1j * w * h)
    np.testing.assert_allclose(frf.convert_frf(mob, w, "mobility", "accelerance"), -(w**2) * h)
    np.testing.assert_allclose(frf.convert_frf(-(w**2) * h, w, "accelerance", "receptance"), h)
    assert frf.magnitude_db(np.array([10.0]))[0] == pytest.approx(20.0)
    np.testing.assert_array_equal(frf.magnitude_db(np.array([0.0, 1e-300j])), [-6000.0, -6000.0])  # zeros: finite
    assert frf.phase_deg(np.array([1j]))[0] == pytest.approx(90.0)
    with pytest.raises(BeamDamageError, match="FRF kind"):
        frf.convert_frf(h, w, "receptance", "inertance")


def _modal_model(n=6, seed=5, batch=()):
    systems = [random_system(n, seed=seed + s) for s in range(int(np.prod(batch, dtype=int)))]
    M, C, K = (np.stack(x).reshape(batch + (n, n)) for x in zip(*systems))
    cm = modal.complex_modes(M, C, K)
    return (M, C, K), cm


def test_pole_residue_backends_agree_and_equal_direct_inversion():
    (M, C, K), cm = _modal_model(batch=(3, 2))
    w = np.linspace(0.05, 1.3, 400) * np.abs(cm.eigenvalues).max()
    psi = cm.eigenvectors
    residues = psi[..., [0, 2, 5], :] * psi[..., 1:2, :]          # (3, 2, 3, n): drive DOF 1
    fast = frf.pole_residue(cm.eigenvalues, residues, w)
    slow = frf.pole_residue(cm.eigenvalues, residues, w, backend="numpy")
    direct = frf.receptance(M, C, K, w, [0, 2, 5], [1])[..., 0, :]
    assert fast.shape == (3, 2, 3, 400)
    scale = np.abs(slow).max(axis=-1, keepdims=True)
    assert np.abs(fast - slow).max() < 1e-12 * scale.max()
    assert np.all(np.abs(fast - slow) <= 1e-12 * scale)
    assert np.abs(fast - direct).max() < 1e-9 * scale.max()


def test_pole_residue_with_residuals_is_the_closed_form_and_broadcasts_eigenvalues():
    lam = np.array([-0.5 + 30j, -1.0 + 80j])
    R = np.array([[[1e-3 + 2e-4j, -5e-4j]], [[2e-3 + 0j, 1e-4 + 1e-4j]]])   # (n_resp=2, n_ref=1, m=2)
    lr, ur = np.array([[3.0], [4.0]]), np.array([[1e-6], [2e-6]])
    w = np.linspace(5.0, 120.0, 50)
    s = 1j * w
    exact = sum(R[..., j, None] / (s - lam[j]) + np.conj(R[..., j, None]) / (s - np.conj(lam[j])) for j in range(2))
    exact = exact - lr[..., None] / w**2 + ur[..., None]
    for backend in ("numba", "numpy"):
        H = frf.pole_residue(lam, R, w, lower_residual=lr, upper_residual=ur, backend=backend)
        np.testing.assert_allclose(H, exact, rtol=1e-12)


def test_pole_residue_writes_complex64_storage_in_place():
    _, cm = _modal_model(n=4, batch=(2,))
    w = np.linspace(1.0, 1.2 * np.abs(cm.eigenvalues).max(), 300)
    res = cm.eigenvectors * cm.eigenvectors[..., :1, :]
    clean = frf.pole_residue(cm.eigenvalues, res, w, backend="numpy")
    store = np.zeros((5, 4, 300), np.complex64)
    out = frf.pole_residue(cm.eigenvalues, res, w, out=store[1:3])
    assert np.shares_memory(out, store)
    np.testing.assert_allclose(store[1:3], clean, rtol=0, atol=1e-6 * np.abs(clean).max())  # float32 rounding
    assert not store[0].any() and not store[3:].any()
    with pytest.raises(BeamDamageError, match="C-contiguous"):
        frf.pole_residue(cm.eigenvalues, res, w, out=np.empty((2, 4, 600), complex)[..., ::2])


def test_poles_and_residues_are_the_eq_1_10_modes_products():
    (M, C, K), cm = _modal_model(n=5, batch=(3,))
    C = C.copy()
    C[2, 1, 1] = np.inf
    pr = frf.poles_and_residues(M, C, K, [0, 4], [2])
    assert pr.residues.shape == (3, 2, 1, 5) and pr.underdamped.tolist() == [True, True, False]
    psi = cm.eigenvectors[:2]
    np.testing.assert_allclose(pr.eigenvalues[:2], cm.eigenvalues[:2], rtol=1e-12)
    np.testing.assert_allclose(pr.residues[:2], psi[:, [0, 4], None, :] * psi[:, None, [2], :], rtol=1e-8,
                               atol=1e-10 * np.abs(psi).max() ** 2)
    assert np.all(np.isnan(pr.eigenvalues[2])) and np.all(np.isnan(pr.residues[2]))


def test_state_space_handles_overdamped_and_nan_members_like_direct_inversion():
    (M, C, K), cm = _modal_model(n=4, batch=(3,))
    C = C.copy()
    C[1] = C[1] * 400.0                       # overdamped member: real poles
    C[2, 0, 0] = np.nan                       # a failed update in the batch
    w = np.linspace(0.1, 1.5, 200) * np.abs(cm.eigenvalues).max()
    with np.errstate(invalid="ignore"):
        H = frf.receptance_state_space(M, C, K, w, [0, 3], [1, 2])
    assert H.shape == (3, 2, 2, 200)
    for i in (0, 1):
        direct = frf.receptance(M[i], C[i], K[i], w, [0, 3], [1, 2])
        assert np.abs(H[i] - direct).max() < 1e-8 * np.abs(direct).max()
    assert np.all(np.isnan(H[2]))
    store = np.empty((3, 2, 1, 200), np.complex128)
    with np.errstate(invalid="ignore"):
        out = frf.receptance_state_space(M, C, K, w, [0, 3], [1], out=store)
    assert out is store
    np.testing.assert_allclose(store[:2], H[:2, :, :1], rtol=1e-12)
    with pytest.raises(BeamDamageError, match="C-contiguous"):  # a strided view would be written as a copy
        frf.receptance_state_space(M, C, K, w, [0, 3], [1], out=np.empty((3, 2, 2, 200), complex)[:, :, :1])


def test_kind_conversion_rejects_0_rad_s_towards_receptance_and_names_the_parameter():
    w = np.array([0.0, 10.0])
    h = np.array([1e-3, 2e-3])
    np.testing.assert_allclose(frf.convert_frf(h, w, "receptance", "mobility"), 1j * w * h)
    with pytest.raises(BeamDamageError, match="0 rad/s"):
        frf.convert_frf(h, w, "mobility", "receptance")
    with pytest.raises(BeamDamageError, match="from_kind"):
        frf.convert_frf(h, w, "inertance", "receptance")
    assert set(frf.FRF_UNITS) == set(frf.FRF_KINDS)
