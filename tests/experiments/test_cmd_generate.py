"""CLI: generate (JSON summary, config errors naming the key) and inspect (curvature check)."""

import json

import numpy as np
import pandas as pd

from experiments.cli import main


def test_generate_json_and_inspect(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 40\n[measurement]\nlines = 32\n')
    rc = main(["generate", "--n", "120", "--out", str(tmp_path / "ds"), "--config", str(cfg), "--seed", "4",
               "--json"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert s["complete"] and s["counts"]["samples"] == 120 and s["n_shards"] == 3 and s["seed"] == 4
    assert len(pd.read_parquet(tmp_path / "ds" / "samples.parquet")) == 120
    rc = main(["inspect", str(tmp_path / "ds"), "--out", str(tmp_path / "ins"), "--json"])
    assert rc == 0
    r = json.loads(capsys.readouterr().out)
    # single slits of 0.2-0.3 mm: the shift follows curvature^2 of each mode
    for m in ("mode1", "mode2", "mode3", "mode4"):
        assert r["curvature_check"][m]["r2"] > 0.95
        assert 0.9 < r["curvature_check"][m]["slope"] < 1.4
    assert (tmp_path / "ins" / "shift_vs_position.png").stat().st_size > 1000


def test_bad_config_names_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[damage]\nwidth_m = [0.01]\n')
    rc = main(["generate", "--n", "5", "--out", str(tmp_path / "ds"), "--config", str(cfg)])
    assert rc == 2
    assert "damage.width_m" in capsys.readouterr().err
    cfg.write_text('[measurment]\nlines = 3\n')
    assert main(["generate", "--n", "5", "--out", str(tmp_path / "ds"), "--config", str(cfg)]) == 2
    assert "measurment" in capsys.readouterr().err


def test_export_round_trips_through_the_readers(tmp_path, capsys):
    from datagen.dataset import Dataset
    from physics.io import read_frf

    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 4\n[measurement]\nlines = 40\n')
    assert main(["generate", "--n", "10", "--out", str(tmp_path / "ds"), "--config", str(cfg), "--json"]) == 0
    capsys.readouterr()
    ds = Dataset(tmp_path / "ds")
    for fmt in ("uff", "npz", "csv"):
        rc = main(["export", str(tmp_path / "ds"), "--samples", "7,2", "--format", fmt, "--out",
                   str(tmp_path / fmt), "--json"])
        assert rc == 0
        files = json.loads(capsys.readouterr().out)["files"]
        assert len(files) == 2 * 2 * 2  # samples x states x kinds
        got = read_frf(tmp_path / fmt / f"sample-000007_current_measured.{fmt}")
        want = ds.frf("measured", rows=[7])[0, 1]
        assert got.response_dofs == ("2:+Y", "3:+Y", "4:+Y", "5:+Y") and got.reference_dofs == ("2:+Y",)
        assert np.allclose(got.frequency_hz, ds.omega_rad_s / (2 * np.pi), rtol=1e-5)
        assert np.abs(got.frf[:, 0, :] - want).max() <= 1e-5 * np.abs(want).max()
    assert main(["export", str(tmp_path / "ds"), "--samples", "3,99", "--out", str(tmp_path / "x")]) == 2
    assert "99" in capsys.readouterr().err
    rc = main(["export", str(tmp_path / "ds"), "--samples", "0,0,5,0", "--kind", "measured", "--format", "npz",
               "--out", str(tmp_path / "dup"), "--json"])
    assert rc == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["samples"] == [0, 5] and len(json.loads(out)["files"]) == 2 * 2
    assert json.loads(out)["warnings"] == ["--samples names 2 id(s) more than once; each sample is written once"]
    assert err == "beam-damage export: warning: --samples names 2 id(s) more than once; each sample is written once\n"
    assert sorted(p.name for p in (tmp_path / "dup").iterdir()) == [
        f"sample-{i:06d}_{s}_measured.npz" for i in (0, 5) for s in ("baseline", "current")]


def test_training_config_by_name_and_robustness_file_on_top(tmp_path, capsys):
    from datagen.config import load_config

    cfg = load_config("training")
    assert cfg["damage"]["intact_fraction"] == 0.25 and cfg["damage"]["ei_loss"] == [0.05, 0.9]
    assert cfg["measurement"]["frf_noise"] == [0.001, 0.03]
    robust = tmp_path / "r.toml"
    robust.write_text('base = "training"\n[damage]\nn_slits = [2, 3]\n[measurement]\nfrf_noise = [0.03, 0.1]\n')
    r = load_config(robust)
    assert r["damage"]["n_slits"] == [2, 3] and r["damage"]["intact_fraction"] == 0.25
    assert r["measurement"]["frf_noise"] == [0.03, 0.1] and r["measurement"]["frf_noise_floor"] == [1e-4, 1e-3]
    from datagen.config import named_configs

    assert {"training", "robust_slits", "robust_noise", "robust_environment"} <= set(named_configs())
    assert load_config("robust_slits")["damage"]["n_slits"] == [2, 3]
    assert load_config("robust_noise")["measurement"]["frf_noise"] == [0.03, 0.1]
    assert load_config("robust_environment")["specimen"]["root_spring_change"] == [-0.25, 0.25]
    assert main(["generate", "--n", "3", "--out", str(tmp_path / "ds"), "--config", "trainin"]) == 2
    assert "trainin" in capsys.readouterr().err


def _tree(root):
    """{relative path: bytes} of every file of a dataset directory."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_resumed_generate_repairs_damage_to_a_byte_identical_dataset(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 4\n[measurement]\nlines = 32\n')
    argv = ["generate", "--n", "10", "--config", str(cfg), "--seed", "3", "--json", "--out"]
    assert main([*argv, str(tmp_path / "ref")]) == 0
    root = tmp_path / "ds"
    assert main([*argv, str(root)]) == 0
    want = _tree(tmp_path / "ref")
    assert _tree(root) == want  # the same command twice: byte-identical
    capsys.readouterr()
    shard0, shard1 = root / "shards" / "shard-000000", root / "shards" / "shard-000001"
    inode0 = shard0.stat().st_ino
    for p, at in ((shard1 / "K_updated.npy", -5), (root / "omega_rad_s.npy", -3)):  # one flipped data byte each
        raw = bytearray(p.read_bytes())
        raw[at] ^= 0xFF
        p.write_bytes(bytes(raw))
    (root / "samples.parquet").write_bytes((root / "samples.parquet").read_bytes()[:1000])
    assert main(["inspect", str(root)]) == 2
    assert "omega_rad_s.npy: missing or damaged" in capsys.readouterr().err

    assert main([*argv, str(root)]) == 0  # resumed: repairs what the checksums show damaged
    err = capsys.readouterr().err
    assert "1 damaged shard(s) [1] will be regenerated" in err
    assert "omega_rad_s.npy: missing or damaged; rewritten from the config" in err
    got = _tree(root)
    assert got.keys() == want.keys()
    assert [k for k in want if got[k] != want[k]] == []
    m, m_ref = (json.loads((r / "manifest.json").read_text()) for r in (root, tmp_path / "ref"))
    assert m["checksums"] == m_ref["checksums"]  # omega's checksum is the config's, not the damaged file's
    assert [e["checksums"] for e in m["shards"]] == [e["checksums"] for e in m_ref["shards"]]
    assert shard0.stat().st_ino == inode0  # the undamaged shard was kept, not recomputed
    assert main(["inspect", str(root), "--out", str(tmp_path / "ins")]) == 0


def test_refused_seed_leaves_nothing_that_blocks_the_corrected_run(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 4\n[measurement]\nlines = 32\n')
    out = tmp_path / "ds"
    assert main(["generate", "--n", "4", "--config", str(cfg), "--out", str(out), "--seed", "-1"]) == 2
    assert capsys.readouterr().err == ("beam-damage generate: error: --seed: seed must be an integer >= 0 "
                                       "(numpy SeedSequence), got -1\n")
    assert not out.exists()
    assert main(["generate", "--n", "4", "--config", str(cfg), "--out", str(out), "--seed", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["complete"]


def test_a_run_failing_on_its_config_names_the_cause_and_leaves_nothing(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 10\n[measurement]\nlines = 32\nfrequency_noise = 0.5\ndamping_noise = 0.5\n'
                   'shape_noise = 0.5\nfrf_noise = 0.5\n')
    out = tmp_path / "ds"
    assert main(["generate", "--n", "30", "--config", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "measured natural frequencies to <= 0" in err and "frequency_noise 0.5" in err
    assert "conjugate pairs" not in err
    assert not out.exists()


BAR_ONE_MODE = """name = "steel-bar"
bc = "free-free"
length_m = 1.0
width_m = 0.04
thickness_m = 0.01
EI_Nm2 = 700.0
mass_per_length_kg_m = 3.14
measured_x_m = [0.8, 0.0, 0.2, 0.4, 0.6, 1.0]
drive_x_m = 0.0
band_hz = [20.0, 100.0]
"""


def test_a_band_holding_fewer_modes_than_classify_needs_is_refused_up_front(tmp_path, capsys):
    """The free-free bar's first bending mode is (4.7300)^2 sqrt(EI/m) / (2 pi L^2) = 53.17 Hz, its second
    146.6 Hz: a 20-100 Hz band holds one; generate refuses before simulating, and train refuses such a dataset
    before reading it, with classify's rule (learn.network.mode_count)."""
    from learn.network.mode_count import MIN_MODES

    (tmp_path / "bar.toml").write_text(BAR_ONE_MODE)
    f1 = 4.7300 ** 2 * np.sqrt(700.0 / 3.14) / (2 * np.pi)
    rc = main(["generate", "--beam", str(tmp_path / "bar.toml"), "--n", "4", "--out", str(tmp_path / "ds")])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == "" and cap.err.count("\n") == 1 and not (tmp_path / "ds").exists()
    assert (f"'band_hz' [20, 100] holds 1 mode(s) the sensors see (mode(s) 1 at {f1:.4g} Hz); classify needs at "
            f"least {MIN_MODES} common modes") in cap.err
    # a dataset whose manifest records such a test (the thesis's, its layout cut to mode 1) is refused by train
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 20\n[measurement]\nlines = 32\n')
    assert main(["generate", "--n", "20", "--out", str(tmp_path / "th"), "--config", str(cfg), "--json"]) == 0
    capsys.readouterr()
    path = tmp_path / "th" / "manifest.json"
    m = json.loads(path.read_text())
    lay = m["layout"]
    lay.update(thesis=False, modes=[1], modes_idx=[0], frequencies_hz=lay["frequencies_hz"][:1], band_hz=[5.0, 60.0])
    path.write_text(json.dumps(m))
    rc = main(["train", "--data", str(tmp_path / "th"), "--out", str(tmp_path / "model"), "--epochs", "1"])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == "" and cap.err.count("\n") == 1 and not (tmp_path / "model").exists()
    assert "'band_hz' [5, 60] holds 1 mode(s) the sensors see (mode(s) 1 at 19.93 Hz); classify needs at least" \
        in cap.err


def test_export_labels_quarter_point_sensors_by_the_convention_every_reader_places():
    """A free-free bar's truth mesh numbers its quarter-point sensors 9, 17, 25, 33: they are written 2..5 (node N at
    (N - 1) L / 4), the drive at 0.25 m node 2; sensors elsewhere keep their nodes, with a warning, and their
    positions in the node geometry of the metadata."""
    import warnings

    from experiments.cli.cmd_export import _labels

    schema = {"measured_dofs": ["9:y", "17:y", "25:y", "33:y"], "frf_reference_dof": "9:y"}
    layout = {"length_m": 1.0, "measured_x_m": [0.25, 0.5, 0.75, 1.0], "drive_x_m": 0.25}
    resp, ref, meta = _labels({"schema": schema, "layout": layout})
    assert resp == ("2:+Y", "3:+Y", "4:+Y", "5:+Y") and ref == ("2:+Y",)
    assert meta["geometry"]["nodes_m"] == {"2": [0.25, 0.0, 0.0], "3": [0.5, 0.0, 0.0], "4": [0.75, 0.0, 0.0],
                                           "5": [1.0, 0.0, 0.0]}
    schema = {"measured_dofs": ["5:y", "9:y", "13:y", "16:y"], "frf_reference_dof": "16:y"}
    layout = {"length_m": 1.0, "measured_x_m": [0.25, 0.5, 0.75, 0.9375], "drive_x_m": 0.9375}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        resp, ref, meta = _labels({"schema": schema, "layout": layout})
    assert resp == ("5:+Y", "9:+Y", "13:+Y", "16:+Y") and ref == ("16:+Y",)
    assert meta["geometry"]["nodes_m"]["16"] == [0.9375, 0.0, 0.0]
    assert len(caught) == 1 and "do not all sit at the quarter points" in str(caught[0].message)
    assert _labels({"schema": {"measured_dofs": ["2:y"], "frf_reference_dof": "5:y"}}) == (("2:+Y",), ("5:+Y",), {})
