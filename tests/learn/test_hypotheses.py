"""The competing explanations of a frequency change, on changes computed by the independent simulator
(experiments/second_sim: its own finite elements, slits, masses and root spring)."""

import numpy as np
import pytest

from experiments.second_sim.fem import Beam, PointMass, Slit, assemble, modes
from learn.network.features import BeamSpec
from datagen.damage import DAMAGE_MODELS, applies_to, damage_defaults
from learn.explanations.shapes import shape_changes
from learn.explanations.hypotheses import BASE_HYPOTHESES, _support_curves, kind_explanation, summary, weigh
from learn.explanations.sensitivity import beam_sensitivity

L, EI, M = 0.6095, 26.9, 0.15792 / 1.219
KR_REL = 948.7                                     # k_r L / EI of the nominal root spring (the models' default)
BASE = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L)


def shifts(beam: Beam) -> np.ndarray:
    f0 = modes(assemble(BASE)).frequencies_hz[:4]
    return modes(assemble(beam)).frequencies_hz[:4] / f0 - 1


#: The mass changes of these tests are point masses: the explanation's spread is none.
POINT_MASSES = {**damage_defaults("mass_change"), "width_fraction": [0.0, 0.0]}
#: The config sections and size grids these tests give two kinds; every other registered kind competes on its
#: defaults and its own size range.
OWN = {"slit": (damage_defaults("slit"), np.linspace(0.0, 0.15, 201)),
       "mass_change": (POINT_MASSES, np.linspace(-0.1, 0.1, 201))}


@pytest.fixture(scope="module")
def models():
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    kinds = {}
    for name in DAMAGE_MODELS:
        d, sizes = OWN.get(name, (damage_defaults(name), None))
        kinds[name] = kind_explanation(name, d, "beam5", beam_sensitivity((L, EI, M), KR_REL, kind=name), sizes)
    grid, curve, what, reclamp, support_shapes = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    return kinds, (grid, curve, what, reclamp), support_shapes


def weighed(models, y, shapes=None):
    kinds, support, support_shapes = models
    return weigh(y, kinds, support, (-0.004, 0.004), length_m=L, shapes=shapes, support_shapes=support_shapes)


def quarter_point_shapes(beam: Beam) -> np.ndarray:
    """The independent simulator's modes 1-4 at x = L/4, L/2, 3L/4, L (4, 4)."""
    asm = assemble(beam)
    return modes(asm).phi[asm.translation_dofs([L * q / 4 for q in range(1, 5)]), :4]


CASES = {
    "slit": Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, slits=(Slit(0.2, 0.004, 0.6),)),
    "global_stiffness": Beam(L, 1.03 * EI, M, root_k_theta_Nm_rad=KR_REL * EI / L),
    "support_change": Beam(L, EI, M, root_k_theta_Nm_rad=0.2 * KR_REL * EI / L),
    "intact": Beam(L, 1.002 * EI, M, root_k_theta_Nm_rad=KR_REL * EI / L),
}


@pytest.mark.parametrize("truth", list(CASES))
def test_the_true_explanation_is_the_most_probable(models, truth):
    rows = weighed(models, shifts(CASES[truth]))
    assert [r.name for r in rows][0] == truth, [(r.name, round(r.probability, 3)) for r in rows]
    assert sorted(r.name for r in rows) == sorted([*BASE_HYPOTHESES, *models[0]])   # the kinds weighed here
    assert sum(r.probability for r in rows) == pytest.approx(1.0)
    assert rows[0].max_abs_frequency_error_pct < 0.15              # 1.5 sigma: first order, a grid of 40 places


