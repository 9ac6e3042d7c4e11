"""The Dask scheduler path gives the same shards as a local run."""

import numpy as np
import pytest

from datagen.config import merge
from datagen.generation import generate
from datagen.dataset import Dataset
from datagen.store import ARRAYS

distributed = pytest.importorskip("distributed")


def test_dask_local_cluster_identical_to_local(tmp_path):
    cfg = merge({"output": {"shard_size": 5}, "measurement": {"lines": 32}})
    generate(tmp_path / "local", cfg, n=12, seed=5, workers=1, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc:
        generate(tmp_path / "dask", cfg, n=12, seed=5, scheduler=lc.scheduler_address, progress=False)
    a, b = Dataset(tmp_path / "local"), Dataset(tmp_path / "dask")
    for k in ARRAYS:
        assert np.array_equal(a.array(k), b.array(k), equal_nan=True), k
    assert a.samples.equals(b.samples)


@pytest.mark.slow
def test_cli_on_a_separately_started_cluster_identical_to_local(tmp_path):
    """`dask scheduler` and `dask worker` as a user starts them, `generate --scheduler tcp://...`."""
    import json

    from dask_cluster import separate_cluster
    from experiments.cli import main

    with separate_cluster(2) as address:
        args = ["generate", "--n", "40", "--seed", "8", "--json"]
        assert main([*args, "--out", str(tmp_path / "cluster"), "--scheduler", address]) == 0
        assert main([*args, "--out", str(tmp_path / "local"), "--workers", "1"]) == 0
    a, b = (json.loads((tmp_path / d / "manifest.json").read_text()) for d in ("cluster", "local"))
    assert a["shards"] and [e["checksums"] for e in a["shards"]] == [e["checksums"] for e in b["shards"]]  # bit for bit
