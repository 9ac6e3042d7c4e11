"""Benchmark: end-to-end ``generate`` and FRF reading vs a one-sample-at-a-time loop, in one run.

Run: ``.venv/bin/python -m experiments.benches.bench_datagen [--n 20000] [--naive 60] [--workers 2] [--json]``

All paths use the default config (beam 5, 20-element truth mesh, 4 measured
DOFs, Pilkey updating on the IIRS mass, 1024 FRF lines, baseline + current
state per sample):

* naive: Python loop over samples; full state-space eigen-solution of the
  truth model, :func:`physics.updating.pilkey`, measured and updated FRFs
  computed eagerly (:func:`datagen.naive.simulate_naive`, ``solution="full"``);
* generate: :func:`datagen.generation.generate` end to end on ``--workers``
  processes, including writing the shards, checksums and ``samples.parquet``;
* read, full FRFs: real/imag float32 tensors (both states, 4 DOFs, 1024
  lines) through :func:`datagen.torchdata.make_loader` with ``--workers``
  worker processes, synthesised on read, for the updated and the measured FRFs;
* read, classifier features: ``log10 |H|`` on the classifier's 96-point
  log-frequency grid, both states, 4 DOFs, synthesised only on the 168 lines
  the grid interpolates from: :func:`learn.network.features.load_pairs` (what ``train``
  reads; ``--workers`` threads, the whole call including the table and modal
  arrays) and the ``DataLoader`` with ``weights`` (``--workers`` processes).

Prints samples/s (wall clock) and samples per CPU second (user + system of
this process and its workers, which a machine shared with other jobs
distorts less), ratios measured in this run, bytes per sample on disk and
peak memory. Targets (issue 10): <= 16 kB/sample, generate >= 50x naive,
read >= 20,000 samples/s of FRF features on 2 cores. ``--config training``
runs the classifier's training configuration instead of the defaults.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import resource
import shutil
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.config import load_config, merge
from datagen.dataset import Dataset
from datagen.generation import generate
from datagen.naive import simulate_naive
from datagen.batch_inputs import draw_batch
from datagen.setup import get_setup
from datagen.store import finalize, read_manifest
from datagen.torchdata import make_loader
from experiments.benches.harness import parser, publish
from learn.network.features import grid_weights, load_pairs

__all__ = ["main"]


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process and its terminated children so far."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _vm_hwm_mb() -> float:
    """This process's peak resident memory (MB) from /proc (``ru_maxrss`` of a spawned process carries its
    parent's peak over the exec)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1]) / 1024
    return float("nan")


