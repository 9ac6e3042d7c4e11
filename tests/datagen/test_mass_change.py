"""Damage kind "mass_change" (datagen/damage/mass_change.py): a signed mass over a length in the current state."""

import json
import re

import numpy as np
import pytest

from datagen.config import load_config, merge
from datagen.damage import DAMAGE_MODELS
from datagen.dataset import Dataset
from datagen.generation import compute_shard, generate
from learn.explanations.classical import run_classical
from learn.explanations.sensitivity import beam_sensitivity
from learn.network.evaluate import metrics
from learn.network.features import labels
from physics.effects import point_mass_matrix
from physics.errors import ConfigError
from physics.fem import beam_model
from physics.modal import undamped_modes
from physics.properties import beam_preset

#: Rigid clamp, Euler-Bernoulli, no test-day changes: the current state differs by the mass change alone.
QUIET = {"specimen": {"root_spring_relative": []},
         "damage": {"kind": "mass_change", "n_masses": [1, 1], "mass_ratio": [-0.02, 0.02],
                    "width_fraction": [0, 0.05]},
         "measurement": {"lines": 64}, "output": {"shard_size": 6}}


def _reference_mass(node_x, x_m, width_m, mass_kg, point_kg=0.0, point_x_m=np.nan, n_points=400):
    """Mass matrix of a mass change by another discretisation: the line part as ``n_points`` equal point masses
    (midpoint rule over the clipped length, physics.effects.point_mass_matrix), plus the point part."""
    L = node_x[-1]
    point_kg = 0.0 if not np.isfinite(point_kg) else point_kg
    a, b = np.clip([x_m - width_m / 2, x_m + width_m / 2], 0, L)
    line = mass_kg - point_kg
    if b - a <= 0:
        out = point_mass_matrix(node_x, line, x_m)
    else:
        xs = a + (np.arange(n_points) + 0.5) * (b - a) / n_points
        out = sum(point_mass_matrix(node_x, line / n_points, x) for x in xs)
    if point_kg:
        out = out + point_mass_matrix(node_x, point_kg, point_x_m)
    return out


def _cantilever_shape_squared(x_m, length_m, r):
    """``W_r(x)^2`` of the uniform cantilever's mode r (0-based), normalised to ``int_0^L W^2 dx = L``."""
    bl = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])[r]
    s = bl * np.asarray(x_m) / length_m
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    return (np.cosh(s) - np.cos(s) - sigma * (np.sinh(s) - np.sin(s))) ** 2


@pytest.fixture(scope="module")
def masses(tmp_path_factory):
    root = tmp_path_factory.mktemp("mass") / "data"
    generate(root, merge(QUIET), n=12, seed=3, progress=False)
    ds = Dataset(root)
    return ds.table(), ds.manifest, root


def test_frequency_changes_are_those_of_the_fe_beam_with_the_mass_change(masses):
    """Truth shifts against an independent solve: physics.fem's 20-element beam plus the mass spread over its
    length as 400 point masses (physics.effects.point_mass_matrix), and to first order
    ``df/f = -(1/2) (m_k / m L) <W_r^2>`` (the mode's displacement squared averaged over the length)."""
    t, manifest, _ = masses
    L = beam_preset("beam5").length_m
    assert manifest["config"]["damage"]["kind"] == "mass_change"
    n_el = manifest["config"]["mesh"]["truth_elements"]
    for _, row in t.iterrows():
        beam = beam_model(n_el, L, row.ei_Nm2, row.m_per_length_kg_m)
        assert beam.dofs[:2] == ("2:y", "2:rz")     # the clamp removed node 1
        dM = _reference_mass(beam.node_x, row.damage0_x_m, row.damage0_width_m, row.damage0_mass_kg)[2:, 2:]
        w0 = undamped_modes(beam.M, beam.K)[0][:4]
        w1 = undamped_modes(beam.M + dM, beam.K)[0][:4]
        stored = np.array([row[f"df{r + 1}_rel"] for r in range(4)])
        np.testing.assert_allclose(stored, w1 / w0 - 1, rtol=1e-4, atol=1e-8)
        a, b = np.clip([row.damage0_x_m - row.damage0_width_m / 2, row.damage0_x_m + row.damage0_width_m / 2], 0, L)
        xs = np.linspace(a, b, 201)
        w2 = np.array([np.mean(_cantilever_shape_squared(xs, L, r)) for r in range(4)])
        np.testing.assert_allclose(stored, -0.5 * row.damage0_size * w2, rtol=0.08, atol=5e-5)
        # a mass added lowers every frequency, a mass lost raises it
        assert np.all(np.sign(stored) == -np.sign(row.damage0_mass_kg)) or np.max(np.abs(stored)) < 1e-7