@pytest.mark.parametrize("x_over_L", [0.3, 0.7, 1.0])
def test_an_added_mass_is_one_of_the_two_most_probable_and_the_doubt_is_said(models, x_over_L):
    """A 2 % mass lowers the four frequencies in a pattern that a slit elsewhere (or, at the tip, a global
    stiffness change) nearly repeats: the mass change is among the two most probable, and the summary says the two
    cannot be told apart."""
    beam = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(x_over_L * L, 0.02 * M * L),))
    rows = weighed(models, shifts(beam))
    assert "mass_change" in (rows[0].name, rows[1].name) and rows[1].probability > 0.25
    assert "cannot be told apart" in summary(rows, [1, 2, 3, 4])


def test_the_slit_posterior_covers_the_slit(models):
    best = weighed(models, shifts(CASES["slit"]))[0]
    p = best.parameters
    theta = Slit(0.2, 0.004, 0.6).hinge_flexibility(L)
    assert p["x_m_95"][0] <= 0.2 <= p["x_m_95"][1] and p["x_m_95"][1] - p["x_m_95"][0] < 0.25 * L
    assert p["size_95"][0] <= theta <= p["size_95"][1] and p["size_label"] == "hinge flexibility"
    assert abs(p["size"] / theta - 1) < 0.15


def test_a_mass_lost_raises_the_frequencies_and_is_named(models):
    """The baseline carries a mass (an accelerometer) at 0.7 L that the current test lacks: every frequency rises,
    which no slit does; a mass change with a negative mass is named, at its place."""
    heavy = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(0.7 * L, 0.02 * M * L),))
    y = modes(assemble(BASE)).frequencies_hz[:4] / modes(assemble(heavy)).frequencies_hz[:4] - 1
    assert np.all(y > 0)
    rows = weighed(models, y)
    assert rows[0].name == "mass_change" and rows[0].parameters["size"] == pytest.approx(-0.02, abs=0.004)
    assert rows[0].parameters["x_m"] == pytest.approx(0.7 * L, abs=0.02)
    assert next(r for r in rows if r.name == "slit").probability < 1e-3


def test_two_explanations_the_modes_cannot_separate_are_said_so(models):
    """Mode 1 alone, lowered by 1 %: a slit near the clamp and a mass near the tip both fit; the summary says
    they cannot be told apart and names what would separate them. So do a slit at 0.16 m and a 3 % mass at 0.45 m
    on modes 1-4 (their frequency changes agree to 0.1 %)."""
    kinds, (grid, curve, what, reclamp), _ = models
    rows = weigh(np.array([-0.01]), {k: v.modes([0]) for k, v in kinds.items()},
                 (grid, curve[:, :1], what, reclamp[:, :1]), (-0.004, 0.004), length_m=L)
    text = summary(rows, [1])
    assert "cannot be told apart" in text and "would separate them" in text
    mass = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(0.45, 0.03 * M * L),))
    rows = weighed(models, shifts(mass))
    assert {rows[0].name, rows[1].name} == {"slit", "mass_change"} and rows[1].probability > 0.2
    assert "a higher mode (a slit follows the curvature squared" in summary(rows, [1, 2, 3, 4])


def test_pairs_weighed_in_one_batch_get_what_each_gets_alone(models):
    from learn.explanations.hypotheses import weigh_many

    kinds, support, _ = models
    Y = np.stack([shifts(CASES[t]) for t in ("slit", "support_change", "intact")])
    batch = weigh_many(Y, kinds, support, (-0.004, 0.004), length_m=L)
    for y, rows in zip(Y, batch):
        alone = weighed(models, y)
        assert [r.name for r in rows] == [r.name for r in alone]
        np.testing.assert_allclose([r.probability for r in rows], [r.probability for r in alone], rtol=1e-9,
                                   atol=1e-15)
        assert rows[0].parameters == alone[0].parameters


