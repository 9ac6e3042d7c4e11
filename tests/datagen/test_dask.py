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
    import shutil
    import socket
    import subprocess
    import sys
    import time
    from pathlib import Path

    from experiments.cli import main

    dask_cli = shutil.which("dask", path=str(Path(sys.executable).parent))
    if dask_cli is None:
        pytest.skip("the dask command line is not installed")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([dask_cli, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--dashboard-address", ":0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        time.sleep(3)
        procs.append(subprocess.Popen([dask_cli, "worker", address, "--nworkers", "2", "--nthreads", "1",
                                       "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
        args = ["generate", "--n", "40", "--seed", "8", "--json"]
        assert main([*args, "--out", str(tmp_path / "cluster"), "--scheduler", address]) == 0
        assert main([*args, "--out", str(tmp_path / "local"), "--workers", "1"]) == 0
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(30)
    a, b = (json.loads((tmp_path / d / "manifest.json").read_text()) for d in ("cluster", "local"))
    assert a["shards"] and [e["checksums"] for e in a["shards"]] == [e["checksums"] for e in b["shards"]]  # bit for bit
