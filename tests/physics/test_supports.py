"""Support effects (clamp, bearing and suspension springs) and the discrepancy search on every bc.

The closed forms are the exact Euler-Bernoulli frequencies of a uniform beam with end springs
(:func:`experiments.studies.plain_beam.exact_beta_l`); the hidden-effect data come from a plain Hermite-element model
(:func:`experiments.studies.plain_beam.plain_fe`), neither of them from physics/.
"""

import numpy as np
import pytest
from scipy.linalg import eigh
from experiments.studies.plain_beam import exact_beta_l, plain_fe

from physics import discrepancy as dsc
from physics import effects as fx
from physics.beam import beam_from_dict, load_beam
from physics.errors import BeamDamageError, ConfigError
from physics.supports import SUPPORTS

BEAM5 = load_beam("beam5")
L, EI, M = BEAM5.length_m, BEAM5.EI_Nm2, BEAM5.mass_per_length_kg_m
NOISE = dsc.Noise(0.002, 0.05, 0.01, 0.5)
# beta L of the classical supports (Blevins, Formulas for Natural Frequency and Mode Shape, table 8-1)
PINNED_PINNED = np.pi * np.arange(1, 5)
CLAMPED_CLAMPED = np.array([4.73004074, 7.85320462, 10.99560784, 14.13716549])


def _beta_l(bc, effects, n_elements=40, n=4):
    model = fx.assemble_beam(L, EI, M, n_elements, bc=bc, effects=effects)
    w2 = eigh(model.K, model.M, eigvals_only=True)
    w2 = w2[2:] if bc == "free-free" else w2
    return (w2[:n] * M * L**4 / EI) ** 0.25


# --------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("kappa", [0.5, 5.0, 50.0])
def test_bearing_springs_between_pinned_and_clamped_and_exact(kappa):
    got = _beta_l("pinned-pinned", {"bearing_flexibility": {"k_theta_Nm_rad": kappa * EI / L}})
    np.testing.assert_allclose(got, exact_beta_l(kappa, np.inf), rtol=1e-5)
    assert np.all((got > PINNED_PINNED * (1 + 1e-3)) & (got < CLAMPED_CLAMPED * (1 - 1e-3)))


def test_bearing_springs_tend_to_pinned_and_to_clamped():
    soft = _beta_l("pinned-pinned", {"bearing_flexibility": {"k_theta_Nm_rad": 1e-7 * EI / L}})
    stiff = _beta_l("pinned-pinned", {"bearing_flexibility": {"k_theta_Nm_rad": 1e8 * EI / L}})
    np.testing.assert_allclose(soft, PINNED_PINNED, rtol=1e-5)
    np.testing.assert_allclose(stiff, CLAMPED_CLAMPED, rtol=1e-5)
    np.testing.assert_allclose(exact_beta_l(0.0, np.inf), PINNED_PINNED, rtol=1e-9)   # the reference itself
    np.testing.assert_allclose(exact_beta_l(np.inf, np.inf), CLAMPED_CLAMPED, rtol=1e-8)


def test_clamp_springs_lie_between_the_limits_and_match_the_exact_roots():
    kappa = 8.0
    got = _beta_l("clamped-clamped", {"clamp_flexibility": {"k_theta_Nm_rad": kappa * EI / L}})
    np.testing.assert_allclose(got, exact_beta_l(kappa, np.inf), rtol=1e-5)
    assert np.all((got > PINNED_PINNED * 1.01) & (got < CLAMPED_CLAMPED * 0.99))
    rigid = _beta_l("clamped-clamped", {})
    np.testing.assert_allclose(rigid, CLAMPED_CLAMPED, rtol=1e-5)
    # translational clamp springs as well: the exact roots with both springs
    both = _beta_l("clamped-clamped", {"clamp_flexibility": {"k_theta_Nm_rad": kappa * EI / L,
                                                             "k_y_N_m": 300.0 * EI / L**3}})
    np.testing.assert_allclose(both, exact_beta_l(kappa, 300.0), rtol=1e-5)