def test_size_is_the_signed_mass_ratio_and_labels_read_it(masses):
    t, _, _ = masses
    L = beam_preset("beam5").length_m
    np.testing.assert_allclose(t.damage0_size, t.damage0_mass_kg / (t.m_per_length_kg_m * L), rtol=1e-15)
    assert t.damage0_size.between(-0.0201, 0.0201).all() and (t.damage0_size < 0).any() and (t.damage0_size > 0).any()
    lab = labels(t, L)
    np.testing.assert_array_equal(lab["size"], t.damage0_size)
    np.testing.assert_allclose(lab["x_over_L"], t.damage0_x_m / L)
    assert "n_slits" not in t and "damage0_ei_loss" not in t
    # a loss is spread over at least the length whose mass carries it (90 % of the mass per length there)
    lost = t.damage0_mass_kg < 0
    assert (-t.damage0_mass_kg[lost] <= 0.9 * t.m_per_length_kg_m[lost] * t.damage0_width_m[lost] * 1.06).all()


def test_the_damage_section_takes_the_keys_of_its_kind():
    cfg = merge({"damage": {"kind": "mass_change"}})
    assert cfg["damage"] == {"kind": "mass_change", "intact_fraction": 0.0, "position_fraction": [0.03, 0.97],
                             "n_masses": [1, 1], "mass_ratio": [-0.05, 0.05], "width_fraction": [0.0, 0.1]}
    training = merge({"damage": {"kind": "mass_change"}}, base=load_config("training"))
    assert training["damage"]["kind"] == "mass_change" and "n_slits" not in training["damage"]
    with pytest.raises(ConfigError, match="'damage.n_slits'"):
        merge({"damage": {"kind": "mass_change", "n_slits": [1, 1]}})
    with pytest.raises(ConfigError, match=re.escape(f"'damage.kind' must be one of {sorted(DAMAGE_MODELS)}")):
        merge({"damage": {"kind": "corrosion"}})
    with pytest.raises(ConfigError, match="'damage.mass_ratio'"):
        merge({"damage": {"kind": "mass_change", "mass_ratio": [0.1, -0.1]}})
    with pytest.raises(ConfigError, match="'damage.mass_ratio'"):
        merge({"damage": {"kind": "mass_change", "mass_ratio": [-0.95, 0.01]}})


def test_mass_sensitivities_are_the_displacement_squared_of_the_cantilever_modes():
    """beam_sensitivity(kind="mass_change") on a rigid clamp: ``d ln f_r / d mu = -(1/2) W_r(x)^2`` to first
    order, averaged over each element (the mass of a unit size spreads over it; 5-point Gauss)."""
    from learn.explanations.sensitivity import beam_sensitivity

    sens = beam_sensitivity("beam5", None, kind="mass_change")
    L, E = sens.length_m, sens.n_elements
    g, wg = np.polynomial.legendre.leggauss(5)
    x = (np.arange(E)[:, None] + 0.5 + g / 2) * L / E                      # (E, 5)
    expected = -0.5 * np.stack([_cantilever_shape_squared(x, L, r) @ wg / 2 for r in range(4)])
    np.testing.assert_allclose(sens.frequency, expected, rtol=1e-3, atol=1e-5)
    assert np.all(sens.frequency <= 0) and -2.0 < sens.frequency[0, -1] < -1.9   # W_1(L)^2 = 4 at the tip itself
    slit = beam_sensitivity("beam5", None)
    assert np.all(slit.frequency[0, :-1] < slit.frequency[0, 1:])   # a slit counts most at the root (curvature)


