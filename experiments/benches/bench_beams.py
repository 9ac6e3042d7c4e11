"""Benchmark: the loop's speed on beams with 4, 8 and 16 sensors, in one run.

Run: ``.venv/bin/python -m experiments.benches.bench_beams [--n 6000] [--workers 2] [--train 30000] [--json]``

Each beam is a steel cantilever (1 m, 40 x 10 mm) with ``S`` sensors equally spaced from ``L / S`` to the tip,
driven at the tip, and a band from 2 Hz to just above its ``S``-th bending mode, so the band holds ``S`` modes
(the Lancaster/Pilkey update then runs on all of them). For each ``S``:

* generate: :func:`datagen.generation.generate` end to end (``--config training``, ``--workers`` processes,
  shards, checksums and ``samples.parquet`` written), samples per second of wall clock;
* classify: :func:`learn.pairs.classify.classify_many` of ``--pairs`` modal-data pairs against one baseline (a model
  trained on the dataset for ``--epochs``), pairs per second;
* with ``--train N`` (the 8-sensor beam only): ``generate`` of N samples and ``train`` on them, seconds.

The cost per sample grows with the truth mesh (``4 (S + 1)`` elements at least, banded solves ``O(n)``), the
projection basis (``S + 4`` modes, dense ``O(p^3)`` per sample) and the updates (``S x S``), so the table prints the
growth of the time per sample relative to the 4-sensor beam. Targets (issue 23): the 8-sensor beam with 8 modes at
>= 1 000 samples/s end to end on 2 cores; training on 30 000 pairs in <= 2 min.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.config import load_config
from datagen.dataset import Dataset
from datagen.generation import generate
from datagen.truth_beam import beam_mapping
from experiments.benches.harness import parser, publish, table
from learn.pairs.classify import classify_many
from learn.network.model_dir import load_model
from learn.network.training import train
from physics.beam import load_beam
from physics.io import ModalData

__all__ = ["beam_toml", "main"]

EI_NM2 = 210e9 * 0.04 * 0.01**3 / 12
MASS_KG_M = 7850 * 0.04 * 0.01


def beam_toml(n_sensors: int, length_m: float = 1.0) -> str:
    """A steel cantilever with ``n_sensors`` equally spaced sensors and a band holding ``n_sensors`` modes."""
    beta = (2 * n_sensors - 1) * np.pi / 2 + 0.3                 # a little above the S-th bending mode's beta L
    f_hi = beta**2 * np.sqrt(EI_NM2 / MASS_KG_M) / (2 * np.pi * length_m**2)
    xs = [round(length_m * k / n_sensors, 9) for k in range(1, n_sensors + 1)]
    return (f'name = "steel-cantilever-{n_sensors}"\nbc = "clamped-free"\nlength_m = {length_m}\nwidth_m = 0.04\n'
            f"thickness_m = 0.01\nEI_Nm2 = {EI_NM2}\nmass_per_length_kg_m = {MASS_KG_M}\nmeasured_x_m = {xs}\n"
            f"drive_x_m = {xs[-1]}\nband_hz = [2.0, {f_hi:.6g}]\n")


def _generate(work: Path, S: int, n: int, workers: int, seed: int = 1) -> tuple[float, Path, dict]:
    (work / f"b{S}.toml").write_text(beam_toml(S))

    cfg = load_config("training")
    cfg["beam"] = beam_mapping(load_beam(work / f"b{S}.toml"))
    out = work / f"data{S}-{n}"
    t0 = time.perf_counter()
    m = generate(out, cfg, n=n, seed=seed, workers=workers, progress=False)
    return time.perf_counter() - t0, out, m


def _classify_rate(data: Path, model_dir: Path, n_pairs: int, epochs: int) -> tuple[float, float]:
    t0 = time.perf_counter()
    train(data, model_dir, epochs=epochs)
    train_s = time.perf_counter() - t0
    model = load_model(model_dir)
    ds = Dataset(data)
    lam, vec = ds.array("eigenvalues_measured"), ds.array("eigenvectors_measured")
    dofs = tuple(model.beam.dofs)
    base = ModalData(lam[0, 0], vec[0, 0], dofs)
    cur = [ModalData(lam[i, 1], vec[i, 1], dofs) for i in range(min(n_pairs, len(lam)))]
    t0 = time.perf_counter()
    classify_many(model, base, cur)
    return len(cur) / (time.perf_counter() - t0), train_s


def markdown(result: dict) -> str:
    """The speed table (and the training line) as markdown."""
    head = ["sensors", "modes", "elements", "generate (samples/s)", "classify (pairs/s)", "cost per sample vs 1st"]
    text = table(head, [[r["sensors"], r["modes"], r["truth_elements"], f"{r['generate_samples_per_s']:.0f}",
                         f"{r['classify_pairs_per_s']:.0f}", f"{r['cost_per_sample_vs_first']:.2f}"]
                        for r in result["rows"]]) + "\n"
    if "train" in result:
        t = result["train"]
        text += (f"\n8 sensors, {t['samples']} samples: generate {t['generate_s']:.1f} s, train {t['train_s']:.1f} s "
                 f"(network fits {', '.join(f'{k} {v:.1f} s' for k, v in t['fit_s'].items())}).\n")
    return text + (f"\n{result['n']} samples per beam on {result['workers']} processes, load average "
                   f"{result['load']:.1f} at the start.\n")


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="any-beam.md", json=True, workers=2)
    p.add_argument("--n", type=int, default=6000, help="samples generated per beam (default 6000)")
    p.add_argument("--sensors", type=int, nargs="+", default=[4, 8, 16], help="sensor counts (default 4 8 16)")
    p.add_argument("--pairs", type=int, default=400, help="pairs classified per beam (default 400)")
    p.add_argument("--epochs", type=int, default=20, help="epochs of the model classify uses (default 20)")
    p.add_argument("--train", type=int, default=0, metavar="N", help="also generate N samples of the 8-sensor beam "
                   "and time train on them (default: off)")
    args = p.parse_args(argv)

    limits = threadpool_limits(1, user_api="blas")     # as the CLI runs: one BLAS thread per process
    load = os.getloadavg()[0]
    work = Path(tempfile.mkdtemp(prefix="bench-beams-"))
    rows = []
    try:
        for S in args.sensors:
            gen_s, data, m = _generate(work, S, args.n, args.workers)
            rate, _ = _classify_rate(data, work / f"model{S}", args.pairs, args.epochs)
            rows.append({"sensors": S, "modes": len(m["layout"]["modes"]), "truth_elements":
                         m["layout"]["truth_elements"], "generate_samples_per_s": args.n / gen_s,
                         "classify_pairs_per_s": rate, "updating": m["layout"]["updating"]})
        base = rows[0]["generate_samples_per_s"]
        for r in rows:
            r["cost_per_sample_vs_first"] = base / r["generate_samples_per_s"]
        result = {"n": args.n, "workers": args.workers, "load": load, "rows": rows}
        if args.train:
            gen_s, data, _ = _generate(work, 8, args.train, args.workers, seed=2)

            t0 = time.perf_counter()
            summary = train(data, work / "model-train", epochs=60)
            result["train"] = {"samples": args.train, "generate_s": gen_s, "train_s": time.perf_counter() - t0,
                               "fit_s": summary["train_seconds"]}
    finally:
        shutil.rmtree(work, ignore_errors=True)
        limits.restore_original_limits()
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    md = markdown(result)
    print(md, end="")
    publish(args, "beams", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
