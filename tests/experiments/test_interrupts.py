"""Interrupted commands and one-line errors (experiments.cli)."""

import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from experiments.benches.bench_interrupts import default_sigint
from experiments.cli import main, one_line
from physics.io import to_jsonable


def _lock(path, pid):
    path.write_text(json.dumps({"pid": pid, "host": socket.gethostname(), "since": "2026-01-01T00:00:00"}))


def test_sigint_and_sigterm_end_generate_in_one_line_and_resume_completes_it(tmp_path):
    """Interrupted mid-run (after its first shard), generate says so in one line with exit 130 / 143; a second
    run completes the dataset with the samples of an uninterrupted run."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    cfg = tmp_path / "small-shards.toml"
    cfg.write_text('base = "training"\n[output]\nshard_size = 100\n')
    args = ["--n", "1200", "--config", str(cfg), "--seed", "3"]
    full = tmp_path / "full"
    assert main(["generate", *args, "--out", str(full)]) == 0
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        out = tmp_path / sig.name
        proc = subprocess.Popen([sys.executable, "-m", "experiments.cli", "generate", *args, "--out", str(out)],
                                env=env, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)
        deadline = time.time() + 120
        while not list((out / "shards").glob("shard-*")) and time.time() < deadline and proc.poll() is None:
            time.sleep(0.05)
        if proc.poll() is not None:
            pytest.skip("generate finished before it could be interrupted")
        proc.send_signal(sig)
        err = proc.communicate(timeout=120)[1]
        assert proc.returncode == code, err
        assert err.strip().count("\n") == 0 and ("interrupted" in err or "terminated" in err), err
        assert not (out / ".lock").exists()
        assert main(["generate", *args, "--out", str(out)]) == 0
        assert (out / "samples.parquet").read_bytes() == (full / "samples.parquet").read_bytes()
        for shard in sorted((full / "shards").iterdir()):
            for f in sorted(shard.iterdir()):
                assert (out / "shards" / shard.name / f.name).read_bytes() == f.read_bytes(), (sig, f)


def test_errors_and_json_stay_one_line_of_valid_utf8(tmp_path, capsys):
    bad = tmp_path / "two\nlines.uff"
    bad.write_text("not a universal file\n")
    assert main(["identify", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "two\\nlines.uff" in err
    assert one_line("a\tb\udcff") == "a\\tb\\udcff"
    json.dumps(to_jsonable({"file\udcff": "x\udcff"})).encode("utf-8")