@pytest.mark.parametrize("x_over_L", [0.3, 0.7, 1.0])
def test_the_shape_changes_tell_an_added_mass_from_a_slit(models, x_over_L):
    """The same 2 % masses with the shapes of both tests (exact, from the independent simulator): the mass change
    is the most probable explanation; a slit, with its shapes, stays the most probable."""
    beam = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=(PointMass(x_over_L * L, 0.02 * M * L),))
    du = shape_changes(np.stack([quarter_point_shapes(BASE), quarter_point_shapes(beam)])[None])[0]
    rows = weighed(models, shifts(beam), du)
    assert rows[0].name == "mass_change", [(r.name, round(r.probability, 3)) for r in rows]
    assert rows[0].parameters["size"] == pytest.approx(0.02, rel=0.3)
    slit = CASES["slit"]
    du = shape_changes(np.stack([quarter_point_shapes(BASE), quarter_point_shapes(slit)])[None])[0]
    assert weighed(models, shifts(slit), du)[0].name == "slit"


def test_a_change_no_explanation_describes_is_said_and_gets_no_damage_interval(models):
    """Mode 2 up by 1 % while modes 1, 3, 4 fall by 0.5 %: no slit, mass, support or temperature does that; the
    most likely explanation misses a mode by more than FIT_LIMIT std, the summary says no explanation fits, and
    the slit reports no interval rather than a narrow one. The true slit of CASES fits."""
    from learn.explanations.hypotheses import FIT_LIMIT

    rows = weighed(models, np.array([-0.005, 0.01, -0.005, -0.005]))
    assert not rows[0].fits and rows[0].max_misfit_std > FIT_LIMIT
    assert summary(rows, [1, 2, 3, 4]).startswith("no explanation fits the change within its noise")
    for kind in ("slit", "mass_change"):       # every damage kind withholds its intervals when it does not fit
        p = next(r for r in rows if r.name == kind).parameters
        assert p["x_m_95"] is None and p["size_68"] is None and p["size_95"] is None and np.isfinite(p["size"])
    good = weighed(models, shifts(CASES["slit"]))[0]
    assert good.fits and good.parameters["x_m_95"] is not None
    assert not summary([good, *weighed(models, shifts(CASES["slit"]))[1:]], [1, 2, 3, 4]).startswith("no expl")


def test_the_verdict_says_when_its_sources_disagree():
    from learn.pairs.verdict import agreement

    net, cl = {"damaged": True}, {"damaged": False, "method": "DLAC"}
    hyp = [{"name": "intact", "probability": 0.51, "fits": True}]
    a = agreement(True, net, cl, hyp, "network")
    assert (a["network"], a["classical"], a["explanations"], a["agree"]) == (True, False, False, False)
    assert a["text"].startswith("They disagree") and "within the noise they weigh" in a["text"]
    b = agreement(True, net, {"damaged": True, "method": "DLAC"},
                  [{"name": "slit", "probability": 0.9, "fits": True}], "network")
    assert b["agree"] and b["text"].startswith("One story")
    c = agreement(False, net, {"damaged": True, "method": "DLAC"},               # withdrawn by the baselines
                  [{"name": "slit", "probability": 0.9, "fits": True}], "network")
    assert not c["agree"] and not c["text"].startswith("One story")
    assert c["text"].endswith("but the verdict is no damage detected: the natural frequencies lie within the normal "
                              "variation the baseline tests measured.")


def _model(damage: dict):
    """A model's beam and config as the explanations read them: beam 5 on the default root spring, trained on data
    of the generator config's ``damage`` section."""
    from learn.network.model_dir import TrainedModel

    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    return TrainedModel("model", {"beam": spec.to_dict(), "generator_config": {"damage": damage},
                                  "root_spring_relative": KR_REL, "truth_beam": {}})


