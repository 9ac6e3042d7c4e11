"""train / evaluate / classify end to end on a tiny generated dataset (real files, real CLI)."""

import json

import warnings

import numpy as np
from pathlib import Path
import pytest

from datagen.config import load_config, merge
from datagen.generation import generate
from experiments.cli import main
from experiments.cli.cmd_classify import KEYS
from learn.network.features import map_frf_to_grid
from physics.io import MeasuredFRF, ModalData, write_frf_npz, write_modal_json
from verdict_pin import _modal_files


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("learn")
    cfg = merge({"measurement": {"lines": 256}, "output": {"shard_size": 100}}, base=load_config("training"))
    generate(root / "data", cfg, n=200, seed=5, progress=False)
    assert main(["train", "--data", str(root / "data"), "--out", str(root / "model"), "--epochs", "3",
                 "--route", "measured", "--json"]) == 0
    return root


@pytest.fixture(scope="module")
def modal_model(tiny):
    """A model of the default (modal) route trained on the tiny dataset."""
    assert main(["train", "--data", str(tiny / "data"), "--out", str(tiny / "modal"), "--epochs", "2", "--json"]) == 0
    return tiny / "modal"


def format_3_copy(model_dir: Path, out: Path) -> Path:
    """The model directory as format 3 wrote it: networks that read every mode (the presence inputs folded into the
    first layer's bias, all present: the same answers on complete pairs), no covariance, one threshold."""
    import shutil

    import torch

    shutil.copytree(model_dir, out, dirs_exist_ok=True)
    cfg = json.loads((out / "config.json").read_text())
    cfg["format"] = "beam-damage-model/3"
    for route, meta in cfg["networks"].items():
        n_modes = 0
        if meta["params"].get("feature_modes") is not None:
            n_modes = max(meta["params"]["feature_modes"]) + 1
        for key in ("feature_modes", "missing_mode_probability", "min_modes"):
            meta["params"].pop(key, None)
        meta.pop("thresholds", None)
        with np.load(out / f"weights-{route}.npz") as z:           # format 3 wrote torch.save files
            t = {k: torch.as_tensor(z[k]) for k in z.files}
        (out / f"weights-{route}.npz").unlink()
        t.pop("ood.covariance", None)
        t.pop("ood.reference_features", None)
        if n_modes:
            W, b = t["net.trunk.0.weight"], t["net.trunk.0.bias"]
            t["net.trunk.0.weight"], t["net.trunk.0.bias"] = W[:, :-n_modes], b + W[:, -n_modes:].sum(dim=1)
        torch.save(t, out / f"weights-{route}.pt")
    (out / "config.json").write_text(json.dumps(cfg))
    return out


def test_train_writes_a_complete_model_directory(tiny):
    cfg = json.loads((tiny / "model" / "config.json").read_text())
    assert cfg["route"] == "measured" and set(cfg["networks"]) == {"measured", "modal", "frequency"}
    assert cfg["beam"] == {"name": "beam5", "length_m": 0.6095, "dofs": ["2:y", "3:y", "4:y", "5:y"],
                           "mass_model": "iirs"}
    assert len(cfg["training_data"][0]["manifest_checksum"]) == 64
    assert cfg["split"]["by"] == "specimen"
    assert cfg["truth_beam"]["name"] == "beam5" and cfg["truth_beam"]["length_m"] == 0.6095
    assert cfg["day_changes"] == {"temperature_stiffness_change": [-0.004, 0.004], "root_spring_change": [-0.08, 0.08]}


def test_load_pairs_reads_format_2_in_chunks(tiny):
    from datagen.dataset import Dataset
    from learn.network.features import GRID_RAD_S, labels, load_pairs

    ds = Dataset(tiny / "data")
    pairs = load_pairs(tiny / "data", frfs=("measured",), chunk=7)       # chunks straddle the 100-sample shards
    rows = [0, 99, 100, 150]
    want = map_frf_to_grid(ds.frf("measured", rows), ds.omega_rad_s, GRID_RAD_S)  # every line, dense map
    np.testing.assert_allclose(pairs.log_frf["measured"][rows], want, atol=1e-4)
    one = load_pairs(tiny / "data", frfs=("measured",), chunk=7, workers=1)
    assert np.array_equal(one.log_frf["measured"], pairs.log_frf["measured"])  # threads change nothing
    t = ds.table(["damaged", "n_damages", "noise_level", "max_frequency_drop_rel", "damage0_x_m"])
    lab = labels(pairs.table, 0.6095)
    np.testing.assert_array_equal(lab["damaged"], t["n_damages"].to_numpy() > 0)
    assert 0.1 < np.mean(~lab["damaged"]) < 0.4                       # a quarter intact in the training config
    dam = lab["damaged"]
    np.testing.assert_allclose(lab["x_over_L"][dam], t["damage0_x_m"].to_numpy()[dam] / 0.6095)
    assert np.all(lab["max_drop"][dam] > 0) and np.all(np.abs(lab["max_drop"][~dam]) < 1e-9)
    np.testing.assert_array_equal(pairs.table["noise_level"], t["noise_level"])


