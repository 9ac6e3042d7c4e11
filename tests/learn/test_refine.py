"""The exact refinement of a damage kind's explanation (learn.explanations.refine) on changes computed by the
independent simulator (experiments/second_sim), and the Birge widening of its intervals."""

from dataclasses import replace

import numpy as np
import pytest

from datagen.damage import damage_defaults
from experiments.second_sim.fem import Beam, PointMass, assemble, modes
from learn.network.features import BeamSpec
from learn.explanations.hypotheses import _support_curves, kind_explanation, summary, weigh
from learn.explanations.refine import ExactKind, kind_parameters, nominal_beam
from learn.explanations.sensitivity import beam_sensitivity

L, EI, M = 0.6095, 26.9, 0.15792 / 1.219
KR_REL = 948.7
BASE = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L)

#: Point masses added up to a quarter of the beam's mass or lost up to a tenth.
POINT_MASSES = {**damage_defaults("mass_change"), "width_fraction": [0.0, 0.0], "mass_ratio": [-0.1, 0.25]}


def _mass_change(exact: bool):
    sens = beam_sensitivity((L, EI, M), KR_REL, kind="mass_change")
    ek = ExactKind("mass_change", POINT_MASSES, "beam5", nominal_beam((L, EI, M), KR_REL), np.arange(4))
    return kind_explanation("mass_change", POINT_MASSES, "beam5", sens, exact=ek if exact else None)


def _weighed(y, exact: bool):
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    grid, curve, what, reclamp, _ = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    rows = weigh(y, {"mass_change": _mass_change(exact)}, (grid, curve, what, reclamp), (-0.004, 0.004),
                 length_m=L)
    return next(r for r in rows if r.name == "mass_change")


@pytest.mark.parametrize("x_over_L", [0.5, 0.7, 1.0])
def test_the_exact_refinement_recovers_a_large_point_mass_the_first_order_grid_misses(x_over_L):
    """A point mass of 15 % of the beam's mass in the independent simulator: the first-order grid does not reproduce
    its frequency changes within the fit limit (or, at the tip, its 95 % place interval misses it); refined on the
    exact model the explanation fits, places it within a hundredth of the length and sizes it within 2 %, its
    intervals holding both."""
    heavy = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(x_over_L * L, 0.15 * M * L),))
    f0, f1 = (modes(assemble(b)).frequencies_hz[:4] for b in (BASE, heavy))
    y = f1 / f0 - 1
    first = _weighed(y, exact=False)
    p = first.parameters
    assert not first.fits or not p["x_m_95"][0] <= x_over_L * L <= p["x_m_95"][1], (first.max_misfit_std, p)
    refined = _weighed(y, exact=True)
    p = refined.parameters
    assert refined.fits and refined.max_misfit_std < 0.5, refined.max_misfit_std
    assert p["x_m"] == pytest.approx(x_over_L * L, abs=0.01 * L) and p["size"] == pytest.approx(0.15, rel=0.02)
    assert p["x_m_95"][0] <= x_over_L * L <= p["x_m_95"][1] and p["size_95"][0] <= 0.15 <= p["size_95"][1], p


def test_the_exact_model_is_the_independent_simulators():
    """The exact model's frequency changes of a 20 % point mass are the independent simulator's (within 1e-4)."""
    ek = ExactKind("mass_change", POINT_MASSES, "beam5", nominal_beam((L, EI, M), KR_REL), np.arange(4))
    heavy = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(0.55 * L, 0.2 * M * L),))
    f0, f1 = (modes(assemble(b)).frequencies_hz[:4] for b in (BASE, heavy))
    np.testing.assert_allclose(ek.changes([0.55 * L], [0.2], [0.0])[0][0], f1 / f0 - 1, atol=1e-4)


def test_the_birge_ratio_widens_a_gaussian_interval_by_its_root():
    """A Gaussian likelihood of std 1 tempered by a Birge ratio of 4: its 68 % interval is +-2 (closed form)."""
    x = np.linspace(0, 20, 4001)
    ll = -0.5 * (x - 10) ** 2
    narrow = kind_parameters(0.0, 1.0, 20.0, "s", x, np.ones_like(x), ll, 0.0, True)
    wide = kind_parameters(0.0, 1.0, 20.0, "s", x, np.ones_like(x), ll, 0.0, True, birge=4.0)
    assert narrow["x_m_68"] == pytest.approx([10 - 1.0, 10 + 1.0], abs=0.01)          # 68.27 %: one std
    assert wide["x_m_68"] == pytest.approx([10 - 2.0, 10 + 2.0], abs=0.01) and wide["birge_ratio"] == 4.0
    assert kind_parameters(0.0, 1.0, 20.0, "s", x, np.ones_like(x), ll, 0.0, False)["x_m_95"] is None


def test_a_change_the_explanation_misfits_within_its_limit_gets_a_wider_interval():
    """An added point mass whose modes' changes are moved by 2.5 standard deviations, alternately up and down (a change
    the mass does not reproduce within its noise, yet within the fit limit): the explanation still fits, its Birge
    ratio exceeds 4, its place interval widens by about its root (the size's, which also holds the size scale's
    10 %, less) and the summary says so."""
    heavy = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(0.45 * L, 0.05 * M * L),))
    f0, f1 = (modes(assemble(b)).frequencies_hz[:4] for b in (BASE, heavy))
    y = f1 / f0 - 1
    sd = np.sqrt(1e-3**2 + (0.03 * y) ** 2)
    clean, off = _weighed(y, exact=True), _weighed(y + np.array([2.5, -2.5, 2.5, -2.5]) * sd, exact=True)
    assert clean.parameters["birge_ratio"] == pytest.approx(1.0) and off.fits and off.max_misfit_std > 1
    assert off.parameters["birge_ratio"] > 4, off.parameters

    def width(p, key):
        return p[key][1] - p[key][0]

    assert width(off.parameters, "x_m_68") > 1.8 * width(clean.parameters, "x_m_68")
    assert width(off.parameters, "size_68") > 1.1 * width(clean.parameters, "size_68")
    assert "its intervals are widened by it" in summary([off, replace(clean, probability=0.0)], [1, 2, 3, 4])
