"""``beam-damage classify``: is a measured beam damaged, where, how much."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from experiments.jsonable import to_jsonable
from learn.classify import classify_many
from learn.measured import on_model_dofs
from learn.model_dir import load_model
from physics.frf import receptance_modal
from physics.io import (FRF, MODAL, MeasuredFRF, accepted, atomic_write_bytes, atomic_write_text, modal_or_frf, read,
                        read_json)

__all__ = ["KEYS", "add_parser", "run"]

KEYS = ("measured", "damaged", "probability_damaged", "location_x_over_L", "location_x_m", "location_std_m",
        "location_zone", "zone_edges_m", "zone_probabilities", "location_ambiguity",
        "location_element", "element_probabilities", "hinge_flexibility", "hinge_flexibility_std", "depth_m",
        "detectable", "probability_support_change", "support_changed", "verdict_from", "in_distribution",
        "out_of_distribution_reasons", "mahalanobis_distance",
        "training_percentile", "distance_terms", "hypotheses", "hypotheses_summary",
        "frequency_change_std", "shape_change_std", "network", "classical",
        "classical_methods", "identification", "input_route", "warnings", "dof_positions")


def add_parser(sub):
    p = sub.add_parser("classify",
                       description=f"BASELINE and each MEASURED are files of {accepted(FRF, MODAL)}. FRFs: "
                                   "receptances, mobilities or accelerances at the model's DOFs; modal data: as "
                                   "'update' accepts. FRF files are identified by LSCF/LSFD over the model's band for "
                                   "its modes, the identification the training data's modal noise describes. A pair "
                                   "outside the training data gets the classical method's verdict, the network's shown"
                                   " beside it, and the features that put it outside (distance_terms); a pair whose "
                                   "tests do not both hold the model's modes gets the classical method's verdict on "
                                   "the modes both hold (at least 2) and no network answer. Every verdict weighs the "
                                   "explanations of the frequency changes (intact, global stiffness, support change, "
                                   "slit, mass change: hypotheses), and a network trained with support changes "
                                   "says whether the supports changed beyond re-clamping (support_changed, "
                                   "probability_support_change). Several MEASURED files "
                                   "give a list of verdicts; --out writes verdict.json and classify.png (one pair) or "
                                   "verdicts.json (several).")
    p.add_argument("--model", required=True, metavar="MODEL_DIR")
    p.add_argument("--baseline", required=True, metavar="BASELINE", help="undamaged state (FRF file or modal JSON)")
    p.add_argument("measured", nargs="+", metavar="MEASURED", help="current state(s) (same kind as BASELINE)")
    p.add_argument("--beam", help="beam of the data: the model's preset name (default) or a beam file of the same "
                                  "length whose measured_x_m places measured DOFs of files without node geometry "
                                  "(else nodes 2..5 at the quarter points); another beam is refused")
    p.add_argument("--mass", choices=("iirs", "lumped"),
                   help="mass model of the data's updating (default: the model's)")
    p.add_argument("--out", metavar="DIR", help="write the verdict(s) and figure here (default without --json: "
                                                "out/classify)")
    p.add_argument("--json", action="store_true", help="print the verdict (a list for several MEASURED) as JSON")
    p.set_defaults(func=run)


def read_input(path):
    """A modal-data file -> ModalData, an FRF file -> MeasuredFRF (:func:`physics.io.modal_or_frf`)."""
    return read(path, modal_or_frf(path))


def identification_method(path) -> str | None:
    """The ``method`` a modal-data JSON file names (``identify --out`` writes it for output-only modes), else None."""
    if modal_or_frf(path) != MODAL or not str(path).lower().endswith(".json"):
        return None
    obj = read_json(path, require_object=False)
    method = obj.get("method") if isinstance(obj, dict) else None
    return method if isinstance(method, str) else None


def run(args):
    model = load_model(args.model)
    _, beam_x_m = model.measured_beam(args.beam, args.mass)
    files = [args.baseline, *args.measured]
    mapped = [on_model_dofs(read_input(f), model.beam, beam_x_m, str(f)) for f in files]
    results = classify_many(model, mapped[0][0], [m[0] for m in mapped[1:]], names=[str(f) for f in files],
                            methods=[identification_method(f) for f in files])
    base_pos = mapped[0][1] and mapped[0][1].to_dict()
    extras = []
    for r, (_, cur_map) in zip(results, mapped[1:]):
        r["dof_positions"] = {"baseline": base_pos, "measured": cur_map and cur_map.to_dict()}
        extras.append(r.pop("_extra"))
    if not args.json and not args.out:
        args.out = "out/classify"
    if args.out:
        _write(args.out, results, extras, mapped[0][0], mapped[1][0], model)
    if not args.json:
        for r in results:
            if len(results) > 1:
                print(f"== {r['measured']}")
            print(model.verdict_text(r))
        if args.out:
            print(f"{'verdict.json and classify.png' if len(results) == 1 else 'verdicts.json'} in {args.out}")
    out = [{k: r[k] for k in KEYS} for r in results]
    return out[0] if len(out) == 1 else out


def _write(out_dir, results, extras, base, cur, model):
    """verdict.json and classify.png (one pair) or verdicts.json (several), each written atomically."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if len(results) > 1:
        atomic_write_text(out / "verdicts.json", json.dumps(to_jsonable(results), indent=1))
        return
    atomic_write_bytes(out / "classify.png", _figure(results[0], extras[0], base, cur, model.beam))
    atomic_write_text(out / "verdict.json", json.dumps(to_jsonable(results[0]), indent=1))


