"""Start-up of the command line: ``beam-damage --help``, every command's ``--help`` and ``classify`` of one
UFF pair, each in fresh processes (median of several runs), and the imports that cost the most.

Run: ``.venv/bin/python -m experiments.benches.bench_startup [--runs 5] [--before CHECKOUT] [--offenders] [--docs]
[--json]``

Each case runs ``python -m experiments.cli ...`` in a new process with ``PYTHONPATH`` set to a checkout (this
one, and with ``--before`` another, e.g. a worktree of an older commit); the runs of the two checkouts alternate,
so that a machine shared with other jobs slows both alike, and the ratio before / after is measured in one run.
Wall time and CPU time (user + system of the child) are reported; the goals are one pair in <= 1.5 s and
``--help`` of any command in <= 0.5 s.

The one-pair case needs a model and a pair: ``--model DIR --pair BASELINE CURRENT``, else they are made once
under ``out/bench_startup`` (``generate --config training --n 400``, ``train --epochs 3`` and a pair of the
independent simulator, ``python -m experiments.second_sim pairs --set easy``).

``--offenders`` lists, for ``classify --help`` and the one-pair run, the third-party modules whose import
took longest (``python -X importtime``, cumulative) and the module of the project that imported each first.
``--docs`` writes the table into ``docs/performance.md`` (block ``startup``).
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

from experiments.cli import COMMANDS
from experiments.benches.harness import parser, publish, table

__all__ = ["GOALS", "PROJECT", "cases", "docs_table", "main", "offenders", "time_case"]

ROOT = Path(__file__).resolve().parents[2]
#: Top-level packages of the project (everything else an import names is a library or the standard library).
PROJECT = ("physics", "datagen", "learn", "experiments")
#: Goals of the wall time (s): any ``--help``, one classified pair.
GOALS = {"help": 0.5, "classify": 1.5}


def _env(checkout: Path) -> dict:
    return {**os.environ, "PYTHONPATH": str(checkout)}


def time_case(argv: list[str], checkout: Path) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of ``python -m experiments.cli *argv`` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "experiments.cli", *argv], env=_env(checkout), cwd=checkout,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"bench_startup: {' '.join(argv)} failed in {checkout}: {proc.stderr.strip()[-300:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cases(model: Path, baseline: Path, current: Path) -> dict:
    """Case name -> CLI arguments: the top help, each command's help, one classified pair."""
    out = {"--help": ["--help"]}
    out.update({f"{name} --help": [name, "--help"] for name in COMMANDS})
    out["classify (1 pair)"] = ["classify", "--model", str(model), "--baseline", str(baseline), str(current),
                                "--json"]
    return out


def offenders(argv: list[str], checkout: Path, top: int = 8) -> list[dict]:
    """The ``top`` third-party modules imported by the project, by cumulative import time (s) in ``python -X
    importtime``, each with the project module that imported it first (None: a function, or the interpreter)."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "experiments.cli", *argv], env=_env(checkout),
                          cwd=checkout, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    rows = []
    for line in proc.stderr.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        _, cumulative, name = line[len("import time:"):].split("|")
        rows.append((len(name) - len(name.lstrip()), name.strip(), int(cumulative) / 1e6))
    found = {}
    for i, (depth, name, seconds) in enumerate(rows):   # importtime lists a module after what it imported
        top_name = name.split(".")[0]
        if top_name in PROJECT or top_name in sys.stdlib_module_names or top_name.startswith("_"):
            continue
        parent = next((n for d, n, _ in rows[i + 1:] if d < depth), None)
        if parent is not None and parent.split(".")[0] not in PROJECT:
            continue                                  # imported by another library: counted in that one
        key = ".".join(name.split(".")[:2])           # scipy.fft, not its private sub-modules
        entry = found.setdefault(key, {"module": key, "seconds": 0.0, "imported_by": parent})
        entry["seconds"] += seconds
    return sorted(found.values(), key=lambda e: -e["seconds"])[:top]


def docs_table(result: dict) -> str:
    """The Markdown table of :func:`main`'s result: median wall / CPU seconds per case, before and after."""
    before = "before" in result["checkouts"]
    return table(["case", *["before: wall / CPU (s)"] * before, "wall / CPU (s)", "goal (s)"],
                 [[f"`{r['case']}`", *[f"{r['before_wall_s']:.2f} / {r['before_cpu_s']:.2f}"] * before,
                   f"{r['after_wall_s']:.2f} / {r['after_cpu_s']:.2f}", f"{r['goal_s']:.1f}"] for r in result["cases"]],
                 ["---", *["---:"] * before, "---:", "---:"]) + "\n"


