"""``beam-damage classify``: is a measured beam damaged, where, how much."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["KEYS", "add_parser", "run"]

KEYS = ("measured", "damaged", "probability_damaged", "location_x_over_L", "location_x_m", "location_std_m",
        "location_element", "element_probabilities", "hinge_flexibility", "hinge_flexibility_std", "depth_m",
        "detectable", "verdict_from", "in_distribution", "out_of_distribution_reasons", "mahalanobis_distance",
        "training_percentile", "network", "classical", "classical_methods", "identification", "input_route",
        "warnings", "dof_positions")


def add_parser(sub):
    from physics.io import FRF, MODAL, accepted

    p = sub.add_parser("classify", help="classify measured beams against their baseline with a trained model",
                       description=f"BASELINE and each MEASURED are files of {accepted(FRF, MODAL)}. FRFs: "
                                   "receptances, mobilities or accelerances at the model's DOFs; modal data: as "
                                   "'update' accepts. FRF files are identified by LSCF/LSFD (4 modes), the "
                                   "identification the training data's modal noise describes. A pair outside the "
                                   "training data gets the classical method's verdict, the network's shown beside it; "
                                   "a pair whose tests do not both hold modes 1-4 gets the classical method's verdict "
                                   "on the modes both hold (at least 2) and no network answer. "
                                   "Several MEASURED files give a list of verdicts; --out writes verdict.json and "
                                   "classify.png (one pair) or verdicts.json (several).")
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
    from physics.io import modal_or_frf, read

    return read(path, modal_or_frf(path))


def run(args):
    from learn.features import BeamSpec
    from learn.workflow import classify_many, load_model, on_model_dofs

    model = load_model(args.model)
    b = model.beam
    beam_x_m = None
    if args.beam and Path(args.beam).suffix.lower() == ".toml":
        from physics.beam import load_beam

        fb = load_beam(args.beam)
        spec = BeamSpec(b.name, fb.length_m, b.dofs, args.mass or b.mass_model)
        beam_x_m = fb.measured_x_m if fb.measured_x_given else None
    else:
        spec = BeamSpec(args.beam or b.name, b.length_m if args.beam in (None, b.name) else _length(args.beam),
                        b.dofs, args.mass or b.mass_model)
    model.check_beam(spec, "measured beam")
    files = [args.baseline, *args.measured]
    mapped = [on_model_dofs(read_input(f), b, beam_x_m, str(f)) for f in files]
    results = classify_many(model, mapped[0][0], [m[0] for m in mapped[1:]], names=[str(f) for f in files])
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
            print(verdict_text(r))
        if args.out:
            print(f"{'verdict.json and classify.png' if len(results) == 1 else 'verdicts.json'} in {args.out}")
    out = [{k: r[k] for k in KEYS} for r in results]
    return out[0] if len(out) == 1 else out


def _length(name):
    from physics.properties import beam_preset
    return beam_preset(name).length_m


def _network_sentence(a: dict) -> str:
    if not a["damaged"]:
        return f"no damage detected (probability of damage {a['probability_damaged']:.1%})"
    if not a["detectable"]:
        return (f"possibly damaged (probability {a['probability_damaged']:.1%}), but not detectable here: a slit like "
                f"the one that would explain the data, near x = {a['location_x_m']:.3f} m, changes the natural "
                "frequencies by less than the measurement resolution")
    depth = "" if a["depth_m"] is None else f", e.g. a slit {a['depth_m'] * 1000:.2f} mm deep over 5.5 mm"
    return (f"damaged (probability {a['probability_damaged']:.1%}): slit at x = {a['location_x_m']:.3f} m +- "
            f"{a['location_std_m']:.3f} m (x/L = {a['location_x_over_L']:.2f}, element {a['location_element']} of "
            f"4), hinge flexibility EI/(k L) = {a['hinge_flexibility']:.3g} +- {a['hinge_flexibility_std']:.2g}"
            f"{depth}")


def _classical_sentence(c: dict) -> str:
    if not c["damaged"]:
        return f"{c['method']}: undamaged"
    return (f"{c['method']}: damaged, x = {c['location_x_m']:.3f} m (element {c['location_element']}), hinge "
            f"flexibility {c['hinge_flexibility']:.3g}")


def verdict_text(res: dict) -> str:
    """The verdict as a reader sees it: the answer, where it comes from, both methods, the caveats."""
    net, cl = res["network"], res["classical"]
    modes = res["identification"].get("modes_classified") or []
    if res["verdict_from"] == "network":
        head = "Verdict (network): " + _network_sentence(net) + "."
    elif net is None:
        head = (f"Verdict (classical method on modes {', '.join(map(str, modes))}, the network needs modes 1-4): "
                + _classical_sentence(cl) + ".")
    else:
        head = ("Verdict (classical method, the pair lies outside the training data): " + _classical_sentence(cl)
                + ".")
    lines = [head[:1].upper() + head[1:]]
    if net is None:
        lines.append("Why: " + "; ".join(res["out_of_distribution_reasons"]) + ".")
        lines.append("Network: no answer (trained on modes 1-4).")
    else:
        if net["damaged"]:
            lines.append("Element probabilities (network): " + ", ".join(f"{k + 1}: {v:.2f}" for k, v in
                                                                         enumerate(net["element_probabilities"])))
        lines.append(f"Network: {_network_sentence(net)}.")
    lines.append(f"Classical ({cl['method']}, the best on the training data): {_classical_sentence(cl)}." if cl else
                 "Classical: no answer (fewer than 2 modes identified in both tests).")
    if net is None:
        lines.append(f"Input route: {res['input_route']}; in distribution: no.")
    else:
        lines.append(f"Input route: {res['input_route']}; distance from the training data: Mahalanobis "
                     f"{res['mahalanobis_distance']:.3g} (beyond {res['training_percentile']:.1f}% of training pairs); "
                     f"in distribution: {'yes' if res['in_distribution'] else 'no'}.")
    ident = res["identification"]
    lines.append(f"Natural frequencies (Hz, {ident['source']}): baseline "
                 + ", ".join(f"{x:.2f}" for x in ident["baseline_frequencies_hz"]) + "; measured "
                 + ", ".join(f"{x:.2f}" for x in ident["measured_frequencies_hz"])
                 + (f"; modes classified: {', '.join(map(str, modes))}" if modes and len(modes) < 4 else ""))
    from physics.io import dof_positions_text

    for name, d in res["dof_positions"].items():
        lines.append(f"{name}: " + (dof_positions_text(d) if d else "modal data without DOF labels: rows taken as "
                                                                  "the model's DOFs"))
    lines += [f"warning: {w}" for w in res["warnings"]]
    return "\n".join(lines)


def _write(out_dir, results, extras, base, cur, model):
    """verdict.json and classify.png (one pair) or verdicts.json (several), each written atomically."""
    import json

    from experiments.cli import to_jsonable
    from physics.io import atomic_write_bytes, atomic_write_text

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if len(results) > 1:
        atomic_write_text(out / "verdicts.json", json.dumps(to_jsonable(results), indent=1))
        return
    atomic_write_bytes(out / "classify.png", _figure(results[0], extras[0], base, cur, model.beam.length_m))
    atomic_write_text(out / "verdict.json", json.dumps(to_jsonable(results[0]), indent=1))


def _figure(res, extra, base, cur, length_m) -> bytes:
    """PNG: baseline and measured FRF (or FRF synthesised from modes), and the network's location distribution."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from physics.io import MeasuredFRF

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6.5))
    for name, d in (("baseline", base), ("measured", cur)):
        if isinstance(d, MeasuredFRF):
            h = d.to_kind("receptance") if d.frequency_hz[0] > 0 else d
            a1.semilogy(h.frequency_hz, np.abs(h.frf[-1, 0]),
                        label=f"{name} {h.response_dofs[-1]}/{h.reference_dofs[0]}")
        else:
            w = np.linspace(1.0, 1.15 * np.abs(d.eigenvalues).max(), 4000)
            psi = d.eigenvectors
            H = np.sum(psi[-1] * psi[0] / (1j * w[:, None] - d.eigenvalues)
                       + np.conj(psi[-1] * psi[0]) / (1j * w[:, None] - np.conj(d.eigenvalues)), axis=1)
            a1.semilogy(w / (2 * np.pi), np.abs(H), label=f"{name} (synthesised from modes, unscaled)")
    a1.set(xlabel="frequency (Hz)", ylabel="|H| (m/N)", title="Baseline vs measured")
    a1.legend(fontsize=7)
    dist = extra["location_distribution"]
    if dist is not None:
        edges = np.linspace(0, length_m, dist.size + 1)
        a2.bar(edges[:-1], dist, width=np.diff(edges), align="edge", color="tab:red", alpha=0.7,
               label="network's location distribution")
    if res["classical"] and res["classical"]["damaged"]:
        a2.axvline(res["classical"]["location_x_m"], color="k", ls="--",
                   label=f"{res['classical']['method']}: x = {res['classical']['location_x_m']:.3f} m")
    for k in range(1, 4):
        a2.axvline(k * length_m / 4, color="grey", ls=":")
    if a2.get_legend_handles_labels()[0]:
        a2.legend(fontsize=7)
    net = res["network"]
    modes = ", ".join(map(str, res["identification"].get("modes_classified") or []))
    a2.set(xlabel="x from the clamp (m)", ylabel="probability",
           title=(f"Network: P(damaged) = {net['probability_damaged']:.2f}" if net else
                  "Network: no answer (it needs modes 1-4)") + f"; verdict from the {res['verdict_from']}"
           + ("" if net else f" method on modes {modes}"))
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
