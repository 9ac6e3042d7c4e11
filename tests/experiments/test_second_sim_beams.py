"""The independent simulator on every support (closed-form frequencies), its beam catalogue (beam files the project
reads, bands, pyuff read-back of the pairs) and the per-beam study's scoring and end-to-end run."""

import json
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest

from experiments.second_sim import beams
from experiments.second_sim.fem import Beam, Slit, assemble, mesh_elements, modes
from experiments.second_sim.writers import KINDS, convert_receptance

EI, M, L = 700.0, 3.14, 1.0
INF = math.inf
#: beta_n L of the free-free and clamped-clamped beam (cosh b cos b = 1)
BETA_CC = np.array([4.730040745, 7.853204624, 10.99560784, 14.13716549])


def _hz(beta_L):
    return np.square(beta_L) * math.sqrt(EI / M) / (2 * math.pi * L ** 2)


def _fe_hz(beam, n):
    return modes(assemble(beam)).frequencies_hz[:n]


@pytest.mark.parametrize(("springs", "beta_L", "rigid"), [
    ({"root_k_theta_Nm_rad": 0.0, "tip_k_y_N_m": INF}, np.pi * np.arange(1, 5), 0),                   # pinned-pinned
    ({"tip_k_y_N_m": INF, "tip_k_theta_Nm_rad": INF}, BETA_CC, 0),                                    # clamped-clamped
    ({"root_k_y_N_m": 0.0, "root_k_theta_Nm_rad": 0.0}, BETA_CC, 2),                                  # free-free
    ({"root_k_y_N_m": 0.0, "root_k_theta_Nm_rad": 0.0, "tip_k_y_N_m": INF, "tip_k_theta_Nm_rad": INF},  # free-clamped
     np.array([1.875104069, 4.694091133, 7.854757438, 10.99554073]), 0),
])
def test_each_support_has_its_closed_form_frequencies(springs, beta_L, rigid):
    f = _fe_hz(Beam(L, EI, M, **springs), rigid + 4)
    np.testing.assert_allclose(f[rigid:], _hz(beta_L), rtol=2e-7)
    assert np.all(f[:rigid] < 1e-3 * f[rigid])                      # rigid-body modes at omega = 0


def test_a_suspended_free_free_beam_bounces_and_pitches_as_a_rigid_bar():
    """Springs k at both ends: bounce omega^2 = 2 k / (m L), pitch 6 k / (m L), far below the first bending mode,
    which they stiffen by the first-order amount phi_1(0)^2 + phi_1(L)^2 = 8 / (m L) times k."""
    k = 50.0
    f = _fe_hz(Beam(L, EI, M, root_k_y_N_m=k, root_k_theta_Nm_rad=0.0, tip_k_y_N_m=k), 3)
    np.testing.assert_allclose(f[:2], np.sqrt([2 * k / (M * L), 6 * k / (M * L)]) / (2 * np.pi), rtol=2e-3)
    w1 = 2 * np.pi * _hz(BETA_CC[0])
    np.testing.assert_allclose(f[2], np.sqrt(w1 ** 2 + 8 * k / (M * L)) / (2 * np.pi), rtol=1e-5)


def test_the_cantilever_defaults_are_unchanged_and_the_ends_can_swap():
    """Beam() is clamped at the root, free at the tip (tip springs 0 add nothing to K); the mirror beam, clamped at
    the tip, has the same frequencies and a slit at x behaves as one at L - x there."""
    base = Beam(L, EI, M)
    a = assemble(base)
    b = assemble(replace(base, tip_k_y_N_m=0.0, tip_k_theta_Nm_rad=0.0))
    assert a.K.shape == (2 * base.n_elements,) * 2 and np.array_equal(a.K, b.K)
    slit = Slit(0.2, 0.004, 0.6)
    mirror = replace(base, root_k_y_N_m=0.0, root_k_theta_Nm_rad=0.0, tip_k_y_N_m=INF, tip_k_theta_Nm_rad=INF,
                     slits=(replace(slit, x_m=L - slit.x_m),))
    # a fine mesh's stiffness spans many decades: LAPACK builds agree on the fundamental to about 1e-8
    np.testing.assert_allclose(_fe_hz(mirror, 4), _fe_hz(replace(base, slits=(slit,)), 4), rtol=1e-8)
    with pytest.raises(ValueError, match="tip_k_y_N_m must be >= 0"):
        Beam(L, EI, M, tip_k_y_N_m=-1.0)