def _fixtures(out: Path) -> tuple[Path, Path, Path]:
    model, pairs = out / "model", out / "pairs"
    steps = [(out / "data" / "manifest.json", ["-m", "experiments.cli", "generate", "--config", "training", "--n",
                                               "400", "--out", str(out / "data")]),
             (model / "config.json", ["-m", "experiments.cli", "train", "--data", str(out / "data"), "--out",
                                      str(model), "--epochs", "3"]),
             (pairs / "pair-000_current.uff", ["-m", "experiments.second_sim", "pairs", "--set", "easy", "--n", "1",
                                               "--out", str(pairs)])]
    for done, args in steps:
        if not done.exists():
            subprocess.run([sys.executable, *args], env=_env(ROOT), cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    return model, pairs / "pair-000_baseline.uff", pairs / "pair-000_current.uff"


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="performance.md", json=True)
    ap.add_argument("--runs", type=int, default=5, help="fresh processes per case and checkout (median)")
    ap.add_argument("--before", type=Path, help="another checkout to time alike (before / after)")
    ap.add_argument("--model", type=Path, help="model directory for the one-pair case")
    ap.add_argument("--pair", type=Path, nargs=2, metavar=("BASELINE", "CURRENT"), help="UFF pair to classify")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_startup", help="where fixtures are made")
    ap.add_argument("--offenders", action="store_true", help="list the slowest third-party imports")
    args = ap.parse_args(argv)
    if args.model and args.pair:
        model, baseline, current = args.model, *args.pair
    else:
        model, baseline, current = _fixtures(args.out)
    checkouts = {"after": ROOT} | ({"before": args.before.resolve()} if args.before else {})
    table = []
    for name, case in cases(model, baseline, current).items():
        runs = {label: [] for label in checkouts}
        for checkout in checkouts.values():   # a first run writes the bytecode caches: not counted
            time_case(case, checkout)
        for _ in range(args.runs):
            for label, checkout in checkouts.items():
                runs[label].append(time_case(case, checkout))
        row = {"case": name}
        for label, values in runs.items():
            row[f"{label}_wall_s"] = statistics.median(w for w, _ in values)
            row[f"{label}_cpu_s"] = statistics.median(c for _, c in values)
        row["goal_s"] = GOALS["classify" if "pair" in name else "help"]
        table.append(row)
    result = {"runs": args.runs, "checkouts": {k: str(v) for k, v in checkouts.items()}, "cases": table}
    if args.offenders:
        result["offenders"] = {f"{label} {name}": offenders(case, checkout)
                               for name, case in cases(model, baseline, current).items()
                               if name in ("classify --help", "classify (1 pair)")
                               for label, checkout in checkouts.items()}
    publish(args, "startup", docs_table(result))
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    before = "before" in checkouts
    print(f"start-up, median of {args.runs} fresh processes (wall s / CPU s)"
          + (f"; before: {checkouts['before']}" if before else ""))
    head = f"{'case':22s} " + (f"{'before':>15s} " if before else "") + f"{'after':>15s} {'goal':>6s}"
    print(head + ("  ratio" if before else ""))
    for r in table:
        cells = f"{r['case']:22s} "
        if before:
            cells += f"{r['before_wall_s']:7.2f} / {r['before_cpu_s']:5.2f} "
        cells += f"{r['after_wall_s']:7.2f} / {r['after_cpu_s']:5.2f} {r['goal_s']:6.1f}"
        if before:
            cells += f"  {r['before_wall_s'] / r['after_wall_s']:5.1f}x"
        print(cells + ("" if r["after_wall_s"] <= r["goal_s"] else "  (above goal)"))
    for name, rows in result.get("offenders", {}).items():
        print(f"\nslowest imports, {name}:")
        for e in rows:
            print(f"  {e['seconds']:6.2f} s  {e['module']:16s} imported by "
                  f"{e['imported_by'] or '(a function, or the interpreter)'}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
