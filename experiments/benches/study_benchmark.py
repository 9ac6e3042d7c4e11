"""Study ``benchmark``: the datagen throughput ratio, training time and identification accuracy in one run.

Runs :mod:`experiments.benches.bench_datagen` (10 000 samples against the naive per-sample loop),
:func:`experiments.benches.bench_identification.method_errors` (simulated beam-5 FRFs, thesis damping,
1 % noise) and a timed training of the default classifier on a ``training``-config
dataset. Every number is measured in this run on this machine; the load average at the
start is reported beside them.
"""

from __future__ import annotations

import contextlib
import io
import os
import time
from pathlib import Path

from datagen.config import load_config
from datagen.generation import generate
from experiments.benches import bench_datagen, bench_identification
from experiments.studies.report import Section, Table
from learn.network.training import train

__all__ = ["run"]


def run(out_dir, n_datagen: int = 10000, n_train: int = 6000, epochs: int = 30) -> tuple[dict, list]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()[0]
    with contextlib.redirect_stdout(io.StringIO()):
        dg = bench_datagen.main(["--n", str(n_datagen), "--naive", "40", "--workers", "2", "--json"])
    ident = bench_identification.method_errors(seeds=2, damping="thesis")


    generate(out / "train-data", load_config("training"), n=n_train, seed=0, workers=2, progress=True)
    t0 = time.perf_counter()
    tr = train(out / "train-data", out / "model", epochs=epochs, seed=0, progress=True)
    train_s = time.perf_counter() - t0

    dg_rows = [{"quantity": k, "value": v} for k, v in dg.items() if isinstance(v, (int, float))]
    id_rows = []
    for name, m in ident["methods"].items():
        for j, (fe, ze, mac) in enumerate(zip(m["frequency_error_pct_rms"], m["damping_error_pct_rms"],
                                              m["mac_mean"]), start=1):
            id_rows.append({"method": name, "mode": j, "frequency error (%)": fe, "damping error (%)": ze,
                            "MAC": mac})
    tr_rows = [{"training pairs": tr.get("train_pairs"), "epochs": epochs, "route": tr.get("route"),
                "train command (s)": train_s,
                **{f"fit {k} (s)": v for k, v in (tr.get("train_seconds") or {}).items()}}]
    summary = {"load_average_at_start": load, "datagen": dg, "identification": ident, "train_seconds": train_s,
               "train": tr}
    sec = Section("Benchmarks, measured in one run",
                  (f"Load average at the start: {load:.1f} on {os.cpu_count()} cores (other jobs slow every rate "
                   "below an idle machine's).",),
                  (Table.from_records(f"Dataset generation and reading ({n_datagen} samples, default config, "
                                      "2 workers) against the naive per-sample loop", dg_rows),
                   Table.from_records("Modal identification of simulated beam-5 FRFs (thesis damping, 1 % noise, "
                                      "RMS over 2 seeds)", id_rows),
                   Table.from_records("Training the default classifier", tr_rows)))
    return summary, [sec]
