"""The Dask scheduler path gives the same shards as a local run."""

import numpy as np
import pytest

from datagen.config import merge
from datagen.parallel import generate
from datagen.store import ARRAYS, Dataset

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
