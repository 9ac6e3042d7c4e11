"""Benchmark: the classifier on output-only pairs beside the FRF route, on the independent simulator's specimens.

Run: ``.venv/bin/python -m experiments.benches.bench_output_only --model MODEL_DIR [--model MODEL_DIR2 ...] [--n 24]
[--seed 500] [--minutes 5] [--out out/output-only] [--docs] [--table output-only-noise]``

Several ``--model`` are scored on the same pairs, e.g. one trained on the FRF route's modal noise beside one
trained on ``generate --modal-noise output-only`` data.

The pairs are the independent simulator's ``eb`` set (:mod:`experiments.second_sim`: beam-5-like cantilevers,
EI +-5 %, temperature and re-clamping between the days, slits anywhere). Each specimen is tested twice in two ways:

* **FRF route**: the set's UFF files (receptances at the quarter points driven at node 2, 2 % noise), as
  ``bench_foreign`` classifies them;
* **output-only route**: the same two beams under white random forces at the tip, ``--minutes`` of
  acceleration at the quarter points at 2 kHz with 2 % sensor noise
  (:func:`experiments.second_sim.ambient.ambient_record`, the pair's own modal damping), identified by
  ``beam-damage identify REC.npz --band 2 800`` (SSI-cov, chosen by itself for records without a force) into
  ``modal.json`` with unscaled shapes.

Both are classified with ``beam-damage classify --model MODEL_DIR --json`` and scored per method as
``bench_foreign`` scores them (element accuracy, detection, false alarms, size error, 1-sigma cover, share of
pairs inside the training data), with one more row, ``explanations``: the pair called damaged when a slit is the
most probable of the competing explanations (``hypotheses``), at its place and size; ``skew warned``: pairs whose
verdict warns that the modes were identified otherwise than the model's training data assumes.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from experiments.benches.bench_foreign import classify_set, score, write_sets
from experiments.second_sim.ambient import ambient_record, write_npz
from experiments.second_sim.fem import Beam, Slit
from experiments.second_sim.pairs import NODE_X_M
from experiments.benches.harness import cli_json, parser, publish, table

__all__ = ["beams_of", "main"]

METHODS = ("verdict", "network", "DLAC", "Cawley-Adams", "explanations")


def with_explanations(v: dict, length_m: float) -> dict:
    """The verdict with one more answer, ``explanations``: damaged when a slit is the most probable explanation of
    the frequency changes (``hypotheses``), at its most probable place and size."""
    top = (v.get("hypotheses") or [{"name": None}])[0]
    p = top.get("parameters") or {}
    slit = top["name"] == "slit"
    answer = {"method": "explanations", "damaged": slit,
              "location_element": min(4, int(p["x_m"] // (length_m / 4)) + 1) if slit else None,
              "size": p.get("size") if slit else None}
    return {**v, "classical_methods": [*(v.get("classical_methods") or []), answer]}


def beams_of(truth: dict):
    """The baseline and current :class:`experiments.second_sim.fem.Beam` of a pair from its truth record."""
    L = truth["length_m"]
    base = Beam(L, truth["EI_Nm2"], truth["mass_per_length_kg_m"], root_k_theta_Nm_rad=truth["root_k_theta_Nm_rad"])
    slits = (Slit(truth["slit_x_m"], truth["width_m"], truth["ei_loss_fraction"]),) if truth["damaged"] else ()
    cur = replace(base, EI_Nm2=base.EI_Nm2 * truth["temperature_ei_factor"],
                  root_k_theta_Nm_rad=base.root_k_theta_Nm_rad * truth["reclamp_k_factor"], slits=slits)
    return base, cur


def output_only_pairs(truth: list, out: Path, minutes: float, seed: int) -> Path:
    """Record, write and identify both tests of every pair output-only; returns the directory of the modal JSON."""
    out.mkdir(parents=True, exist_ok=True)
    for t in truth:
        k = int(t["pair"])
        for state, beam in zip(("baseline", "current"), beams_of(t)):
            target = out / f"pair-{k:03d}_{state}.json"
            if target.is_file():
                continue
            rec = ambient_record(beam, NODE_X_M[1:], duration_s=60 * minutes, damping=t["damping_ratios"],
                                 seed=seed + 2 * k + (state == "current"))
            npz = out / f"pair-{k:03d}_{state}.npz"
            write_npz(npz, rec)
            cli_json(["identify", str(npz), "--band", "2", "800", "--out", str(out / f"id-{k:03d}-{state}")])
            (out / f"id-{k:03d}-{state}" / "modal.json").replace(target)
            npz.unlink()
    return out


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md", out="out/output-only", seed=500)
    p.add_argument("--model", required=True, metavar="MODEL_DIR", action="append",
                   help="a trained model (repeatable: each is scored on the same pairs)")
    p.add_argument("--n", type=int, default=24, help="pairs (default 24)")
    p.add_argument("--minutes", type=float, default=5.0, help="record length of each test (default 5)")
    p.add_argument("--table", choices=("output-only-classify", "output-only-noise"), default="output-only-classify",
                   help="the docs table written (with --docs): one model's routes, or models trained on FRF-route "
                        "against output-only modal noise")
    args = p.parse_args(argv)

    out = Path(args.out)
    truth = write_sets(out, ["eb"], args.n, args.seed)["eb"]
    pair_dir = out / "pairs" / "eb"
    oma_dir = output_only_pairs(truth, out / "output-only", args.minutes, args.seed)
    rows = []
    for model in args.model:
        for route, directory, ext in (("FRF (UFF, LSCF/LSFD)", pair_dir, "uff"),
                                      (f"output-only ({args.minutes:g} min records, SSI-cov)", oma_dir, "json")):
            verdicts = [with_explanations(v, truth[0]["length_m"])
                        for v in classify_set(Path(model), directory, truth, ext=ext)]
            warned = sum(any("retrain on data from" in w for w in v.get("warnings") or ()) for v in verdicts)
            for r in score(verdicts, truth):
                if r["method"] in METHODS:
                    rows.append({"model": Path(model).name, "route": route, "skew_warned": warned, **r})
    md = markdown(rows, args)
    sys.stdout.write(md)
    (out / "output_only.json").write_text(json.dumps({"config": vars(args), "rows": rows}, indent=1) + "\n")
    publish(args, args.table, md)
    return 0


def markdown(rows: list[dict], args) -> str:
    def pct(v):
        return "-" if v is None or not np.isfinite(v) else f"{v:.0%}"

    head = ["model", "route", "method", "element acc.", "detection", "false alarms", "size err.", "1-sigma cover",
            "inside", "skew warned"]
    return table(head, [[f"`{r['model']}`", r["route"], r["method"], pct(r["element_accuracy"]), pct(r["detection"]),
                         f"{r['false_alarms']} of {r['intact_pairs']}", pct(r["median_size_error"]),
                         pct(r["size_one_sigma_cover"]), pct(r.get("in_distribution")), r["skew_warned"]]
                        for r in rows]) + f"\n\n{args.n} pairs of the `eb` set, seed {args.seed}.\n"


if __name__ == "__main__":
    raise SystemExit(main())
