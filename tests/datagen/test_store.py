"""Dataset format: determinism across workers, atomic shards, resume, checksums, FRFs on read, loader."""

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from datagen.config import merge
from datagen.generation import generate
from datagen.dataset import Dataset, load_torch
from datagen.store import ARRAYS
from physics.errors import ConfigError, FileFormatError

CFG = merge({"output": {"shard_size": 7}, "measurement": {"lines": 64}, "damage": {"n_slits": [0, 2]}})
N = 30  # 5 shards, the last one short


def _arrays(root):
    ds = Dataset(root)
    return {k: ds.array(k) for k in ARRAYS}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    root = tmp_path_factory.mktemp("ref") / "ds"
    generate(root, CFG, n=N, seed=11, workers=1, progress=False)
    return root


def test_layout_and_readable_with_pandas_numpy(reference):
    m = json.loads((reference / "manifest.json").read_text())
    assert m["complete"] and m["seed"] == 11 and m["counts"]["samples"] == N and m["n_shards"] == 5
    assert m["package_version"] and m["config"] == CFG
    table = pd.read_parquet(reference / "samples.parquet")
    assert len(table) == N and list(table["sample_id"]) == list(range(N))
    poles = np.load(reference / "shards" / "shard-000004" / "truth_poles.npy", mmap_mode="r", allow_pickle=False)
    assert poles.shape == (2, 2, 8) and poles.dtype == np.complex128
    assert not (reference / "shards" / "shard-000004" / "frf_updated.npy").exists()  # FRFs are made when read
    frf = Dataset(reference).frf("updated", rows=[28, 29])
    assert frf.shape == (2, 2, 4, 64) and frf.dtype == np.complex64
    assert table["n_damages"].between(0, 2).all()
    assert (table["damaged"] == (table["n_damages"] > 0)).all()
    one = table[table.n_damages == 0]
    assert one["damage0_x_m"].isna().all() and (one["damage0_element4"] == 0).all()
    assert Dataset(reference).verify()


def test_workers_do_not_change_results(reference, tmp_path):
    generate(tmp_path / "w2", CFG, n=N, seed=11, workers=2, progress=False)
    a, b = _arrays(reference), _arrays(tmp_path / "w2")
    for k in ARRAYS:
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    ta = pd.read_parquet(reference / "samples.parquet")
    tb = pd.read_parquet(tmp_path / "w2" / "samples.parquet")
    pd.testing.assert_frame_equal(ta, tb)


def test_resume_after_interruption_is_byte_identical(reference, tmp_path):
    root = tmp_path / "ds"
    m = generate(root, CFG, n=N, seed=11, workers=1, progress=False, max_new_shards=2)
    assert not m["complete"] and len(m["shards"]) == 2
    # simulate a crash while a third shard was being written: a half-written temp dir
    tmp = root / "shards" / ".tmp-shard-000002-999"
    tmp.mkdir()
    (tmp / "frf_updated.npy").write_bytes(b"\x93NUMPY partial")
    ds = Dataset(root)  # a reader only sees recorded, complete shards
    assert len(ds.shards) == 2 and len(ds.samples) == 14
    from datagen.inspection import inspect_dataset

    assert inspect_dataset(root, tmp_path / "inspect")["warnings"] == [
        f"{root}: incomplete: 14 of 30 samples asked (an interrupted generate; the same command resumes it)"]
    m = generate(root, CFG, n=N, seed=11, workers=1, progress=False)
    assert m["complete"] and not tmp.exists()
    for name in ARRAYS:
        for i in range(5):
            f = f"shards/shard-{i:06d}/{name}.npy"
            assert (root / f).read_bytes() == (reference / f).read_bytes(), f
    assert (root / "samples.parquet").read_bytes() != b""
    pd.testing.assert_frame_equal(pd.read_parquet(root / "samples.parquet"),
                                  pd.read_parquet(reference / "samples.parquet"))


def test_renamed_but_unrecorded_shard_is_adopted_or_redone(reference, tmp_path):
    root = tmp_path / "ds"
    generate(root, CFG, n=N, seed=11, workers=1, progress=False, max_new_shards=3)
    m = json.loads((root / "manifest.json").read_text())
    m["shards"] = m["shards"][:2]  # crash between the rename and the manifest update
    (root / "manifest.json").write_text(json.dumps(m))
    # corrupt nothing: it is adopted after its checksums verify
    m2 = generate(root, CFG, n=N, seed=11, workers=1, progress=False, max_new_shards=0)
    assert [e["index"] for e in m2["shards"]] == [0, 1, 2]