def _figure(res, extra, base, cur, beam) -> bytes:
    """PNG: baseline and measured FRF (or FRF synthesised from modes), and the beam (supports, sensors, zones) under
    the network's location distribution."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6.5))
    for name, d in (("baseline", base), ("measured", cur)):
        if isinstance(d, MeasuredFRF):
            h = d.to_kind("receptance") if d.frequency_hz[0] > 0 else d
            a1.semilogy(h.frequency_hz, np.abs(h.frf[-1, 0]),
                        label=f"{name} {h.response_dofs[-1]}/{h.reference_dofs[0]}")
        else:
            w = np.linspace(1.0, 1.15 * np.abs(d.eigenvalues).max(), 4000)
            H = receptance_modal(d.eigenvalues, d.eigenvectors, w, response=[-1], reference=[0])[0, 0]
            a1.semilogy(w / (2 * np.pi), np.abs(H), label=f"{name} (synthesised from modes, unscaled)")
    a1.set(xlabel="frequency (Hz)", ylabel="|H| (m/N)", title="Baseline vs measured")
    a1.legend(fontsize=7)
    length_m = beam.length_m
    dist = extra["location_distribution"]
    if dist is not None:
        edges = np.linspace(0, length_m, dist.size + 1)
        a2.bar(edges[:-1], dist, width=np.diff(edges), align="edge", color="tab:red", alpha=0.7,
               label="network's location distribution")
    if res["classical"] and res["classical"]["damaged"]:
        a2.axvline(res["classical"]["location_x_m"], color="k", ls="--",
                   label=f"{res['classical']['method']}: x = {res['classical']['location_x_m']:.3f} m")
    for x in beam.zone_edges_m[1:-1]:
        a2.axvline(x, color="grey", ls=":")
    _draw_beam(a2, beam)
    if a2.get_legend_handles_labels()[0]:
        a2.legend(fontsize=7)
    net = res["network"]
    modes = ", ".join(map(str, res["identification"].get("modes_classified") or []))
    a2.set(xlabel="x (m)", ylabel="probability",
           title=(f"Network: P(damaged) = {net['probability_damaged']:.2f}" if net else
                  "Network: no answer (it needs more modes)") + f"; verdict from the {res['verdict_from']}"
           + ("" if net else f" method on modes {modes}"))
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def _draw_beam(ax, beam) -> None:
    """The beam under the location axis: its supports (clamp: a wall; pin: a triangle), sensors (v) and zones."""
    L = beam.length_m
    bc = "clamped-free" if beam.test is None else beam.test.bc
    ends = {"clamped-free": ("clamp", None), "free-free": (None, None), "pinned-pinned": ("pin", "pin"),
            "clamped-clamped": ("clamp", "clamp")}[bc]
    y = ax.get_ylim()[1] if ax.has_data() else 1.0
    ax.plot([0, L], [-0.06 * y] * 2, color="k", lw=3, solid_capstyle="butt")
    for x, kind in zip((0.0, L), ends):
        if kind == "clamp":
            ax.plot([x, x], [-0.14 * y, 0.02 * y], color="k", lw=5)
        elif kind == "pin":
            ax.plot([x], [-0.1 * y], marker="^", ms=10, color="k")
    ax.plot(beam.sensors_x_m, [-0.02 * y] * len(beam.sensors_x_m), "v", color="tab:blue", ms=7,
            label=f"sensors ({len(beam.sensors_x_m)}), {bc}")
    ax.set_ylim(-0.18 * y, 1.05 * y)