def test_projection_and_the_drop_label_hold_with_test_day_changes():
    """With a root spring, temperature and re-clamping between the days and 0-2 masses per specimen: the batched
    projection matches the per-sample state-space solution (datagen.naive, the current state on M + dM), and the
    drop label is the masses' alone (physics.fem with the root spring and the point masses, no day-to-day change)."""
    from datagen.naive import simulate_naive
    from datagen.batch_inputs import draw_batch
    from datagen.pipeline import simulate_batch
    from datagen.setup import get_setup
    from physics.modal import modal_parameters

    setup = get_setup(merge({"specimen": {"temperature_stiffness_change": [-0.003, 0.003],
                                          "root_spring_change": [-0.05, 0.05]},
                             "damage": {"kind": "mass_change", "n_masses": [0, 2], "mass_ratio": [-0.05, 0.05]},
                             "measurement": {"lines": 64}}))
    inp = draw_batch(np.random.default_rng(4), 8, setup)
    assert set(inp.damage) == {"mass_kg", "width_m", "point_kg", "point_x_m"}
    assert (inp.n_damages == 2).any() and (inp.n_damages == 0).any()
    out = simulate_batch(setup, inp)
    full = simulate_naive(setup, inp, solution="full")
    f_s, z_s = modal_parameters(out["truth_poles"][..., :4])
    f_f, z_f = modal_parameters(full["truth_poles"][..., :4])
    np.testing.assert_allclose(f_s, f_f, rtol=1e-4)
    np.testing.assert_allclose(z_s, z_f, rtol=1e-3)
    n_el, L = setup.n_elements, setup.length_m
    for b in range(len(inp)):
        beam = beam_model(n_el, L, inp.EI_Nm2[b], inp.mass_per_length_kg_m[b], root_spring=inp.root_spring_Nm_rad[b])
        names = [f"{n}:{d}" for n in range(1, n_el + 2) for d in ("y", "rz")]
        keep = [names.index(d) for d in beam.dofs]                        # with the root rotation on its spring
        dM = sum(_reference_mass(beam.node_x, x, w, m)[np.ix_(keep, keep)]
                 for x, w, m in zip(inp.x_m[b], inp.damage["width_m"][b], inp.damage["mass_kg"][b]) if np.isfinite(x))
        w0 = undamped_modes(beam.M, beam.K)[0][:4]
        w1 = undamped_modes(beam.M + dM, beam.K)[0][:4]
        assert out["damage_frequency_drop"][b] == pytest.approx(np.max(1 - w1 / w0), abs=1e-8)


def test_inspect_summarises_a_mass_change_dataset(masses, tmp_path):
    """No slit columns: the curvature check is empty (n = 0), the labels are the mass change's, the units too."""
    from datagen.inspection import inspect_dataset

    t, manifest, root = masses
    s = inspect_dataset(root, tmp_path / "inspect")
    assert all(c == {"slope": None, "r2": None, "n": 0} for c in s["curvature_check"].values())
    assert s["labels"]["damage0_mass_kg"]["min"] == t.damage0_mass_kg.min() and "damage0_ei_loss" not in s["labels"]
    assert manifest["schema"]["columns"]["damage{k}_mass_kg"].startswith("kg (signed")
    assert "signed mass ratio" in manifest["schema"]["columns"]["damage{k}_size"]
    assert (tmp_path / "inspect" / "shift_vs_position.png").stat().st_size > 0


def test_a_loss_beyond_what_the_beam_carries_is_refused_in_one_line():
    """A 5 % loss spread over at most 2 % of the length: 90 % of the beam's own mass there is 1.8 % of its mass."""
    with pytest.raises(ConfigError) as e:
        generate_cfg = merge({"damage": {"kind": "mass_change", "mass_ratio": [-0.05, 0.0],
                                         "width_fraction": [0.0, 0.02]}})
        from datagen.setup import build_setup

        build_setup(generate_cfg)
    msg = str(e.value)
    assert "\n" not in msg and "'damage.mass_ratio': a loss of 0.05 of the beam's mass" in msg
    assert "0.001421 kg" in msg or "carries (0.00142" in msg