def test_meshes_put_nodes_at_every_sensor():
    assert mesh_elements(1.2, [0.0, 0.3, 1.2 * 5 / 11]) == 132        # the first multiple of 4 and 11 >= 112
    assert mesh_elements(2.0, [0.75], 112) == 112
    with pytest.raises(ValueError, match="no uniform mesh"):
        mesh_elements(1.0, [1 / math.pi], 10, 200)


def test_the_catalogue_covers_every_support_and_1_to_12_sensors():
    cat = beams.CATALOGUE
    assert len(cat) >= 6 and len({c.name for c in cat}) == len(cat)
    assert {c.bc for c in cat} == set(beams.SUPPORTS)
    assert {len(c.sensors_x_m) for c in cat} >= {1, 12}
    assert len({c.material for c in cat}) >= 3 and {"pvc", "gfrp"} & {c.material for c in cat}
    assert min(c.length_m for c in cat) >= 0.3 and max(c.length_m for c in cat) <= 3.0
    for c in cat:
        asm = assemble(beams.nominal_beam(c))
        asm.translation_dofs(c.sensors_x_m)                            # every sensor is a free node of the mesh
        f = beams.bending_frequencies_hz(beams.nominal_beam(c), c.bc, c.n_modes + 1)
        lo, hi = beams.band_hz(c)
        assert np.count_nonzero((f >= lo) & (f <= hi)) == c.n_modes, c.name


@pytest.mark.parametrize("name", ["steel-bar-ff-12s", "steel-girder-pp-1s", "pvc-bar-cc-5s"])
def test_beam_files_read_by_the_project_give_the_simulator_frequencies(name):
    """The project's beam-file reader and layout (the system under test) on the simulator's beam.toml: the same
    keys and values, and its nominal bending frequencies within 0.1 % of the simulator's (two codes)."""
    from physics.beam import beam_from_dict
    from physics.layout import layout_of

    cb = next(c for c in beams.CATALOGUE if c.name == name)
    doc = tomllib.loads(beams.beam_toml(cb))
    E, rho, _ = beams.MATERIALS[cb.material]
    assert doc["EI_Nm2"] == pytest.approx(E * cb.width_m * cb.thickness_m ** 3 / 12, rel=1e-9)
    assert doc["mass_per_length_kg_m"] == pytest.approx(rho * cb.width_m * cb.thickness_m, rel=1e-9)
    assert doc["bc"] == cb.bc and doc["measured_x_m"] == pytest.approx(cb.sensors_x_m, rel=1e-9)
    lay = layout_of(beam_from_dict(doc, name))
    assert lay.modes == tuple(range(1, cb.n_modes + 1))
    f = beams.bending_frequencies_hz(beams.nominal_beam(cb), cb.bc, cb.n_modes)
    np.testing.assert_allclose(lay.frequencies_hz, f, rtol=1e-3)
    np.testing.assert_allclose(lay.zones_x_m, beams.default_zones(cb), atol=1e-9)


def test_pairs_are_uff_files_pyuff_reads_with_geometry_units_and_kinds(tmp_path):
    import pyuff

    cb = next(c for c in beams.CATALOGUE if c.name == "gfrp-strip-ff-4s")
    recs = beams.simulate_beam_pairs(cb, 3, seed=5)
    out = beams.write_beam_pairs(cb, recs, tmp_path / "b", seed=5)
    assert tomllib.loads((out / "beam.toml").read_text())["name"] == cb.name
    kinds = set()
    for r in recs:
        for day, H, kind in (("baseline", r.baseline, r.kinds[0]), ("current", r.current, r.kinds[1])):
            sets = pyuff.UFF(str(out / f"pair-{r.pair:03d}_{day}.uff")).read_sets()
            units, geo, frfs = sets[0], sets[1], sets[2:]
            assert units["type"] == 164 and units["length"] == 1000.0
            assert geo["type"] == 15
            np.testing.assert_allclose(geo["x"], 1000 * np.asarray(cb.sensors_x_m), rtol=1e-7)
            assert [int(s["rsp_node"]) for s in frfs] == [1, 2, 3, 4]
            assert {int(s["ref_node"]) for s in frfs} == {cb.drive_sensor + 1}
            assert {int(s["ordinate_spec_data_type"]) for s in frfs} == {KINDS[kind][0]}
            data = np.array([s["data"] for s in frfs])
            np.testing.assert_allclose(data, convert_receptance(H, r.freq_hz, kind), rtol=1e-5,
                                       atol=1e-6 * np.abs(data).max())
            kinds.add(kind)
    assert kinds == set(KINDS)
    truth = json.loads((out / "truth.json").read_text())
    for t, r in zip(truth["pairs"], recs):
        assert t["intact"] == (not t["damaged"]) and r.truth == t
        if t["damaged"]:
            assert t["hinge_flexibility"] == pytest.approx(t["width_m"] * t["ei_loss_fraction"]
                                                           / ((1 - t["ei_loss_fraction"]) * cb.length_m))
            edges = truth["zone_edges_m"]
            assert edges[t["zone"] - 1] <= t["slit_x_m"] < edges[t["zone"]]
            assert max(1 - np.divide(t["current_frequencies_hz"], t["baseline_frequencies_hz"])) > 0


