"""Slit model: flexibility-exact slit elements, slit damping energy integrals, layered section, frequency shifts."""

import numpy as np
import pytest

from datagen.config import merge
from datagen.damage import element4_index
from datagen.damage.slit import clamped_flexibility, overlap_energy, slit_corrections, \
    stiffness_from_flexibility
from datagen.setup import get_setup
from physics.modal import undamped_modes
from datagen.damage.slit import slit_section_ei
from datagen.specimen import SectionLayout
from physics.properties import beam_preset
from physics.errors import ConfigError
from physics.effects import timoshenko_stiffness
from physics.fem import assemble, element_stiffness


def test_overlap_energy_whole_element_is_eq_3_9_and_splits_add():
    l = 0.03
    assert np.allclose(overlap_energy(0.0, 1.0, l), element_stiffness(1.0, l), rtol=1e-13, atol=1e-6)
    parts = overlap_energy(0.0, 0.37, l) + overlap_energy(0.37, 1.0, l)
    assert np.allclose(parts, overlap_energy(0.0, 1.0, l), rtol=1e-13, atol=1e-6)


@pytest.mark.parametrize("phi", [0.3, 10.8])   # 10.8: beam 5 with kGA = 27 100 N on the 20-element truth mesh
def test_timoshenko_overlap_energy_is_the_bending_part_of_the_element(phi):
    """EI G(whole element) + the shear energy of the constant shear strain of the interdependent interpolation
    (Friedman & Kosmatka 1993) gives physics.effects' Timoshenko element (G weights the slit damping)."""
    l, ei = 0.03, 22.674
    kga = 12 * ei / (phi * l**2)
    g = phi / (1 + phi) * np.array([-1 / l, -0.5, 1 / l, -0.5])       # gamma = w' - theta, DOFs [w1, t1, w2, t2]
    total = ei * overlap_energy(0.0, 1.0, l, phi) + kga * l * np.outer(g, g)
    np.testing.assert_allclose(total, timoshenko_stiffness(ei, kga, l), rtol=1e-12, atol=1e-9)


def _condensed_eb(ei_pieces, bounds):
    """End-node stiffness of one element made of EB sub-elements with constant EI on [bounds[i], bounds[i+1]]
    (nodal static condensation: exact for piecewise-constant EI with sub-element edges at the steps)."""
    ke = np.stack([element_stiffness(e, b - a) for e, a, b in zip(ei_pieces, bounds[:-1], bounds[1:])])
    k = assemble(ke)
    ends = [0, 1, k.shape[0] - 2, k.shape[0] - 1]
    inner = [i for i in range(k.shape[0]) if i not in ends]
    kbi = k[np.ix_(ends, inner)]
    return k[np.ix_(ends, ends)] - kbi @ np.linalg.solve(k[np.ix_(inner, inner)], kbi.T)