def test_a_loss_from_a_bolted_mass_is_bounded_by_that_mass(tmp_path):
    """On a beam file with added masses a loss takes first from the heaviest one within its length (a point mass
    off that mass, at its position), the rest from the beam's own mass; the current mass matrix stays positive."""
    from datagen.batch_inputs import draw_batch
    from datagen.setup import get_setup

    beam = {"name": "bar", "length_m": 0.38, "width_m": 0.0254, "thickness_m": 0.00475, "section": "rectangular",
            "modulus_pa": 2e11, "density_kg_m3": 7850.0,
            "effects": {"added_mass": [{"mass_kg": 0.035, "x_m": x} for x in (0.05, 0.11, 0.17, 0.23, 0.29, 0.35)]}}
    cfg = merge({"beam": beam, "damage": {"kind": "mass_change", "mass_ratio": [-0.15, -0.01],
                                          "width_fraction": [0.1, 0.2]}, "measurement": {"lines": 64}})
    setup = get_setup(cfg)
    assert len(setup.added_masses) == 6
    inp = draw_batch(np.random.default_rng(0), 40, setup)
    d = inp.damage
    took = np.isfinite(d["point_x_m"][:, 0])
    assert took.any()
    np.testing.assert_array_less(-d["point_kg"][took, 0], 0.9 * 0.035 + 1e-12)
    assert np.all(np.isin(np.round(d["point_x_m"][took, 0], 9), np.round([0.05, 0.11, 0.17, 0.23, 0.29, 0.35], 9)))
    # the added mass taken from lies within the change's length
    assert np.all(np.abs(d["point_x_m"][took, 0] - inp.x_m[took, 0]) <= d["width_m"][took, 0] / 2 + 1e-12)
    m = setup.preset.mass_per_length_kg_m
    line = -(d["mass_kg"][:, 0] - d["point_kg"][:, 0])
    assert np.all(line <= 0.9 * m * d["width_m"][:, 0] * (1 + 1e-9))


def test_a_ten_percent_mass_loss_is_called_a_change_with_its_sign_by_the_classical_methods(tmp_path):
    """Every frequency rises: DLAC, MDLAC and sensitivity updating (mass sensitivities) report a negative size, a
    mass lost, above their detection threshold, instead of 'undamaged'."""
    from learn.explanations.classical import run_classical
    from learn.network.features import load_pairs
    from learn.explanations.sensitivity import beam_sensitivity

    root = tmp_path / "loss"
    generate(root, merge({**QUIET, "damage": {"kind": "mass_change", "mass_ratio": [-0.1, -0.1],
                                              "width_fraction": [0.15, 0.15], "position_fraction": [0.6, 0.9]}}),
             n=4, seed=5, progress=False)
    pairs = load_pairs(root)
    sens = beam_sensitivity("beam5", None, kind="mass_change")
    assert np.all(np.abs(pairs.eigenvalues[:, 1, :4]) > np.abs(pairs.eigenvalues[:, 0, :4]))   # every mode rises
    outs, _ = run_classical(pairs.eigenvalues, pairs.eigenvectors, sens, {"freq": 1e-3, "upd": 1e-3})
    for o in outs:
        assert o.damaged.all(), o.name
        assert np.all(o.size < 0), (o.name, o.size)
    dlac = next(o for o in outs if o.name == "DLAC")
    np.testing.assert_allclose(dlac.size, -0.1, rtol=0.5)


def test_dlac_places_mass_changes_with_the_mass_sensitivities_and_not_with_the_slits():
    """docs/datasets.md ("Columns"): the classical methods take the kind's sensitivities. On 200 samples of
    ``--config mass_change`` (seed 0; 112 damaged with a drop above 0.2 %), DLAC puts 105 of them (0.94) in the
    right thesis element with the mass sensitivities and 2 (0.02) with the slit's, whose curvature peaks elsewhere."""
    cfg = load_config("mass_change")
    cfg["measurement"]["lines"] = 32
    table, arrays = compute_shard(json.dumps(cfg), 0, 0, 0, 200)
    truth = labels(table, 0.6095)
    accuracy = {}
    for kind in ("mass_change", "slit"):
        outs, _ = run_classical(arrays["eigenvalues_measured"], arrays["eigenvectors_measured"],
                                beam_sensitivity("beam5", 948.7, kind=kind), damaged=truth["damaged"])
        accuracy[kind] = metrics(next(o for o in outs if o.name == "DLAC"), truth).element_accuracy
    assert int(np.sum(truth["damaged"] & (truth["max_drop"] > 0.002))) == 112
    assert accuracy == pytest.approx({"mass_change": 105 / 112, "slit": 2 / 112}, abs=1e-9)
