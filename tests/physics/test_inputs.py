"""Inputs are checked before they are read (physics.io.inputs): a 2 GB sparse file of each format is refused
within a memory limit far below its size."""

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = str(Path(__file__).resolve().parents[2])


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (1536 * 2**20, 1536 * 2**20))   # 1.5 GiB of address space


@pytest.mark.parametrize("name, argv, expect", [
    ("big.uff", ["identify"], "MiB"),
    ("big.csv", ["identify"], "MiB"),
    ("big.npz", ["identify"], "not a readable .npz"),
    ("big.json", ["update", "--modal"], "MiB"),
])
def test_a_2gb_sparse_file_is_refused_under_a_memory_limit(tmp_path, name, argv, expect):
    path = tmp_path / name
    with open(path, "wb") as f:
        f.truncate(2 << 30)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (ROOT, os.environ.get("PYTHONPATH")) if p),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "experiments.cli", *argv, str(path)], capture_output=True,
                          text=True, env=env, preexec_fn=_limit_memory, timeout=120)
    assert proc.returncode == 2, proc.stderr[-500:]
    assert proc.stderr.count("\n") == 1 and expect in proc.stderr, proc.stderr