def test_format_1_and_other_beams_are_refused_in_one_line(tiny, tmp_path, capsys):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(tiny / "data", old)
    m = json.loads((old / "manifest.json").read_text())
    (old / "manifest.json").write_text(json.dumps({**m, "format": "beam-damage-dataset/1"}))
    assert main(["evaluate", "--model", str(tiny / "model"), "--data", str(old)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'beam-damage-dataset/1' is not supported" in err
    cfg = merge({"updating": {"mass_model": "lumped"}, "output": {"shard_size": 10}}, base=load_config("training"))
    generate(tmp_path / "lumped", cfg, n=10, seed=1, progress=False)
    assert main(["evaluate", "--model", str(tiny / "model"), "--data", str(tmp_path / "lumped")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mass model 'lumped' instead of 'iirs'" in err


def test_evaluate_writes_table_and_figures(tiny, capsys):
    assert main(["evaluate", "--model", str(tiny / "model"), "--data", str(tiny / "data"),
                 "--out", str(tiny / "eval"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    methods = {r["method"] for r in res["rows"]}
    assert {"network (measured)", "DLAC", "MDLAC", "Cawley-Adams", "sensitivity updating"} <= methods
    for f in ("metrics.csv", "roc.png", "confusion.png", "location_error.png", "reliability.png"):
        assert (tiny / "eval" / f).stat().st_size > 0


def test_classify_modal_json_prints_exactly_the_keys(tiny, capsys):
    base, cur = _modal_files(tiny, 0.5)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert tuple(res) == KEYS
    assert res["input_route"] == "modal" and 1 <= res["location_element"] <= 4
    assert sum(res["network"]["element_probabilities"]) == pytest.approx(1.0, abs=1e-4)
    # the verdict is the network's inside the training data, else the classical method's; both are shown
    inside = res["training_percentile"] <= 99.9 and not res["out_of_distribution_reasons"]
    assert res["in_distribution"] is inside and res["verdict_from"] == ("network" if inside else "classical")
    source = res["network"] if inside else res["classical"]
    assert (res["damaged"], res["location_element"]) == (source["damaged"], source["location_element"])
    assert res["classical"]["method"] in {m["method"] for m in res["classical_methods"]}
    assert {"method", "damaged", "location_element", "location_x_over_L"} <= set(res["classical"])
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--out", str(tiny / "cl")]) == 0
    assert "Classical (" in capsys.readouterr().out
    assert (tiny / "cl" / "classify.png").stat().st_size > 0


@pytest.fixture(scope="module")
def frf_pair(tiny) -> list:
    """The tiny dataset's first pair as two FRF files on another frequency grid (700 lines)."""
    from datagen.dataset import Dataset

    ds = Dataset(tiny / "data")
    H = ds.array("frf_measured")[:1]
    w = ds.omega_rad_s
    lines = np.linspace(w[0], w[-1], 700) / (2 * np.pi)     # a different frequency grid
    paths = []
    for s in (0, 1):
        h = np.stack([np.interp(lines * 2 * np.pi, w, H[0, s, k].real) + 1j * np.interp(lines * 2 * np.pi, w,
                      H[0, s, k].imag) for k in range(4)])[:, None, :]
        frf = MeasuredFRF(lines, h, ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",))
        paths.append(str(tiny / f"frf{s}.npz"))
        write_frf_npz(paths[-1], frf)
    return paths


#: The renumbered UFF files' nodes (model node -> test node) and the test nodes' positions (mm).
UFF_NODES, UFF_X_MM = {2: 101, 3: 102, 4: 103, 5: 104}, {101: 152.375, 102: 304.75, 103: 457.125, 104: 609.5}


@pytest.fixture(scope="module")
def renumbered_uffs(tiny, frf_pair) -> list:
    """``frf_pair`` as a test system writes it: nodes 101..104 in its own order, millimetres, dataset-15
    coordinates at the quarter points."""
    from systems import write_renumbered_uff

    from physics.io import read_frf

    return [str(write_renumbered_uff(tiny / f"renumbered{s}.uff", read_frf(p), UFF_NODES, UFF_X_MM, [3, 1, 0, 2]))
            for s, p in enumerate(frf_pair)]


def test_classify_frf_on_another_grid_is_accepted(tiny, frf_pair, capsys):
    paths = frf_pair
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", paths[0], paths[1], "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["input_route"] == "measured"


def test_classify_reads_a_one_sensor_frf_pair_on_its_frequencies_alone(tiny, frf_pair, capsys):
    """One response of the model's four (the tip, driven as in training): the frequency network's verdict."""
    from physics.io import read_frf, write_frf_npz

    one = []
    for s, p in enumerate(frf_pair):
        f = read_frf(p)
        one.append(str(tiny / f"one{s}.npz"))
        write_frf_npz(one[-1], MeasuredFRF(f.frequency_hz, f.frf[3:4], f.response_dofs[3:4], f.reference_dofs))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", *one, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["input_route"] == "frequency" and res["network"] is not None
    assert "natural frequencies without mode shapes: the verdict reads the frequencies alone" in res["warnings"]


def test_classify_places_a_renumbered_shuffled_mm_uff_by_its_geometry(tiny, frf_pair, renumbered_uffs, capsys):
    """``renumbered_uffs``: the same verdict as the canonical files."""
    from systems import write_renumbered_uff

    from physics.io import read_frf

    paths, uffs, nodes, x_mm = frf_pair, renumbered_uffs, UFF_NODES, UFF_X_MM
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", paths[0], paths[1], "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)
    assert ref["dof_positions"]["measured"]["source"] == "quarter-point convention"
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", uffs[0], uffs[1], "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    pos = res["dof_positions"]["measured"]
    assert pos["source"] == "uff geometry" and pos["dofs"] == ["104:+Y", "102:+Y", "101:+Y", "103:+Y"]
    assert pos["model_dofs"] == ["5:y", "3:y", "2:y", "4:y"]
    assert res["input_route"] == "measured" == ref["input_route"]
    for key in ("probability_damaged", "location_x_m", "location_std_m", "size"):   # UFF: 6-7 digits
        assert res["network"][key] == pytest.approx(ref["network"][key], rel=1e-5), key
    np.testing.assert_allclose(res["network"]["element_probabilities"], ref["network"]["element_probabilities"],
                               rtol=1e-6, atol=1e-9)
    # an extra sensor (node 105 at 400 mm, between the quarter points) is left out, and named
    extra = []
    for s, p in enumerate(paths):
        f = read_frf(p)
        f = MeasuredFRF(f.frequency_hz, np.concatenate([f.frf, 0.5 * (f.frf[1:2] + f.frf[2:3])]),
                        f.response_dofs + ("6:+Y",), f.reference_dofs)
        extra.append(str(write_renumbered_uff(tiny / f"extra{s}.uff", f, {**nodes, 6: 105},
                                              {**x_mm, 105: 400.0})))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", *extra, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert "105:+Y (x = 0.4 m)" in res["dof_positions"]["measured"]["detail"]
    assert res["network"]["probability_damaged"] == pytest.approx(ref["network"]["probability_damaged"], rel=1e-5)
    # node 103 placed at 400 mm: no sensor at model DOF 4:y, refused in one line naming the file and the DOFs
    write_renumbered_uff(tiny / "offgrid.uff", read_frf(paths[1]), nodes, {**x_mm, 103: 400.0})
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", uffs[0], str(tiny / "offgrid.uff")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "offgrid.uff" in err and "no measured DOF at model DOF(s) 4:y" in err
    assert "103:+Y -> none (x = 0.4 m)" in err


def test_classify_of_a_uff_pair_imports_no_heavy_library(tiny, renumbered_uffs):
    """One UFF pair classified in a fresh process (``renumbered_uffs``) loads none of torch (the network
    answers in NumPy), scikit-learn, scipy.signal, matplotlib (no figure asked), pandas, pyarrow, numba."""
    import os
    import subprocess
    import sys

    uffs = renumbered_uffs
    code = ("import json, sys; from experiments.cli import main; "
            f"code = main(['classify', '--model', {str(tiny / 'model')!r}, '--baseline', *{uffs!r}, '--json']); "
            "print(json.dumps([code, sorted(m for m in ('torch', 'sklearn', 'scipy.signal', 'matplotlib', "
            "'pandas', 'pyarrow', 'numba') if m in sys.modules)]))")
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert json.loads(proc.stdout.splitlines()[-1]) == [0, []], proc.stderr


def test_modal_route_model_classifies_frf_files_through_identified_modes(tiny, modal_model, capsys):
    capsys.readouterr()
    assert json.loads((modal_model / "config.json").read_text())["route"] == "modal"   # the default route
    from datagen.dataset import Dataset

    ds = Dataset(tiny / "data")
    H = ds.array("frf_measured")[:1]
    paths = []
    for s in (0, 1):          # the dataset's own lines: mode 1 (0.13 % damping) is a one-line peak on them
        paths.append(str(tiny / f"own{s}.npz"))
        write_frf_npz(paths[-1], MeasuredFRF(ds.omega_rad_s / (2 * np.pi), H[0, s][:, None, :],
                                             ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",)))
    assert main(["classify", "--model", str(tiny / "modal"), "--baseline", paths[0], paths[1], "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    f_true = np.abs(ds.array("truth_poles")[0, :, :4]) / (2 * np.pi)
    np.testing.assert_allclose(res["identification"]["baseline_frequencies_hz"], f_true[0], rtol=2e-3)
    np.testing.assert_allclose(res["identification"]["measured_frequencies_hz"], f_true[1], rtol=2e-3)
    assert res["input_route"] == "modal" and res["identification"]["source"] == "identified from FRFs"
    assert res["identification"]["method"] == "lscf"
    assert not any("not calibrated against the identification" in w for w in res["warnings"])


def test_refusals_and_bad_input_exit_2(tiny, capsys):
    base, cur = _modal_files(tiny, 0.5)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--mass", "lumped"]) == 2
    assert "mass model 'lumped' instead of 'iirs'" in capsys.readouterr().err
    obj = json.loads(open(cur).read())
    obj["dofs"] = ["2:y", "3:y", "4:y", "6:y"]
    (tiny / "other.json").write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, str(tiny / "other.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "other.json" in err
    assert "no measured DOF at model DOF(s) 5:y" in err and "6:y -> none (x = 0.7619 m)" in err
    obj["dofs"], obj["eigenvectors"] = ["2:y", "3:y", "4:y"], obj["eigenvectors"][:3]
    (tiny / "three.json").write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, str(tiny / "three.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "three.json" in err and "no measured DOF at model DOF(s) 5:y" in err
    assert main(["evaluate", "--model", str(tiny / "nowhere"), "--data", str(tiny / "data")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a model directory" in err


def test_classify_several_independent_uff_files_in_one_call(tiny, capsys):
    """Pairs written by the independent simulator (112-element Timoshenko beam, 0.5 Hz lines, accelerance in one
    file, node geometry in mm): one call with two MEASURED files gives two verdicts, each from modes LSCF/LSFD
    finds within 0.2 % of the simulator's natural frequencies."""
    from experiments.second_sim import simulate_pairs, write_pairs

    d = write_pairs(simulate_pairs("timoshenko", 3, 7), tiny / "indep")
    truth = json.loads((d / "truth.json").read_text())["pairs"]
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", str(d / "pair-000_baseline.uff"),
                 str(d / "pair-000_current.uff"), str(d / "pair-001_current.uff"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert isinstance(res, list) and [r["measured"] for r in res] == [str(d / "pair-000_current.uff"),
                                                                    str(d / "pair-001_current.uff")]
    for r, t in zip(res, truth[:2]):
        np.testing.assert_allclose(r["identification"]["measured_frequencies_hz"], t["current_frequencies_hz"],
                                   rtol=2e-3)
        np.testing.assert_allclose(r["identification"]["baseline_frequencies_hz"], truth[0]["baseline_frequencies_hz"],
                                   rtol=2e-3)
        assert r["verdict_from"] in ("network", "classical") and r["classical"]["method"]


def _beam_frfs(tmp, loss, element, fmax_hz, names=("base", "cur")):
    """Receptances at nodes 2..5 driven at node 2 (0.5 Hz lines from 2 Hz to ``fmax_hz``, 0.5 % modal damping) of
    the nominal beam 5 (40 elements, the models' root spring) and of the same beam with element ``element`` of 40
    losing ``loss`` of its EI, written as UFF files; modes 1-4 lie at 19.9, 125, 349, 684 Hz."""
    from physics.fem import beam_model
    from physics.io import write_uff58
    from physics.modal import undamped_modes
    from physics.properties import beam_preset

    p = beam_preset("beam5")
    f = np.ones((2, 40))
    f[1, element] -= loss
    m = beam_model(40, p.length_m, p.EI_Nm2, p.mass_per_length_kg_m, ei_factors=f,
                   root_spring=948.7 * p.EI_Nm2 / p.length_m)
    w, phi = undamped_modes(m.M, m.K)
    idx = m.index(["11:y", "21:y", "31:y", "41:y"])
    f_hz = np.arange(2.0, fmax_hz + 0.25, 0.5)
    om = 2 * np.pi * f_hz
    paths = []
    for s, name in enumerate(names):
        ph, wr = phi[s][idx, :8], w[s, :8, None]
        H = np.einsum("jr,r,rf->jf", ph, ph[0], 1 / (wr**2 - om**2 + 2j * 0.005 * wr * om))
        paths.append(str(tmp / f"{name}.uff"))
        write_uff58(paths[-1], MeasuredFRF(f_hz, H[:, None, :], ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",)))
    return paths


def test_a_band_below_mode_4_gets_the_network_beside_the_classical_methods_on_the_modes_found(tiny, modal_model,
                                                                                             capsys):
    """Files of 2-500 Hz (modes 1-3) and 2-250 Hz (modes 1-2): the network and every classical method answer on
    those modes; a slit in element 2 of 4 (1.2-1.6 % drops) is found there by the classical method, a uniform 0.1 %
    EI change (temperature) is not called damage. A format-3 model's network needs modes 1-4: the classical
    verdict."""
    base, cur = _beam_frfs(tiny, 0.5, 14, 500.0)
    assert main(["classify", "--model", str(modal_model), "--baseline", base, cur, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert tuple(res) == KEYS
    assert res["network"] is not None and res["identification"]["modes_classified"] == [1, 2, 3]
    assert np.isfinite(res["mahalanobis_distance"]) and 0 <= res["training_percentile"] <= 100
    assert all("4" not in t["feature"].split(" m")[-1] for t in res["distance_terms"])   # mode 4 has no term
    assert (f"mode 4 not identified in {base} (LSCF/LSFD found 3 modes in 2-500 Hz); mode 4 not identified in {cur} "
            "(LSCF/LSFD found 3 modes in 2-500 Hz): the network and the classical methods answer on modes 1, 2, 3"
            in res["warnings"])
    assert res["classical"]["damaged"] and res["classical"]["location_element"] == 2
    assert res["verdict_from"] == ("network" if res["in_distribution"] else "classical")
    old = format_3_copy(modal_model, tiny / "modal-format3")
    assert main(["classify", "--model", str(old), "--baseline", base, cur, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["verdict_from"] == "classical" and res["network"] is None and res["in_distribution"] is False
    assert res["mahalanobis_distance"] is None and res["training_percentile"] is None
    assert res["out_of_distribution_reasons"] == [
        f"mode 4 not identified in {base} (LSCF/LSFD found 3 modes in 2-500 Hz); mode 4 not identified in {cur} "
        "(LSCF/LSFD found 3 modes in 2-500 Hz): the network needs modes 1-4"]
    assert res["identification"]["modes_classified"] == [1, 2, 3]
    np.testing.assert_allclose(res["identification"]["baseline_frequencies_hz"], [19.886, 124.627, 348.962],
                               rtol=1e-4)
    assert res["damaged"] and res["location_element"] == 2 == res["classical"]["location_element"]
    assert (res["damaged"], res["location_x_m"]) == (res["classical"]["damaged"], res["classical"]["location_x_m"])
    assert {c["method"] for c in res["classical_methods"]} == {"Cawley-Adams", "DLAC", "MDLAC",
                                                                "sensitivity updating"}
    assert main(["classify", "--model", str(old), "--baseline", base, cur, "--out", str(tiny / "cut")]) == 0
    text = capsys.readouterr().out
    assert "Verdict (classical method on modes 1, 2, 3, the network needs modes 1-4): " in text
    assert "Network: no answer" in text
    assert json.loads((tiny / "cut" / "verdict.json").read_text())["network"] is None
    assert (tiny / "cut" / "classify.png").stat().st_size > 0
    # on complete pairs the format-3 copy answers as the model itself
    full = _beam_frfs(tiny, 0.5, 14, 800.0, ("fbase", "fcur"))
    got = [json.loads(capsys.readouterr().out) for m in (modal_model, old)
           if main(["classify", "--model", str(m), "--baseline", *full, "--json"]) == 0]
    assert got[0]["network"]["probability_damaged"] == pytest.approx(got[1]["network"]["probability_damaged"],
                                                                     rel=1e-4)
    assert got[0]["mahalanobis_distance"] == pytest.approx(got[1]["mahalanobis_distance"], rel=1e-6)
    # a model reading FRFs answers such a pair itself; the classical answer is on modes 1-3
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["input_route"] == "measured" and res["network"] is not None
    assert res["identification"]["modes_classified"] == [1, 2, 3] and res["classical"]["location_element"] == 2
    # two modes: still an answer, from both
    base2, cur2 = _beam_frfs(tiny, 0.5, 14, 250.0, ("base2", "cur2"))
    assert main(["classify", "--model", str(modal_model), "--baseline", base2, cur2, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["identification"]["modes_classified"] == [1, 2] and res["network"] is not None
    assert res["classical"]["damaged"]
    assert main(["classify", "--model", str(old), "--baseline", base2, cur2, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["network"] is None and res["damaged"] and res["verdict_from"] == "classical"
    # intact: a uniform 0.1 % EI change of the whole beam between the tests
    base3, cur3 = _beam_frfs(tiny, 0.0, 14, 500.0, ("base3", "cur3"))
    from physics.io import read_frf, write_uff58

    warm = read_frf(cur3)
    write_uff58(cur3, MeasuredFRF(warm.frequency_hz * np.sqrt(0.999), warm.frf / 0.999, warm.response_dofs,
                                  warm.reference_dofs))
    assert main(["classify", "--model", str(old), "--baseline", base3, cur3, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["verdict_from"] == "classical" and not res["damaged"]
    assert not any(c["damaged"] for c in res["classical_methods"])


def test_several_files_complete_and_incomplete_pairs_in_one_call(tiny, modal_model, capsys):
    base, full = _beam_frfs(tiny, 0.5, 14, 800.0, ("mbase", "mfull"))
    _, cut = _beam_frfs(tiny, 0.5, 14, 500.0, ("mbase-cut", "mcut"))
    assert main(["classify", "--model", str(modal_model), "--baseline", base, full, cut, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert [r["identification"]["modes_classified"] for r in res] == [[1, 2, 3, 4], [1, 2, 3]]
    assert res[0]["network"] is not None and res[0]["training_percentile"] is not None
    assert res[1]["network"] is not None and res[1]["training_percentile"] is not None
    assert res[1]["classical"]["location_element"] == 2
    # a format-3 model: the complete pair to the network, the other to the classical methods
    old = format_3_copy(modal_model, tiny / "modal-format3")
    assert main(["classify", "--model", str(old), "--baseline", base, full, cut, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res[0]["network"] is not None and res[1]["network"] is None and res[1]["verdict_from"] == "classical"
    assert res[1]["out_of_distribution_reasons"] == [
        f"mode 4 not identified in {cut} (LSCF/LSFD found 3 modes in 2-500 Hz): the network needs modes 1-4"]
    assert res[1]["location_element"] == 2
    # the baseline cut below mode 4: every pair falls back; verdicts.json is written
    assert main(["classify", "--model", str(old), "--baseline", str(tiny / "mbase-cut.uff"), full, cut,
                 "--out", str(tiny / "many")]) == 0
    many = json.loads((tiny / "many" / "verdicts.json").read_text())
    assert [r["network"] for r in many] == [None, None] and [r["location_element"] for r in many] == [2, 2]
    assert capsys.readouterr().out.count("Verdict (classical method on modes 1, 2, 3") == 2


def test_natural_frequencies_alone_get_a_figure_of_their_frequencies(tiny, capsys):
    """Modal data without shapes: the verdict and classify.png are written (the first panel marks each test's
    frequencies, no FRF is synthesised without shapes)."""
    paths = []
    for p in _modal_files(tiny, 0.5):
        obj = json.loads(open(p).read())
        del obj["eigenvectors"], obj["dofs"]
        paths.append(str(tiny / f"alone-{Path(p).name}"))
        Path(paths[-1]).write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", *paths, "--out", str(tiny / "alone")]) == 0
    assert "natural frequencies without mode shapes" in capsys.readouterr().err
    res = json.loads((tiny / "alone" / "verdict.json").read_text())
    assert res["input_route"] == "frequency" and tuple(res) == KEYS
    assert (tiny / "alone" / "classify.png").stat().st_size > 0


def test_a_missing_middle_mode_and_a_single_mode(tiny, capsys):
    """Modal data of a slit in element 1 of 4 whose current test misses mode 3: classified on modes 1, 2 and 4 by
    the network and the classical methods; a test holding mode 1 alone is refused in one line."""
    base, cur = _modal_files(tiny, 0.5)
    obj = json.loads(open(cur).read())
    keep = [0, 1, 3]
    for key in ("eigenvalues", "natural_frequencies_hz", "damping_ratios"):
        if key in obj:
            obj[key] = [obj[key][k] for k in keep]
    obj["eigenvectors"] = [[row[k] for k in keep] for row in obj["eigenvectors"]]
    (tiny / "no3.json").write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, str(tiny / "no3.json"),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["identification"]["modes_classified"] == [1, 2, 4] and res["network"] is not None
    assert res["input_route"] == "modal" and np.isfinite(res["mahalanobis_distance"])
    assert not any("MAC" in r for r in res["out_of_distribution_reasons"])      # the three modes pair
    assert (f"mode 3 not identified in {tiny / 'no3.json'} (it holds 3 modes): the network and the classical "
            "methods answer on modes 1, 2, 4") in res["warnings"]
    assert res["classical"]["damaged"] and res["classical"]["location_element"] == 1
    for key in ("eigenvalues", "natural_frequencies_hz", "damping_ratios"):
        if key in obj:
            obj[key] = obj[key][:1]
    obj["eigenvectors"] = [row[:1] for row in obj["eigenvectors"]]
    (tiny / "one.json").write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, str(tiny / "one.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "one.json: 1 of modes 1-4 found in both" in err
    assert "modes 2, 3, 4 not identified in" in err and "at least 2 common modes" in err


def test_roving_hammer_and_negative_senses_give_the_verdict_of_the_canonical_files(tiny, modal_model, capsys):
    """The same FRFs as a roving-hammer test writes them (one accelerometer at node 2, the hammer at nodes 2..5:
    responses and references swapped, H_ij = H_ji), and with node 4 measured towards -Y (its row negated,
    labelled '4:-Y'): the verdict and the identified frequencies are those of the canonical files."""
    from dataclasses import replace

    from physics.io import read_frf, write_uff58

    canonical = _beam_frfs(tiny, 0.4, 12, 800.0, names=("hb", "hc"))
    assert main(["classify", "--model", str(modal_model), "--baseline", *canonical, "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)
    # the classical answer is physics (the 2-epoch network's decision is not), so it pins the pair
    assert ref["classical"]["damaged"] and ref["classical"]["location_element"] == 2
    for variant in ("roving", "negative"):
        paths = []
        for p in canonical:
            f = read_frf(p)
            if variant == "roving":
                g = MeasuredFRF(f.frequency_hz, np.swapaxes(f.frf, 0, 1), f.reference_dofs, f.response_dofs)
            else:
                g = replace(f, frf=f.frf * np.array([1, 1, -1, 1])[:, None, None],
                            response_dofs=("2:+Y", "3:+Y", "4:-Y", "5:+Y"))
            paths.append(str(tiny / f"{variant}-{len(paths)}.uff"))
            write_uff58(paths[-1], g)
        assert main(["classify", "--model", str(modal_model), "--baseline", *paths, "--json"]) == 0
        res = json.loads(capsys.readouterr().out)
        for key in ("damaged", "location_element", "verdict_from"):
            assert res[key] == ref[key], (variant, key)
        for key, value in ref["classical"].items():
            assert res["classical"][key] == (value if isinstance(value, str) else pytest.approx(value, rel=1e-4))
        for key in ("probability_damaged", "location_x_m", "size"):
            assert res[key] == pytest.approx(ref[key], rel=1e-4), (variant, key)
        np.testing.assert_allclose(res["identification"]["measured_frequencies_hz"],
                                   ref["identification"]["measured_frequencies_hz"], rtol=1e-6)
        if variant == "roving":
            assert "reciprocity" in res["dof_positions"]["measured"]["detail"]


@pytest.mark.parametrize("kind", ["modal json", "uff"])
def test_the_printed_verdict_the_json_and_the_written_file_are_one_verdict(tiny, capsys, kind):
    """``classify`` prints the model's verdict text of the very result ``--json`` gives, and writes that result
    to verdict.json: for modal JSON files and for renumbered, shuffled UFF files (the FRF route)."""
    from systems import write_renumbered_uff

    from datagen.dataset import Dataset
    from learn.network.model_dir import load_model

    if kind == "modal json":
        files = _modal_files(tiny, 0.4)
    else:
        ds = Dataset(tiny / "data")
        H = ds.array("frf_measured")[1]
        files = [str(write_renumbered_uff(tiny / f"pin{s}.uff",
                                          MeasuredFRF(ds.omega_rad_s / (2 * np.pi), H[s][:, None, :],
                                                      ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",)),
                                          {2: 101, 3: 102, 4: 103, 5: 104},
                                          {101: 152.375, 102: 304.75, 103: 457.125, 104: 609.5}, [3, 1, 0, 2]))
                 for s in (0, 1)]
    args = ["classify", "--model", str(tiny / "model"), "--baseline", *files]
    assert main([*args, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    out = tiny / f"pin-{kind.replace(' ', '-')}"
    assert main([*args, "--out", str(out)]) == 0
    cap = capsys.readouterr()
    text = cap.out                                   # the verdict's warnings go to stderr (experiments.cli.main)
    assert text == load_model(tiny / "model").verdict_text({**res, "warnings": []}) \
        + f"\nverdict.json and classify.png in {out}\n"
    assert all(f"beam-damage classify: warning: {w}" in cap.err for w in res["warnings"])
    assert json.loads((out / "verdict.json").read_text()) == res
    assert res["input_route"] == ("modal" if kind == "modal json" else "measured")
    assert text.startswith(f"Verdict ({res['verdict_from']}")


def test_a_pair_far_outside_the_training_data_gets_finite_network_numbers_and_no_raw_warning(tiny, modal_model,
                                                                                             capsys, monkeypatch):
    """Beam 5's Table 4.5 against itself with every frequency halved: the network's inputs lie far outside the
    training data; its probability and sizes stay finite and no numpy overflow warning reaches the user."""
    from physics.io import format_complex, read_json

    src = Path(__file__).resolve().parents[2] / "physics" / "data" / "thesis" / "beam5_table_4_5.json"
    obj = read_json(src)
    obj["eigenvalues"] = [format_complex(complex(str(c).replace(" ", "")) / 2) for c in obj["eigenvalues"]]
    half = tiny / "half.json"
    half.write_text(json.dumps(obj))
    assert main(["classify", "--model", str(modal_model), "--baseline", str(src), str(half), "--json"]) == 0
    cap = capsys.readouterr()
    outside = "beam-damage classify: warning: the pair lies outside the training data"
    assert "overflow" not in cap.err and all(line.startswith(outside) for line in cap.err.splitlines()), cap.err
    res = json.loads(cap.out)
    assert res["verdict_from"] == "classical" and not res["in_distribution"]
    net = res["network"]
    assert 0.0 <= net["probability_damaged"] <= 1.0
    assert np.isfinite(net["size"]) and np.isfinite(net["size_std"])
    # the estimator itself when its network's outputs overflow (as a network's may on such pairs)
    import learn.network.estimator
    from learn.network.forward import forward
    from learn.network.model_dir import load_model

    est = load_model(modal_model).networks["modal"]

    def overflowing(weights, x):
        with np.errstate(over="ignore", invalid="ignore"):
            return {k: v * 1e308 * 10 for k, v in forward(weights, x).items()}   # +-inf (and NaN where 0 * inf)

    monkeypatch.setattr(learn.network.estimator, "forward", overflowing)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = est.predict_details(np.zeros((2, est.n_features_in_)))
    for name in ("probability_damaged", "x_over_L", "size", "size_std"):
        assert np.all(np.isfinite(getattr(d, name))), name


def _series_files(tmp, rng, name, n, slit=None):
    """``n`` modal JSON tests of the independent simulator's beam-5 cantilever whose 3 % bolted mass is re-placed
    +-3 cm around 0.7 L each time (temperature +-0.3 % EI), optionally with a slit."""
    from experiments.second_sim.fem import Beam, PointMass, assemble, modes

    p = []
    for k in range(n):
        L, EI, m = 0.6095, 26.9, 0.15792 / 1.219
        beam = Beam(L, EI * (1 + 0.003 * rng.uniform(-1, 1)), m, root_k_theta_Nm_rad=948.7 * EI / L,
                    masses=(PointMass(0.7 * L + rng.uniform(-0.03, 0.03), 0.03 * m * L),),
                    slits=() if slit is None else (slit,))
        asm = assemble(beam)
        md = modes(asm)
        w = 2 * np.pi * md.frequencies_hz[:4]
        phi = md.phi[asm.translation_dofs([L * q / 4 for q in range(1, 5)]), :4]
        p.append(str(tmp / f"{name}{k:02d}.json"))
        write_modal_json(p[-1], ModalData(-0.002 * w + 1j * w, phi.astype(complex), ("2:y", "3:y", "4:y", "5:y")))
    return p


def test_several_baselines_measure_the_normal_variation_and_decide_with_it(modal_model, tmp_path, capsys):
    """Ten baseline tests of a beam whose bolted mass is re-placed between tests (independent simulator): the
    verdict measures their scatter mode by mode, an intact test lies within it (never called damaged), a slit
    that lowers mode 1 by about 1 % lies beyond it; the explanations are weighed with the measured scatter. With
    one baseline the verdict says the normal variation is assumed."""
    from experiments.second_sim.fem import Slit

    rng = np.random.default_rng(4)
    base = _series_files(tmp_path, rng, "base", 10)
    intact = _series_files(tmp_path, rng, "intact", 2)
    slit = _series_files(tmp_path, rng, "slit", 1, Slit(0.1, 0.004, 0.6))
    assert main(["classify", "--model", str(modal_model), "--baseline", str(tmp_path / "base*.json"), *intact,
                 *slit, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert [tuple(r) for r in res] == [KEYS] * 3
    lnf = np.log([json.loads(Path(b).read_text())["natural_frequencies_hz"] for b in base])
    nv = [r["normal_variation"] for r in res]
    assert nv[0]["n_baselines"] == 10 and nv[0]["measured"] and nv[0]["reference_baseline"] in base
    np.testing.assert_allclose(nv[0]["frequency_std_pct"], 100 * np.std(lnf, axis=0, ddof=1), rtol=1e-6)
    assert max(nv[0]["frequency_std_pct"]) > 0.1                  # the masses' scatter, not the 0.1 % assumed
    assert [v["beyond"] for v in nv] == [False, False, True]
    assert not res[0]["damaged"] and not res[1]["damaged"]
    assert nv[2]["frequency_change_pct"][0] < -0.8 and nv[2]["p_value"] < 0.01 <= nv[0]["p_value"]
    assert isinstance(res[2]["frequency_change_std"], list) and len(res[2]["frequency_change_std"]) == 4
    assert res[2]["hypotheses"][0]["name"] != "intact"
    # a damage the network calls within the measured variation is withdrawn: the headline says the verdict
    withdrawn = {**res[2], "damaged": False, "verdict_from": "network", "warnings": [],
                 "network": {**res[2]["network"], "damaged": True, "probability_damaged": 0.9},
                 "normal_variation": {**nv[2], "beyond": False, "p_value": 0.5}}
    from learn.network.model_dir import load_model

    head = load_model(modal_model).verdict_text(withdrawn).splitlines()[0]
    assert head == ("Verdict (network, against the normal variation of 10 baseline tests): no damage detected: the "
                    "natural frequencies lie within it (p = 0.5), though the network alone calls it damaged "
                    "(probability 90.0%).")
    # one baseline: the variation is assumed, said in the text
    assert main(["classify", "--model", str(modal_model), "--baseline", base[0], intact[0]]) == 0
    out = capsys.readouterr().out
    assert "Normal variation between tests: assumed" in out
    assert main(["classify", "--model", str(modal_model), "--baseline", base[0], "--baseline", base[1],
                 "--baseline", base[2], intact[0]]) == 0
    assert "Normal variation measured on 3 baseline tests" in capsys.readouterr().out
    assert main(["classify", "--model", str(modal_model), "--baseline", str(tmp_path / "none*.json"), intact[0]]) == 2


def test_the_training_line_spacing_is_read_for_a_preset_beams_test_too():
    """A model of a beam file's test: its band over its lines; a preset beam's (no test): the recorded band
    (rad/s) over the lines; without lines, none (``classify`` then compares no spacing)."""
    from types import SimpleNamespace

    from experiments.cli.cmd_classify import training_line_spacing_hz

    def model(test, **measurement):
        return SimpleNamespace(beam=SimpleNamespace(test=test), recorded=SimpleNamespace(measurement=measurement))

    assert training_line_spacing_hz(model(SimpleNamespace(band_hz=(10.0, 810.0)), lines=801)) == 1.0
    preset = training_line_spacing_hz(model(None, band_rad_s=[1.0, 5000.0], lines=1024))
    assert preset == pytest.approx(4999.0 / (2 * np.pi) / 1023)
    assert training_line_spacing_hz(model(None, band_rad_s=[1.0, 5000.0])) is None


def test_a_mode_of_negative_damping_is_named_in_a_warning(tiny, modal_model, capsys):
    """Table 4.5 with mode 2's eigenvalue mirrored into the right half-plane (a negative damping ratio): classify
    runs and names the mode; the table itself gives no such warning."""
    from physics.io import format_complex, read_json

    src = Path(__file__).resolve().parents[2] / "physics" / "data" / "thesis" / "beam5_table_4_5.json"
    obj = read_json(src)
    lam = complex(str(obj["eigenvalues"][1]).replace(" ", ""))
    obj["eigenvalues"][1] = format_complex(complex(-lam.real, lam.imag))
    neg = tiny / "negative.json"
    neg.write_text(json.dumps(obj))
    assert main(["classify", "--model", str(modal_model), "--baseline", str(src), str(neg), "--json"]) == 0
    err = capsys.readouterr().err
    assert f"warning: {neg}: mode 2 has negative damping" in err and f"{src}: mode" not in err
