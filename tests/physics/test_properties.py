import numpy as np
import pytest

from physics import fem, modal, properties
from physics.errors import BeamDamageError


def test_closed_form_frequencies_reproduce_table_4_2(beam5, beam5_data):
    f = properties.cantilever_frequencies_hz(beam5.EI_Nm2, beam5.mass_per_length_kg_m, beam5.length_m)
    np.testing.assert_allclose(f, beam5_data["theoretical_frequencies_hz"], rtol=1e-3)


def test_exact_beta_l_agrees_with_the_thesis_digits():
    np.testing.assert_allclose(properties.cantilever_beta_l(4), properties.THESIS_BETA_L, atol=6e-5)
    bl = properties.cantilever_beta_l(6)
    np.testing.assert_allclose(np.cos(bl) * np.cosh(bl), -1.0, atol=1e-9)


def test_static_test_recovers_ei_and_r_squared():
    EI, x, a = 22.674, 0.5, 0.6
    loads = np.linspace(0.5, 5.0, 10)
    defl = loads * x**2 * (3 * a - x) / (6 * EI)  # eq. 4.2
    res = properties.equivalent_ei(loads, defl, x, a)
    assert res.EI_Nm2 == pytest.approx(EI, rel=1e-12)
    assert res.r_squared == pytest.approx(1.0, abs=1e-12)
    noisy = properties.equivalent_ei(loads, defl * (1 + 0.02 * np.sin(np.arange(10))), x, a)
    assert 0.99 < noisy.r_squared < 1.0
    with pytest.raises(BeamDamageError):
        properties.equivalent_ei(loads, defl, 0.7, 0.6)


def test_layered_ei_homogeneous_and_sandwich():
    b, h, E = 0.05, 0.01, 70e9
    assert properties.layered_ei(b, [0, h / 2], [E]) == pytest.approx(E * b * h**3 / 12, rel=1e-13)
    # the general form equals eq. 4.1 for a symmetric sandwich ...
    sym = properties.layered_ei(b, [0, 0.003, 0.0035], [1e8, 60e9])
    gen = properties.section_ei(b, [0, 0.0005, 0.0065], [0.0005, 0.0065, 0.007], [60e9, 1e8, 60e9])
    assert gen == pytest.approx(sym, rel=1e-12)
    # ... and a thinner top face lowers EI
    cut = properties.section_ei(b, [0, 0.0005, 0.0065], [0.0005, 0.0065, 0.0068], [60e9, 1e8, 60e9])
    assert cut < 0.8 * gen


def test_unknown_preset():
    with pytest.raises(BeamDamageError, match="beam5"):
        properties.beam_preset("beam7")


@pytest.mark.parametrize("mode", [0, 1, 2, 3, 5])
def test_cantilever_curvature_is_normalised_and_clamped_root_value(mode):
    L = 0.6095
    x = np.linspace(0.0, L, 200001)
    k2 = properties.cantilever_curvature_squared(x, L, mode)
    assert np.trapezoid(k2, x) == pytest.approx(1.0, rel=1e-6)  # quadrature, independent of the closed form
    assert k2[0] == pytest.approx(4.0 / L, rel=1e-9)            # phi''(0) = 2 b^2, int phi''^2 = b^4 L
    assert k2[-1] == pytest.approx(0.0, abs=1e-6 / L)            # free end: no moment


def test_cantilever_curvature_predicts_fe_element_strain_energy_fractions():
    # first-order sensitivity of a fine FE cantilever: element share of the modal strain energy
    n_el, L = 120, 0.6
    model = fem.beam_model(n_el, L, 1.0, 1.0)
    w, phi = modal.undamped_modes(model.M, model.K)
    full = np.zeros((2 * (n_el + 1), phi.shape[1]))
    full[2:] = phi
    ke = fem.element_stiffness(1.0, L / n_el)
    for mode in range(3):
        energy = np.array([full[2 * e:2 * e + 4, mode] @ ke @ full[2 * e:2 * e + 4, mode] for e in range(n_el)])
        x_mid = (np.arange(n_el) + 0.5) * L / n_el
        pred = properties.cantilever_curvature_squared(x_mid, L, mode) * L / n_el
        np.testing.assert_allclose(energy / energy.sum(), pred, atol=2e-3 * pred.max())