def test_a_single_sensor_beam_draws_its_ends_as_geometry(tmp_path):
    import pyuff

    cb = next(c for c in beams.CATALOGUE if len(c.sensors_x_m) == 1)
    out = beams.write_beam_pairs(cb, beams.simulate_beam_pairs(cb, 1, seed=1), tmp_path)
    geo = pyuff.UFF(str(out / "pair-000_baseline.uff")).read_sets(1)
    np.testing.assert_allclose(geo["x"], [1000 * cb.sensors_x_m[0], 0.0, 1000 * cb.length_m])


def test_the_beams_cli_writes_one_beam_and_refuses_an_unknown_one(tmp_path, capsys):
    from experiments.second_sim.__main__ import main

    assert main(["beams", "--out", str(tmp_path), "--n", "2", "--only", "al-strip-cf-3s", "--seed", "3"]) == 0
    assert sorted(p.name for p in (tmp_path / "al-strip-cf-3s").iterdir()) == [
        "beam.toml", "pair-000_baseline.uff", "pair-000_current.uff", "pair-001_baseline.uff",
        "pair-001_current.uff", "truth.csv", "truth.json"]
    assert main(["beams", "--out", str(tmp_path), "--only", "nope"]) == 2
    err = capsys.readouterr().err
    assert "unknown beam 'nope'" in err and err.count("\n") == 1


def _verdict(damaged, x, zone, s, s_sd=None, x_sd=None, cl=None):
    net = {"damaged": damaged, "location_x_m": x, "location_zone": zone, "size": s,
           "size_std": s_sd, "location_std_m": x_sd}
    return {**net, "network": net, "zone_edges_m": [0.0, 0.5, 1.0, 2.0], "input_route": "modal",
            "in_distribution": True,
            "classical_methods": [{"method": "DLAC", "damaged": cl is not None, "location_x_m": cl,
                                   "location_zone": None if cl is None else 1 + (cl >= 0.5) + (cl >= 1.0),
                                   "size": 0.01}]}


def test_scores_count_zones_places_false_alarms_sizes_and_folding():
    from experiments.benches.study_beams import score_beam

    truth = [{"damaged": True, "slit_x_m": 0.4, "hinge_flexibility": 0.02},
             {"damaged": True, "slit_x_m": 1.5, "hinge_flexibility": 0.01},
             {"damaged": True, "slit_x_m": 0.9, "hinge_flexibility": 0.01},
             {"damaged": False, "slit_x_m": None, "hinge_flexibility": 0.0},
             {"damaged": False, "slit_x_m": None, "hinge_flexibility": 0.0}]
    verdicts = [_verdict(True, 0.42, 1, 0.025, 0.01, 0.03, cl=0.6),    # right zone, |dx| 0.02, size +25 % (covered)
                _verdict(True, 1.45, 3, 0.008, 0.001, 0.1, cl=1.5),    # right zone, |dx| 0.05, size -20 % (not)
                _verdict(False, 0.9, 2, 0.0),                         # missed
                _verdict(True, 0.2, 1, 0.01, cl=0.3),                  # false alarm
                _verdict(False, 0.2, 1, 0.0)]
    meta = {"beam": "b", "bc": "clamped-free", "length_m": 2.0, "measured_x_m": [0.5, 1.0], "symmetric": False,
            "zone_edges_m": [0.0, 0.5, 1.0, 2.0], "pairs": truth}
    rows = {r["method"]: r for r in score_beam(verdicts, meta)}
    net = rows["network"]
    assert net["zone_accuracy"] == pytest.approx(2 / 3) and net["detection"] == pytest.approx(2 / 3)
    assert net["median_dx_over_L"] == pytest.approx((0.02 + 0.05) / 2 / 2.0)
    assert net["false_alarm_pct"] == pytest.approx(50.0) and net["false_alarms"] == 1
    assert net["median_size_error"] == pytest.approx(0.225)
    assert net["size_one_sigma_cover"] == pytest.approx(0.5) and net["location_one_sigma_cover"] == pytest.approx(1.0)
    dlac = rows["DLAC"]
    assert dlac["zone_accuracy"] == pytest.approx(1 / 3) and dlac["best_classical"] == "DLAC"
    assert np.isnan(dlac["size_one_sigma_cover"]) and net["zones_as_simulator"]
    # a symmetric beam read by one sensor: truth and answers on x <= L / 2
    folded = {**meta, "bc": "pinned-pinned", "symmetric": True, "measured_x_m": [0.75]}
    rows = {r["method"]: r for r in score_beam([_verdict(True, 0.5, 2, 0.01), _verdict(True, 0.55, 2, 0.01),
                                                *verdicts[2:]], folded)}
    assert rows["network"]["folded"] and rows["network"]["zone_accuracy"] == pytest.approx(1 / 3)  # 0.4 in zone 1
    assert rows["network"]["median_dx_over_L"] == pytest.approx((0.1 + 0.05) / 2 / 2.0)   # truth 1.5 -> 0.5


