import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import modal, thesis, updating
from physics.errors import BeamDamageError, ConvergenceError, OverdampedError, ShapeError
from systems import random_system


_fixture = thesis.load


def _c(vals):
    return np.array([[complex(v) for v in row] for row in vals]) if isinstance(vals[0], list) else \
        np.array([complex(v) for v in vals])


def test_example_1_iterates_to_the_printed_decimals():
    ex = _fixture("example1_two_dof")
    res = updating.pilkey(np.array(ex["M"], float), _c(ex["eigenvalues"]), _c(ex["eigenvectors"]),
                          tol=1e-13, keep_history=True)
    for k, printed in ex["C_iterates"].items():
        np.testing.assert_array_equal(np.round(res.history[int(k)], 4) + 0.0, printed)
    np.testing.assert_allclose(res.K, ex["K_identified"], atol=5e-5)
    assert res.converged and res.history.shape == (res.iterations + 1, 2, 2)


def test_eigenvalue_check_accepts_real_normal_modes_and_rejects_inconsistent_real_shapes():
    """Real shapes are valid input when they are normal modes of a proportionally damped system (Example 1):
    Pilkey's eq. 5.2 supplies the complex scale, and the updated model reproduces the eigenvalues the
    thesis prints; the real parts of beam 5's measured complex shapes are no such modes and miss by far."""
    from physics.beam import load_beam
    from physics.io import modal_data_from_dict

    ex = _fixture("example1_two_dof")
    M = np.array(ex["M"], float)
    res = updating.pilkey(M, _c(ex["eigenvalues"]), _c(ex["eigenvectors"]), tol=1e-13)
    err, lam = updating.eigenvalue_errors(M, res.C, res.K, _c(ex["eigenvalues"]))
    # the true system's eigenvalues, computed independently, printed to 5 significant digits
    true = np.sort_complex(modal.complex_modes(M, np.array(ex["C_true"]), np.array(ex["K_true"])).eigenvalues)
    np.testing.assert_allclose(np.sort_complex(lam), true, rtol=5e-5)
    assert err.max() < 5e-5
    d = modal_data_from_dict(thesis.beam_state("undamaged"))
    b = load_beam("beam5")
    m = b.fe_model()
    Mb = updating.reduced_mass(m.M, m.K, m.index(b.masters))
    good = updating.pilkey(Mb, d.eigenvalues, d.eigenvectors)
    assert updating.eigenvalue_errors(Mb, good.C, good.K, d.eigenvalues)[0].max() < updating.REPRODUCTION_TOL
    bad = updating.pilkey(Mb, d.eigenvalues, d.eigenvectors.real.astype(complex))
    assert updating.eigenvalue_errors(Mb, bad.C, bad.K, d.eigenvalues)[0].max() > updating.REFUSAL_TOL


def test_example_2_iterates_within_a_thousandth():
    ex = _fixture("example2_ortiz_beam")
    M, C, K = (np.array(ex[k], float) for k in ("M", "C_reference", "K"))
    cm = modal.complex_modes(M, C, K)
    res = updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, tol=1e-13, keep_history=True)
    for k in ("1", "5", "15", "20"):  # C10 has a printed asymmetric entry, checked in validate
        np.testing.assert_allclose(res.history[int(k)], ex["C_iterates"][k], atol=1e-3)
    np.testing.assert_allclose(res.C, C, rtol=1e-8, atol=1e-10)  # exact modes -> exact C
    np.testing.assert_allclose(res.K, ex["K_identified_iter20"], rtol=1e-3, atol=1.0)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 12), seed=st.integers(0, 2**31), zeta=st.floats(0.001, 0.005))
def test_pilkey_recovers_random_lightly_damped_non_proportional_systems(n, seed, zeta):
    M, C, K = random_system(n, seed, damping=zeta)
    cm = modal.complex_modes(M, C, K)
    rng = np.random.default_rng(seed)
    scaled = cm.eigenvectors * (rng.uniform(0.5, 2, n) * np.exp(1j * rng.uniform(0, 6, n)))  # any scaling
    res = updating.pilkey(M, cm.eigenvalues, scaled, tol=1e-13, max_iter=5000)
    assert np.linalg.norm(res.C - C) <= 1e-8 * np.linalg.norm(C)
    assert np.linalg.norm(res.K - K) <= 1e-8 * np.linalg.norm(K)


