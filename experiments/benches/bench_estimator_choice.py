"""Benchmark: ``monitor`` with each mode's frequency estimator chosen over the baseline period against the
identification alone, on output-only series of the independent simulator.

Run: ``python -m experiments.benches.bench_estimator_choice [--seeds 0] [--sizes small] [--n-tests 90]
[--baseline-tests 30] [--rate 0.01] [--out out/bench_estimator_choice] [--docs]``

Each series (:mod:`experiments.second_sim.series`, ``kind="output-only"``: the steel cantilever's 60-s ambient
records at 3 sensors over a year, temperature, re-mounting and a re-placed mass changing, the slit from day 270) is
monitored twice by :func:`learn.monitor.monitor_series` (band 5-400 Hz, 1 % false alarms; with the measured
temperatures, ``regression``, and without, ``pca``): ``frequency_estimator="choose"`` (each mode's frequency by the
more repeatable over the baseline period of the identification and the record's FFT peak,
:mod:`learn.monitor.estimator_choice`) and ``"identification"``. Per run: the false alarms (flagged intact tests
after the baseline period), the detection (flagged damaged tests) and the choice per mode. The records and the
identification cache are kept in ``--out`` (the first run identifies every record: minutes).
"""

from __future__ import annotations

import json
import os
import time
import warnings
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.harness import parser, publish, table  # noqa: E402
from experiments.second_sim.series import SLIT_SIZES, SeriesConfig, simulate_series, write_series  # noqa: E402
from learn.monitor import IdentificationSettings, SeriesInput, monitor_series, read_conditions  # noqa: E402
from learn.monitor.alarms import FLAGGED_STATUSES  # noqa: E402
from learn.monitor.estimator_choice import FREQUENCY_ESTIMATORS  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["BAND_HZ", "main", "run_series"]

#: The band identified (the output-only series' band).
BAND_HZ = (5.0, 400.0)


def run_series(root: Path, seed: int, size: str, n_tests: int, n_baseline: int, rate: float) -> list:
    """One series (simulated into ``root`` once) monitored with each normal model and frequency estimator: one row
    per run."""
    if not (root / "truth.json").is_file():
        cfg = SeriesConfig(n_tests=n_tests, seed=seed, kind="output-only", slit_ei_loss=SLIT_SIZES[size])
        write_series(cfg, simulate_series(cfg), root)
    damaged = np.array([t["damaged"] for t in json.loads((root / "truth.json").read_text())["tests"]])
    cond = read_conditions(root / "conditions.csv")
    rows = []
    for model, series in (("regression", cond), ("pca", SeriesInput(cond.files, cond.times, cond.time_values))):
        for est in FREQUENCY_ESTIMATORS:
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = monitor_series(series, n_baseline, IdentificationSettings(BAND_HZ), root / "cache", rate, model,
                                     progress=False, chart="none", frequency_estimator=est)
            flag = np.array([r["status"] in FLAGGED_STATUSES for r in res.rows])
            ok = np.array([r["identified"] for r in res.rows])
            later = np.arange(flag.size) >= n_baseline
            intact, hit = later & ~damaged & ok, damaged & ok
            choice = res.frequency_choice
            rows.append({"seed": seed, "size": size, "model": model, "estimator": est,
                         "false_alarms": float(flag[intact].mean()) if intact.any() else None,
                         "n_intact": int(intact.sum()),
                         "detection": float(flag[hit].mean()) if hit.any() else None, "n_damaged": int(hit.sum()),
                         "estimators": None if choice is None else list(choice.estimators),
                         "texts": None if choice is None else choice.texts(),
                         "seconds": time.perf_counter() - t0})
    return rows


def markdown(rows: list, rate: float) -> str:
    head = ["seed", "slit", "normal model", "frequency estimator", "false alarms", "detection", "estimators per mode"]
    lines = [[r["seed"], r["size"], r["model"], r["estimator"], f"{100 * r['false_alarms']:.1f} % of {r['n_intact']}",
              f"{100 * r['detection']:.1f} % of {r['n_damaged']}",
              ", ".join(r["estimators"]) if r["estimators"] else "identification"] for r in rows]
    texts = dict.fromkeys(f"seed {r['seed']}, {r['size']}: " + "; ".join(r["texts"]) for r in rows if r["texts"])
    return table(head, lines) + "".join(f"\n\n{t}" for t in texts) + (
        f"\n\nShare of the intact later tests (false alarms) and of the damaged tests (detection) flagged at "
        f"{rate:g}. `python -m experiments.benches.bench_estimator_choice --docs`")


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_estimator_choice")
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    p.add_argument("--sizes", nargs="+", choices=list(SLIT_SIZES), default=["small"])
    p.add_argument("--n-tests", type=int, default=90, help="tests over the year (default 90)")
    p.add_argument("--baseline-tests", type=int, default=30, help="tests of the baseline period (default 30)")
    p.add_argument("--rate", type=float, default=0.01, help="false-alarm rate (default 0.01)")
    a = p.parse_args(argv)
    out = Path(a.out)
    rows = []
    for seed in a.seeds:
        for size in a.sizes:
            rows += run_series(out / f"seed{seed}_{size}_{a.n_tests}", seed, size, a.n_tests, a.baseline_tests,
                               a.rate)
    md = markdown(rows, a.rate)
    print(md)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "estimator_choice.json", json.dumps({"rate": a.rate, "rows": rows}, indent=1))
    publish(a, "estimator-choice", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