def test_suspension_bounce_and_pitch_of_a_stiff_bar_and_exact_bending_modes():
    k_y = 0.005 * EI / L**3                     # soft: bounce at 0.45 % of the first bending mode
    model = fx.assemble_beam(L, EI, M, 40, bc="free-free", effects={"suspension": {"k_y_N_m": k_y}})
    w = np.sqrt(eigh(model.K, model.M, eigvals_only=True))
    np.testing.assert_allclose(w[0], np.sqrt(2 * k_y / (M * L)), rtol=1e-4)      # bounce
    np.testing.assert_allclose(w[1], np.sqrt(6 * k_y / (M * L)), rtol=1e-4)      # pitch: 2 k (L/2)^2 / (m L^3/12)
    kappa_y = 50.0                                # stiffer: the bending modes rise, as the exact roots
    got = _beta_l("free-free", {"suspension": {"k_y_N_m": kappa_y * EI / L**3}})
    exact = exact_beta_l(0.0, kappa_y, 6)[2:]
    np.testing.assert_allclose(got, exact, rtol=1e-5)
    assert got[0] > CLAMPED_CLAMPED[0] * 1.001   # free-free bending modes have the clamped-clamped beta L


def test_root_flexibility_keeps_its_meaning_on_a_cantilever():
    kappa = 20.0
    model = fx.assemble_beam(L, EI, M, 40, effects={"root_flexibility": {"k_theta_Nm_rad": kappa * EI / L}})
    assert model.dofs[0] == "1:rz"
    lam = (eigh(model.K, model.M, eigvals_only=True)[:3] * M * L**4 / EI) ** 0.25
    np.testing.assert_allclose(lam, exact_beta_l(kappa, np.inf, 3, right=(0.0, 0.0)), rtol=1e-5)
    np.testing.assert_allclose(exact_beta_l(np.inf, np.inf, 3, right=(0.0, 0.0)), [1.87510407, 4.69409113,
                                                                                   7.85475744], rtol=1e-8)