def test_resume_refuses_other_config(reference, tmp_path):
    root = tmp_path / "ds"
    generate(root, CFG, n=N, seed=11, workers=1, progress=False, max_new_shards=1)
    with pytest.raises(ConfigError, match=r"another --seed \(11, not 12\)"):
        generate(root, CFG, n=N, seed=12, workers=1, progress=False)
    with pytest.raises(ConfigError, match=r"another --n \(30, not 31\)"):
        generate(root, CFG, n=N + 1, seed=11, workers=1, progress=False)
    other = merge({"measurement": {"lines": 65}}, base=CFG)
    with pytest.raises(ConfigError, match=r"another config \(measurement.lines\)"):
        generate(root, other, n=N, seed=11, workers=1, progress=False)


def test_seed_changes_data(reference, tmp_path):
    generate(tmp_path / "s", CFG, n=7, seed=12, workers=1, progress=False)
    a = Dataset(tmp_path / "s").array("frf_measured")
    assert not np.allclose(a, Dataset(reference).array("frf_measured")[:7])


def test_frf_on_read_is_identical_to_store_frf_and_independent_of_row_selection(reference, tmp_path):
    cfg = merge({**CFG, "output": {**CFG["output"], "store_frf": True}})
    generate(tmp_path / "st", cfg, n=N, seed=11, workers=1, progress=False)
    on_read, stored = Dataset(reference), Dataset(tmp_path / "st")
    for kind in ("measured", "updated"):
        files = np.concatenate([np.load(tmp_path / "st" / "shards" / e["name"] / f"frf_{kind}.npy")
                                for e in stored.shards])
        whole = on_read.frf(kind)
        assert whole.shape == (N, 2, 4, 64) and np.array_equal(whole, files, equal_nan=True), kind
        rows = [29, 3, 17, 3]  # any order, repeats, across shards: each sample's noise is its own
        assert np.array_equal(on_read.frf(kind, rows=rows), whole[rows], equal_nan=True), kind
    for k in ARRAYS:  # the stored definition of the samples does not depend on the option
        assert np.array_equal(on_read.array(k), stored.array(k), equal_nan=True), k


def test_a_subset_of_lines_has_exactly_the_values_of_the_full_frf(tmp_path):
    """Reading only some lines (the classifier's grid needs 168 of 1024) changes no value, noise floor included;
    the stored peak is the noise-free FRF's maximum, and shards written without it are still read exactly."""
    from physics.frf import pole_residue

    cfg = merge({**CFG, "measurement": {**CFG["measurement"], "frf_noise_floor": [1e-3, 1e-2]}})
    generate(tmp_path / "f", cfg, n=10, seed=3, workers=1, progress=False)
    ds = Dataset(tmp_path / "f")
    lines = np.array([0, 5, 6, 40, 63, 17])
    for kind in ("measured", "updated"):
        assert np.array_equal(ds.frf(kind, lines=lines), ds.frf(kind)[..., lines], equal_nan=True), kind
    lam, psi = ds.array("truth_poles"), ds.array("truth_shapes")
    clean = pole_residue(lam, psi * psi[..., :1, :], ds.omega_rad_s)       # numpy route, complex128
    np.testing.assert_allclose(ds.array("frf_peak"), np.abs(clean).max(axis=-1), rtol=1e-12)
    old = tmp_path / "old"                                                   # as written before frf_peak existed
    shutil.copytree(tmp_path / "f", old)
    m = json.loads((old / "manifest.json").read_text())
    for e in m["shards"]:
        (old / "shards" / e["name"] / "frf_peak.npy").unlink()
        del e["checksums"]["frf_peak.npy"], e["sizes"]["frf_peak.npy"]
    (old / "manifest.json").write_text(json.dumps(m))
    assert np.isnan(Dataset(old).array("frf_peak")).all()
    assert np.array_equal(Dataset(old).frf("measured", lines=lines), ds.frf("measured", lines=lines))
    from datagen.synth import SOURCES, measured_frf  # the same in float64: stored peak == peak of every line

    a = {k: ds.array(k) for k in SOURCES["measured"]}
    assert np.array_equal(measured_frf(a, ds.omega_rad_s, np.complex128, lines=lines),
                          measured_frf({**a, "frf_peak": None}, ds.omega_rad_s, np.complex128)[..., lines])