def _table_at_scale(root: str, rows: int) -> dict:
    """The samples table at ``rows`` rows: finalize streams shard tables into ``samples.parquet``, then
    two columns and one row group are read back. Runs in a fresh process (its peak memory is its own):
    the dataset's shard tables are hard-linked as many times as needed under a scratch directory."""
    import pyarrow.parquet as pq


    src = Path(root)
    m = read_manifest(src)
    scratch = src.parent / "table-at-scale"
    (scratch / "shards").mkdir(parents=True)
    os.link(src / "omega_rad_s.npy", scratch / "omega_rad_s.npy")
    shards, n = [], 0
    while n < rows:
        for e in m["shards"]:
            if n >= rows:
                break
            name = f"shard-{len(shards):06d}"
            (scratch / "shards" / name).mkdir()
            os.link(src / "shards" / e["name"] / "samples.parquet", scratch / "shards" / name / "samples.parquet")
            shards.append({**e, "name": name, "index": len(shards)})
            n += e["n_samples"]
    t = time.perf_counter()
    finalize(scratch, {**m, "shards": shards})
    out = {"table_rows": n, "table_finalize_s": time.perf_counter() - t,
           "table_bytes": (scratch / "samples.parquet").stat().st_size,
           "table_row_groups": pq.ParquetFile(scratch / "samples.parquet").metadata.num_row_groups,
           "table_finalize_peak_rss_MB": _vm_hwm_mb()}
    t = time.perf_counter()
    cols = Dataset(scratch, verify=False).table(["damage0_x_m", "damaged"])
    out["table_two_columns_s"] = time.perf_counter() - t
    t = time.perf_counter()
    f = pq.ParquetFile(scratch / "samples.parquet")
    group = f.read_row_group(f.metadata.num_row_groups // 2).to_pandas()
    out["table_one_row_group_s"] = time.perf_counter() - t
    out["table_read_peak_rss_MB"] = _vm_hwm_mb()
    assert len(cols) == n and len(group) > 0
    return out


def main(argv=None):
    ap = parser(__file__, __doc__, docs="datasets.md", json=True, workers=2)
    ap.add_argument("--n", type=int, default=20000, help="samples generated end to end and read back")
    ap.add_argument("--naive", type=int, default=60, help="samples for the per-sample loop")
    ap.add_argument("--batch", type=int, default=512, help="read batch size")
    ap.add_argument("--keep", help="directory to keep the generated dataset in (default: a temporary one)")
    ap.add_argument("--config", default=None, help="named generator config (default: the built-in defaults)")
    ap.add_argument("--table-rows", type=int, default=0,
                    help="also build the samples table at this many rows (e.g. 10000000) from the generated "
                         "shards' tables and time column and row-group reads")
    a = ap.parse_args(argv)
    if a.docs and a.config not in DOCS_BLOCKS:
        ap.error(f"--docs: docs/{a.docs} holds the tables of the default and the training config only")

    cfg = load_config(a.config) if a.config else merge({})
    res = {"config": a.config or "defaults (beam5, 20 truth elements, 1024 lines, IIRS mass)",
           "workers": a.workers, "n": a.n}
    res.update(_naive_rates(cfg, a.naive))
    tmp = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="bench_datagen_"))
    root = tmp / "ds"
    if root.exists():
        shutil.rmtree(root)
    try:
        res.update(_generate_rates(tmp, root, cfg, a.n, a.workers))
        res["ratio_generate_vs_naive_full"] = res["generate_samples_per_s"] / res["naive_full_samples_per_s"]
        res["ratio_cpu_efficiency_generate_vs_naive"] = (res["generate_samples_per_cpu_s"]
                                                         / res["naive_full_samples_per_cpu_s"])
        res.update(_read_rates(tmp, root, a.n, a.workers, a.batch))
        if a.table_rows:
            with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
                res.update(pool.submit(_table_at_scale, str(root), a.table_rows).result())
    finally:
        if not a.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    res["peak_rss_parent_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    res["peak_rss_largest_worker_MB"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        for k, v in res.items():
            print(f"{k:42s} {v:.1f}" if isinstance(v, float) else f"{k:42s} {v}")
    publish(a, DOCS_BLOCKS.get(a.config, ""), docs_table(res))
    return res


#: Block of docs/datasets.md per ``--config``.
DOCS_BLOCKS = {None: "datasets-defaults", "training": "datasets-training"}


def _sig(v: float, digits: int = 3) -> str:
    """``v`` rounded to ``digits`` significant figures, thousands separated by a space."""
    return f"{float(f'{v:.{digits}g}'):,.0f}".replace(",", " ")


def docs_table(res: dict) -> str:
    """Markdown table of one run for docs/datasets.md."""
    cfg = "`--config training`" if res["config"] == "training" else "default config"
    rate = "read_{}_{}_samples_per_s"
    return "\n".join([
        f"| {cfg}, {_sig(res['n'], 6)} samples, {res['workers']} worker{'s' * (res['workers'] != 1)} | value |",
        "| --- | --- |",
        f"| bytes per sample on disk | {_sig(res['bytes_per_sample'], 4)} |",
        f"| naive loop (samples/s) | {res['naive_full_samples_per_s']:.1f} |",
        f"| `generate` end to end (samples/s) | {_sig(res['generate_samples_per_s'], 4)} "
        f"({res['ratio_generate_vs_naive_full']:.0f}x the loop; "
        f"{res['ratio_cpu_efficiency_generate_vs_naive']:.0f}x per CPU second) |",
        f"| grid features, measured FRFs: DataLoader / `load_pairs` (samples/s) | "
        f"{_sig(res[rate.format('measured', 'grid_features_loader')])} / "
        f"{_sig(res[rate.format('measured', 'grid_features_load_pairs')])} |",
        f"| grid features, updated-model FRFs: DataLoader / `load_pairs` (samples/s) | "
        f"{_sig(res[rate.format('updated', 'grid_features_loader')])} / "
        f"{_sig(res[rate.format('updated', 'grid_features_load_pairs')])} |",
        f"| full FRFs (1024 lines): updated / measured (samples/s) | {_sig(res[rate.format('updated', 'frf')])} / "
        f"{_sig(res[rate.format('measured', 'frf')])} |"]) + "\n"


def _naive_rates(cfg, n: int) -> dict:
    """Samples per second (wall and CPU) of the per-sample loop, ``n`` samples, one thread, after a warm-up."""
    setup = get_setup(cfg)
    inp = draw_batch(np.random.default_rng(0), n, setup)
    with threadpool_limits(1):
        simulate_naive(setup, inp.take(slice(0, 2)), solution="full")  # warm-up (numba, caches)
        t, c = time.perf_counter(), _cpu_s()
        simulate_naive(setup, inp, solution="full")
        return {"naive_full_samples_per_s": n / (time.perf_counter() - t),
                "naive_full_samples_per_cpu_s": n / (_cpu_s() - c)}


def _generate_rates(tmp: Path, root: Path, cfg, n: int, workers: int) -> dict:
    """Samples per second (wall and CPU) and bytes per sample of ``generate`` writing ``n`` samples to ``root``,
    after a small warm-up dataset in ``tmp / "warm"`` (compile caches of the worker processes)."""
    generate(tmp / "warm", merge({"output": {"shard_size": 64}}), n=64 * workers, seed=9,
             workers=workers, progress=False)  # compile caches of the worker processes
    t, c = time.perf_counter(), _cpu_s()
    generate(root, cfg, n=n, seed=1, workers=workers, progress=False)
    return {"generate_samples_per_s": n / (time.perf_counter() - t),
            "generate_samples_per_cpu_s": n / (_cpu_s() - c),
            "bytes_per_sample": sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) / n}