def test_the_explanations_prior_and_spread_follow_the_generator_config():
    """The model's own kind spans the sizes its data draw (a slit's hinge flexibility of its deepest, widest slit;
    a mass change's signed mass ratios) and averages its sensitivities over the lengths its data spread over; the
    other kinds keep their defaults."""
    from datagen.damage.slit import hinge_flexibility
    from learn.explanations.hypotheses import kind_explanations

    slit_cfg = {**damage_defaults("slit"), "ei_loss": [0.1, 0.5], "width_m": [0.002, 0.01]}
    kinds = kind_explanations(_model(slit_cfg))
    assert kinds["slit"].sizes[0] == 0.0
    assert kinds["slit"].sizes[-1] == pytest.approx(float(hinge_flexibility(0.5, 0.01, L)), rel=1e-12)  # 0.0164
    assert (kinds["mass_change"].sizes[0], kinds["mass_change"].sizes[-1]) == (-0.05, 0.05)        # its defaults
    mass_cfg = {**damage_defaults("mass_change"), "mass_ratio": [-0.2, 0.1], "width_fraction": [0.1, 0.3]}
    kinds = kind_explanations(_model(mass_cfg))
    assert (kinds["mass_change"].sizes[0], kinds["mass_change"].sizes[-1]) == (-0.2, 0.1)
    # a window 0.2 L long is 8 elements of the 40: half of each end element and the 7 between
    point = beam_sensitivity("beam5", KR_REL, kind="mass_change").frequency
    e = 20
    expected = (0.5 * point[:, e - 4] + point[:, e - 3:e + 4].sum(axis=1) + 0.5 * point[:, e + 4]) / 8
    np.testing.assert_allclose(kinds["mass_change"].sens.frequency[:, e], expected, rtol=1e-12)
    assert not np.allclose(kinds["mass_change"].sens.frequency[:, e], point[:, e], rtol=1e-3)
    # the slit's defaults: 0.3 mm deep into the 0.5 mm face sheet over 10 mm
    assert kinds["slit"].sizes[-1] == pytest.approx(0.01334, rel=1e-3)


@pytest.mark.parametrize("x_over_L, ratio", [(0.35, 0.03), (0.7, -0.02), (0.55, 0.01)])
def test_the_mass_change_intervals_cover_a_simulated_mass(x_over_L, ratio):
    """A point mass added (or, carried by the baseline, lost) in the independent simulator: the mass change's 95 %
    intervals of place and signed size, from a model trained on point masses within +-5 %, hold the true ones."""
    from learn.explanations.hypotheses import kind_explanations

    kinds = kind_explanations(_model({**damage_defaults("mass_change"), "width_fraction": [0.0, 0.0]}))
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    grid, curve, what, reclamp, _ = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    point = (PointMass(x_over_L * L, abs(ratio) * M * L),)
    heavy = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L, masses=point)
    f_base, f_cur = (modes(assemble(b)).frequencies_hz[:4] for b in ((BASE, heavy) if ratio > 0 else (heavy, BASE)))
    rows = weigh(f_cur / f_base - 1, kinds, (grid, curve, what, reclamp), (-0.004, 0.004), length_m=L)
    p = next(r for r in rows if r.name == "mass_change").parameters
    assert p["size_label"] == "mass ratio"
    assert p["x_m_95"][0] <= x_over_L * L <= p["x_m_95"][1], p
    assert p["size_95"][0] <= ratio <= p["size_95"][1] and p["size_95"][1] - p["size_95"][0] < abs(ratio), p
    assert p["size_68"][0] >= p["size_95"][0] and p["size_68"][1] <= p["size_95"][1]


class _Stiffening:
    """A throwaway damage kind (registered by the tests only): a stiffness loss like a slit's under another name."""

    kind = "stiffening_test"
    defaults = {"theta": [0.0, 0.02]}
    size_meaning = "hinge flexibility of a test kind"
    size_label = "test flexibility"
    label = "a test stiffening"
    size_transform = "log"
    perturbs = "stiffness"
    sections = None
    separates = {"slit": "nothing at all (a slit by another name)"}

    def size_range(self, d, beam):
        return tuple(d["theta"])

    def spread_m(self, d, length_m):
        return 0.0

    def describe(self, x_m, size, preset, section=None):
        return f"a test stiffening at x = {x_m:.3f} m of {size:.3g}"

    def damage_at(self, d, beam, x_m, size, extent, mass_per_length_kg_m, length_m):
        return DAMAGE_MODELS["slit"].damage_at({"width_m": [0.004, 0.004]}, beam, x_m, size, extent,
                                               mass_per_length_kg_m, length_m)

    def corrections(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements, shear_phi=0.0):
        return DAMAGE_MODELS["slit"].corrections(params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements)