# --------------------------------------------------------------------------- refusals
def test_support_effects_that_do_not_fit_are_refused_in_one_line():
    with pytest.raises(ConfigError) as e:
        beam_from_dict({"preset": "beam5", "bc": "free-free", "effects": {"root_flexibility": {"k_theta_Nm_rad": 5.0}}},
                       "bar.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("bar.toml:")
    assert "'root_flexibility'" in msg and "free-free" in msg and "'suspension'" in msg
    with pytest.raises(BeamDamageError, match="'bearing_flexibility'.*clamped-free.*'root_flexibility'"):
        fx.assemble_beam(L, EI, M, 8, effects={"bearing_flexibility": {"k_theta_Nm_rad": 5.0}})
    with pytest.raises(BeamDamageError, match="'suspension'.*pinned-pinned.*'bearing_flexibility'"):
        BEAM5.with_effects({"suspension": {"k_y_N_m": 5.0}}, bc="pinned-pinned")
    free = BEAM5.with_effects({}, bc="free-free")
    meas = dsc.Measurement(np.array([100.0, 280.0, 550.0]))
    with pytest.raises(BeamDamageError) as e:
        dsc.analyse(free, meas, candidates=("root_flexibility",))
    assert str(e.value) == ("candidate effect 'root_flexibility' does not fit a free-free beam; its candidates are "
                            "shear_deformation, rotary_inertia, suspension, added_mass, local_damping")


def test_candidates_follow_the_supports():
    common = {"shear_deformation", "rotary_inertia", "added_mass", "local_damping"}
    for bc, sup in SUPPORTS.items():
        assert set(fx.candidates_for(bc)) == common | {sup.effect}
    assert fx.candidates_for("clamped-free") == ("shear_deformation", "rotary_inertia", "root_flexibility",
                                                 "added_mass", "local_damping")
    assert set(fx.CANDIDATES) == common | {s.effect for s in SUPPORTS.values()}


# --------------------------------------------------------------------------- hidden effects, independent data
def _measured(bc, sensors, seed=1, shapes=True, **truth):
    """Five bending modes of the plain FE truth (EI 2 % above the beam's) with 0.2 % / 0.01 noise."""
    rng = np.random.default_rng(seed)
    f, sh = plain_fe(bc, L, 1.02 * EI, M, x_sensors=sensors, **truth)
    f = f * (1 + 0.002 * rng.standard_normal(f.size))
    if not shapes:
        return dsc.Measurement(f)
    sh = sh / np.max(np.abs(sh), axis=0) + 0.01 * rng.standard_normal(sh.shape)
    return dsc.Measurement(f, None, sh, tuple(sensors))


def _analyse(bc, meas, sensors):
    beam = BEAM5.with_effects({}, bc=bc, measured_x_m=tuple(sensors), n_elements=8)
    return dsc.analyse(beam, meas, NOISE, max_effects=1, n_elements=24, n_starts=3)


FREE_SENSORS = [L * k / 8 for k in range(9)]
INNER_SENSORS = [L * k / 8 for k in range(1, 8)]
W1_FREE = 22.3733 / L**2 * np.sqrt(1.02 * EI / M)


def test_free_free_hidden_added_mass_is_named_and_the_gap_shrinks():
    mass = 0.1 * M * L
    res = _analyse("free-free", _measured("free-free", FREE_SENSORS, mass=(mass, 48)), FREE_SENSORS)
    assert res.named_effects == ("added_mass",)
    assert res.final.parameters["added_mass.mass_kg"] == pytest.approx(mass, rel=0.1)
    assert res.final.parameters["added_mass.x_m"] == pytest.approx(48 * L / 64, abs=0.03 * L)
    assert res.steps[0].base.residuals.max_abs_frequency_error_pct > 2.0
    assert res.final.residuals.max_abs_frequency_error_pct < 0.6


@pytest.mark.parametrize("shapes", [False, True])
def test_free_free_hidden_suspension_is_named_and_its_stiffness_recovered(shapes):
    k_y = 0.5 * M * L * (0.15 * W1_FREE) ** 2            # bounce at 15 % of the first bending mode
    res = _analyse("free-free", _measured("free-free", FREE_SENSORS, k_y=k_y, shapes=shapes), FREE_SENSORS)
    assert res.named_effects == ("suspension",)
    assert res.final.parameters["suspension.k_y_N_m"] == pytest.approx(k_y, rel=0.1)
    assert res.steps[0].base.residuals.max_abs_frequency_error_pct > 1.0
    assert res.final.residuals.max_abs_frequency_error_pct < 0.6


def test_pinned_beam_hidden_bearing_springs_are_named():
    k = 3.0 * EI / L
    res = _analyse("pinned-pinned", _measured("pinned-pinned", INNER_SENSORS, k_theta=k, shapes=False),
                   INNER_SENSORS)
    assert res.named_effects == ("bearing_flexibility",)
    assert res.final.parameters["bearing_flexibility.k_theta_Nm_rad"] == pytest.approx(k, rel=0.05)
    assert res.nominal.max_abs_frequency_error_pct > 10 > 0.6 > res.final.residuals.max_abs_frequency_error_pct


def test_clamped_clamped_hidden_clamp_springs_are_named():
    k = 20.0 * EI / L
    # a clamp on a rotational spring is a pin with that spring: the plain FE holds the translations only
    res = _analyse("clamped-clamped", _measured("pinned-pinned", INNER_SENSORS, k_theta=k), INNER_SENSORS)
    assert res.named_effects == ("clamp_flexibility",)
    assert res.final.parameters["clamp_flexibility.k_theta_Nm_rad"] == pytest.approx(k, rel=0.05)
    assert res.final.residuals.max_abs_frequency_error_pct < 0.6 < res.nominal.max_abs_frequency_error_pct


def test_pinned_beam_without_bearing_springs_names_nothing_and_gives_a_limit():
    res = _analyse("pinned-pinned", _measured("pinned-pinned", INNER_SENSORS, shapes=False), INNER_SENSORS)
    assert res.named_effects == ()
    lim = res.detection_limits["bearing_flexibility"]
    assert lim.quantity == "k_L_over_EI" and not lim.named_below and 1e-3 < lim.limit < 1.0
