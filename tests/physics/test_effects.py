"""Effects against closed-form frequency equations solved here by root finding (independent of the FE code).

* Timoshenko cantilever: the two coupled ODEs
  ``kGA (w'' - psi') + rho A w^2 w = 0`` and ``EI psi'' + kGA (w' - psi) + rho I w^2 psi = 0``,
  general solution ``cosh, sinh (alpha x), cos, sin (beta x)`` below the cut-off
  frequency, clamped at 0 (``w = psi = 0``), free at L (``psi' = 0``, ``w' - psi = 0``).
* Tip mass (Blevins, Table 8-1 case 4 form):
  ``1 + cos bL cosh bL + mu bL (cos bL sinh bL - sin bL cosh bL) = 0``, ``mu = M_tip / (m L)``.
* Root springs: Euler-Bernoulli beam with ``EI w''(0) = k_theta w'(0)``, ``EI w'''(0) = -k_y w(0)``, free tip.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from physics import modal, properties
from physics.beam import load_beam
from physics.effects import (assemble_beam, hermite_row, interpolation_matrix, timoshenko_mass,
                             timoshenko_stiffness, validate_effects)
from physics.errors import ConfigError
from physics.fem import element_mass, element_stiffness

L, EI, M_PER_L, H = 0.6095, 22.674, 0.15792 / 1.219, 0.007264


def _roots(fun, omega_max, n, grid=20000):
    w = np.linspace(1e-3, omega_max, grid)
    v = np.array([fun(x) for x in w])
    idx = np.nonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)[0]
    roots = [brentq(fun, w[i], w[i + 1], xtol=1e-12) for i in idx]
    # drop poles (sign changes through infinity): keep points where |f| is small relative to neighbours
    roots = [r for r, i in zip(roots, idx) if abs(fun(r)) < 1e-6 * (abs(v[i]) + abs(v[i + 1]) + 1e-300)]
    return np.array(roots[:n])


def timoshenko_cantilever_rad_s(EI, kGA, rhoA, rhoI, L, n=4, omega_max=2.5e4):
    def det(w):
        c = rhoA * w**2 / kGA
        a4, a2, a0 = EI * kGA, kGA * rhoI * w**2 + rhoA * w**2 * EI, rhoA * w**2 * (rhoI * w**2 - kGA)
        disc = np.sqrt(a2**2 - 4 * a4 * a0)
        al = np.sqrt((-a2 + disc) / (2 * a4))       # lambda^2 = +al^2
        be = np.sqrt((a2 + disc) / (2 * a4))        # lambda^2 = -be^2
        ca, cb = (al**2 + c) / al, (c - be**2) / be
        x = L
        # columns: cosh, sinh, cos, sin; rows: w(0), psi(0), psi'(L), w'(L) - psi(L)
        w0 = [1, 0, 1, 0]
        p0 = [0, ca, 0, -cb]
        dp = [ca * al * np.cosh(al * x), ca * al * np.sinh(al * x), cb * be * np.cos(be * x), cb * be * np.sin(be * x)]
        # (w' - psi) / c, with al - ca = -c/al and be + cb = c/be written out (no cancellation as kGA -> inf)
        sh = [-np.sinh(al * x) / al, -np.cosh(al * x) / al, -np.sin(be * x) / be, np.cos(be * x) / be]
        A = np.array([w0, p0, dp, sh], dtype=float)
        return np.linalg.det(A / np.abs(A).max(axis=1, keepdims=True))
    return _roots(det, omega_max, n)


def tip_mass_cantilever_rad_s(EI, m, L, m_tip, n=4):
    mu = m_tip / (m * L)
    f = lambda b: 1 + np.cos(b) * np.cosh(b) + mu * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))  # noqa
    f_scaled = lambda b: f(b) / np.cosh(b)  # noqa: E731
    bl = _roots(f_scaled, 14.0, n)
    return bl**2 / L**2 * np.sqrt(EI / m)


def root_spring_cantilever_rad_s(EI, m, L, k_theta, k_y=np.inf, n=4):
    def det(b):
        be = b / L
        x = L
        # w = A cosh + B sinh + C cos + D sin (beta x); derivatives
        d = lambda k, x: np.array([  # noqa: E731
            be**k * (np.cosh(be * x) if k % 2 == 0 else np.sinh(be * x)),
            be**k * (np.sinh(be * x) if k % 2 == 0 else np.cosh(be * x)),
            be**k * [np.cos, lambda t: -np.sin(t), lambda t: -np.cos(t), np.sin][k % 4](be * x),
            be**k * [np.sin, np.cos, lambda t: -np.sin(t), lambda t: -np.cos(t)][k % 4](be * x)])
        r1 = d(0, 0) if np.isinf(k_y) else EI * d(3, 0) + k_y * d(0, 0)
        r2 = EI * d(2, 0) - k_theta * d(1, 0)
        A = np.array([r1, r2, d(2, x), d(3, x)])
        return np.linalg.det(A / np.abs(A).max(axis=1, keepdims=True))
    bl = _roots(det, 14.0, n)
    return bl**2 / L**2 * np.sqrt(EI / m)


def _freqs(model, n=4):
    w, _ = modal.undamped_modes(model.M, model.K)
    return w[:n]


def test_timoshenko_element_reduces_to_euler_bernoulli():
    le = 0.15
    np.testing.assert_allclose(timoshenko_stiffness(EI, np.inf, le), element_stiffness(EI, le), rtol=1e-14)
    np.testing.assert_allclose(timoshenko_mass(M_PER_L, 0.0, EI, np.inf, le), element_mass(M_PER_L, le),
                               rtol=1e-14)


def test_timoshenko_static_tip_deflection_is_exact():
    # one element: tip deflection under unit tip load = L^3/(3 EI) + L/kGA (exact for the element)
    kga = 1e4
    k = timoshenko_stiffness(EI, kga, L)[2:, 2:]
    assert np.linalg.solve(k, [1.0, 0.0])[0] == pytest.approx(L**3 / (3 * EI) + L / kga, rel=1e-12)


@pytest.mark.parametrize("kga", [5e3, 2e4, 1e5])
def test_timoshenko_cantilever_against_frequency_equation(kga):
    rho_i = M_PER_L * H**2 / 12
    exact = timoshenko_cantilever_rad_s(EI, kga, M_PER_L, rho_i, L)
    fe = _freqs(assemble_beam(L, EI, M_PER_L, 80, thickness_m=H, effects={"shear_deformation": {"kGA_N": kga}}))
    np.testing.assert_allclose(fe, exact, rtol=5e-4)  # shear-dominated elements converge as h^2
    np.testing.assert_allclose(fe[:2], exact[:2], rtol=3e-5)
    eb = _freqs(assemble_beam(L, EI, M_PER_L, 80))
    assert np.all(fe < eb)  # shear flexibility lowers every mode, the higher ones more
    assert (eb[3] / fe[3]) > (eb[0] / fe[0])


def test_rotary_inertia_against_rayleigh_beam_limit():
    rho_i = 50 * M_PER_L * H**2 / 12  # exaggerated so the effect is visible above the tolerance
    exact = timoshenko_cantilever_rad_s(EI, 1e12, M_PER_L, rho_i, L)
    fe = _freqs(assemble_beam(L, EI, M_PER_L, 40, effects={"rotary_inertia": {"rho_I_kg_m": rho_i}}))
    np.testing.assert_allclose(fe, exact, rtol=2e-5)
    assert fe[3] < 0.99 * _freqs(assemble_beam(L, EI, M_PER_L, 40))[3]


def test_euler_bernoulli_limit_of_the_closed_form():
    exact = timoshenko_cantilever_rad_s(EI, 1e13, M_PER_L, 1e-12, L)
    eb = properties.cantilever_frequencies_hz(EI, M_PER_L, L, properties.cantilever_beta_l(4)) * 2 * np.pi
    np.testing.assert_allclose(exact, eb, rtol=1e-6)


@pytest.mark.parametrize("kga, rate", [(1e4, 3.8), (1e8, 12.0)])
def test_timoshenko_mesh_convergence(kga, rate):
    """Mode-4 error falls as h^2 when shear dominates the element (phi >> 1), as h^4 when it is slender."""
    exact = timoshenko_cantilever_rad_s(EI, kga, M_PER_L, M_PER_L * H**2 / 12, L)
    errs = [np.abs(_freqs(assemble_beam(L, EI, M_PER_L, n, thickness_m=H,
                                        effects={"shear_deformation": {"kGA_N": kga}})) / exact - 1)[3]
            for n in (8, 16, 32)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] / errs[1] > rate and errs[1] / errs[2] > rate


@pytest.mark.parametrize("mu", [0.05, 0.5])
def test_tip_mass_against_frequency_equation(mu):
    m_tip = mu * M_PER_L * L
    exact = tip_mass_cantilever_rad_s(EI, M_PER_L, L, m_tip)
    fe = _freqs(assemble_beam(L, EI, M_PER_L, 40, effects={"added_mass": {"mass_kg": m_tip}}))
    np.testing.assert_allclose(fe, exact, rtol=1e-5)


@pytest.mark.parametrize("k_rel", [2.0, 50.0])
def test_root_spring_against_frequency_equation(k_rel):
    k_theta = k_rel * EI / L
    exact = root_spring_cantilever_rad_s(EI, M_PER_L, L, k_theta)
    fe = _freqs(assemble_beam(L, EI, M_PER_L, 40, effects={"root_flexibility": {"k_theta_Nm_rad": k_theta}}))
    np.testing.assert_allclose(fe, exact, rtol=1e-5)


def test_translational_and_rotational_root_springs_against_frequency_equation():
    k_theta, k_y = 20 * EI / L, 500 * EI / L**3
    exact = root_spring_cantilever_rad_s(EI, M_PER_L, L, k_theta, k_y)
    fe = _freqs(assemble_beam(L, EI, M_PER_L, 40,
                              effects={"root_flexibility": {"k_theta_Nm_rad": k_theta, "k_y_N_m": k_y}}))
    np.testing.assert_allclose(fe, exact, rtol=1e-5)


def test_point_mass_between_nodes_uses_the_shape_functions():
    node_x = np.linspace(0, L, 5)
    N, dN = hermite_row(node_x[2], node_x)
    assert N[4] == pytest.approx(1.0) and np.count_nonzero(np.abs(N) > 1e-14) == 1
    assert dN[5] == pytest.approx(1.0)
    # a mass at mid-element on a coarse mesh approaches the fine-mesh (nodal) answer
    fine = _freqs(assemble_beam(L, EI, M_PER_L, 64, effects={"added_mass": {"mass_kg": 0.01, "x_m": 5 * L / 8}}))
    coarse = _freqs(assemble_beam(L, EI, M_PER_L, 16, effects={"added_mass": {"mass_kg": 0.01, "x_m": 5 * L / 8}}))
    np.testing.assert_allclose(coarse[:3], fine[:3], rtol=2e-4)
    m = assemble_beam(L, EI, M_PER_L, 4)
    T = interpolation_matrix(m, [L / 4, L])
    assert T.shape == (2, len(m.dofs)) and T[0, m.index(["2:y"])[0]] == pytest.approx(1.0)


def test_local_damping_matches_first_order_perturbation_and_makes_modes_complex():
    c, x = 0.05, 0.9 * L
    m = assemble_beam(L, EI, M_PER_L, 24, effects={"local_damping": {"c_Ns_m": c, "x_m": x}})
    w, phi = modal.undamped_modes(m.M, m.K)
    T = interpolation_matrix(m, [x])
    zeta_pert = c * (T @ phi[:, :4]) ** 2 / (2 * w[:4])   # zeta_j = c phi_j(x)^2 / (2 w_j)
    cm = modal.complex_modes(m.M, m.C, m.K)
    np.testing.assert_allclose(cm.damping_ratios[:4], zeta_pert.ravel(), rtol=2e-2)
    psi = cm.eigenvectors[:, :4]
    # non-proportional damping: the modes are complex (phases spread), proportional damping gives real modes
    y = psi[m.index(["7:y", "13:y", "19:y", "25:y"])]
    y = y / y[np.argmax(np.abs(y), axis=0), np.arange(4)]
    assert np.max(np.abs(y.imag)) > 1e-4
    prop = assemble_beam(L, EI, M_PER_L, 24, effects={"proportional_damping": {"beta_s": 1e-9}})
    psi_p = modal.complex_modes(prop.M, prop.C, prop.K).eigenvectors[:, :4]
    yp = psi_p[m.index(["7:y", "13:y", "19:y", "25:y"])]
    yp = yp / yp[np.argmax(np.abs(yp), axis=0), np.arange(4)]
    assert np.max(np.abs(yp.imag)) < 1e-10


def test_effect_validation_is_one_line_naming_the_key():
    with pytest.raises(ConfigError, match="effects.added_mass.mass_kg"):
        validate_effects({"added_mass": {"mass_kg": float("nan")}}, "f.toml")
    with pytest.raises(ConfigError, match="needs parameter 'c_Ns_m'"):
        validate_effects({"local_damping": {"x_m": 0.1}}, "f.toml")


def test_beam_file_effects_reach_the_model():
    b = load_beam("beam5").with_effects({"shear_deformation": {"kGA_N": 2e4}})
    assert _freqs(b.fe_model(20))[3] < 0.95 * _freqs(load_beam("beam5").fe_model(20))[3]


BOLTED = """
name = "bar"
section = "rectangular"
length_m = 0.38
width_m = 0.0254
thickness_m = 0.00475
modulus_pa = 2.0e11
density_kg_m3 = 7850.0
"""


def _bolted_file(tmp_path, xs=(0.05, 0.11, 0.17, 0.23, 0.29, 0.35), extra=""):
    p = tmp_path / "bolted.toml"
    p.write_text(BOLTED + "".join(f"\n[[effects.added_mass]]\nmass_kg = 0.035\nx_m = {x}\n" for x in xs) + extra)
    return p


def test_several_added_masses_give_the_independent_simulators_frequencies(tmp_path):
    """Six bolted masses, one [[effects.added_mass]] table each, on a solid steel bar: the beam file's 40-element
    model against experiments.second_sim's 112-element Euler-Bernoulli beam with the same point masses."""
    from experiments.second_sim.fem import Beam as SimBeam, PointMass, assemble as sim_assemble, modes as sim_modes

    beam = load_beam(_bolted_file(tmp_path))
    assert len(beam.effects) == 6 and beam.section == "rectangular"
    assert beam.EI_Nm2 == pytest.approx(2e11 * 0.0254 * 0.00475**3 / 12)
    assert beam.mass_per_length_kg_m == pytest.approx(7850 * 0.0254 * 0.00475)
    model = beam.fe_model(40)
    from scipy.linalg import eigh

    f = np.sqrt(eigh(model.K, model.M, eigvals_only=True)[:5]) / (2 * np.pi)
    sim = SimBeam(0.38, beam.EI_Nm2, beam.mass_per_length_kg_m,
                  masses=tuple(PointMass(x, 0.035) for x in (0.05, 0.11, 0.17, 0.23, 0.29, 0.35)))
    np.testing.assert_allclose(f, sim_modes(sim_assemble(sim)).frequencies_hz[:5], rtol=5e-5)   # 40 vs 112 elements
    # one table, or a table per mass: the same model as their sum
    one = load_beam(_bolted_file(tmp_path, xs=(0.23,)))
    assert list(one.effects) == ["added_mass"]
    plain = load_beam(_bolted_file(tmp_path, xs=()))
    dM = beam.fe_model(40).M - plain.fe_model(40).M
    from physics.effects import point_mass_matrix
    node_x = np.linspace(0, 0.38, 41)
    ref = sum(point_mass_matrix(node_x, 0.035, x) for x in (0.05, 0.11, 0.17, 0.23, 0.29, 0.35))[2:, 2:]
    np.testing.assert_allclose(dM, ref, atol=1e-15)


