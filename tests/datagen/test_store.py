"""Dataset format: determinism across workers, atomic shards, resume, loader."""

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from datagen.config import merge
from datagen.parallel import generate
from datagen.store import ARRAYS, Dataset, load_torch
from physics.errors import ConfigError

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
    frf = np.load(reference / "shards" / "shard-000004" / "frf_updated.npy", mmap_mode="r", allow_pickle=False)
    assert frf.shape == (2, 2, 4, 64) and frf.dtype == np.complex64
    assert table["n_slits"].between(0, 2).all()
    one = table[table.n_slits == 0]
    assert one["slit1_x_m"].isna().all() and (one["slit1_element4"] == 0).all()
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
    with pytest.raises(ConfigError, match="seed"):
        generate(root, CFG, n=N, seed=12, workers=1, progress=False)


def test_seed_changes_data(reference, tmp_path):
    generate(tmp_path / "s", CFG, n=7, seed=12, workers=1, progress=False)
    a = Dataset(tmp_path / "s").array("frf_measured")
    assert not np.allclose(a, Dataset(reference).array("frf_measured")[:7])


def test_load_torch(reference):
    t = load_torch(reference, arrays=("frf_updated", "K_updated"), columns=("slit1_depth_m", "f1_hz_dam"))
    assert tuple(t["frf_updated"].shape) == (N, 2, 4, 64, 2)
    assert tuple(t["K_updated"].shape) == (N, 2, 4, 4)
    assert tuple(t["labels"].shape) == (N, 2)
    frf = Dataset(reference).array("frf_updated")
    assert np.allclose(t["frf_updated"][..., 1].numpy(), frf.imag)