@pytest.mark.parametrize("phi", [0.0, 0.3, 10.8])   # 10.8: beam 5 with kGA = 27 100 N on the 20-element truth mesh
def test_uniform_flexibility_gives_the_project_elements(phi):
    l, ei = 0.03, 22.674
    k = stiffness_from_flexibility(clamped_flexibility(ei, l, phi), l)
    want = element_stiffness(ei, l) if phi == 0.0 else timoshenko_stiffness(ei, 12 * ei / (phi * l**2), l)
    np.testing.assert_allclose(k, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_slit_over_the_whole_element_scales_it_by_the_remaining_rigidity():
    L, ei, r = 0.03, 22.674, 0.63
    dK, _ = slit_corrections(np.array([[L / 2]]), np.array([[L]]), np.array([[r * ei]]), np.zeros((1, 1)),
                             np.array([ei]), L, 1)
    k0 = element_stiffness(ei, L)
    np.testing.assert_allclose(k0 + dK[0, 0], (1 - r) * k0, rtol=1e-12, atol=1e-12 * np.abs(k0).max())


def test_overlapping_slits_lose_the_deepest_rigidity_not_the_sum():
    L, n_el = 1.0, 1
    x, w = np.array([[0.4, 0.6]]), np.array([[0.4, 0.4]])         # [0.2, 0.6] and [0.4, 0.8] of the one element
    loss = np.array([[0.5, 0.9]])
    dK, _ = slit_corrections(x, w, loss, np.zeros((1, 2)), np.ones(1), L, n_el)
    want = _condensed_eb([1.0, 0.5, 0.1, 1.0], [0.0, 0.2, 0.4, 0.8, 1.0])
    np.testing.assert_allclose(element_stiffness(1.0, L) + dK[0, 0], want, rtol=1e-12, atol=1e-12)
    same, _ = slit_corrections(np.array([[0.5, 0.5]]), np.array([[0.2, 0.2]]), np.array([[0.9, 0.9]]),
                               np.zeros((1, 2)), np.ones(1), L, n_el)
    np.testing.assert_allclose(element_stiffness(1.0, L) + same[0, 0], _condensed_eb([1.0, 0.1, 1.0], [0, 0.4, 0.6, 1]),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("phi", [0.0, 10.8])
@pytest.mark.parametrize("x, w, r", [(0.2713, 0.0123, 0.7), (0.05, 0.002, 0.2), (0.6095 - 0.004, 0.02, 0.95)])
def test_cantilever_tip_deflection_with_a_slit_is_the_closed_form(phi, x, w, r):
    """Static tip load P on the clamped 20-element truth mesh: P L^3/(3 EI) + P L/kGA + P r/((1-r) EI) int (L-s)^2 ds
    over the slit (clipped to the beam), exact on any mesh; the second slit sits across an element edge."""
    L, n_el, ei, P = 0.6095, 20, 22.674, 1.7
    le = L / n_el
    kga = np.inf if phi == 0.0 else 12 * ei / (phi * le**2)
    k0 = np.broadcast_to(timoshenko_stiffness(ei, kga, le), (n_el, 4, 4))
    dK, _ = slit_corrections(np.array([[x]]), np.array([[w]]), np.array([[r * ei]]), np.zeros((1, 1)),
                             np.array([ei]), L, n_el, phi)
    K = assemble(k0 + dK[0])[2:, 2:]
    f = np.zeros(K.shape[0])
    f[-2] = P
    a, b = max(x - w / 2, 0.0), min(x + w / 2, L)
    want = P * L**3 / (3 * ei) + P * L / kga + P * r / ((1 - r) * ei) * ((L - a)**3 - (L - b)**3) / 3
    assert np.linalg.solve(K, f)[-2] == pytest.approx(want, rel=1e-10)


def test_section_matches_table_4_1_and_eq_4_1():
    p = beam_preset("beam5")
    lay = SectionLayout.matching(p.EI_Nm2, p.width_m, p.thickness_m, 0.0005, 1e8)
    assert lay.EI == pytest.approx(22.674, rel=1e-12)
    # eq. 4.1 written out by hand for face/core/face
    h2, c = p.thickness_m / 2, p.thickness_m / 2 - 0.0005
    by_hand = 2 * p.width_m / 3 * (1e8 * c**3 + lay.face_modulus_pa * (h2**3 - c**3))
    assert by_hand == pytest.approx(22.674, rel=1e-12)
    assert slit_section_ei(lay, 0.0) == pytest.approx(22.674, rel=1e-12)
    # a homogeneous section cut by d: E b (h-d)^3 / 12 (closed form, shifted neutral axis)
    hom = SectionLayout(0.05, 0.006, 0.001, 70e9, 70e9)
    assert slit_section_ei(hom, 0.0015) == pytest.approx(70e9 * 0.05 * 0.0045**3 / 12, rel=1e-12)
    loss = 1 - slit_section_ei(lay, np.array([0.0002, 0.0003])) / lay.EI
    assert np.all(np.diff(loss) > 0) and 0.1 < loss[0] < loss[1] < 0.5


def test_bad_section_names_key():
    with pytest.raises(ConfigError, match="section.face_thickness_m"):
        merge({"section": {"face_thickness_m": -1.0}})
    with pytest.raises(ConfigError, match="damage.depth_m"):
        merge({"damage": {"depth_m": [0.0003, 0.0002]}})
    with pytest.raises(ConfigError, match="damage.bogus"):
        merge({"damage": {"bogus": 1}})


def test_element4_index():
    assert list(element4_index(np.array([0.01, 0.16, 0.31, 0.6, np.nan]), 0.6095)) == [1, 2, 3, 4, 0]


@pytest.mark.parametrize("r", [0.01, 0.6])
def test_frequency_shift_follows_curvature_squared(r):
    """A narrow slit at x changes w_r^2 by -dEI/(1 - r) w kappa_r(x)^2 (mass-normalised modes; r = dEI/EI):
    the curvature-squared sensitivity, with the flexibility of the reduced section at finite depth."""
    setup = get_setup(merge({"specimen": {"root_spring_relative": []}}))
    L, n_el = setup.length_m, setup.n_elements
    le = L / n_el
    K0, M0 = 22.674 * setup.K0, 0.13 * setup.M0
    w, phi = undamped_modes(M0, K0)
    w2 = w**2
    full = np.zeros((2 * (n_el + 1), 4))
    full[setup.keep] = phi[:, :4]
    dEI, w = r * 22.674, 1e-4  # narrow slit: first order in its width
    xs = np.array([0.05, 0.1713, 0.3, 0.4444, 0.55])  # not on element boundaries
    actual, predicted = [], []
    for x in xs:
        dKe, _ = slit_corrections(np.array([[x]]), np.array([[w]]), np.array([[dEI]]), np.zeros((1, 1)),
                                  np.array([22.674]), L, n_el)
        dK = np.zeros((2 * (n_el + 1),) * 2)
        for e in range(n_el):
            dK[2 * e:2 * e + 4, 2 * e:2 * e + 4] += dKe[0, e]
        w2d = undamped_modes(M0, K0 + dK[np.ix_(setup.keep, setup.keep)])[0] ** 2
        e = int(x // le)
        xi = x / le - e
        B = np.array([-6 + 12 * xi, (-4 + 6 * xi) * le, 6 - 12 * xi, (-2 + 6 * xi) * le]) / le**2
        kappa = B @ full[2 * e:2 * e + 4]
        predicted.append(-dEI / (1 - r) * w * kappa**2)
        actual.append(w2d[:4] - w2[:4])
    actual, predicted = np.array(actual), np.array(predicted)
    scale = np.abs(predicted).max(axis=0)  # per mode, over positions
    assert np.all(np.abs(actual - predicted) <= 2e-3 * scale)
    # and the shift really varies with position (a constant would not pass)
    assert np.all(np.abs(predicted).min(axis=0) < 0.5 * scale)


def test_timoshenko_curvature_energy_plus_shear_energy_is_the_timoshenko_element():
    """Bending energy of the Timoshenko curvature field plus the (constant) shear energy equals
    physics.effects.timoshenko_stiffness; phi = 0 is the Hermite basis."""
    from datagen.damage.slit import curvature_basis

    l, ei, kga = 0.03, 26.7, 2.7e4
    phi = 12 * ei / (kga * l**2)
    _, b1 = curvature_basis(l, phi)
    gamma = -(ei / kga) * b1 / l                  # shear strain row: -EI/kGA d(kappa)/dx
    k = ei * overlap_energy(0.0, 1.0, l, phi) + kga * l * np.outer(gamma, gamma)
    np.testing.assert_allclose(k, timoshenko_stiffness(ei, kga, l), rtol=1e-12, atol=1e-9 * np.abs(k).max())
    assert np.abs(overlap_energy(0.0, 1.0, l, phi) * ei - element_stiffness(ei, l)).max() > 0.5 * np.abs(k).max()


def test_slit_corrections_with_a_shear_ratio_per_sample_are_the_scalar_ones():
    """A per-sample shear ratio (specimen.shear_flexibility) gives, sample by sample, the corrections of that
    sample's scalar ratio."""
    L, n_el = 0.6, 8
    phi = np.array([0.0, 0.3, 10.8])
    x, w = np.array([[0.21], [0.33], [0.5]]), np.array([[0.02], [0.05], [0.004]])
    loss, beta, ei = np.array([[5.0], [12.0], [20.0]]), np.array([[1e-5], [0.0], [2e-5]]), np.array([22., 25., 27.])
    dK, dC = slit_corrections(x, w, loss, beta, ei, L, n_el, phi)
    for b in range(3):
        dKb, dCb = slit_corrections(x[b:b + 1], w[b:b + 1], loss[b:b + 1], beta[b:b + 1], ei[b:b + 1], L, n_el,
                                    float(phi[b]))
        np.testing.assert_allclose(dK[b], dKb[0], rtol=1e-12, atol=1e-12 * np.abs(dKb).max())
        np.testing.assert_allclose(dC[b], dCb[0], rtol=1e-12, atol=1e-12 * np.abs(dCb).max() + 1e-300)
    euler, _ = slit_corrections(x, w, loss, beta, ei, L, n_el, 0.0)
    assert np.abs(dK[2] - euler[2]).max() > 0.1 * np.abs(euler[2]).max()  # the ratio matters


def test_each_kind_describes_its_damage_for_the_verdict():
    """The verdict's prose comes from the kind: a slit of the hinge flexibility of a 0.25 mm cut 5.5 mm wide is
    described with that depth (the layered section inverted), a mass change by its sign and share of the mass."""
    from datagen.config import DEFAULTS
    from datagen.damage import DAMAGE_MODELS
    from datagen.damage.slit import hinge_flexibility

    from physics.properties import beam_preset

    p, sec = beam_preset("beam5"), DEFAULTS["section"]
    lay = SectionLayout.matching(p.EI_Nm2, p.width_m, p.thickness_m, sec["face_thickness_m"], sec["core_modulus_pa"])
    theta = float(hinge_flexibility(1 - slit_section_ei(lay, 0.00025) / lay.EI, 0.0055, p.length_m))
    text = DAMAGE_MODELS["slit"].describe(0.1524, theta, "beam5", section=DEFAULTS["section"])
    assert text == f"a slit at x = 0.152 m of hinge flexibility EI/(k L) = {theta:.3g} (e.g. 0.25 mm deep over 5.5 mm)"
    assert DAMAGE_MODELS["slit"].describe(0.3, 1e3, "beam5", section=DEFAULTS["section"]).endswith("= 1e+03")
    assert DAMAGE_MODELS["mass_change"].describe(0.3, -0.0125, "beam5") == \
        "a mass lost at x = 0.300 m of 1.25% of the beam's mass"
    assert DAMAGE_MODELS["mass_change"].describe(0.61, 0.004, "beam5").startswith("a mass added at x = 0.610 m")


def test_equivalent_depth_inverts_the_layered_section():
    from datagen.config import DEFAULTS
    from datagen.damage.slit import equivalent_depth, slit_section_ei
    from datagen.specimen import SectionLayout

    p = beam_preset("beam5")
    lay = SectionLayout.matching(p.EI_Nm2, p.width_m, p.thickness_m, DEFAULTS["section"]["face_thickness_m"],
                                 DEFAULTS["section"]["core_modulus_pa"])
    r = 1 - float(slit_section_ei(lay, 0.00025)) / lay.EI
    theta = 0.005 * r / ((1 - r) * p.length_m)
    assert equivalent_depth(theta, "beam5", 0.005, DEFAULTS["section"]) == pytest.approx(0.00025, rel=1e-3)
    assert equivalent_depth(1e3, "beam5", 0.005, DEFAULTS["section"]) is None