def test_several_masses_round_trip_and_a_bad_one_names_its_table(tmp_path):
    from physics.beam import beam_to_toml

    beam = load_beam(_bolted_file(tmp_path, xs=(0.1, 0.2)))
    assert list(beam.effects) == ["added_mass", "added_mass#2"]
    text = beam_to_toml(beam)
    assert text.count("[[effects.added_mass]]") == 2
    (tmp_path / "back.toml").write_text(text)
    assert load_beam(tmp_path / "back.toml") == beam
    bad = tmp_path / "bad.toml"
    bad.write_text(BOLTED + "\n[[effects.added_mass]]\nmass_kg = 0.035\n[[effects.added_mass]]\nmass_kg = -1.0\n")
    with pytest.raises(ConfigError) as e:
        load_beam(bad)
    assert str(e.value) == f"{bad}: 'effects.added_mass[2].mass_kg' must be >= 0, got -1.0"
    beyond = _bolted_file(tmp_path, xs=(0.1, 0.5))
    with pytest.raises(ConfigError, match=r"'effects.added_mass#2.x_m' = 0.5 lies beyond 'length_m' = 0.38"):
        load_beam(beyond)
    twice = tmp_path / "twice.toml"
    twice.write_text(BOLTED + "\n[[effects.root_flexibility]]\nk_theta_Nm_rad = 1.0\n")
    with pytest.raises(ConfigError, match="'effects.root_flexibility' must be one table"):
        load_beam(twice)


