"""Debond, slit or mass change? The competing explanations on independent pairs, through ``classify``.

Run::

    python -m experiments.second_sim kinds --n 10 --seed 5 --out out/kind-pairs
    python -m experiments.second_sim kinds --n 10 --seed 6 --changes debond --tied-tips --out out/kind-pairs-tied
    beam-damage generate --config debond --n 12000 --seed 1 --out out/debond-train
    beam-damage train --data out/debond-train --out out/debond-model --epochs 30
    python -m experiments.benches.bench_debond --model out/debond-model --pairs out/kind-pairs out/kind-pairs-tied

The pairs come from :mod:`experiments.second_sim.kind_pairs` (beam 5 with a face-core debond on the layered
model, a slit, a point mass added, or none; modal noise 0.03 % / 3 % / 0.5 %; no code shared with the
project). Each pair's modal data is classified as a user would (``beam-damage classify --model M --baseline
pair-K_baseline.json pair-K_current.json --json``). The confusion table counts, per true change, the most likely
explanation (the first of the verdict's ``hypotheses``), the share whose most likely explanation fits the change
within its noise, the network's detections, and the pairs whose summary does not say the two most likely cannot
be told apart on the modes measured (the summaries of debonds that cannot be told apart, with what they say
would separate them, are printed).

Writes ``debond.csv`` and ``debond.json`` in ``--out``; ``--json`` prints the rows; ``--docs`` writes the table
into docs/datasets.md (block ``debond``).
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pandas as pd

from experiments.benches.harness import cli_json, parser, publish, table

__all__ = ["classify_pairs", "confusion", "main", "markdown"]


def classify_pairs(model: Path, pair_dir: Path, extra=()) -> tuple[list, list]:
    """``classify --json`` of every pair of ``pair_dir`` (its ``truth.json``; ``extra``: arguments before the pair's);
    returns ``(truth rows, verdicts)``."""
    truth = json.loads((pair_dir / "truth.json").read_text())["pairs"]
    verdicts = [cli_json(["classify", "--model", str(model), *extra, "--baseline", str(pair_dir / t["baseline"]),
                          str(pair_dir / t["current"])]) for t in truth]
    return truth, verdicts


def _change(t: dict) -> str:
    """The true change's label (a debond: with its tips' condition)."""
    if t["change"] == "debond":
        return "debond (tied tips)" if t.get("tied_tips") else "debond (sliding)"
    return t["change"]


def confusion(truth: list, verdicts: list) -> tuple[list[dict], list[str]]:
    """Rows ``{change, pairs, network detected, <explanation>: share, ..., fits, told apart}`` and the
    explanations' names in the order reported; ``fits``: the share of pairs whose most likely explanation fits;
    ``told apart``: the share whose summary does not say the two most likely cannot be told apart."""
    names: list[str] = []
    by: dict = {}
    for t, v in zip(truth, verdicts):
        hyp = v.get("hypotheses") or []
        best = hyp[0]["name"] if hyp else "none"
        for h in hyp:
            names += [h["name"]] if h["name"] not in names else []
        g = by.setdefault(_change(t), {"n": 0, "best": Counter(), "net": 0, "apart": 0, "fits": 0})
        g["n"] += 1
        g["best"][best] += 1
        g["fits"] += bool(hyp and hyp[0].get("fits", True))
        g["net"] += bool((v.get("network") or {}).get("damaged", v.get("damaged")))
        g["apart"] += "cannot be told apart" not in (v.get("hypotheses_summary") or "")
    rows = []
    for change, g in by.items():
        row = {"change": change, "pairs": g["n"], "network detected": g["net"] / g["n"]}
        row.update({n: g["best"][n] / g["n"] for n in names})
        row["fits"] = g["fits"] / g["n"]
        row["told apart"] = g["apart"] / g["n"]
        rows.append(row)
    return rows, names


def markdown(rows: list[dict], names: list[str]) -> str:
    """The rows as the docs' table (shares in %)."""
    cols = ["pairs", "network detected", *names, "fits", "told apart"]
    return table(["true change", *cols], [[r["change"], r["pairs"], *(f"{100 * r[c]:.0f} %" for c in cols[1:])]
                                          for r in rows]) + "\n"


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="datasets.md", json=True, out="out/debond-bench")
    ap.add_argument("--model", required=True)
    ap.add_argument("--pairs", required=True, nargs="+", help="directories of second_sim kinds")
    a = ap.parse_args(argv)
    truth, verdicts = [], []
    for d in a.pairs:
        t, v = classify_pairs(Path(a.model), Path(d))
        truth += t
        verdicts += v
    rows, names = confusion(truth, verdicts)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(out / "debond.csv", index=False)
    summaries = [{"change": _change(t), "x_m": t["x_m"], "size": t["size"], "summary": v.get("hypotheses_summary"),
                  "hypotheses": [{k: h.get(k) for k in ("name", "probability", "fits", "parameters")}
                                 for h in v.get("hypotheses") or []]} for t, v in zip(truth, verdicts)]
    (out / "debond.json").write_text(json.dumps({"rows": rows, "pairs": summaries}, indent=1, default=float))
    if a.json:
        print(json.dumps(rows, indent=1, default=float))
    else:
        print(markdown(rows, names))
        for s in summaries:
            if s["change"].startswith("debond") and "cannot be told apart" in (s["summary"] or ""):
                print(f"{s['change']} at x = {s['x_m']:.3f} m, size {s['size']:.3g}: {s['summary']}")
    publish(a, "debond", markdown(rows, names))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
