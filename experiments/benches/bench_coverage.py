"""Benchmark: whether the verdict's 68 % and 95 % intervals cover the truth, per damage kind and support.

Run: ``python -m experiments.benches.bench_coverage --out out/coverage [--n-pairs 60] [--train-n 6000] [--seed 0]
[--only SUPPORT] [--kinds slit mass_change] [--json] [--docs]``

Pairs from the independent simulator (:mod:`experiments.second_sim.beams`: its own FE beam, supports as built,
day-to-day changes, FRFs measured with noise and written as UFF; no code shared with the package), one catalogue
beam per support, damaged pairs holding a slit (1-10 mm wide, 30-90 % EI loss) or a mass change (a point mass of
1-20 % of the beam's mass added, or 1-8 % lost over 10-25 % of the length). Each beam and kind goes through the
loop as a user runs it (:func:`experiments.benches.study_beams.run_beam`: ``generate --config training`` or
``--config mass_change``, ``train``, ``classify --baseline B C --json`` per pair). Per support, kind and source of
intervals (the network's answer; the competing explanation of the true kind):

* ``answered``: damaged pairs with an interval (the network: pairs it calls damaged; an explanation: pairs it fits);
* ``x 68`` / ``x 95``: share of those whose true place lies inside the 68 % / 95 % interval (the truth folded
  onto ``x <= L / 2`` where classify folds, a symmetric support read on frequencies alone);
* ``size 68`` / ``size 95``: the same for the size (hinge flexibility of a slit, signed mass ratio of a mass).

An interval that covers holds the truth about as often as it says (68 / 95 %, within the binomial scatter of the
``answered`` pairs: +-2 standard errors are printed). Writes ``coverage.csv``, ``coverage.json`` and
``coverage.md`` in ``--out``; ``--docs`` writes the table into docs/classifier.md (block ``coverage``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from experiments.benches.study_beams import fold, folded, run_beam
from experiments.second_sim.beams import CATALOGUE
from experiments.benches.harness import parser, publish, table
from physics.io import atomic_write_text

__all__ = ["BEAMS", "CONFIGS", "cover", "main", "markdown"]

#: One catalogue beam per support.
BEAMS = {"clamped-free": "al-strip-cf-3s", "free-free": "gfrp-strip-ff-4s", "pinned-pinned": "al-beam-pp-6s",
         "clamped-clamped": "pvc-bar-cc-5s"}

#: The training config of each simulated damage kind.
CONFIGS = {"slit": "training", "mass_change": "mass_change"}

LEVELS = ("68", "95")


def _inside(interval, value) -> bool | None:
    if interval is None or value is None or not np.all(np.isfinite(interval)) or not np.isfinite(value):
        return None
    lo, hi = interval
    return bool(lo <= value <= hi)


def cover(verdicts: list[dict], truth: dict, kind: str) -> list[dict]:
    """Coverage rows (one per source) of one beam's verdicts against the simulator's ``truth.json``."""
    L = float(truth["length_m"])
    counts = {src: {"answered": 0, **{f"{q}_{lv}": 0 for q in ("x", "size") for lv in LEVELS}}
              for src in ("network", "explanation")}
    damaged = 0
    for v, t in zip(verdicts, truth["pairs"]):
        if not t["damaged"]:
            continue
        damaged += 1
        x_true = float(t["damage_x_m"])
        x_true = float(fold(x_true, L)) if folded(v, truth) else x_true
        s_true = float(t["damage_size"])
        net = v.get("network") or {}
        expl = next((h for h in (v.get("hypotheses") or []) if h["name"] == kind), None)
        sources = {"network": net if net.get("damaged") else None,
                   "explanation": (expl or {}).get("parameters") if expl and expl.get("fits") else None}
        for src, a in sources.items():
            if not a or a.get("x_m_68") is None:
                continue
            c = counts[src]
            c["answered"] += 1
            for lv in LEVELS:
                c[f"x_{lv}"] += bool(_inside(a.get(f"x_m_{lv}"), x_true))
                c[f"size_{lv}"] += bool(_inside(a.get(f"size_{lv}"), s_true))
    rows = []
    for src, c in counts.items():
        n = c["answered"]
        rows.append({"support": truth["bc"], "beam": truth["beam"], "kind": kind, "source": src,
                     "damaged_pairs": damaged, "answered": n,
                     **{k: (c[k] / n if n else float("nan")) for k in c if k != "answered"}})
    return rows


def _pct(v) -> str:
    return "-" if not np.isfinite(v) else f"{100 * v:.0f} %"


def markdown(rows: list[dict]) -> str:
    def se(n):
        return "-" if not n else f"{200 * np.sqrt(0.68 * 0.32 / n):.0f} / {200 * np.sqrt(0.95 * 0.05 / n):.0f} %"
    return table(["support", "kind", "intervals of", "answered / damaged", "x 68", "x 95", "size 68", "size 95",
                  "+-2 s.e. (68 / 95)"],
                 [[r["support"], r["kind"], r["source"], f"{r['answered']} / {r['damaged_pairs']}",
                   *(_pct(r[k]) for k in ("x_68", "x_95", "size_68", "size_95")), se(r["answered"])]
                  for r in rows]) + "\n"


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="classifier.md", json=True, out="out/coverage", seed=0, workers=2)
    p.add_argument("--n-pairs", type=int, default=60)
    p.add_argument("--train-n", type=int, default=6000)
    p.add_argument("--only", choices=sorted(BEAMS), action="append", help="a support (repeatable; default all)")
    p.add_argument("--kinds", nargs="+", choices=sorted(CONFIGS), default=sorted(CONFIGS))
    a = p.parse_args(argv)
    out = Path(a.out)
    by_name = {c.name: c for c in CATALOGUE}
    rows = []
    for support in a.only or BEAMS:
        cb = by_name[BEAMS[support]]
        for kind in a.kinds:
            spread = {"damage": kind} if kind != "slit" else None
            run_beam(cb, out, a.n_pairs, a.train_n, a.seed, a.workers, spread=spread,
                     tag="" if spread is None else f"damage={kind}", model_tag="" if kind == "slit" else kind,
                     config=CONFIGS[kind])
            d = out / cb.name
            suffix = "" if spread is None else f"-damage={kind}"
            mt = "" if kind == "slit" else f"-{kind}"
            truth = json.loads((d / f"pairs-n{a.n_pairs}-s{a.seed}{suffix}" / "truth.json").read_text())
            verdicts = json.loads((d / f"verdicts-n{a.n_pairs}-s{a.seed}-t{a.train_n}{suffix}{mt}.json").read_text())
            rows += cover(verdicts, truth, kind)
    out.mkdir(parents=True, exist_ok=True)
    md = markdown(rows)
    meta = {"n_pairs": a.n_pairs, "train_n": a.train_n, "seed": a.seed, "beams": BEAMS, "configs": CONFIGS}
    atomic_write_text(out / "coverage.json", json.dumps({**meta, "rows": rows}, indent=1) + "\n")
    keys = list(rows[0]) if rows else []
    atomic_write_text(out / "coverage.csv", "\n".join([",".join(keys)] + [",".join(str(r[k]) for k in keys)
                                                                            for r in rows]) + "\n")
    atomic_write_text(out / "coverage.md", md)
    publish(a, "coverage", md)
    print(json.dumps(rows, indent=1) if a.json else md)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
