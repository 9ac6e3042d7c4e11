"""Mass changes of real size on data the project did not make: the bolted cantilever's pairs through ``classify``.

Run::

    python -m experiments.second_sim bolted --pairs 60 --seed 7 --out out/bolted-pairs
    beam-damage generate --config MASS_TOML --beam out/bolted-pairs/bolted.toml --n 12000 --seed 1 --out out/mc-train
    beam-damage train --data out/mc-train --out out/mc-model --epochs 30
    python -m experiments.benches.bench_mass_change --model out/mc-model --pairs out/bolted-pairs [--out out/mc-bench]

with ``MASS_TOML`` a training config of ``kind = "mass_change"`` (docs/datasets.md: ``mass_ratio = [-0.2, 0.2]``,
``width_fraction = [0.0, 0.25]``). The pairs come from :mod:`experiments.second_sim.bolted` (its own FE beam,
masses added as point masses of 1-20 % of the bar's mass anywhere, lost as 1-8 % taken off a bolted mass; no code
shared with the project). Each pair is classified as a user would (``beam-damage classify --model M --beam
bolted.toml --baseline pair-K_baseline.json pair-K_current.json --json``). Per change (added, lost, intact) and
method (the verdict, the network, each classical method):

* ``detected``: pairs called damaged (for intact pairs: false alarms);
* ``sign right``: detected pairs whose size has the truth's sign (a mass added: > 0, lost: < 0);
* ``zone right``: detected pairs located in the truth's zone (the beam file's zones: between the sensors);
* ``size err.``: median ``|s - s_true|`` of the signed mass ratio over detected pairs with the right sign.

Writes ``mass_change.csv`` and ``mass_change.json`` in ``--out``; ``--json`` prints the rows; ``--docs`` writes
the table into docs/datasets.md (block ``mass_change``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from experiments.benches.bench_debond import classify_pairs
from experiments.benches.harness import parser, publish, table

__all__ = ["main", "markdown", "score"]


def _answers(v: dict) -> dict:
    """Method -> (damaged, x_m, signed size, zone) of one verdict."""
    out = {"verdict": (v["damaged"], v.get("location_x_m"), v.get("size"), v.get("location_zone"))}
    net = v.get("network")
    if net:
        out["network"] = (net["damaged"], net.get("location_x_m"), net.get("size"),
                          net.get("location_zone"))
    for c in v.get("classical_methods") or []:
        out[c["method"]] = (c["damaged"], c.get("location_x_m"), c.get("size"), c.get("location_zone"))
    return out


def score(truth: list, verdicts: list, zone_edges_m) -> list[dict]:
    """The rows of the module docstring."""
    edges = np.asarray(zone_edges_m, float)
    recs = []
    for t, v in zip(truth, verdicts):
        for method, (dmg, x, size, _) in _answers(v).items():
            recs.append({"method": method, "change": t["change"], "damaged": bool(dmg), "truth_ratio": t["mass_ratio"],
                         "truth_zone": int(np.searchsorted(edges, t["x_m"], side="right")) if t["damaged"] else 0,
                         "zone": int(np.searchsorted(edges, x, side="right")) if x is not None else 0,
                         "size": np.nan if size is None else float(size)})
    df = pd.DataFrame(recs)
    rows = []
    for (method, change), g in df.groupby(["method", "change"], sort=False):
        det = g[g.damaged]
        sign = det[np.sign(det["size"]) == np.sign(det.truth_ratio)] if change != "intact" else det.iloc[:0]
        rows.append({"method": method, "change": change, "pairs": len(g), "detected": len(det) / len(g),
                     "sign right": len(sign) / len(det) if len(det) and change != "intact" else np.nan,
                     "zone right": float(np.mean(det.zone == det.truth_zone)) if len(det) and change != "intact"
                     else np.nan,
                     "size err.": float(np.median(np.abs(sign["size"] - sign.truth_ratio))) if len(sign) else np.nan})
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as the docs' table (fractions in %, NaN as a dash)."""
    def pct(v):
        return "-" if v != v else f"{100 * v:.0f} %"

    return table(["change", "method", "pairs", "detected", "sign right", "zone right", "size err."],
                 [[r["change"], r["method"], r["pairs"], pct(r["detected"]), pct(r["sign right"]), pct(r["zone right"]),
                   "-" if r["size err."] != r["size err."] else f"{r['size err.']:.3f}"]
                  for r in sorted(rows, key=lambda r: ("added", "lost", "intact").index(r["change"]))]) + "\n"


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="datasets.md", json=True, out="out/mass_change")
    ap.add_argument("--model", required=True)
    ap.add_argument("--pairs", required=True, help="directory of second_sim bolted --pairs")
    a = ap.parse_args(argv)
    pair_dir = Path(a.pairs)
    truth, verdicts = classify_pairs(Path(a.model), pair_dir, ["--beam", str(pair_dir / "bolted.toml")])
    rows = score(truth, verdicts, verdicts[0]["zone_edges_m"][1:-1])
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(out / "mass_change.csv", index=False)
    (out / "mass_change.json").write_text(json.dumps({"rows": rows, "verdicts": verdicts}, indent=1, default=float))
    if a.json:
        print(json.dumps(rows, indent=1, default=float))
    else:
        print(pd.DataFrame(rows).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    publish(a, "mass_change", markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
