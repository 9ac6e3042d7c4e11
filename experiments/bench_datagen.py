"""Benchmark: batched dataset pipeline vs a one-sample-at-a-time loop, side by side in one run.

Run: ``.venv/bin/python -m experiments.bench_datagen [--n 20000] [--naive 100] [--workers 2]``

Both paths simulate the same pipeline on the default config (beam 5, 20-element
truth mesh, 4 measured DOFs, Pilkey updating on the IIRS mass, 1024 FRF lines,
reference + damaged state per sample):

* naive: Python loop over samples; full state-space eigen-solution of the
  truth model, :func:`physics.updating.pilkey`, FRFs by direct inversion
  (:func:`datagen.pipeline.simulate_naive`, ``modes="full"``);
* naive-projection: the same loop with the batched path's modal shortcut;
* batched: :func:`datagen.pipeline.simulate_shard` (vectorised chunks), one
  process, then all ``--workers`` processes over shards.

Prints samples/s, the ratio batched/naive and peak memory (tracemalloc for the
one-process batched shard, ru_maxrss of the parent and of the workers).
Disk writing is not included (see ``beam-damage generate`` for end-to-end rates).
"""

from __future__ import annotations

import argparse
import json
import resource
import time
import tracemalloc
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np


def _shard(args):
    from threadpoolctl import threadpool_limits

    from datagen.config import merge
    from datagen.pipeline import get_setup, simulate_shard

    seed, index, n = args
    setup = get_setup(merge({}))
    with threadpool_limits(1):
        simulate_shard(setup, np.random.SeedSequence(seed, spawn_key=(index,)), n)
    return n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="samples for the multi-process batched run")
    ap.add_argument("--naive", type=int, default=60, help="samples for the per-sample loops")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--shard", type=int, default=1000)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    from threadpoolctl import threadpool_limits

    from datagen.config import merge
    from datagen.pipeline import draw_batch, get_setup, simulate_naive, simulate_shard

    setup = get_setup(merge({}))
    res = {"config": "defaults (beam5, 20 truth elements, 1024 lines, IIRS mass)", "workers": a.workers}
    inp = draw_batch(np.random.default_rng(0), a.naive, setup)
    with threadpool_limits(1):
        simulate_naive(setup, inp.take(slice(0, 2)), modes="full")
        t = time.perf_counter()
        simulate_naive(setup, inp, modes="full")
        res["naive_full_samples_per_s"] = a.naive / (time.perf_counter() - t)
        t = time.perf_counter()
        simulate_naive(setup, inp, modes="projection")
        res["naive_projection_samples_per_s"] = a.naive / (time.perf_counter() - t)
        simulate_shard(setup, np.random.SeedSequence(1), 256)
        tracemalloc.start()
        t = time.perf_counter()
        simulate_shard(setup, np.random.SeedSequence(2), a.shard)
        res["batched_1proc_samples_per_s"] = a.shard / (time.perf_counter() - t)
        res["batched_1proc_tracemalloc_peak_MB"] = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    jobs = [(3, i, min(a.shard, a.n - i * a.shard)) for i in range(-(-a.n // a.shard))]
    with ProcessPoolExecutor(a.workers, mp_context=get_context("spawn")) as pool:
        list(pool.map(_shard, [(9, 0, 64)] * a.workers))  # start and warm the workers
        t = time.perf_counter()
        done = sum(pool.map(_shard, jobs))
        res["batched_all_cores_samples_per_s"] = done / (time.perf_counter() - t)
    res["ratio_batched_all_cores_vs_naive_full"] = res["batched_all_cores_samples_per_s"] / res["naive_full_samples_per_s"]
    res["ratio_batched_1proc_vs_naive_full"] = res["batched_1proc_samples_per_s"] / res["naive_full_samples_per_s"]
    res["ratio_batched_all_cores_vs_naive_projection"] = (res["batched_all_cores_samples_per_s"]
                                                          / res["naive_projection_samples_per_s"])
    res["seconds_per_100k_samples_all_cores"] = 1e5 / res["batched_all_cores_samples_per_s"]
    res["peak_rss_parent_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    res["peak_rss_largest_worker_MB"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        for k, v in res.items():
            print(f"{k:48s} {v:.1f}" if isinstance(v, float) else f"{k:48s} {v}")
    return res


if __name__ == "__main__":
    main()
