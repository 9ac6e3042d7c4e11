import numpy as np
import pytest

from physics import modal
from physics.errors import OverdampedError, ShapeError
from systems import random_system


def test_sdof_eigenvalue_closed_form():
    m, c, k = 2.0, 0.3, 800.0
    cm = modal.complex_modes([[m]], [[c]], [[k]])
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    np.testing.assert_allclose(cm.eigenvalues, [-zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)], rtol=1e-12)
    np.testing.assert_allclose(cm.natural_frequencies_hz, [wn / (2 * np.pi)], rtol=1e-12)
    np.testing.assert_allclose(cm.damping_ratios, [zeta], rtol=1e-10)
    # eq. 1.10: psi^2 (2 lambda m + c) = 1
    lam = cm.eigenvalues[0]
    assert cm.eigenvectors[0, 0] ** 2 * (2 * lam * m + c) == pytest.approx(1.0)


def test_modes_solve_the_quadratic_eigenproblem_and_are_normalised():
    M, C, K = random_system(6, seed=3)
    cm = modal.complex_modes(M, C, K)
    assert np.all(cm.eigenvalues.imag > 0) and np.all(np.diff(cm.eigenvalues.imag) > 0)
    for lam, psi in zip(cm.eigenvalues, cm.eigenvectors.T):
        r = (lam**2 * M + lam * C + K) @ psi
        assert np.linalg.norm(r) < 1e-9 * np.linalg.norm(K) * np.linalg.norm(psi)
        assert psi @ (2 * lam * M + C) @ psi == pytest.approx(1.0, rel=1e-10)


def test_lancaster_identities_hold_for_the_complete_set():
    M, C, K = random_system(5, seed=7)
    cm = modal.complex_modes(M, C, K)
    P, L = cm.eigenvectors, cm.eigenvalues
    np.testing.assert_allclose(2 * (P @ P.T).real, 0, atol=1e-10)
    np.testing.assert_allclose(2 * ((P * L) @ P.T).real, np.linalg.inv(M), rtol=1e-9, atol=1e-12)


def test_batched_modes_equal_single():
    systems = [random_system(4, seed=s) for s in range(3)]
    M, C, K = (np.stack(x) for x in zip(*systems))
    batch = modal.complex_modes(M, C, K)
    for i in range(3):
        one = modal.complex_modes(*systems[i])
        np.testing.assert_allclose(batch.eigenvalues[i], one.eigenvalues, rtol=1e-12)
        np.testing.assert_allclose(modal.mac(batch.eigenvectors[i], one.eigenvectors).diagonal(), 1, atol=1e-10)


def test_overdamped_and_bad_shapes_are_rejected():
    with pytest.raises(OverdampedError, match="real eigenvalues"):
        modal.complex_modes([[1.0]], [[10.0]], [[1.0]])  # zeta = 5
    with pytest.raises(ShapeError, match="C must have shape"):
        modal.complex_modes(np.eye(2), np.eye(3), np.eye(2))
    with pytest.raises(ShapeError, match="NaN"):
        modal.complex_modes(np.eye(2), np.full((2, 2), np.nan), np.eye(2))
    with pytest.raises(OverdampedError):
        modal.eigenvalues_from_modal([10.0], [1.2])


def test_mac_and_modal_parameters_round_trip():
    f, z = np.array([21.5, 129.7]), np.array([0.0016, 0.0025])
    f2, z2 = modal.modal_parameters(modal.eigenvalues_from_modal(f, z))
    np.testing.assert_allclose(f2, f, rtol=1e-13)
    np.testing.assert_allclose(z2, z, rtol=1e-10)
    a = np.array([[1.0, 0.0], [1.0, 1.0]])
    np.testing.assert_allclose(modal.mac(a, 3j * a), [[1.0, 0.5], [0.5, 1.0]])


def test_underdamped_modes_skip_overdamped_high_modes_closed_form():
    # three uncoupled oscillators; the stiffest is overdamped (zeta = 5): closed-form SDOF poles
    m = np.array([1.0, 2.0, 1.0])
    k = np.array([100.0, 800.0, 1e4])
    c = np.array([0.4, 1.6, 1e3])
    M, C, K = np.diag(m), np.diag(c), np.diag(k)
    with pytest.raises(OverdampedError):
        modal.complex_modes(M, C, K)
    cm = modal.underdamped_modes(M, C, K, 2)
    wn, z = np.sqrt(k / m)[:2], (c / (2 * np.sqrt(k * m)))[:2]
    np.testing.assert_allclose(cm.eigenvalues, -z * wn + 1j * wn * np.sqrt(1 - z**2), rtol=1e-12)
    for j in range(2):  # eq. 1.10 on the mode's own DOF, zero elsewhere
        psi = cm.eigenvectors[:, j]
        assert abs(psi[1 - j]) < 1e-12 and abs(psi[2]) < 1e-12
        assert psi[j] ** 2 * (2 * cm.eigenvalues[j] * m[j] + c[j]) == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(OverdampedError, match="n_modes=3"):
        modal.underdamped_modes(M, C, K, 3)


def test_underdamped_modes_equal_complex_modes_when_all_are_underdamped():
    systems = [random_system(5, seed=s) for s in (11, 12)]
    M, C, K = (np.stack(x) for x in zip(*systems))
    full = modal.complex_modes(M, C, K)
    low = modal.underdamped_modes(M, C, K, 3)
    np.testing.assert_allclose(low.eigenvalues, full.eigenvalues[:, :3], rtol=1e-12)
    np.testing.assert_allclose(np.abs(modal.mac(low.eigenvectors[0], full.eigenvectors[0, :, :3]).diagonal()), 1,
                               atol=1e-10)


def test_the_lowest_frequencies_of_a_fine_mesh_keep_their_precision():
    """A cantilever of 600 Hermite elements: the direct problem's ``f_1`` errs by 3.5e-5 of the closed form
    (eq. 4.5; ``eps w_max^2 / w_1^2``), the inverse one's, which :func:`undamped_frequencies_rad_s` takes at the low
    end, by under 2e-6; the highest frequencies are the direct problem's, unchanged."""
    from physics import properties
    from physics.beam import load_beam

    b = load_beam("beam5")
    m = b.fe_model(600)
    direct, _ = modal.undamped_modes(m.M, m.K)
    both = modal.undamped_frequencies_rad_s(m.M, m.K)
    closed = properties.cantilever_frequencies_hz(b.EI_Nm2, b.mass_per_length_kg_m, b.length_m,
                                                  properties.uniform_beta_l("clamped-free", 4))
    assert abs(direct[0] / (2 * np.pi) / closed[0] - 1) > 1e-5
    np.testing.assert_allclose(both[:4] / (2 * np.pi), closed, rtol=2e-6)
    np.testing.assert_array_equal(both[-10:], direct[-10:])