def test_lancaster_formulas_are_exact_with_the_true_normalisation():
    M, C, K = random_system(5, seed=11)
    cm = modal.complex_modes(M, C, K)
    np.testing.assert_allclose(updating.lancaster_damping(M, cm.eigenvalues, cm.eigenvectors), C, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(updating.lancaster_stiffness(cm.eigenvalues, cm.eigenvectors), K, rtol=1e-9)


def test_batched_pilkey_equals_single_and_flags_each_member():
    systems = [random_system(4, seed=s) for s in range(3)]
    M, C, K = (np.stack(x) for x in zip(*systems))
    cm = modal.complex_modes(M, C, K)
    res = updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, tol=1e-12)
    assert res.converged.shape == (3,) and res.converged.all()
    for i in range(3):
        one = updating.pilkey(M[i], cm.eigenvalues[i], cm.eigenvectors[i], tol=1e-12)
        np.testing.assert_allclose(res.K[i], one.K, rtol=1e-9)


def test_inputs_it_cannot_handle_are_rejected():
    M, C, K = random_system(3, seed=0)
    cm = modal.complex_modes(M, C, K)
    lam, phi = cm.eigenvalues, cm.eigenvectors
    with pytest.raises(OverdampedError, match="real eigenvalue"):
        updating.pilkey(M, lam.real + 0j, phi)
    with pytest.raises(OverdampedError, match="conjugate"):
        updating.pilkey(M, np.array([lam[0], np.conj(lam[0]), lam[2]]), phi)
    with pytest.raises(ShapeError, match="one eigenvalue per DOF"):
        updating.pilkey(M, lam[:2], phi[:, :2])
    with pytest.raises(ShapeError, match="eigenvectors must be 3x3"):
        updating.pilkey(M, lam, phi[:2])
    with pytest.raises(ShapeError, match="NaN"):
        updating.pilkey(M, lam, np.where(np.eye(3, dtype=bool), np.nan, phi))


def test_non_convergence_is_reported_not_hidden():
    M, C, K = random_system(4, seed=5)
    cm = modal.complex_modes(M, C, K)
    with pytest.raises(ConvergenceError, match="did not converge after 3 iterations"):
        updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, max_iter=3)
    res = updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, max_iter=3, raise_on_failure=False)
    assert res.converged is False and res.residual > 1e-10


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 12), seed=st.integers(0, 2**31), zeta=st.floats(0.001, 0.2))
def test_direct_scaling_recovers_random_systems_at_any_damping(n, seed, zeta):
    M, C, K = random_system(n, seed, damping=zeta)
    cm = modal.complex_modes(M, C, K)
    res = updating.lancaster_direct(M, cm.eigenvalues, cm.eigenvectors * 3.0)
    assert res.residual < 1e-10
    assert np.linalg.norm(res.C - C) <= 1e-8 * np.linalg.norm(C)
    assert np.linalg.norm(res.K - K) <= 1e-8 * np.linalg.norm(K)


def test_spurious_pilkey_fixed_point_is_detected_not_returned():
    # found by the property test: at ~3.5 % non-proportional damping the true C is an unstable fixed point
    M, C, K = random_system(9, 9, damping=0.03125)
    cm = modal.complex_modes(M, C, K)
    with pytest.raises(ConvergenceError, match="spurious fixed point"):
        updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, tol=1e-13, max_iter=5000)
    flagged = updating.pilkey(M, cm.eigenvalues, cm.eigenvectors, tol=1e-13, max_iter=5000, raise_on_failure=False)
    assert flagged.converged is False and np.linalg.norm(flagged.C - C) > 0.1 * np.linalg.norm(C)
    assert updating.orthogonality_misfit(M, cm.eigenvalues, flagged.eigenvectors) > 0.1
    assert updating.orthogonality_misfit(M, cm.eigenvalues, cm.eigenvectors) < 1e-12


def test_batched_pilkey_keeps_members_independent():
    good = random_system(4, seed=1)
    cm = modal.complex_modes(*good)
    lam = np.stack([cm.eigenvalues, cm.eigenvalues])
    phi = np.stack([cm.eigenvectors, np.full((4, 4), 1e200 + 0j)])  # second member overflows
    M = np.stack([good[0], good[0]])
    res = updating.pilkey(M, lam, phi, tol=1e-12, raise_on_failure=False)
    assert res.converged.tolist() == [True, False]
    assert np.isnan(res.C[1]).all()
    np.testing.assert_allclose(res.C[0], updating.pilkey(good[0], cm.eigenvalues, cm.eigenvectors, tol=1e-12).C)


def test_analyst_mass_iirs_equals_a_direct_iirs_of_each_specimen_and_table_4_1(beam5, beam5_data):
    from physics import fem, reduction

    mpl = beam5.mass_per_length_kg_m * np.array([0.9, 1.0, 1.15])
    Ma = updating.analyst_mass(mpl, beam5.length_m, "iirs")
    assert Ma.shape == (3, 4, 4)
    for i, (m, ei) in enumerate(zip(mpl, (18.0, beam5.EI_Nm2, 30.0))):  # EI must not matter
        model = fem.beam_model(4, beam5.length_m, ei, m)
        direct = reduction.iirs(model.M, model.K, model.index(beam5.masters)).M
        np.testing.assert_allclose(Ma[i], direct, rtol=1e-9, atol=1e-12 * np.abs(direct).max())
    printed = np.array(beam5_data["iirs_reduced"]["M"])
    assert np.linalg.norm(Ma[1] - printed) / np.linalg.norm(printed) < 1e-3
    np.testing.assert_array_equal(updating.analyst_mass(mpl, beam5.length_m, "reduced"), Ma)  # old spelling


