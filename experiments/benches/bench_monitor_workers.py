"""Benchmark: identification of a monitoring series' records over worker processes (``monitor --workers N``) and
over a Dask cluster (``monitor --scheduler``).

Run: ``python -m experiments.benches.bench_monitor_workers --out out/bench_monitor_workers [--n-tests 40]
[--kind frf] [--workers 2] [--scheduler tcp://host:8786 | --no-dask]``

Writes ``--n-tests`` records of the independent simulator's series (:mod:`experiments.second_sim.series`, FRFs as
UFF or output-only records as NPZ) once, identifies them (no cache) with one process, with ``--workers`` processes
(:func:`learn.monitor.workers.identify_files`) and on a Dask cluster (``--scheduler``'s, else a local cluster of
``--workers`` one-thread processes started for the run, its start not timed; left out without the ``dask`` extra or
with ``--no-dask``), checks that every run gives the same modes bit for bit (their cache entries' JSON text) and
prints records per second of each and their ratio to one process.
"""

from __future__ import annotations

import json
import os
import time
from contextlib import ExitStack
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from experiments.benches.harness import parser  # noqa: E402
from experiments.second_sim.series import SeriesConfig, simulate_series, write_series  # noqa: E402
from learn.monitor.identification import IdentificationSettings  # noqa: E402
from learn.monitor.workers import identify_files  # noqa: E402

__all__ = ["main"]


def _cluster(scheduler, workers: int):
    """A context giving a Dask client: of ``scheduler``, or of a local cluster of ``workers`` processes."""
    import distributed

    stack = ExitStack()
    if scheduler is None:
        lc = stack.enter_context(distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                          dashboard_address=None))
        scheduler = lc.scheduler_address
    client = stack.enter_context(distributed.Client(scheduler))
    client.run(lambda: __import__("learn.monitor.workers"))          # the workers' imports, not timed
    return stack, client


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
    p.add_argument("--scheduler", help="a running Dask scheduler's address (default: a local cluster)")
    p.add_argument("--no-dask", action="store_true", help="leave the Dask cluster out")
    a = p.parse_args(argv)
    out = Path(a.out)
    files = _files(out, a.n_tests, a.kind)
    settings = IdentificationSettings((5.0, 400.0)) if a.kind == "output-only" else IdentificationSettings()
    cache = out / "no-cache"                      # keys computed, entries returned, never written
    runs = {"1 worker": 1, f"{a.workers} workers": a.workers}
    stack = None
    if not a.no_dask:
        try:
            stack, client = _cluster(a.scheduler, a.workers)
            runs["dask " + ("cluster" if a.scheduler else f"local cluster, {a.workers} workers")] = client
        except ImportError:
            print("no Dask run: the 'dask' extra is not installed")
    res = {}
    try:
        for name, w in runs.items():
            t0 = time.perf_counter()
            modes, errors, pending = identify_files(files, settings, cache, w)
            dt = time.perf_counter() - t0
            res[name] = {"seconds": dt, "records_per_s": len(files) / dt, "entries": [text for _, text in pending],
                         "identified": sum(m is not None for m in modes)}
    finally:
        if stack is not None:
            stack.close()
    one = res["1 worker"]
    same = all(r["entries"] == one["entries"] for r in res.values())
    print(f"{len(files)} {a.kind} records on {os.cpu_count()} cores ({one['identified']} identified); identical "
          f"results: {same}")
    for name, r in res.items():
        print(f"  {name}: {r['records_per_s']:.2f} records/s ({r['seconds']:.1f} s), ratio to 1 worker "
              f"{r['records_per_s'] / one['records_per_s']:.2f}")
    return {"identical": same, **{f"records_per_s ({k})": r["records_per_s"] for k, r in res.items()}}


if __name__ == "__main__":
    main()
