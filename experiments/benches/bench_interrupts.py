"""The kill/interrupt matrix of ``generate``: each interruption, then the same command resumed, compared
byte for byte with an uninterrupted run.

Run: ``.venv/bin/python -m experiments.benches.bench_interrupts [--cases all] [--json]``

Cases (a ``generate`` of 12 shards in a subprocess, ``--workers 1``):

* ``kill-start``: SIGKILL 0.2 s after the process starts (before or while it writes its first files);
* ``kill-mid-shard``: SIGKILL while the third shard is being computed/written;
* ``kill-manifest``: SIGKILL inside the second manifest rewrite, its temporary file half written;
* ``truncated-manifest``: ``manifest.json`` cut to half its length, then SIGKILL (a write that was not atomic);
* ``sigint`` / ``sigterm``: the signal after the second shard; the command must end with one stderr line
  and exit code 130 / 143.

A case passes when the resumed run exits 0 and every file of the directory equals the reference's (no
leftover temporaries, no lock). Prints one row per case and the number that passed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from experiments.benches.harness import parser

__all__ = ["CASES", "default_sigint", "main", "run_case", "run_matrix", "tree"]

CONFIG = "[output]\nshard_size = 3\n[measurement]\nlines = 32\n"
N = 36  # 12 shards
SEED = 5

#: A driver that SIGKILLs itself inside the given manifest rewrite (count) after writing half of it.
_KILL_IN_MANIFEST = """
import os, signal, sys
import datagen.store as store
calls = [0]
real = store.atomic_write_text
def write(path, text):
    calls[0] += 1
    if calls[0] == {count}:
        if {truncate}:
            open(path, "w").write(text[: len(text) // 2])
        else:
            open(path.parent / ".manifest.json.killed.tmp", "w").write(text[: len(text) // 2])
        os.kill(os.getpid(), signal.SIGKILL)
    real(path, text)
store.atomic_write_text = write
from experiments.cli import main
sys.exit(main(sys.argv[1:]))
"""

CASES = ("kill-start", "kill-mid-shard", "kill-manifest", "truncated-manifest", "sigint", "sigterm")


def _argv(out: Path, config: Path) -> list[str]:
    return ["generate", "--n", str(N), "--seed", str(SEED), "--workers", "1", "--config", str(config),
            "--out", str(out)]


def default_sigint():
    """SIGINT back to its default action in a child about to run a command."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _spawn(args, driver=None):
    """The command in a child whose SIGINT has its default action, as in a terminal's foreground job (a shell
    without job control starts background jobs with SIGINT ignored, and Python then keeps ignoring it)."""
    code = driver or "import sys; from experiments.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=default_sigint)


def tree(root: Path) -> dict:
    """{relative path: bytes} of every file below ``root``."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _wait_for_shards(out: Path, k: int, proc, timeout_s: float = 60.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s and proc.poll() is None:
        d = out / "shards"
        if d.is_dir() and sum(p.name.startswith("shard-") for p in d.iterdir()) >= k:
            return
        time.sleep(0.01)


def run_case(case: str, work: Path, config: Path, reference: dict) -> dict:
    """Interrupt one run as ``case`` says, resume it, compare with ``reference``; returns the case's record."""
    out = work / case
    args = _argv(out, config)
    expect_rc = {"sigint": 130, "sigterm": 143}.get(case, -signal.SIGKILL)
    if case in ("kill-manifest", "truncated-manifest"):
        proc = _spawn(args, _KILL_IN_MANIFEST.format(count=3, truncate=case == "truncated-manifest"))
    else:
        proc = _spawn(args)
        if case == "kill-start":
            time.sleep(0.2)
        else:
            _wait_for_shards(out, 3 if case == "kill-mid-shard" else 2, proc)
        sig = {"sigint": signal.SIGINT, "sigterm": signal.SIGTERM}.get(case, signal.SIGKILL)
        if proc.poll() is None:
            proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    first = {"rc": proc.returncode, "stderr_lines": len(lines), "stderr": lines[-1] if lines else ""}
    resumed = subprocess.run([sys.executable, "-m", "experiments.cli", *args], capture_output=True, text=True,
                             timeout=300)
    got = tree(out) if out.exists() else {}
    diff = sorted(k for k in reference.keys() | got.keys() if reference.get(k) != got.get(k))
    one_line = case not in ("sigint", "sigterm") or first["stderr_lines"] == 1
    ok = first["rc"] == expect_rc and one_line and resumed.returncode == 0 and not diff
    return {"case": case, **first, "expected_rc": expect_rc, "resume_rc": resumed.returncode,
            "resume_stderr": resumed.stderr.strip()[:200], "differing_files": diff[:5], "identical": not diff,
            "ok": ok}


def run_matrix(cases=CASES, work: Path | None = None) -> list[dict]:
    """Run the reference, then every case; returns one record per case."""
    with tempfile.TemporaryDirectory(prefix="bench-interrupts-") as tmp:
        work = Path(work or tmp)
        config = work / "c.toml"
        config.write_text(CONFIG)
        ref = work / "reference"
        done = subprocess.run([sys.executable, "-m", "experiments.cli", *_argv(ref, config)], capture_output=True,
                              text=True, timeout=300)
        if done.returncode != 0:
            raise RuntimeError(f"reference run failed: {done.stderr.strip()}")
        reference = tree(ref)
        return [run_case(c, work, config, reference) for c in cases]


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, json=True)
    ap.add_argument("--cases", default="all", help=f"comma-separated cases of {', '.join(CASES)} (default all)")
    a = ap.parse_args(argv)
    cases = CASES if a.cases == "all" else tuple(a.cases.split(","))
    env_path = os.environ.get("PYTHONPATH", "")
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(Path(__file__).resolve().parents[2]), env_path) if p)
    rows = run_matrix(cases)
    if a.json:
        print(json.dumps(rows, indent=1))
    else:
        for r in rows:
            print(f"{r['case']:<20} rc {r['rc']:>4} (want {r['expected_rc']:>4})  stderr lines {r['stderr_lines']}  "
                  f"resume rc {r['resume_rc']}  byte-identical {r['identical']}  {'ok' if r['ok'] else 'FAIL'}"
                  f"  {r['stderr'][:70]}")
        print(f"{sum(r['ok'] for r in rows)} of {len(rows)} cases ok")
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
