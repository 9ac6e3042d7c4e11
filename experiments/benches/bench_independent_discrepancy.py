"""Benchmark: ``beam-damage discrepancy`` on the hidden-effect cases of the independent simulator.

The cases come from ``python -m experiments.second_sim effects --seed S --out DIR``
(its own mesh, elements and damping, no code shared with ``physics.effects``):
per case a modal JSON (complex modes), a frequency JSON (frequencies and damping
ratios) and a baseline UFF, and ``cases.json`` with the truth. Each file goes
through the command a user would run, ``beam-damage discrepancy --beam beam5
--measured FILE --json`` (default noise, default candidates), and the named
effects are counted per truth and data kind.

    python -m experiments.second_sim effects --seed 0 --out DIR0   # once per seed
    python -m experiments.benches.bench_independent_discrepancy DIR0 [DIR1 ...] --out OUT
        [--kinds modal frequencies uff]
        [--cli-args="--frequency-noise 0.0003 --shape-noise 0.005"]

Writes ``OUT/independent_confusion.{csv,json,md}`` (one row per case and kind in
the CSV/JSON; the Markdown table counts, per truth, the first effect named,
``~`` when reported indistinguishable from another, ``+X`` a second effect,
``(<lim)`` a hidden effect left unnamed below the reported detection limit)
and prints the Markdown table with the chi^2/dof noise checks per kind.

Scoring (:func:`verdict`): *right* when the truth is named first (or reported
indistinguishable from the one named) and nothing else is; *right but
undetectable* when nothing is named and the command's ``detection_limits``
say an effect of the truth's size (at the truth's position, nearest measured
point) is below what these data and this noise can name, or the effect is
reported not testable on this data (a dashpot from frequencies and damping
ratios); *wrong* otherwise, in particular an effect left unnamed although
the reported limit says its size should have been named. The two right
kinds are counted separately in the table.
"""

from __future__ import annotations

import csv
import io
import json
import time
from collections import Counter
from pathlib import Path

import numpy as np

from experiments.benches.harness import cli_json, parser, table, write_table
from experiments.studies.study_discrepancy import SHORT
from physics.discrepancy.limits import DetectionLimit
from physics.io import atomic_write_text

__all__ = ["below_limit", "main", "markdown", "run_cases", "run_cli", "truth_size", "verdict"]

KINDS = {"modal": "modal JSON", "frequencies": "frequencies + damping", "uff": "FRF (UFF)"}


def run_cli(measured: Path, extra=()) -> dict:
    """``beam-damage discrepancy --beam beam5 --measured FILE --json [extra]`` in this process; its JSON, or
    ``{"error": ...}`` when it exits non-zero."""
    try:
        return cli_json(["discrepancy", "--beam", "beam5", "--measured", str(measured), *extra])
    except RuntimeError as exc:
        return {"error": str(exc)}


def truth_label(case: dict) -> str:
    e = case["effect"]
    if e == "none":
        return "none"
    v, lab = case["value"], case["label"]
    desc = {"k_L_over_EI": f"k L/EI = {v:g}", "tip_mass_fraction": f"tip mass {100 * v:g} % m L",
            "quarter_mass_fraction": f"mass {100 * v:g} % m L at L/4", "kGA_over_EI_L2": f"kGA L^2/EI = {v:g}",
            "added_damping_ratio": f"dashpot at L/4, +{100 * v:g} % damping"}.get(lab, f"{lab} {v:g}")
    return f"{SHORT[e]}: {desc}"


def run_cases(dirs, kinds, extra=(), progress=True) -> list[dict]:
    rows = []
    for d in map(Path, dirs):
        spec = json.loads((d / "cases.json").read_text(encoding="utf-8"))
        for case in spec["cases"]:
            for kind in kinds:
                t0 = time.perf_counter()
                out = run_cli(d / case["files"][kind], extra)
                row = {"dir": d.name, "case": case["case"], "truth": case["effect"], "truth_label": truth_label(case),
                       "truth_size": truth_size(case), "truth_x_m": case["parameters"].get("x_m"),
                       "base_damping": case["damping"]["kind"], "kind": kind, "seconds": time.perf_counter() - t0}
                if "error" in out:
                    row.update(named="error", effects=[], error=out["error"])
                else:
                    row.update(named=out["named_effect"], effects=out["effects"],
                               indistinguishable_from=out["indistinguishable_from"],
                               separating_measurement=out["separating_measurement"], evidence=out["evidence"],
                               chi2_per_dof=out["chi2_per_dof"], noise_consistent=out["noise_consistent"],
                               noise_verdict=out["noise_check"]["verdict"], noise_dof=out["noise_check"]["dof"],
                               not_tested=sorted(out["not_tested"]), gap_before_pct=out["gap_before"][
                                   "max_abs_frequency_error_pct"],
                               gap_after_pct=out["gap_after"]["max_abs_frequency_error_pct"],
                               parameters=out["parameters"], detection_limits=out["detection_limits"],
                               estimated_noise_scale=out["estimated_noise"]["scale"])
                rows.append(row)
                if progress:
                    ties = ",".join(row.get("indistinguishable_from") or [])
                    print(f"  {d.name} case {case['case']:2d} {kind:11s} truth {case['effect']:18s} -> "
                          f"{'+'.join(row['effects']) or row['named']}{' ~' + ties if ties else ''}"
                          f" chi2/dof {row.get('chi2_per_dof', float('nan')):.3g} ({row['seconds']:.0f} s)", flush=True)
    return rows


