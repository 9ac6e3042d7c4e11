"""``beam-damage classify``: is a measured beam damaged, where, how much."""

from __future__ import annotations

from pathlib import Path

import numpy as np

KEYS = ("damaged", "probability_damaged", "location_x_over_L", "location_x_m", "location_std_m", "location_element",
        "element_probabilities", "stiffness_loss_Nm3", "stiffness_loss_std_Nm3", "depth_m", "detectable",
        "input_route", "warnings", "dof_positions")


def add_parser(sub):
    p = sub.add_parser("classify", help="classify a measured beam against its baseline with a trained model",
                       description="BASELINE and MEASURED are FRF files (UFF58 .uff/.unv, CSV, NPZ) with receptances "
                                   "at the model's DOFs, or modal-data JSON as 'update' accepts. FRFs on any frequency "
                                   "lines are interpolated onto the model's log-frequency grid; modal data use the "
                                   "model's modal-route network. Prints a verdict beside the best classical "
                                   "baseline's answer; --out writes verdict.json and classify.png.")
    p.add_argument("--model", required=True, metavar="MODEL_DIR")
    p.add_argument("--baseline", required=True, metavar="BASELINE", help="undamaged state (FRF file or modal JSON)")
    p.add_argument("measured", metavar="MEASURED", help="current state (same kind as BASELINE)")
    p.add_argument("--beam", help="beam of the data: the model's preset name (default) or a beam file of the same "
                                  "length whose measured_x_m places measured DOFs of files without node geometry "
                                  "(else nodes 2..5 at the quarter points); another beam is refused")
    p.add_argument("--mass", choices=("iirs", "lumped"), help="mass model of the data's updating (default: the model's)")
    p.add_argument("--out", metavar="DIR", help="write verdict.json and classify.png here (default without --json: "
                                                "out/classify)")
    p.add_argument("--json", action="store_true", help="print exactly the verdict keys as JSON")
    p.set_defaults(func=run)


def read_input(path):
    """Modal JSON -> ModalData, anything else -> MeasuredFRF."""
    from physics.io import read_frf, read_modal_json

    return read_modal_json(path) if str(path).lower().endswith(".json") else read_frf(path)


def run(args) -> dict:
    from learn.features import BeamSpec
    from learn.workflow import classify, load_model, on_model_dofs, peak_modal_data

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
    (base, base_map), (cur, cur_map) = (on_model_dofs(read_input(f), b, beam_x_m, str(f))
                                        for f in (args.baseline, args.measured))
    res = classify(model, base, cur, identified=peak_modal_data(base, cur))
    res["dof_positions"] = {"baseline": base_map and base_map.to_dict(), "measured": cur_map and cur_map.to_dict()}
    extra = res.pop("_extra")
    if not args.json and not args.out:
        args.out = "out/classify"
    if args.out:
        _write(args.out, res, extra, base, cur, model)
    if not args.json:
        print(verdict_text(res, extra, b.length_m))
        if args.out:
            print(f"verdict.json and classify.png in {args.out}")
    return {k: res[k] for k in KEYS}


def _length(name):
    from physics.properties import beam_preset
    return beam_preset(name).length


def verdict_text(res: dict, extra: dict, length_m: float) -> str:
    p = res["probability_damaged"]
    lines = []
    if not res["damaged"]:
        lines.append(f"No damage detected (probability of damage {p:.1%}).")
    elif not res["detectable"]:
        lines.append(f"Possibly damaged (probability {p:.1%}), but not detectable here: a slit like the one that would "
                     f"explain the data, near x = {res['location_x_m']:.3f} m, changes the natural frequencies by less "
                     f"than the measurement resolution.")
    else:
        depth = "" if res["depth_m"] is None else f", i.e. a slit about {res['depth_m'] * 1000:.2f} mm deep over 5.5 mm"
        lines.append(f"Damaged (probability {p:.1%}): slit at x = {res['location_x_m']:.3f} m +- "
                     f"{res['location_std_m']:.3f} m (x/L = {res['location_x_over_L']:.2f}, element "
                     f"{res['location_element']} of 4), stiffness loss dEI*w = {res['stiffness_loss_Nm3']:.3g} +- "
                     f"{res['stiffness_loss_std_Nm3']:.2g} N m^3{depth}.")
    lines.append("Element probabilities: " + ", ".join(f"{k + 1}: {v:.2f}" for k, v in
                                                       enumerate(res["element_probabilities"])))
    lines.append(f"Input route: {res['input_route']}; distance from the training data: Mahalanobis "
                 f"{extra['mahalanobis_distance']:.3g} (beyond {extra['training_percentile']:.1f}% of training pairs).")
    bl = extra.get("baseline")
    if bl:
        lines.append(f"Best classical baseline ({bl['method']}): {'damaged' if bl['damaged'] else 'undamaged'}, "
                     f"location x = {bl['location_x_m']:.3f} m (element {bl['location_element']}), "
                     f"stiffness loss {bl['stiffness_loss_Nm3']:.3g} N m^3.")
    from physics.io import dof_positions_text

    for name, d in res["dof_positions"].items():
        lines.append(f"{name}: " + (dof_positions_text(d) if d else "modal data without DOF labels: rows taken as "
                                                                  "the model's DOFs"))
    lines += [f"warning: {w}" for w in res["warnings"]]
    return "\n".join(lines)


def _write(out_dir, res, extra, base, cur, model):
    import io
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from experiments.cli import to_jsonable
    from physics.io import MeasuredFRF, atomic_write_bytes, atomic_write_text

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    L = model.beam.length_m
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6.5))
    for name, d in (("baseline", base), ("measured", cur)):
        if isinstance(d, MeasuredFRF):
            h = d.to_kind("receptance") if d.frequency_hz[0] > 0 else d
            a1.semilogy(h.frequency_hz, np.abs(h.frf[-1, 0]), label=f"{name} {h.response_dofs[-1]}/{h.reference_dofs[0]}")
        else:
            w = np.linspace(1.0, 1.15 * np.abs(d.eigenvalues).max(), 4000)
            psi = d.eigenvectors
            H = np.sum(psi[-1] * psi[0] / (1j * w[:, None] - d.eigenvalues)
                       + np.conj(psi[-1] * psi[0]) / (1j * w[:, None] - np.conj(d.eigenvalues)), axis=1)
            a1.semilogy(w / (2 * np.pi), np.abs(H), label=f"{name} (synthesised from modes, unscaled)")
    a1.set(xlabel="frequency (Hz)", ylabel="|H| (m/N)", title="Baseline vs measured")
    a1.legend(fontsize=7)
    dist = extra["location_distribution"]
    edges = np.linspace(0, L, dist.size + 1)
    a2.bar(edges[:-1], dist, width=np.diff(edges), align="edge", color="tab:red", alpha=0.7)
    for k in range(1, 4):
        a2.axvline(k * L / 4, color="grey", ls=":")
    a2.set(xlabel="x from the clamp (m)", ylabel="probability",
           title=f"Location distribution (P(damaged) = {res['probability_damaged']:.2f})")
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out / "classify.png", buf.getvalue())
    atomic_write_text(out / "verdict.json", json.dumps(to_jsonable({**res, "baseline_method": extra.get("baseline"),
                                                                    "mahalanobis_distance": extra["mahalanobis_distance"],
                                                                    "training_percentile": extra["training_percentile"]}),
                                                       indent=1))
