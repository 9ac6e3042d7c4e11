import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss

from physics import fem, modal, properties
from physics.errors import BeamDamageError


def _shape_functions(x, l):
    """Hermite shape functions of eq. 3.5 and their second derivatives."""
    xi = x / l
    n = np.array([1 - 3 * xi**2 + 2 * xi**3, l * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, l * (-xi**2 + xi**3)])
    d2 = np.array([(-6 + 12 * xi) / l**2, (-4 + 6 * xi) / l, (6 - 12 * xi) / l**2, (-2 + 6 * xi) / l])
    return n, d2


def test_element_matrices_equal_the_energy_integrals_eqs_3_6_3_7():
    l, m, ei = 0.37, 1.3, 25.0
    g, wg = leggauss(6)
    x = 0.5 * l * (g + 1)
    n, d2 = _shape_functions(x, l)
    M_int = m * 0.5 * l * np.einsum("iq,jq,q->ij", n, n, wg)
    K_int = ei * 0.5 * l * np.einsum("iq,jq,q->ij", d2, d2, wg)
    np.testing.assert_allclose(fem.element_mass(m, l), M_int, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(fem.element_stiffness(ei, l), K_int, rtol=1e-12, atol=1e-10)


@pytest.mark.parametrize(
    "bc, beta_l",
    [
        ("clamped-free", [1.8751040687, 4.6940911330, 7.8547574382]),
        ("pinned-pinned", [np.pi, 2 * np.pi, 3 * np.pi]),
        ("clamped-clamped", [4.7300407449, 7.8532046241, 10.9956078380]),
        ("free-free", [4.7300407449, 7.8532046241, 10.9956078380]),
    ],
)
def test_fine_mesh_converges_to_closed_form(bc, beta_l):
    L, EI, m = 0.8, 30.0, 0.4
    model = fem.beam_model(40, L, EI, m, bc=bc)
    w, _ = modal.undamped_modes(model.M, model.K)
    if bc == "free-free":
        assert np.all(np.abs(w[:2]) < 1e-3 * w[2])  # two rigid-body modes
        w = w[2:]
    exact = np.array(beta_l) ** 2 / L**2 * np.sqrt(EI / m)
    np.testing.assert_allclose(w[:3], exact, rtol=1e-5)
    assert np.all(w[:3] >= exact * (1 - 1e-9))  # consistent-mass FE bounds from above


def test_dofs_are_named_and_bcs_remove_the_right_ones():
    model = fem.beam_model(4, 0.6095, 22.674, 0.13)
    assert model.dofs == ("2:y", "2:rz", "3:y", "3:rz", "4:y", "4:rz", "5:y", "5:rz")
    assert model.translations() == ("2:y", "3:y", "4:y", "5:y")
    np.testing.assert_array_equal(model.index(["5:y", "2:y"]), [6, 0])
    with pytest.raises(BeamDamageError, match="1:y"):
        model.index(["1:y"])
    assert fem.beam_model(2, 1.0, 1.0, 1.0, bc="pinned-pinned").dofs == ("1:rz", "2:y", "2:rz", "3:rz")


def test_stiff_root_spring_tends_to_the_clamp_and_soft_spring_lowers_frequencies():
    clamped = fem.beam_model(8, 0.6, 22.0, 0.13)
    w_c, _ = modal.undamped_modes(clamped.M, clamped.K)
    stiff = fem.beam_model(8, 0.6, 22.0, 0.13, root_spring=1e9)
    w_s, _ = modal.undamped_modes(stiff.M, stiff.K)
    np.testing.assert_allclose(w_s[:4], w_c[:4], rtol=1e-6)
    assert np.all(w_s[:4] < w_c[:4])  # any finite spring is softer than the clamp
    soft = fem.beam_model(8, 0.6, 22.0, 0.13, root_spring=50.0)
    w_f, _ = modal.undamped_modes(soft.M, soft.K)
    assert w_f[0] < 0.9 * w_c[0]
    # a rigid bar on a rotational spring: w^2 = k_r / (m L^3 / 3) when EI -> infinity
    rigid = fem.beam_model(8, 0.6, 1e5, 0.13, root_spring=50.0)  # beam modes far above
    w_r, _ = modal.undamped_modes(rigid.M, rigid.K)
    np.testing.assert_allclose(w_r[0] ** 2, 50.0 / (0.13 * 0.6**3 / 3), rtol=2e-4)


def test_batched_assembly_equals_one_model_at_a_time():
    rng = np.random.default_rng(0)
    factors = rng.uniform(0.5, 1.0, size=(3, 5))
    ei = np.array([20.0, 22.0, 24.0])
    batch = fem.beam_model(5, 0.6, ei, 0.13, ei_factors=factors, damping_factors=1e-4 * factors)
    for i in range(3):
        one = fem.beam_model(5, 0.6, ei[i], 0.13, ei_factors=factors[i], damping_factors=1e-4 * factors[i])
        np.testing.assert_allclose(batch.K[i], one.K, rtol=1e-14)
        np.testing.assert_allclose(batch.C[i], one.C, rtol=1e-14)
        np.testing.assert_allclose(batch.M[i], one.M, rtol=1e-14)


def test_element_factor_scales_only_that_element():
    base = fem.beam_model(4, 0.6, 20.0, 0.1)
    f = np.array([1.0, 0.5, 1.0, 1.0])
    damaged = fem.beam_model(4, 0.6, 20.0, 0.1, ei_factors=f)
    ke = fem.element_stiffness(20.0, 0.15)
    diff = base.K - damaged.K
    # element 2 joins nodes 2 and 3 = free DOFs 0..3
    np.testing.assert_allclose(diff[:4, :4], 0.5 * ke, rtol=1e-12)
    assert np.allclose(diff[4:, :], 0)


def test_lumped_mass_is_eq_4_6_and_the_translation_partition_of_the_consistent_mass():
    p = properties.beam_preset("beam5")
    le = p.length_m / 4
    M = fem.lumped_mass(p.mass_per_length_kg_m, le)
    c = p.mass_per_length_kg_m * le / 420
    np.testing.assert_allclose(M, c * np.array([[312, 54, 0, 0], [54, 312, 54, 0], [0, 54, 312, 54], [0, 0, 54, 156]]))
    model = fem.beam_model(4, p.length_m, p.EI_Nm2, p.mass_per_length_kg_m)
    idx = model.index(p.masters)
    np.testing.assert_allclose(M, model.M[np.ix_(idx, idx)], rtol=1e-14)
    np.testing.assert_allclose(M[0, 1], 2.537e-3, rtol=5e-4)  # the thesis's printed off-diagonal


def test_bad_arguments_raise_clear_errors():
    with pytest.raises(BeamDamageError, match="'bc' = 'fixed' unknown"):
        fem.beam_model(4, 1.0, 1.0, 1.0, bc="fixed")
    with pytest.raises(BeamDamageError, match="positive"):
        fem.beam_model(4, 1.0, -1.0, 1.0)
    with pytest.raises(BeamDamageError, match="root rotational spring"):
        fem.beam_model(4, 1.0, 1.0, 1.0, bc="free-free", root_spring=10.0)


@pytest.mark.parametrize("bc, spring, expected", [
    ("clamped-free", False, ["2:y", "2:rz", "3:y", "3:rz"]),
    ("clamped-free", True, ["1:rz", "2:y", "2:rz", "3:y", "3:rz"]),
    ("free-free", False, ["1:y", "1:rz", "2:y", "2:rz", "3:y", "3:rz"]),
    ("pinned-pinned", False, ["1:rz", "2:y", "2:rz", "3:rz"]),
    ("clamped-clamped", False, ["2:y", "2:rz"]),
])
def test_kept_dofs_indices_and_names(bc, spring, expected):
    keep = fem.kept_dofs(3, bc, root_spring=spring)
    all_names = ["1:y", "1:rz", "2:y", "2:rz", "3:y", "3:rz"]
    assert list(keep.names) == expected
    assert [all_names[i] for i in keep.indices] == expected
    model = fem.beam_model(2, 1.0, 1.0, 1.0, bc=bc, root_spring=5.0 if spring else None)
    assert model.dofs == keep.names and model.K.shape == (len(expected),) * 2