@pytest.mark.slow
def test_the_study_runs_end_to_end_on_one_beam(tmp_path, capsys):
    from experiments.benches.study_beams import main

    assert main(["--out", str(tmp_path), "--only", "al-strip-cf-3s", "--n-pairs", "6", "--train-n", "1500",
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    rows = {r["method"]: r for r in res["rows"]}
    assert {"verdict", "network", "Cawley-Adams", "DLAC", "MDLAC"} <= set(rows)
    assert all(r["pairs"] == 6 and r["beam"] == "al-strip-cf-3s" for r in rows.values())
    assert res["config"] == {**res["config"], "n_pairs": 6, "train_n": 1500, "seed": 0}
    for name in ("beams.csv", "beams.json", "beams.md", "beams.png"):
        assert (tmp_path / name).stat().st_size > 100
    assert "al-strip-cf-3s" in (tmp_path / "beams.md").read_text()



def test_mass_changes_move_the_frequencies_the_way_their_mass_says():
    """A mass added lowers every mode; a mass lost is taken evenly off its length (its points sum to the stated
    share of the beam's mass, at most half the beam's own mass there) and raises some mode; the pairs' truth
    names the kind, place and signed size; slit pairs draw as before (the damage field is a new branch)."""
    cb = next(c for c in beams.CATALOGUE if c.name == "gfrp-strip-ff-4s")
    sp = replace(beams.SPREAD, damage="mass_change")
    nominal = beams.nominal_beam(cb)
    f0 = beams.bending_frequencies_hz(nominal, cb.bc, cb.n_modes)
    rng = np.random.default_rng(5)
    beam_kg = cb.mass_per_length_kg_m * cb.length_m
    signs = set()
    for _ in range(8):
        pts, t, change = beams._mass_change(rng, cb, nominal, f0, sp)
        f1 = beams.bending_frequencies_hz(replace(nominal, masses=nominal.masses + pts), cb.bc, cb.n_modes)
        assert sum(p.mass_kg for p in pts) == pytest.approx(t["mass_ratio"] * beam_kg)
        assert np.max(np.abs(f1 / f0 - 1)) == pytest.approx(change) and change >= sp.min_drop
        if t["mass_ratio"] > 0:
            assert len(pts) == 1 and np.all(f1 < f0) and 0.01 <= t["mass_ratio"] <= 0.2
        else:
            assert len(pts) == beams.LOST_POINTS and np.max(f1 / f0 - 1) > 0
            assert -t["mass_ratio"] <= 0.5 * t["mass_width_m"] / cb.length_m + 1e-12
        signs.add(np.sign(t["mass_ratio"]))
    assert signs == {-1.0, 1.0}
    pairs = beams.simulate_beam_pairs(cb, 2, 3, sp)
    for p in pairs:
        t = p.truth
        assert t["damage_kind"] == ("mass_change" if t["damaged"] else None)
        assert t["damage_size"] == (t["mass_ratio"] if t["damaged"] else 0.0)
    slits = beams.simulate_beam_pairs(cb, 1, 3)
    assert [p.truth["slit_x_m"] for p in slits] == [p.truth["slit_x_m"] for p in beams.simulate_beam_pairs(
        cb, 1, 3, replace(beams.SPREAD, damage="slit"))]
