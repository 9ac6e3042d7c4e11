"""The writer's lock of a dataset directory and re-runs that must not write: who holds it, stale locks."""

import json
import os
import socket
import subprocess
import sys

import pytest

from datagen.config import merge
from datagen.generation import generate
from datagen.lock import LOCK_NAME, LockedError
from experiments.cli import main

CFG = merge({"output": {"shard_size": 4}, "measurement": {"lines": 32}})


def _lock(root, pid, host=None):
    root.mkdir(parents=True, exist_ok=True)
    (root / LOCK_NAME).write_text(json.dumps({"pid": pid, "host": host or socket.gethostname(),
                                              "since": "2026-01-02T03:04:05Z"}))


@pytest.fixture
def live_pid():
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    yield proc.pid
    proc.kill()
    proc.wait()


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_second_writer_is_refused_naming_the_holder(tmp_path, live_pid, capsys):
    root = tmp_path / "ds"
    generate(root, CFG, n=8, seed=1, progress=False, max_new_shards=1)
    _lock(root, live_pid)
    before = {p.name: p.read_bytes() for p in root.rglob("*") if p.is_file()}
    with pytest.raises(LockedError, match=rf"pid {live_pid} on {socket.gethostname()} since 2026-01-02T03:04:05Z"):
        generate(root, CFG, n=8, seed=1, progress=False)
    (tmp_path / "c.toml").write_text("[output]\nshard_size = 4\n[measurement]\nlines = 32\n")
    rc = main(["generate", "--n", "8", "--out", str(root), "--seed", "1", "--config", str(tmp_path / "c.toml")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and f"pid {live_pid}" in err and "another `generate`" in err
    after = {p.name: p.read_bytes() for p in root.rglob("*") if p.is_file()}
    assert after == before  # nothing touched, the holder's lock kept


def test_a_lock_of_another_host_is_never_taken_over(tmp_path):
    root = tmp_path / "ds"
    _lock(root, _dead_pid(), host="elsewhere.example")
    with pytest.raises(LockedError, match="on elsewhere.example"):
        generate(root, CFG, n=4, seed=1, progress=False)
    assert (root / LOCK_NAME).exists()


@pytest.mark.parametrize("content", ["dead", "garbage"])
def test_a_stale_lock_is_taken_over_and_released(tmp_path, content):
    root = tmp_path / "ds"
    if content == "dead":
        _lock(root, _dead_pid())
    else:
        root.mkdir()
        (root / LOCK_NAME).write_text("{not json")
        os.utime(root / LOCK_NAME, (0, 0))
    m = generate(root, CFG, n=8, seed=1, progress=False)
    assert m["complete"] and m["counts"]["samples"] == 8
    assert sorted(p.name for p in root.iterdir() if p.name.startswith(".")) == []


def test_rerun_of_a_complete_dataset_writes_nothing(tmp_path):
    root = tmp_path / "ds"
    generate(root, CFG, n=8, seed=1, progress=False)
    stamp = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in root.rglob("*")}
    generate(root, CFG, n=8, seed=1, progress=False)
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in root.rglob("*")} == stamp


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_rerun_of_a_complete_dataset_in_a_read_only_directory(tmp_path):
    root = tmp_path / "ds"
    generate(root, CFG, n=8, seed=1, progress=False)
    dirs = [root, *[p for p in root.rglob("*") if p.is_dir()]]
    for d in dirs:
        d.chmod(0o555)
    try:
        assert generate(root, CFG, n=8, seed=1, progress=False)["complete"]
    finally:
        for d in dirs:
            d.chmod(0o755)
