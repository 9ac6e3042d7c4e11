"""The loop on beams unlike the thesis's: a free-free steel bar with 6 accelerometers (two at its free ends) and a
pinned girder with one sensor; generate -> train -> classify by the CLI, checked against closed forms and the
samples' own labels."""

import json

import numpy as np
import pytest

from experiments.cli import main
from tests.systems import write_renumbered_uff

EI, M, L = 700.0, 3.14, 1.0
BAR = f"""name = "steel-bar"
bc = "free-free"
length_m = {L}
width_m = 0.04
thickness_m = 0.01
EI_Nm2 = {EI}
mass_per_length_kg_m = {M}
measured_x_m = [0.8, 0.0, 0.2, 0.4, 0.6, 1.0]
drive_x_m = 0.0
band_hz = [20.0, 700.0]
"""
FAST = 'base = "training"\n[output]\nshard_size = 200\n[measurement]\nlines = 512\n'


@pytest.fixture(scope="module")
def bar(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bar")
    (tmp / "bar.toml").write_text(BAR)
    (tmp / "fast.toml").write_text(FAST)
    assert main(["generate", "--beam", str(tmp / "bar.toml"), "--config", str(tmp / "fast.toml"), "--n", "1500",
                 "--seed", "4", "--out", str(tmp / "data")]) == 0
    assert main(["train", "--data", str(tmp / "data"), "--out", str(tmp / "model"), "--epochs", "25"]) == 0
    return tmp


def test_a_free_free_bar_is_simulated_on_its_own_test(bar):
    from datagen.dataset import Dataset
    from learn.network.features import beam_of_manifest, labels

    ds = Dataset(bar / "data")
    lay = ds.manifest["layout"]
    assert lay["bc"] == "free-free" and lay["modes"] == [1, 2, 3, 4] and not lay["thesis"]
    # bending frequencies of the nominal bar: beta L = 4.7300, 7.8532, 10.9956, 14.1372
    closed = np.square([4.7300, 7.8532, 10.9956, 14.1372]) * np.sqrt(EI / M) / (2 * np.pi * L**2)
    np.testing.assert_allclose(lay["frequencies_hz"], closed, rtol=2e-4)
    # specimens scatter around it (EI +-8 %, mass +-4 %): the baseline's mode-r frequency over the closed form
    f = ds.table([f"f{r}_hz_base" for r in range(1, 5)]).to_numpy() / closed
    assert 0.9 < f.min() and f.max() < 1.1 and np.ptp(f[:, 0] / f[:, 3]) < 0.02   # rigid-body modes left out
    assert ds.manifest["schema"]["frf_reference_row"] == 0 and len(ds.manifest["schema"]["measured_dofs"]) == 6
    assert ds.manifest["layout"]["updating"].startswith("no updated model: the band holds 4 mode(s)")
    H = ds.frf("measured", np.arange(3))
    assert H.shape == (3, 2, 6, 512)
    # the driving point (the free end x = 0) and the far free end move in phase in mode 1 and in antiphase in 2
    lam = ds.array("truth_poles", [0])[0, 0]
    psi = ds.array("truth_shapes", [0])[0, 0]
    used = lay["modes_idx"]
    ratio = (psi[5, used] / psi[0, used]).real
    np.testing.assert_allclose(np.sign(ratio), [1, -1, 1, -1])
    np.testing.assert_allclose(np.abs(lam[used]) / (2 * np.pi) / closed, f[0], rtol=1e-3)
    spec = beam_of_manifest(ds.manifest)
    np.testing.assert_allclose(spec.zone_edges_m, [0, 0.2, 0.4, 0.6, 0.8, 1.0])
    t = labels(ds.samples, spec)
    dam = t["damaged"]
    np.testing.assert_array_equal(t["element"][dam], np.ceil(t["x_over_L"][dam] / 0.2).clip(1, 5).astype(int))


def test_train_and_classify_files_of_the_bar(bar, capsys):
    from datagen.dataset import Dataset
    from physics.io import MeasuredFRF

    cfg = json.loads((bar / "model" / "config.json").read_text())
    assert set(cfg["networks"]) == {"modal", "frequency"} and cfg["beam"]["test"]["bc"] == "free-free"
    net = next(m for m in cfg["test_metrics"] if m["method"] == "network (modal)")
    assert net["false_alarm_rate"] <= 0.08            # about 60 intact test pairs: 5 false alarms at most
    ds = Dataset(bar / "data")
    t = ds.samples
    i = int(np.flatnonzero(t["damaged"] & (t["max_frequency_drop_rel"] > 0.02))[0])
    H = ds.array("frf_measured", [i])[0]
    xs = sorted(ds.manifest["layout"]["sensors_x_m"])
    dofs = tuple(f"{k + 2}:+Y" for k in range(6))
    files = []
    for st in range(2):
        frf = MeasuredFRF(ds.omega_rad_s / (2 * np.pi), H[st][:, None, :], dofs, (dofs[0],))
        files.append(str(write_renumbered_uff(bar / f"t{st}.uff", frf, {k + 2: 31 + k for k in range(6)},
                                              {31 + k: 1000 * x for k, x in enumerate(xs)}, [3, 0, 5, 1, 4, 2])))
    assert main(["classify", "--model", str(bar / "model"), "--baseline", *files, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["zone_edges_m"] == pytest.approx([0, 0.2, 0.4, 0.6, 0.8, 1.0])
    assert res["location_element"] is None and res["identification"]["modes_model"] == [1, 2, 3, 4]
    x_true = float(t["damage0_x_m"][i])
    assert res["damaged"] and abs(res["location_x_m"] - x_true) < 0.06, (res["location_x_m"], x_true)
    assert res["location_zone"] == int(np.ceil(x_true / 0.2))


@pytest.mark.parametrize(("change", "message"), [
    ("measured_x_m = [0.2, 0.2]", "sensors 1 and 2 coincide at 0.2 m"),
    ('bc = "pinned-free"', "leaves the beam a mechanism"),
    ("band_hz = [1.0, 5.0]", "'band_hz' [1, 5] holds no bending mode"),
    ("measured_x_m = [0.5, 1.3]", "'measured_x_m' positions must lie in [0, length_m = 1.0]"),
    # the band holds mode 2 alone (146 Hz), antisymmetric: the mid-point is its node
    ("band_hz = [100.0, 200.0]\nmeasured_x_m = [0.0, 0.5]",
     "sensor 2 at 0.5 m lies at a node of every mode in the band"),
])
def test_a_test_generate_cannot_run_is_refused_in_one_line(tmp_path, capsys, change, message):
    keys = tuple(line.split(" = ")[0] + " " for line in change.splitlines())
    text = "\n".join(line for line in BAR.splitlines() if not line.startswith(keys)) + f"\n{change}\n"
    (tmp_path / "b.toml").write_text(text)
    assert main(["generate", "--beam", str(tmp_path / "b.toml"), "--n", "10", "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert f"error: {tmp_path / 'b.toml'}: " in err and message in err and err.count("\n") == 1
    assert not (tmp_path / "d").exists()


def test_export_writes_the_measured_frfs_of_a_dataset_without_an_updated_model(bar, tmp_path, capsys):
    """6 sensors, 4 modes: no Lancaster/Pilkey update, so export writes the measured FRFs and refuses 'updated'."""
    assert main(["export", str(bar / "data"), "--samples", "3", "--format", "uff", "--out", str(tmp_path / "e")]) == 0
    assert sorted(p.name for p in (tmp_path / "e").iterdir()) == [
        "sample-000003_baseline_measured.uff", "sample-000003_current_measured.uff"]
    capsys.readouterr()
    assert main(["export", str(bar / "data"), "--samples", "3", "--kind", "updated", "--out", str(tmp_path / "u")]) == 2
    err = capsys.readouterr().err
    assert "no updated model: the band holds 4 mode(s) the sensors see and there are 6 sensors" in err
    assert not (tmp_path / "u").exists()


def test_a_beam_file_of_the_thesis_test_keeps_the_thesis_dataset(tmp_path):
    """beam5 written as a beam file (quarter-point sensors, no band) simulates what --preset beam5 does."""
    from datagen.dataset import Dataset
    from physics.beam import preset_beam, write_beam

    write_beam(tmp_path / "b5.toml", preset_beam("beam5"))
    cfg = tmp_path / "c.toml"
    cfg.write_text("[measurement]\nlines = 64\n")
    for name, extra in (("file", ["--beam", str(tmp_path / "b5.toml")]), ("preset", [])):
        assert main(["generate", *extra, "--config", str(cfg), "--n", "40", "--seed", "2",
                     "--out", str(tmp_path / name)]) == 0
    a, b = Dataset(tmp_path / "file"), Dataset(tmp_path / "preset")
    assert a.manifest["layout"]["thesis"] and a.manifest["schema"]["measured_dofs"] == ["2:y", "3:y", "4:y", "5:y"]
    np.testing.assert_allclose(a.array("truth_poles"), b.array("truth_poles"), rtol=1e-12)
    np.testing.assert_allclose(a.array("K_updated"), b.array("K_updated"), rtol=1e-9)


def test_natural_frequencies_alone_get_a_verdict_with_the_mirror_ambiguity_stated(bar, capsys):
    """Modal JSON with natural_frequencies_hz only: the frequency-route network and the frequency-only classical
    methods answer, and on this symmetric bar the verdict names the mirror position."""
    from datagen.dataset import Dataset

    ds = Dataset(bar / "data")
    t = ds.samples
    i = int(np.flatnonzero(t["damaged"] & (t["max_frequency_drop_rel"] > 0.02))[0])
    f = np.abs(ds.array("eigenvalues_measured", [i])[0]) / (2 * np.pi)
    files = []
    for st in range(2):
        (bar / f"f{st}.json").write_text(json.dumps({"natural_frequencies_hz": f[st].tolist()}))
        files.append(str(bar / f"f{st}.json"))
    assert main(["classify", "--model", str(bar / "model"), "--baseline", *files, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["input_route"] == "frequency" and res["damaged"]
    assert {c["method"] for c in res["classical_methods"]} == {"Cawley-Adams", "DLAC", "MDLAC"}
    x = res["location_x_m"]
    x_true = float(t["damage0_x_m"][i])
    assert min(abs(x - x_true), abs(1.0 - x - x_true)) < 0.08, (x, x_true)
    assert f"L - x = {1.0 - x:.3f} m" in res["location_ambiguity"]
    assert "natural frequencies without mode shapes" in " ".join(res["warnings"])


def test_inspect_checks_the_bars_shifts_against_free_free_curvatures(bar, tmp_path, capsys):
    """Single-slit frequency shifts of the free-free bar follow the closed-form free-free curvature squared (a
    cantilever's would not: its curvature is largest at x = 0, where a free end has none)."""
    assert main(["inspect", str(bar / "data"), "--out", str(tmp_path / "i"), "--json"]) == 0
    check = json.loads(capsys.readouterr().out)["curvature_check"]
    assert sorted(check) == ["mode1", "mode2", "mode3", "mode4"]
    for c in check.values():
        assert 0.8 < c["slope"] < 1.05 and c["r2"] > 0.9 and c["n"] > 500
    assert (tmp_path / "i" / "frf_overlay.png").stat().st_size > 10_000


def test_a_pair_outside_the_training_data_names_the_features_that_put_it_there(bar, capsys):
    """Modal data of an intact pair whose mode-2 frequency rises 10 % alone (no slit or day change of the training
    does that): outside, with df2 the largest term of the squared distance; the terms of every feature sum to it."""
    from datagen.dataset import Dataset
    from learn.network.features import feature_names, modal_features
    from learn.network.model_dir import load_model
    from physics.io import ModalData, write_modal_json

    ds = Dataset(bar / "data")
    i = int(np.flatnonzero(~ds.samples["damaged"].to_numpy())[0])
    lam = ds.array("eigenvalues_measured", [i])[0]
    vec = ds.array("eigenvectors_measured", [i])[0]
    lam_cur = lam[1] * np.array([1.0, 1.1, 1.0, 1.0])
    model = load_model(bar / "model")
    write_modal_json(bar / "m0.json", ModalData(lam[0], vec[0], model.beam.dofs))
    write_modal_json(bar / "m1.json", ModalData(lam_cur, vec[1], model.beam.dofs))
    assert main(["classify", "--model", str(bar / "model"), "--baseline", str(bar / "m0.json"), str(bar / "m1.json"),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert not res["in_distribution"] and res["training_percentile"] > 99.9
    top = res["distance_terms"][0]
    expected = 100 * (abs(lam_cur[1]) / abs(lam[0, 1]) - 1)                # 10 % on the pair's own small change
    assert top["feature"] == "df2 (%)" and top["value"] == pytest.approx(expected, rel=1e-6)
    assert top["training_std"] > 5 and top["share"] > 0.3
    assert "largest terms: df2 (%)" in res["out_of_distribution_reasons"][0]
    # 4 shifts, 6 sensors x 4 modes of shape changes, 4 interior points x 4 modes of curvature changes
    names = feature_names("modal", model.beam)
    assert len(names) == 4 + 24 + 16 and names[4] == f"dphi {model.beam.dofs[0]} m1"
    X = modal_features(np.stack([lam[0], lam_cur])[None], np.stack([vec[0], vec[1]])[None], 4, model.beam.test)
    est = model.networks["modal"]
    terms, _ = est.distance_terms(X)
    assert terms.shape == (1, 44) and terms.sum() == pytest.approx(est.mahalanobis(X)[0] ** 2, rel=1e-9)


def test_a_complete_dataset_of_a_beam_file_with_a_band_resumes(bar, capsys):
    """The beam file's band_hz and zones are recorded as JSON lists and compared as such: re-running the same
    generate command on the finished dataset is a resume, not 'a different config'."""
    before = (bar / "data" / "manifest.json").read_bytes()
    assert main(["generate", "--beam", str(bar / "bar.toml"), "--config", str(bar / "fast.toml"), "--n", "1500",
                 "--seed", "4", "--out", str(bar / "data")]) == 0
    assert "1500 samples" in capsys.readouterr().out
    assert (bar / "data" / "manifest.json").read_bytes() == before


@pytest.mark.parametrize(("sensors", "method", "folded"), [
    ([0.3, 0.5, 0.8], "DLAC", True), ([0.3, 0.5, 0.8], "network (frequency)", True),
    ([0.3, 0.5, 0.8], "network (modal)", False), ([0.3], "network (modal)", True)])
def test_mirror_ambiguous_locations_are_scored_on_the_half_beam(sensors, method, folded):
    """On a pinned-pinned beam every answer at the mirror image L - x of the truth: right for a method that reads
    frequencies alone or one sensor (scored folded, as classify answers), wrong for the network reading shapes."""
    from learn.explanations.classical import MethodOutput
    from learn.network.evaluate import metrics
    from learn.network.features import BeamSpec
    from physics.beam import beam_from_dict
    from physics.layout import layout_of

    beam = beam_from_dict({"name": "g", "bc": "pinned-pinned", "length_m": 1.0, "width_m": 0.04,
                           "thickness_m": 0.01, "EI_Nm2": EI, "mass_per_length_kg_m": M, "measured_x_m": sensors})
    spec = BeamSpec("g", 1.0, tuple(f"{k}:y" for k in range(len(sensors))), "iirs", layout_of(beam))
    x = np.array([0.05, 0.15, 0.3, 0.35, 0.45])
    truth = {"damaged": np.ones(5, bool), "max_drop": np.full(5, 0.01), "x_over_L": x,
             "element": spec.zone_of_x_over_L(x), "size": np.full(5, 0.01)}
    out = MethodOutput(method, np.ones(5), np.ones(5, bool), 1 - x, np.full(5, 0.01))
    m = metrics(out, truth, length_m=spec)
    assert m.element_accuracy == (1.0 if folded else 0.0)
    assert m.median_location_error_mm == pytest.approx(0.0 if folded else 1000 * np.median(np.abs(1 - 2 * x)))
