"""Which normal-variation model ``monitor`` uses without measured conditions: each model of
:data:`learn.monitor.NORMAL_MODELS` scored through the CLI on monitoring series of the independent simulator
(:mod:`experiments.second_sim.series`: temperature, re-mounting, a re-placed mass, a slit from a known day).

For every series (seed, slit size) and model: the false-alarm rate on the intact tests after the baseline period,
the true-positive rate on the damaged tests, and the detection delay (tests from the first damaged one to the first
alarm on a damaged test). The identification is cached per series (``OUT/<series>/monitor/cache``), so every
model after the first costs only its fits.

    python -m experiments.benches.bench_monitor_models --out out/bench_monitor_models [--n-tests 240] [--seeds 0 1 2 3]
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments.benches.harness import cli_json, parser
from learn.monitor import NORMAL_MODELS
from experiments.second_sim.series import SLIT_SIZES, SeriesConfig, simulate_series, write_series as write

__all__ = ["main", "run_monitor", "score", "write_series"]

SIZES = ("small", "medium", "large")


def write_series(root: Path, seed: int, size: str, n_tests: int, kind: str) -> Path:
    if not (root / "truth.json").is_file():
        cfg = SeriesConfig(n_tests=n_tests, seed=seed, kind=kind, slit_ei_loss=SLIT_SIZES.get(size) or float(size))
        write(cfg, simulate_series(cfg), root)
    return root


def run_monitor(root: Path, model: str, n_baseline: int, rate: float, conditions: bool) -> dict:
    """``beam-damage monitor`` on a series (outputs in ``root/monitor``, its identification cache shared by every
    model); returns its JSON."""
    out = root / "monitor"
    csv = root / "conditions.csv"
    if conditions:
        argv = ["monitor", "--conditions", str(csv)]
    else:                                   # the files in time order, no conditions
        files = [root / line.split(",")[0] for line in csv.read_text().splitlines()[1:]]
        argv = ["monitor", *map(str, files), "--normal-model", model]
    return cli_json(argv + ["--baseline-tests", str(n_baseline), "--false-alarm-rate", str(rate), "--out", str(out)])


def score(result: dict, truth: dict, n_baseline: int) -> dict:
    damaged = np.array([t["damaged"] for t in truth["tests"]])
    alarm = np.array([r["alarm"] for r in result["tests"]])
    ok = np.array([r["identified"] for r in result["tests"]])
    after = np.arange(damaged.size) >= n_baseline
    intact = after & ~damaged & ok
    hit = damaged & ok
    first = int(np.argmax(damaged)) if damaged.any() else None
    alarms_damaged = np.flatnonzero(alarm & damaged)
    return {"false_alarm_rate": float(alarm[intact].mean()) if intact.any() else None,
            "n_intact": int(intact.sum()),
            "true_positive_rate": float(alarm[hit].mean()) if hit.any() else None, "n_damaged": int(hit.sum()),
            "delay_tests": int(alarms_damaged[0] - first) if alarms_damaged.size else None}


def main(argv=None) -> int:
    p = parser(__file__, __doc__, out="out/bench_monitor_models")
    p.add_argument("--n-tests", type=int, default=240)
    p.add_argument("--baseline-tests", type=int, default=80)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--sizes", nargs="+", default=list(SIZES),
                   help="slit sizes cycled over the seeds: small, medium, large or an EI loss of the 4-mm slit")
    p.add_argument("--kind", choices=("frf", "output-only"), default="frf")
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--models", nargs="+", default=[m for m in NORMAL_MODELS if m != "regression"])
    args = p.parse_args(argv)
    rows = []
    for seed in args.seeds:
        size = args.sizes[seed % len(args.sizes)]
        root = write_series(Path(args.out) / f"{args.kind}-seed{seed}-{size}", seed, size, args.n_tests, args.kind)
        truth = json.loads((root / "truth.json").read_text())
        for model in ["regression", *args.models]:
            res = run_monitor(root, model, args.baseline_tests, args.rate, model == "regression")
            row = {"series": root.name, "slit": size, "model": model,
                   "threshold": res["threshold"]["value"], **score(res, truth, args.baseline_tests)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    out = Path(args.out) / f"summary-{args.kind}-{'-'.join(map(str, args.seeds))}.json"
    out.write_text(json.dumps({"config": vars(args), "rows": rows}, indent=1))
    print(f"{'model':>10} {'false alarms':>13} " + " ".join(f"{'TPR ' + s:>10}" for s in dict.fromkeys(args.sizes)))
    for model in ["regression", *args.models]:
        mine = [r for r in rows if r["model"] == model]
        fa = sum(r["false_alarm_rate"] * r["n_intact"] for r in mine) / max(sum(r["n_intact"] for r in mine), 1)
        tpr = {s: [r["true_positive_rate"] for r in mine if r["slit"] == s] for s in dict.fromkeys(args.sizes)}
        print(f"{model:>10} {fa:13.3%} " + " ".join(f"{np.mean(v):10.1%}" if v else f"{'-':>10}"
                                                    for v in tpr.values()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