def test_loader_maps_log_magnitudes_onto_a_grid_from_the_lines_it_needs(reference):
    from datagen.torchdata import make_loader
    from learn.network.features import grid_weights

    ds = Dataset(reference)
    W = grid_weights(ds.omega_rad_s, np.geomspace(60.0, 4800.0, 20))[0]
    batches = list(make_loader(reference, "measured", batch_size=8, features="log_magnitude", weights=W))
    got = np.concatenate([b["frf"].numpy() for b in batches])
    want = np.log10(np.abs(ds.frf("measured").astype(complex))) @ W.T   # dense float64 map of every line
    assert got.shape == (N, 2, 4, 20)
    np.testing.assert_allclose(got, want, atol=2e-5)


def test_measured_frf_noise_matches_its_level(reference):
    """The measured FRF deviates from the noise-free truth by the recorded relative level (0.5%)."""
    from physics.frf import pole_residue

    ds = Dataset(reference)
    lam, psi = ds.array("truth_poles"), ds.array("truth_shapes")
    clean = pole_residue(lam, psi * psi[..., :1, :], ds.omega_rad_s)
    rel = (ds.frf("measured").astype(complex) - clean) / clean
    level = ds.table(["noise_level"])["noise_level"].to_numpy()
    assert np.allclose(level, 0.005)
    assert np.sqrt(np.mean(np.abs(rel) ** 2)) == pytest.approx(0.005, rel=0.03)
    # the two test days carry independent noise
    assert abs(np.corrcoef(rel[:, 0].real.ravel(), rel[:, 1].real.ravel())[0, 1]) < 0.05


def test_damaged_shard_is_refused_and_regenerated_on_resume(reference, tmp_path):
    root = tmp_path / "ds"
    shutil.copytree(reference, root)
    victim = root / "shards" / "shard-000002" / "truth_shapes.npy"
    raw = bytearray(victim.read_bytes())
    raw[-5] ^= 0xFF  # same size, one flipped byte: only the checksum sees it
    victim.write_bytes(bytes(raw))
    ds = Dataset(root)  # opening checks sizes only
    ds.frf("updated", rows=[0])  # shard 0 is fine
    with pytest.raises(FileFormatError, match="shard-000002.*truth_shapes.npy.*generate"):
        ds.frf("measured", rows=[15])
    (root / "shards" / "shard-000003" / "K_updated.npy").write_bytes(b"truncated")
    with pytest.raises(FileFormatError, match="shard-000003.*K_updated.npy"):
        Dataset(root)
    m = generate(root, CFG, n=N, seed=11, workers=1, progress=False)
    assert m["complete"] and Dataset(root).verify()
    for i in (2, 3):
        for f in ("truth_shapes.npy", "K_updated.npy"):
            p = f"shards/shard-{i:06d}/{f}"
            assert (root / p).read_bytes() == (reference / p).read_bytes(), p


def test_table_column_selection_and_row_groups(reference):
    import pyarrow.parquet as pq

    t = Dataset(reference).table(["sample_id", "stiffness_loss_Nm3"])
    assert list(t.columns) == ["sample_id", "stiffness_loss_Nm3"] and len(t) == N
    meta = pq.ParquetFile(reference / "samples.parquet").metadata
    assert meta.num_rows == N and meta.num_row_groups == 1
    m = json.loads((reference / "manifest.json").read_text())
    assert m["format"] == "beam-damage-dataset/2" and m["schema"]["states"] == ["baseline", "current"]
    assert m["schema"]["columns"]["stiffness_loss_Nm3"].startswith("N m^3")


def test_samples_table_is_written_in_whole_row_groups(reference, tmp_path, monkeypatch):
    """Shards of 7 rows are streamed into row groups of exactly ROW_GROUP rows (here 8), the rest last."""
    import pyarrow.parquet as pq

    from datagen import store

    root = tmp_path / "ds"
    shutil.copytree(reference, root)
    monkeypatch.setattr(store, "ROW_GROUP", 8)
    store.finalize(root, json.loads((root / "manifest.json").read_text()))
    meta = pq.ParquetFile(root / "samples.parquet").metadata
    assert [meta.row_group(i).num_rows for i in range(meta.num_row_groups)] == [8, 8, 8, 6]
    pd.testing.assert_frame_equal(pd.read_parquet(root / "samples.parquet"),
                                  pd.read_parquet(reference / "samples.parquet"))