def test_analyst_mass_lumped_is_eq_4_6_and_unknown_names_are_named(beam5):
    M = updating.analyst_mass(beam5.mass_per_length_kg_m, beam5.length_m, "lumped")
    c = beam5.mass_per_length_kg_m * beam5.length_m / 4 / 420
    np.testing.assert_allclose(M, c * np.array([[312, 54, 0, 0], [54, 312, 54, 0], [0, 54, 312, 54], [0, 0, 54, 156]]),
                               rtol=1e-14)
    with pytest.raises(BeamDamageError, match="mass_model 'consistent'"):
        updating.analyst_mass(1.0, 1.0, "consistent")


def test_reduced_mass_of_a_non_uniform_model_is_its_iirs_mass_and_partition():
    from physics import fem, reduction

    f = np.array([1.0, 0.7, 1.3, 1.1])
    model = fem.beam_model(4, 0.6, 20.0, 0.13, mass_factors=f)
    masters = model.index(["2:y", "3:y", "4:y", "5:y"])
    direct = reduction.iirs(model.M, model.K, masters).M
    np.testing.assert_allclose(updating.reduced_mass(model.M, model.K, masters), direct, rtol=1e-12)
    np.testing.assert_array_equal(updating.reduced_mass(model.M, model.K, masters, "lumped"),
                                  model.M[np.ix_(masters, masters)])
    uniform = fem.beam_model(4, 0.6, 20.0, 0.13)
    np.testing.assert_allclose(updating.reduced_mass(uniform.M, uniform.K, masters, "lumped"),
                               updating.analyst_mass(0.13, 0.6, "lumped"), rtol=1e-14)


@pytest.mark.parametrize("method", ["pilkey", "direct"])
def test_any_column_scaling_of_the_modes_gives_the_same_model(method):
    """Modes have arbitrary scale: columns of 1e-200 and 1e+90 (whose products leave float range) update alike."""
    M, C, K = random_system(4, seed=3)
    cm = modal.complex_modes(M, C, K)
    scaled = cm.eigenvectors * np.array([1e-200, 1.0, 1e90, 3e-150j])
    run = (lambda p: updating.pilkey(M, cm.eigenvalues, p, tol=1e-13)) if method == "pilkey" else \
        (lambda p: updating.lancaster_direct(M, cm.eigenvalues, p))
    res = run(scaled)
    np.testing.assert_allclose(res.C, C, rtol=1e-7, atol=1e-9 * np.abs(C).max())
    np.testing.assert_allclose(res.K, K, rtol=1e-9)


@pytest.mark.parametrize("method", ["pilkey", "direct"])
def test_linearly_dependent_modes_are_a_shape_error_not_a_linalg_error(method):
    M, C, K = random_system(4, seed=3)
    cm = modal.complex_modes(M, C, K)
    phi = cm.eigenvectors.copy()
    phi[:, 2] = 2.5j * phi[:, 0]                       # mode 3 a multiple of mode 1
    assert updating.eigenvector_condition(phi) > 1e15 and updating.eigenvector_condition(cm.eigenvectors) < 1e3
    fit = updating.pilkey if method == "pilkey" else updating.lancaster_direct
    with pytest.raises(ShapeError, match="linearly dependent"):
        fit(M, cm.eigenvalues, phi)


def test_batched_pilkey_flags_a_dependent_member_and_keeps_the_other():
    M, C, K = random_system(4, seed=5)
    cm = modal.complex_modes(M, C, K)
    ones = np.ones((4, 4), complex)                     # rank 1
    res = updating.pilkey(np.stack([M, M]), np.stack([cm.eigenvalues] * 2), np.stack([ones, cm.eigenvectors]),
                          tol=1e-12, raise_on_failure=False)
    assert res.converged.tolist() == [False, True]
    assert np.isnan(res.C[0]).all() and np.isnan(res.K[0]).all()
    np.testing.assert_allclose(res.K[1], K, rtol=1e-8)


def test_lancaster_stiffness_is_nan_where_the_flexibility_is_singular():
    M, C, K = random_system(3, seed=2)
    cm = modal.complex_modes(M, C, K)
    phi_n = cm.eigenvectors
    out = updating.lancaster_stiffness(np.stack([cm.eigenvalues] * 2), np.stack([phi_n, np.zeros_like(phi_n)]))
    np.testing.assert_allclose(out[0], K, rtol=1e-9)
    assert np.isnan(out[1]).all()
