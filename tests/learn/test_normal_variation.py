"""The normal variation measured on several baseline tests: its scatter against a direct computation on the
independent simulator's tests, and its test's false-alarm rate and power on Gaussian populations."""

import numpy as np
import pytest

from experiments.second_sim.fem import Beam, PointMass, assemble, modes
from learn.features import BeamSpec
from learn.normal_variation import FREQUENCY_STD_FLOOR, NormalVariation, measure
from physics.errors import BeamDamageError
from physics.io import ModalData

L, EI, M = 0.6095, 26.9, 0.15792 / 1.219
SPEC = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")


def _population(rng, n, p, rho, sigma=1e-3):
    """``n`` tests' ln f of ``p`` modes about 100 Hz, each mode with std ``sigma``, correlation ``rho``."""
    chol = np.linalg.cholesky((1 - rho) * np.eye(p) + rho) * sigma
    return rng.standard_normal((n, p)) @ chol.T + np.log(100.0), chol


@pytest.mark.parametrize(("rho", "n", "tests"), [(0.0, 6, ["largest_z"]), (0.8, 6, ["largest_z"]),
                                                 (0.0, 13, ["hotelling", "largest_z"]),
                                                 (0.8, 13, ["hotelling", "largest_z"])])
def test_the_false_alarm_rate_is_held_for_independent_and_correlated_modes(rho, n, tests):
    """500 populations of n baselines, one new intact test each: alarms at about the 1 % asked for (binomial
    mean 5, 95 % range 1-10), whether the modes move alone or together (temperature)."""
    rng = np.random.default_rng(7)
    alarms = 0
    for _ in range(500):
        base, chol = _population(rng, n, 4, rho)
        nv = NormalVariation(tuple(map(str, range(n))), base, None, np.zeros_like(base), 0)
        out = nv.test(rng.standard_normal(4) @ chol.T + np.log(100.0), 0.01)
        alarms += out["beyond"]
    assert out["tests"] == tests
    assert 1 <= alarms <= 12, alarms


def test_a_change_breaking_the_modes_common_pattern_is_found_by_hotelling():
    """Modes moving together (rho 0.9) with 40 baselines: mode 1 alone 3.5 std lower is beyond the variation in
    nearly every population, and the test that says so is Hotelling's; a shift of every mode alike of the same
    norm (what temperature does) far less often."""
    rng = np.random.default_rng(3)
    found, common, kinds = 0, 0, set()
    for _ in range(100):
        base, chol = _population(rng, 40, 4, 0.9)
        nv = NormalVariation(tuple(map(str, range(40))), base, None, np.zeros_like(base), 0)
        x = rng.standard_normal(4) @ chol.T + np.log(100.0)
        out = nv.test(x + np.array([-3.5e-3, 0, 0, 0]))
        found += out["beyond"]
        kinds.add(out["test"])
        common += nv.test(x - 3.5e-3 * np.ones(4) / 2)["beyond"]
    assert found >= 95 and "hotelling" in kinds
    assert common <= 25


def _test_of(rng, mass_x_m):
    """One test of the independent simulator's cantilever with a 3 % bolted mass at ``mass_x_m``: ModalData at
    the quarter points (1 % damping), and its 4 natural frequencies ``|lambda| / 2 pi`` (Hz)."""
    beam = Beam(L, EI * (1 + 0.003 * rng.uniform(-1, 1)), M, root_k_theta_Nm_rad=948.7 * EI / L,
                masses=(PointMass(mass_x_m, 0.03 * M * L),))
    asm = assemble(beam)
    md = modes(asm)
    w = 2 * np.pi * md.frequencies_hz[:4]
    phi = md.phi[asm.translation_dofs([L * q / 4 for q in range(1, 5)]), :4]
    lam = -0.01 * w + 1j * w
    return ModalData(lam, phi.astype(complex), SPEC.dofs), np.abs(lam) / (2 * np.pi)


def test_the_scatter_of_re_placed_masses_is_measured_mode_by_mode():
    """Baselines of the independent simulator whose bolted mass is re-placed +-3 cm: the measured scatter of each
    mode is the sample std of its ln f (computed directly here), the reference baseline the one nearest the
    medians, shapes signed alike."""
    rng = np.random.default_rng(0)
    tests = [_test_of(rng, 0.7 * L + rng.uniform(-0.03, 0.03)) for _ in range(9)]
    f = np.array([t[1] for t in tests])
    nominal = modes(assemble(Beam(L, EI, M, root_k_theta_Nm_rad=948.7 * EI / L))).frequencies_hz[:4]
    nv = measure([t[0] for t in tests], SPEC, nominal)
    np.testing.assert_allclose(nv.frequency_std_rel, np.std(np.log(f), axis=0, ddof=1), rtol=1e-9)
    np.testing.assert_allclose(nv.frequency_mean_hz, np.exp(np.log(f).mean(axis=0)), rtol=1e-12)
    assert np.all(nv.frequency_std_rel > 5 * FREQUENCY_STD_FLOOR)         # the masses move the modes visibly
    z2 = np.sum(((np.log(f) - np.median(np.log(f), axis=0)) / nv.frequency_std_rel) ** 2, axis=1)
    assert nv.reference == int(np.argmin(z2))
    dots = np.einsum("sm,nsm->nm", nv.shapes[nv.reference], nv.shapes)
    assert np.all(dots > 0.9)                                             # one sign per mode across the tests
    summary = nv.summary()
    assert summary["n_baselines"] == 9 and summary["modes_counts"] == [9, 9, 9, 9]
    # an intact test with the mass inside its range lies within; the mass moved 15 cm lies beyond
    within = nv.test(np.log(_test_of(rng, 0.7 * L)[1]))
    beyond = nv.test(np.log(_test_of(rng, 0.7 * L - 0.15)[1]))
    assert not within["beyond"] and beyond["beyond"], (within["p_value"], beyond["p_value"])


def test_fewer_than_two_baselines_or_a_bad_rate_are_refused():
    rng = np.random.default_rng(1)
    one = _test_of(rng, 0.5)[0]
    with pytest.raises(BeamDamageError, match="at least 2 baseline tests"):
        measure([one], SPEC, np.array([20.0, 130.0, 360.0, 700.0]))
    nv = NormalVariation(("a", "b"), np.log([[10.0, 50.0], [10.1, 50.2]]), None, np.zeros((2, 2)), 0)
    with pytest.raises(BeamDamageError, match="false-alarm rate must lie in"):
        nv.test(np.log([10.0, 50.0]), 0.7)
    with pytest.raises(BeamDamageError, match="no mode of the test is held by 2"):
        nv.test(np.array([np.nan, np.nan]))