def test_beam_preset_unit_names():
    p = properties.beam_preset("beam5")
    assert (p.length_m, p.total_length_m) == (0.6095, 1.219)
    assert p.mass_per_length_kg_m == pytest.approx(0.15792 / 1.219)
    assert not hasattr(p, "EI") and not hasattr(p, "m_per_length")


@pytest.mark.parametrize(("bc", "rigid"), [("clamped-free", 0), ("free-free", 2), ("pinned-pinned", 0),
                                           ("clamped-clamped", 0)])
def test_curvature_squared_of_every_support_predicts_fe_strain_energy_fractions(bc, rigid):
    """Element shares of the modal strain energy of a fine FE beam (an independent computation) against the closed
    form at modes 1, 2 and 8; the closed form integrates to 1 (quadrature) up to mode 12, where cosh and sinh of
    beta L ~ 40 would cancel to nothing in the textbook form."""
    _check_against_fe(bc, rigid)


def _check_against_fe(bc: str, rigid: int):
    """A fine FE beam's element strain-energy shares at modes 1, 2 and 8 against the closed form; the closed form
    integrates to 1 (quadrature) at modes 1, 6 and 12."""
    n_el, L = 160, 0.8
    model = fem.beam_model(n_el, L, 1.0, 1.0, bc=bc)
    w, phi = modal.undamped_modes(model.M, model.K)
    index = {d: i for i, d in enumerate(model.dofs)}
    full = np.zeros((2 * (n_el + 1), phi.shape[1]))
    for j, name in enumerate(fem.dof_names(n_el + 1)):
        if name in index:
            full[j] = phi[index[name]]
    ke = fem.element_stiffness(1.0, L / n_el)
    x_mid = (np.arange(n_el) + 0.5) * L / n_el
    for mode in (0, 1, 7):
        v = full[2 * np.arange(n_el)[:, None] + np.arange(4)[None, :], rigid + mode]      # (n_el, 4)
        energy = np.einsum("ei,ij,ej->e", v, ke, v)
        pred = properties.curvature_squared(x_mid, L, mode, bc) * L / n_el
        np.testing.assert_allclose(energy / energy.sum(), pred, atol=3e-3 * pred.max())
    x = np.linspace(0.0, L, 400001)
    for mode in (0, 5, 11):
        assert np.trapezoid(properties.curvature_squared(x, L, mode, bc), x) == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize("ends", [("clamped", "pinned"), ("pinned", "clamped")])
def test_a_support_added_with_other_ends_gets_its_own_curvature(monkeypatch, ends):
    """A clamped-pinned support (and its mirror) registered in SUPPORTS: beta L from tan = tanh (3.9266, 7.0686,
    10.2102, 13.3518), and the closed form predicts a fine FE beam's element strain-energy shares (the FE holds the
    DOFs the record's ends name: an independent computation), integrating to 1 up to mode 12."""
    import dataclasses

    from physics import supports

    name = "-".join(ends)
    record = dataclasses.replace(supports.SUPPORTS["clamped-clamped"], name=name, ends=ends)
    monkeypatch.setitem(supports.SUPPORTS, name, record)
    np.testing.assert_allclose(properties.clamped_pinned_beta_l(4), [3.9266, 7.0686, 10.2102, 13.3518], atol=1e-4)
    _check_against_fe(name, 0)


def test_a_support_whose_ends_have_no_closed_form_is_refused(monkeypatch):
    """A pinned-free record (a mechanism) is not read as pinned-pinned: one line naming its ends."""
    import dataclasses

    from physics import supports
    from physics.errors import BeamDamageError

    record = dataclasses.replace(supports.SUPPORTS["pinned-pinned"], name="pinned-free", ends=("pinned", "free"))
    monkeypatch.setitem(supports.SUPPORTS, "pinned-free", record)
    with pytest.raises(BeamDamageError, match="no closed-form curvature for ends pinned-free"):
        properties.curvature_squared(0.1, 1.0, 0, "pinned-free")
