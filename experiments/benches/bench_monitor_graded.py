"""Benchmark: does the size ``monitor`` reports grow with the damage? A graded series of the independent simulator.

Run: ``python -m experiments.benches.bench_monitor_graded --out out/bench_monitor_graded [--n-tests 120]
[--baseline-tests 40] [--model MODEL_DIR]``

The series (:mod:`experiments.second_sim.series`: the steel cantilever tested ``--n-tests`` times over a year, the
temperature, the re-mounting and the re-placed mass changing) holds three damage states one after the other: the
slit at 0.15 L of size ``small`` from day 150, ``medium`` from day 240 and ``large`` from day 300 (the same tests
before each state: :func:`simulate_series` draws the environment independently of the damage). ``monitor`` runs
with the measured temperatures (regression) and without (``pca``); per event it prints the tests, the modes that
moved, the size (the root mean square over the modes of the event's mean change), and with ``--model`` the most
likely explanation and its size; beside it the simulator's own size (the same of the slit's frequency drops).
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import replace
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.harness import cli_json, parser  # noqa: E402
from experiments.second_sim.series import (SLIT_SIZES, SeriesConfig, simulate_series, slit_frequency_drop,  # noqa: E402
                                           write_series)

__all__ = ["STATES", "graded_series", "main"]

#: (first day, slit size) of each damage state.
STATES = ((150.0, "small"), (240.0, "medium"), (300.0, "large"))


def graded_series(out: Path, n_tests: int, seed: int = 0) -> Path:
    """The graded series' files, ``conditions.csv`` and ``truth.json`` in ``out`` (written once)."""
    if (out / "truth.json").is_file():
        return out
    base = SeriesConfig(n_tests=n_tests, seed=seed, damage_day=STATES[0][0])
    runs = {size: simulate_series(replace(base, slit_ei_loss=SLIT_SIZES[size])) for _, size in STATES}
    tests = []
    for t in runs[STATES[0][1]]:
        size = [s for day, s in STATES if t.truth["day"] >= day]
        tests.append(runs[size[-1]][t.index] if size else t)
    write_series(base, tests, out)
    return out


def main(argv=None) -> dict:
    p = parser(__file__, __doc__, out="out/bench_monitor_graded")
    p.add_argument("--n-tests", type=int, default=120)
    p.add_argument("--baseline-tests", type=int, default=40)
    p.add_argument("--model", help="trained model directory: the explanations of each event")
    a = p.parse_args(argv)
    out = Path(a.out)
    d = graded_series(out / "series", a.n_tests)
    truth = json.loads((d / "truth.json").read_text())
    drops = {size: 100 * slit_frequency_drop(replace(SeriesConfig(), slit_ei_loss=SLIT_SIZES[size]))
             for _, size in STATES}
    for _, size in STATES:
        print(f"state {size}: the simulator's slit drop per mode " + ", ".join(f"{v:.3f}" for v in drops[size])
              + " %")
    result = {}
    for label, extra in (("regression", ["--conditions", str(d / "conditions.csv")]),
                         ("pca", [str(d / t["file"]) for t in truth["tests"]])):
        argv = ["monitor", *extra, "--baseline-tests", str(a.baseline_tests), "--beam", str(d / "beam.toml"),
                "--out", str(out / f"monitor-{label}")]
        if a.model:
            argv += ["--model", a.model]
        res = cli_json(argv)
        rows = []
        for e in res["events"]:
            days = [truth["tests"][i]["day"] for i in e["members"]]
            states = sorted({truth["tests"][i]["slit_size"] for i in e["members"]})
            hyps = (e.get("verdict") or {}).get("hypotheses") or [{}]
            h = hyps[0]
            slit = next((x for x in hyps if x.get("name") == "slit"), {})
            rows.append({"first_day": days[0], "last_day": days[-1], "alarms": e["n_alarms"],
                         "slit_ei_loss": states, "moved": e["moved"], "direction": e["direction"],
                         "size_pct": e["size_pct"], "against": e["against"],
                         "truth_pct": _truth(drops, truth, e["members"]),
                         "explanation": h.get("name"), "explanation_size": (h.get("parameters") or {}).get("size"),
                         "slit_x_m": (slit.get("parameters") or {}).get("x_m"),
                         "slit_size": (slit.get("parameters") or {}).get("size"),
                         "slit_size_truth": float(np.mean([_hinge(truth["tests"][i]["slit_size"]) for i in
                                                           e["members"]]))})
        result[label] = rows
        print(f"{label}: {res['counts']['alarm']} alarms after the baseline, {len(rows)} events")
        for r in rows:
            print(f"  days {r['first_day']:.0f}-{r['last_day']:.0f}: {r['alarms']} alarms, slit EI loss "
                  f"{r['slit_ei_loss']}, modes {r['moved']} {r['direction']}, size {_pct(r['size_pct'])} % "
                  f"(simulator {_pct(r['truth_pct'])} %; against {r['against']})"
                  + (f"; most likely {r['explanation']} (size {_pct(r['explanation_size'])}); slit at "
                     f"{_pct(r['slit_x_m'])} m, hinge flexibility {_pct(r['slit_size'])} (the simulator's "
                     f"{_pct(r['slit_size_truth'])})" if r["explanation"] else ""))
    with open(out / "graded.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["model", *result["regression"][0].keys()] if result["regression"] else ["model"])
        for label, rows in result.items():
            for r in rows:
                w.writerow([label, *r.values()])
    return result


def _truth(drops: dict, truth: dict, members) -> float | None:
    """The simulator's own size of an event: the root mean square over the modes of its alarms' mean slit drop."""
    name = {v: k for k, v in SLIT_SIZES.items()}
    d = [drops[name[truth["tests"][i]["slit_size"]]] if truth["tests"][i]["slit_size"] else np.zeros(4)
         for i in members]
    return float(np.sqrt(np.mean(np.mean(d, axis=0) ** 2)))


def _hinge(ei_loss: float, width_m: float = 0.004, length_m: float = 0.8) -> float:
    """A slit's hinge flexibility ``w r / ((1 - r) L)`` (:mod:`datagen.damage`) of its EI loss ``r``."""
    return width_m * ei_loss / ((1 - ei_loss) * length_m)


def _pct(v) -> str:
    return "–" if v is None else f"{v:.3g}"


if __name__ == "__main__":
    main()
