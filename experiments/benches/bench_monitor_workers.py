"""Benchmark: identification of a monitoring series' records over worker processes (``monitor --workers N``).

Run: ``python -m experiments.benches.bench_monitor_workers --out out/bench_monitor_workers [--n-tests 40]
[--kind frf] [--workers 2]``

Writes ``--n-tests`` records of the independent simulator's series (:mod:`experiments.second_sim.series`, FRFs as
UFF or output-only records as NPZ) once, identifies them (no cache) with one process and with ``--workers``
processes (:func:`learn.monitor.workers.identify_files`), checks that both give the same modes bit for bit (their
cache entries' JSON text) and prints records per second of each and their ratio.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from experiments.benches.harness import parser  # noqa: E402
from experiments.second_sim.series import SeriesConfig, simulate_series, write_series  # noqa: E402
from learn.monitor.identification import IdentificationSettings  # noqa: E402
from learn.monitor.workers import identify_files  # noqa: E402

__all__ = ["main"]


def _files(out: Path, n: int, kind: str) -> list:
    d = out / f"series-{kind}-{n}"
    if not (d / "truth.json").is_file():
        cfg = SeriesConfig(n_tests=n, kind=kind, damage_day=None, seed=0)
        write_series(cfg, simulate_series(cfg), d)
    truth = json.loads((d / "truth.json").read_text())
    return [str(d / t["file"]) for t in truth["tests"]]


def main(argv=None) -> dict:
    p = parser(__file__, __doc__, out="out/bench_monitor_workers", workers=2)
    p.add_argument("--n-tests", type=int, default=40)
    p.add_argument("--kind", choices=("frf", "output-only"), default="frf")
    a = p.parse_args(argv)
    out = Path(a.out)
    files = _files(out, a.n_tests, a.kind)
    settings = IdentificationSettings((5.0, 400.0)) if a.kind == "output-only" else IdentificationSettings()
    cache = out / "no-cache"                      # keys computed, entries returned, never written
    res = {}
    for w in (1, a.workers):
        t0 = time.perf_counter()
        modes, errors, pending = identify_files(files, settings, cache, w)
        dt = time.perf_counter() - t0
        res[w] = {"seconds": dt, "records_per_s": len(files) / dt, "entries": [text for _, text in pending],
                  "identified": sum(m is not None for m in modes)}
    same = res[1]["entries"] == res[a.workers]["entries"]
    ratio = res[a.workers]["records_per_s"] / res[1]["records_per_s"]
    print(f"{len(files)} {a.kind} records on {os.cpu_count()} cores: 1 worker {res[1]['records_per_s']:.2f} records/s "
          f"({res[1]['seconds']:.1f} s), {a.workers} workers {res[a.workers]['records_per_s']:.2f} records/s "
          f"({res[a.workers]['seconds']:.1f} s): ratio {ratio:.2f}; identical results: {same} "
          f"({res[1]['identified']} identified)")
    return {"ratio": ratio, "identical": same, **{f"records_per_s_{w}": r["records_per_s"] for w, r in res.items()}}


if __name__ == "__main__":
    main()