def test_other_format_is_refused_with_a_clear_message(reference, tmp_path):
    root = tmp_path / "old"
    shutil.copytree(reference, root)
    m = json.loads((root / "manifest.json").read_text())
    m["format"] = "beam-damage-dataset/0"
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(FileFormatError, match="format 'beam-damage-dataset/0' is not supported"):
        Dataset(root)


def test_load_torch(reference):
    t = load_torch(reference, arrays=("frf_updated", "K_updated"), columns=("damage0_depth_m", "f1_hz_cur"))
    assert tuple(t["frf_updated"].shape) == (N, 2, 4, 64, 2)
    assert tuple(t["K_updated"].shape) == (N, 2, 4, 4)
    assert tuple(t["labels"].shape) == (N, 2)
    frf = Dataset(reference).array("frf_updated")
    assert np.allclose(t["frf_updated"][..., 1].numpy(), frf.imag)


def test_torch_loader_synthesises_in_workers_and_refuses_damaged_shards(reference, tmp_path):
    from datagen.torchdata import make_loader

    loader = make_loader(reference, "measured", columns=("stiffness_loss_Nm3",), batch_size=8, shuffle=True,
                         num_workers=2, seed=4)
    seen = {}
    for b in loader:
        assert b["frf"].shape[1:] == (2, 4, 64, 2) and b["labels"].shape[1] == 1
        for sid, h in zip(b["sample_id"].tolist(), b["frf"]):
            seen[sid] = h
    assert sorted(seen) == list(range(N))
    want = Dataset(reference).frf("measured")
    got = np.stack([seen[i][..., 0].numpy() + 1j * seen[i][..., 1].numpy() for i in range(N)])
    assert np.array_equal(got, want)  # workers and order do not change a sample's FRF (noise included)
    root = tmp_path / "bad"
    shutil.copytree(reference, root)
    p = root / "shards" / "shard-000001" / "noise_seed.npy"
    raw = bytearray(p.read_bytes())
    raw[-1] ^= 1
    p.write_bytes(bytes(raw))
    with pytest.raises(FileFormatError, match=r"shard-000001.*noise_seed.npy") as exc:
        make_loader(root, "measured", num_workers=2)
    assert "\n" not in str(exc.value)


@pytest.fixture(scope="module")
def other_seed(tmp_path_factory):
    root = tmp_path_factory.mktemp("other") / "ds"
    generate(root, CFG, n=N, seed=12, workers=1, progress=False)
    return root


def _swap_shard(reference, other, root, with_entry):
    shutil.copytree(reference, root)
    shutil.rmtree(root / "shards" / "shard-000002")
    shutil.copytree(other / "shards" / "shard-000002", root / "shards" / "shard-000002")
    if with_entry:
        m = json.loads((root / "manifest.json").read_text())
        m["shards"][2] = json.loads((other / "manifest.json").read_text())["shards"][2]
        (root / "manifest.json").write_text(json.dumps(m))


@pytest.mark.parametrize("with_entry", [False, True], ids=["shard-only", "shard-and-manifest-entry"])
def test_shard_of_another_seed_is_refused_and_regenerated(reference, other_seed, tmp_path, with_entry, capsys):
    root = tmp_path / "ds"
    _swap_shard(reference, other_seed, root, with_entry)
    m = json.loads((root / "manifest.json").read_text())
    assert m["identity"]["seed"] == 11 and m["shards"][2]["identity"]["seed"] == (12 if with_entry else 11)
    assert json.loads((root / "shards/shard-000002/checksums.json").read_text())["identity"]["seed"] == 12
    with pytest.raises(FileFormatError, match="shard-000002"):
        Dataset(root).verify_or_raise()
    m = generate(root, CFG, n=N, seed=11, workers=1, progress=False)
    assert "[2] will be regenerated" in capsys.readouterr().err
    assert m["complete"] and Dataset(root).verify()
    for f in sorted((reference / "shards" / "shard-000002").iterdir()):
        assert (root / "shards/shard-000002" / f.name).read_bytes() == f.read_bytes(), f.name
    assert (root / "samples.parquet").read_bytes() == (reference / "samples.parquet").read_bytes()


def test_copied_manifest_entry_is_named_by_the_loader(reference, other_seed, tmp_path):
    root = tmp_path / "ds"
    _swap_shard(reference, other_seed, root, with_entry=True)
    with pytest.raises(FileFormatError, match=r"shard-000002: belongs to another dataset .*seed 12, not 11"):
        Dataset(root)
