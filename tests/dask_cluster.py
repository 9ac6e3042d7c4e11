"""A Dask cluster started as a user starts one: `dask scheduler` and `dask worker` processes of this environment."""

import contextlib
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import pytest


@contextlib.contextmanager
def separate_cluster(n_workers: int = 2):
    """Yield the ``tcp://`` address of a scheduler with ``n_workers`` one-thread workers, each its own process
    (skips the test when the ``dask`` command line is not installed); every process is stopped on exit."""
    import distributed

    dask_cli = shutil.which("dask", path=str(Path(sys.executable).parent))
    if dask_cli is None:
        pytest.skip("the dask command line is not installed")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = [subprocess.Popen([dask_cli, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--dashboard-address", ":0"], **quiet)]
    try:
        procs.append(subprocess.Popen([dask_cli, "worker", address, "--nworkers", str(n_workers), "--nthreads", "1",
                                       "--no-dashboard"], **quiet))
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(n_workers, timeout=60)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(30)