def cell(rows) -> str:
    c = Counter()
    for r in rows:
        name = SHORT.get(r["named"], r["named"])
        if r.get("indistinguishable_from"):
            name += "~" + "/".join(SHORT[e] for e in r["indistinguishable_from"])
        if len(r["effects"]) > 1:
            name += " +" + "+".join(SHORT[e] for e in r["effects"][1:])
        if r["truth"] != "none" and verdict(r) == "undetectable":
            name += " (<lim)"
        c[name] += 1
    return ", ".join(f"{k} {v}" for k, v in c.most_common())


def truth_size(case: dict) -> float:
    """The hidden effect's size in the dimensionless quantity of the command's ``detection_limits``."""
    # k L/EI, kGA L^2/EI, mass / (m L) and the dashpot's added damping ratio are the cases' own labels
    return float(case["value"])


def below_limit(r) -> bool:
    """The unnamed truth is below the detection limit the command reported for it (or not testable)."""
    if r["truth"] in r.get("not_tested", []):
        return True
    lim = (r.get("detection_limits") or {}).get(r["truth"])
    return lim is not None and DetectionLimit.from_dict(r["truth"], lim).below_limit(r["truth_size"], r["truth_x_m"])


def verdict(r) -> str:
    """``"right"``, ``"undetectable"`` (right: nothing named, the truth below the reported limit) or ``"wrong"``."""
    if r["named"] == "error":
        return "wrong"
    if r["truth"] == "none":
        return "right" if not r["effects"] else "wrong"
    if (r["named"] == r["truth"] or r["truth"] in r.get("indistinguishable_from", [])) and len(r["effects"]) == 1:
        return "right"
    return "undetectable" if not r["effects"] and below_limit(r) else "wrong"


def markdown(rows, kinds) -> str:
    n_dirs = len({r["dir"] for r in rows})
    by_kind = [[r for r in rows if r["kind"] == k] for k in kinds]
    body = [[lab, *(cell([r for r in rk if r["truth_label"] == lab]) for rk in by_kind)]
            for lab in dict.fromkeys(r["truth_label"] for r in rows)]
    for what, title in (("right", "**right (or tied with the truth), nothing else**"),
                        ("undetectable", "right but undetectable (none named, truth below the reported limit)"),
                        ("wrong", "wrong")):
        body.append([title, *(f"{sum(verdict(r) == what for r in rk)}/{len(rk)}" for rk in by_kind)])
    chi = []
    for rk in ([r for r in rk if r["named"] != "error" and np.isfinite(r["chi2_per_dof"])] for rk in by_kind):
        q = np.percentile([r["chi2_per_dof"] for r in rk], [10, 50, 90]) if rk else [np.nan] * 3
        chi.append(f"{q[1]:.2g} ({q[0]:.2g}-{q[2]:.2g}); consistent {sum(r['noise_consistent'] for r in rk)}/{len(rk)}")
    body.append(["chi^2/dof after, median (10-90 %)", *chi])
    sc = []
    for v in ([r["estimated_noise_scale"] for r in rk if "estimated_noise_scale" in r] for rk in by_kind):
        q = np.percentile(v, [10, 50, 90]) if v else [np.nan] * 3
        sc.append(f"{q[1]:.2g} ({q[0]:.2g}-{q[2]:.2g})")
    body.append(["noise scale used for the selection (x the assumed), median (10-90 %)", *sc])
    return table([f"truth ({n_dirs} seed{'s' if n_dirs > 1 else ''})", *(KINDS[k] for k in kinds)], body) + "\n"


def main(argv=None):
    ap = parser(__file__, __doc__)
    ap.add_argument("dirs", nargs="+", help="directories written by 'python -m experiments.second_sim effects'")
    ap.add_argument("--out", required=True, help="directory for independent_confusion.csv/json/md")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=list(KINDS))
    ap.add_argument("--cli-args", default="", help="extra arguments of the command, e.g. "
                                                   "'--frequency-noise 0.0003 --shape-noise 0.005' (the actual noise)")
    ap.add_argument("--docs", metavar="BLOCK", choices=DOCS_BLOCKS,
                    help="write the table into this block of docs/discrepancy.md: " + ", ".join(DOCS_BLOCKS))
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = run_cases(args.dirs, args.kinds, tuple(args.cli_args.split()))
    for r in rows:
        r["verdict"] = verdict(r)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    md = markdown(rows, args.kinds)
    atomic_write_text(out / "independent_confusion.md", md)
    atomic_write_text(out / "independent_confusion.json", json.dumps(rows, indent=1, default=float) + "\n")
    buf = io.StringIO()
    keys = ["dir", "case", "truth", "truth_label", "base_damping", "kind", "named", "effects", "indistinguishable_from",
            "evidence", "chi2_per_dof", "noise_consistent", "noise_verdict", "estimated_noise_scale", "verdict",
            "truth_size", "detection_limits", "gap_before_pct", "gap_after_pct", "seconds"]
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (json.dumps(r[k]) if isinstance(r.get(k), (list, dict)) else r.get(k, "")) for k in keys})
    atomic_write_text(out / "independent_confusion.csv", buf.getvalue())
    print(md)
    print(f"{time.perf_counter() - t0:.0f} s")
    if args.docs:
        write_table("discrepancy.md", args.docs, md)


#: Blocks of docs/discrepancy.md: the run with the default noise, and the one given the actual noise (--cli-args).
DOCS_BLOCKS = ("discrepancy-independent-default-noise", "discrepancy-independent-actual-noise")


if __name__ == "__main__":
    main()