def _read_rates(tmp: Path, root: Path, n_samples: int, workers: int, batch: int) -> dict:
    """Samples per second (wall and CPU) reading the dataset at ``root`` back: the torch loader of FRFs and of
    grid features, and :func:`learn.network.features.load_pairs`, for the updated and the measured FRFs."""
    res = {}
    W = grid_weights(np.load(root / "omega_rad_s.npy"))[0]
    for kind in ("updated", "measured"):
        for what, opts in (("frf", {}), ("grid_features_loader", {"features": "log_magnitude", "weights": W})):
            loader = make_loader(root, kind, columns=("stiffness_loss_Nm3",), batch_size=batch,
                                 num_workers=workers, **opts)
            c = _cpu_s()
            it = iter(loader)
            next(it)  # start the workers
            t = time.perf_counter()
            n = sum(b["frf"].shape[0] for b in it)
            res[f"read_{kind}_{what}_samples_per_s"] = n / (time.perf_counter() - t)
            del it, loader  # joins the workers, so their CPU time is counted
            res[f"read_{kind}_{what}_samples_per_cpu_s"] = (n + batch) / (_cpu_s() - c)
        load_pairs(tmp / "warm", frfs=(kind,), workers=workers)  # compiled kernels loaded in this process
        c, t = _cpu_s(), time.perf_counter()
        load_pairs(root, frfs=(kind,), workers=workers)
        res[f"read_{kind}_grid_features_load_pairs_samples_per_s"] = n_samples / (time.perf_counter() - t)
        res[f"read_{kind}_grid_features_load_pairs_samples_per_cpu_s"] = n_samples / (_cpu_s() - c)
    return res


if __name__ == "__main__":
    main()