@pytest.fixture
def stiffening(monkeypatch):
    """``DAMAGE_MODELS`` with the throwaway kind registered."""
    from datagen.damage import DAMAGE_MODELS

    monkeypatch.setitem(DAMAGE_MODELS, _Stiffening.kind, _Stiffening())
    return _Stiffening.kind


def test_a_kind_registered_anywhere_is_weighed_described_and_separated(stiffening):
    """No kind is written into learn: a kind added to DAMAGE_MODELS gets its explanation (its prior from the
    model's config, its sensitivities from its perturbs), its intervals, its separating measurement in the summary,
    counts as damage in the verdict's agreement and speaks its own prose in the verdict."""
    from learn.explanations.hypotheses import kind_explanations
    from learn.pairs.verdict import DamageWords, _classical_sentence, _damage_sentence, agreement

    kinds = kind_explanations(_model({"kind": stiffening, "theta": [0.0, 0.015]}))
    assert set(kinds) >= {"slit", "mass_change", stiffening}
    assert kinds[stiffening].perturbs == "stiffness" and kinds[stiffening].sizes[-1] == 0.015
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    grid, curve, what, reclamp, _ = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    rows = weigh(shifts(CASES["slit"]), kinds, (grid, curve, what, reclamp), (-0.004, 0.004), length_m=L)
    assert {rows[0].name, rows[1].name} == {"slit", stiffening}, [(r.name, r.probability) for r in rows]
    mine = next(r for r in rows if r.name == stiffening).parameters
    theta = Slit(0.2, 0.004, 0.6).hinge_flexibility(L)
    assert mine["size_label"] == "test flexibility" and mine["size_95"][0] <= theta <= mine["size_95"][1]
    assert "nothing at all (a slit by another name) would separate them" in summary(rows, [1, 2, 3, 4])
    best = {"name": stiffening, "probability": 0.6, "fits": True}
    assert agreement(True, {"damaged": True}, None, [best], "network")["agree"]
    a = {"damaged": True, "detectable": True, "probability_damaged": 0.97, "decision_threshold": 0.9,
         "location_x_m": 0.2, "location_std_m": 0.02, "location_x_over_L": 0.33, "location_element": 2,
         "size": 0.0098, "size_std": 0.002}
    words = DamageWords(stiffening)
    text = _damage_sentence(a, words)
    assert "a test stiffening at x = 0.200 m of 0.0098" in text and "test flexibility +- 0.002" in text
    assert "slit" not in text and "hinge" not in text
    assert _classical_sentence({"method": "DLAC", **a}, words) == ("DLAC: damaged, a test stiffening at x = 0.200 m "
                                                                   "of 0.0098 (element 2 of 4)")


def test_a_kind_is_offered_only_on_the_sections_it_exists_on():
    """A face-core debond needs faces on a core: a model of a solid steel bar weighs no debond, a model of the
    thesis's sandwich beam does; every other kind is weighed on both."""
    from learn.explanations.hypotheses import kind_explanations

    solid = _model(damage_defaults("slit"))
    solid.config["generator_config"]["beam"] = {"name": "bar", "section": "rectangular", "length_m": L,
                                                "width_m": 0.0254, "thickness_m": 0.00475, "modulus_pa": 2.0e11,
                                                "density_kg_m3": 7850.0}
    assert "debond" not in kind_explanations(solid)
    assert set(kind_explanations(solid)) == {k for k in DAMAGE_MODELS if applies_to(k, "rectangular")}
    assert set(kind_explanations(_model(damage_defaults("slit")))) == set(DAMAGE_MODELS)