def test_a_solid_section_says_what_it_is(tmp_path):
    """A solid bar: EI and mass from its material, Cowper's shear coefficient, no core keys, no rotary-inertia
    candidate; a circle from its diameter."""
    from physics.effects import candidates_for
    from physics.properties import solid_section

    beam = load_beam(_bolted_file(tmp_path, xs=()))
    s = beam.solid
    nu = 0.3
    assert s.shear_coefficient == pytest.approx(10 * (1 + nu) / (12 + 11 * nu))
    assert s.kGA_N == pytest.approx(s.shear_coefficient * 2e11 / 2.6 * 0.0254 * 0.00475)
    assert "rotary_inertia" not in candidates_for("clamped-free", "rectangular")
    assert "rotary_inertia" in candidates_for("clamped-free", "sandwich")
    core = tmp_path / "core.toml"
    core.write_text(BOLTED + "core_modulus_pa = 1.0e8\n")
    with pytest.raises(ConfigError, match="'core_modulus_pa' describes a sandwich section, not this rectangular one"):
        load_beam(core)
    rod = tmp_path / "rod.toml"
    rod.write_text('name = "rod"\nsection = "circular"\nlength_m = 0.5\ndiameter_m = 0.01\nmodulus_pa = 7.0e10\n'
                   'density_kg_m3 = 2700.0\n')
    r = load_beam(rod)
    assert r.width_m == r.thickness_m == 0.01 and r.EI_Nm2 == pytest.approx(7e10 * np.pi * 0.01**4 / 64)
    assert r.mass_per_length_kg_m == pytest.approx(2700 * np.pi * 0.01**2 / 4)
    assert solid_section("circular", 0.01, 0.01, 7e10, 0.3).shear_coefficient == pytest.approx(6 * 1.3 / 8.8)
    given = tmp_path / "given.toml"
    given.write_text('name = "box"\nlength_m = 1.0\nwidth_m = 0.05\nthickness_m = 0.05\nEI_Nm2 = 1.0e4\n'
                     'mass_per_length_kg_m = 2.0\n')
    assert load_beam(given).section == "given"
