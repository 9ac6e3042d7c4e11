"""``beam-damage classify``: is a measured beam damaged, where, how much."""

from __future__ import annotations

import glob
import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from learn.pairs.classify import DEFAULT_FALSE_ALARM_RATE, KEYS, classify_pairs
from learn.pairs.verdict import explanation_label, verdict_text
from learn.pairs.measured import on_model_dofs, measured_test_differences
from learn.network.model_dir import load_model
from physics.errors import BeamDamageError, ConfigError
from physics.frf import FRF_UNITS, receptance_modal
from physics.io import (
    FRF,
    MODAL,
    MeasuredFRF,
    ModalData,
    accepted,
    atomic_write_bytes,
    atomic_write_text,
    figure_png,
    modal_or_frf,
    pyplot,
    read,
    read_json,
    to_jsonable,
)

__all__ = ["KEYS", "add_parser", "run"]

def add_parser(sub):
    p = sub.add_parser("classify",
                       description=f"BASELINE and each MEASURED are files of {accepted(FRF, MODAL)}. FRFs: "
                                   "receptances, mobilities or accelerances at the model's DOFs; modal data: as "
                                   "'update' accepts. FRF files are identified by LSCF/LSFD over the model's band as "
                                   "'identify --band' identifies them, the identification the training data's modal "
                                   "noise describes, and every pole is paired with the model's modes (by frequency, "
                                   "and by shape with two or more sensors; identification.*_poles lists them). How "
                                   "the files' test differs from the model's (reference DOF, FRF kind, band, line "
                                   "spacing, sensors) is named in warnings. A pair "
                                   "outside the training data gets the classical method's verdict, the network's shown"
                                   " beside it, and the features that put it outside (distance_terms); a pair whose "
                                   "tests do not both hold the model's modes gets the classical method's verdict on "
                                   "the modes both hold (at least 2) and no network answer. Every verdict weighs the "
                                   "explanations of the frequency changes (intact, global stiffness, support change "
                                   "and every damage kind: hypotheses), and a network trained with support changes "
                                   "says whether the supports changed beyond re-clamping (support_changed, "
                                   "probability_support_change). Several MEASURED files "
                                   "give a list of verdicts; --out writes verdict.json and classify.png (one pair) or "
                                   "verdicts.json (several).")
    p.add_argument("--model", required=True, metavar="MODEL_DIR")
    p.add_argument("--baseline", required=True, action="append", metavar="BASELINE",
                   help="undamaged state (FRF file or modal JSON); repeat it, or give a quoted glob pattern such as "
                        "'base/*.uff', for several baseline tests: their scatter is the normal variation between "
                        "tests (measured instead of assumed) that a change must exceed")
    p.add_argument("--false-alarm-rate", type=float, default=DEFAULT_FALSE_ALARM_RATE, metavar="ALPHA",
                   help="false-alarm rate of the test against the normal variation measured on several baselines, "
                        f"in (0, 0.5) (default {DEFAULT_FALSE_ALARM_RATE})")
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


def baseline_files(given: list[str]) -> list[str]:
    """The baseline files of ``--baseline`` values: each a path or a glob pattern (sorted matches), in order,
    each file once; a pattern matching nothing is refused in one line."""
    out = []
    for g in given:
        if glob.has_magic(g):
            hits = sorted(glob.glob(g))
            if not hits:
                raise BeamDamageError(f"--baseline {g!r}: the pattern matches no file")
            out += hits
        else:
            out.append(g)
    return list(dict.fromkeys(out))


def identification_method(path) -> str | None:
    """The ``method`` a modal-data JSON file names (``identify --out`` writes it for output-only modes), else None."""
    if modal_or_frf(path) != MODAL or not str(path).lower().endswith(".json"):
        return None
    obj = read_json(path, require_object=False)
    method = obj.get("method") if isinstance(obj, dict) else None
    return method if isinstance(method, str) else None


def training_line_spacing_hz(model) -> float | None:
    """The line spacing (Hz) of the model's training FRFs: its test's band (or the recorded band of a preset beam's
    test, ``band_rad_s``) over its ``lines``; None when not recorded."""
    measurement = model.recorded.measurement
    lines = measurement.get("lines")
    if model.beam.test is not None:
        band_hz = model.beam.test.band_hz
    elif "band_rad_s" in measurement:
        band_hz = [w / (2 * np.pi) for w in measurement["band_rad_s"]]
    else:
        return None
    return (band_hz[1] - band_hz[0]) / (int(lines) - 1) if lines else None


def run(args):
    if not 0 < args.false_alarm_rate < 0.5:
        raise ConfigError(f"--false-alarm-rate {args.false_alarm_rate:g}: expected a rate in (0, 0.5)")
    model = load_model(args.model)
    _, beam_x_m = model.measured_beam(args.beam, args.mass)
    baselines = baseline_files(args.baseline)
    nb = len(baselines)
    files = [*baselines, *args.measured]
    raw = [read(f, modal_or_frf(f)) for f in files]                 # ModalData or MeasuredFRF
    for f, d in zip(files, raw):
        if isinstance(d, ModalData) and np.any(d.eigenvalues.real > 0):
            k = np.flatnonzero(d.eigenvalues.real > 0)
            warnings.warn(f"{f}: mode{'s' * (k.size > 1)} {', '.join(str(j + 1) for j in k)} "
                          f"{'have' if k.size > 1 else 'has'} negative damping (an eigenvalue's real part > 0): a "
                          "growing oscillation, or a poorly identified damping",
                          UserWarning, stacklevel=2)
    methods = [identification_method(f) for f in files]
    df = training_line_spacing_hz(model)
    mapped = [on_model_dofs(d, model.beam, beam_x_m, str(f)) for d, f in zip(raw, files)]
    differ = measured_test_differences(files, raw, mapped, model.beam, df)
    base = [m[0] for m in mapped[:nb]]
    pairs = classify_pairs(model, base if nb > 1 else base[0], [m[0] for m in mapped[nb:]],
                           names=[str(f) for f in files], methods=methods, false_alarm_rate=args.false_alarm_rate)
    ref = files.index(pairs[0].normal_variation.get("reference_baseline", files[0]))
    base_pos = mapped[ref][1] and mapped[ref][1].to_dict()
    pairs = [replace(c, warnings=differ + [w for w in c.warnings if w not in differ],
                     dof_positions={"baseline": base_pos, "measured": cur_map and cur_map.to_dict()})
             for c, (_, cur_map) in zip(pairs, mapped[nb:])]
    results = [c.to_dict() for c in pairs]
    if not args.json and not args.out:
        args.out = "out/classify"
    if args.out:
        _write(args.out, results, pairs[0], mapped[ref][0], mapped[nb][0], model)
    if not args.json:
        for r in results:
            if len(results) > 1:
                print(f"== {r['measured']}")
            print(verdict_text({**r, "warnings": []}, model.words))   # warnings: on stderr (experiments.cli.main)
        if args.out:
            print(f"{'verdict.json and classify.png' if len(results) == 1 else 'verdicts.json'} in {args.out}")
    return results[0] if len(results) == 1 else results


def _write(out_dir, results, pair, base, cur, model):
    """verdict.json and classify.png (one pair) or verdicts.json (several), each written atomically."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if len(results) > 1:
        atomic_write_text(out / "verdicts.json", json.dumps(to_jsonable(results), indent=1))
        return
    atomic_write_bytes(out / "classify.png", _figure(results[0], pair, base, cur, model.beam))
    atomic_write_text(out / "verdict.json", json.dumps(to_jsonable(results[0]), indent=1))


def _figure(res, pair, base, cur, beam) -> bytes:
    """PNG of one verdict: the two tests' FRFs in the file's kind with the identified modes marked; each mode's
    measured frequency change beside the competing explanations' predictions; the beam (supports, sensors, zones)
    under the location of the verdict's own source (none when the verdict is undamaged)."""
    plt = pyplot()

    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(7.5, 9.5))
    label = _file_labels(res)
    ident = res["identification"]
    kind = "receptance"
    for (name, d), colour, found in zip((("baseline", base), ("measured", cur)), ("tab:blue", "tab:orange"),
                                        (ident["baseline_frequencies_hz"], ident["measured_frequencies_hz"])):
        if isinstance(d, MeasuredFRF):
            kind = d.kind
            a1.semilogy(d.frequency_hz, np.abs(d.frf[-1, 0]), color=colour,
                        label=f"{name}: {label(d.response_dofs[-1])} / {label(d.reference_dofs[0])}")
        elif d.eigenvectors is not None:
            w = np.linspace(1.0, 1.15 * np.abs(d.eigenvalues).max(), 4000)
            H = receptance_modal(d.eigenvalues, d.eigenvectors, w, response=[-1], reference=[0])[0, 0]
            a1.semilogy(w / (2 * np.pi), np.abs(H), color=colour, label=f"{name} (synthesised from its modes, "
                                                                        "unscaled)")
        alone = getattr(d, "eigenvectors", 0) is None                    # natural frequencies without shapes
        for k, f in enumerate(found):
            a1.axvline(f, color=colour, ls=":", lw=0.8, label=None if k or not alone else f"{name}: frequencies")
    a1.set(xlabel="frequency (Hz)", ylabel=f"|H| ({FRF_UNITS[kind]})",
           title=f"The two tests ({kind}); dotted: the modes identified")
    a1.legend(fontsize=7)
    modes, change = pair.modes, pair.frequency_change_pct
    if change is not None and len(modes):
        x = np.arange(len(modes))
        a2.bar(x, change, width=0.5, color="0.6", label="measured")
        for h, marker in zip((res.get("hypotheses") or [])[:3], ("o", "s", "^")):
            a2.plot(x, h["predicted_change_pct"], marker, ls="none",
                    label=f"{explanation_label(h['name'])} ({h['probability']:.2f})")
        a2.axhline(0, color="k", lw=0.6)
        a2.set_xticks(x, [f"mode {m}" for m in modes])
        a2.legend(fontsize=7)
    a2.set(ylabel="frequency change (%)", title="Each mode's change and what the explanations predict")
    _location(a3, res, (pair.answers.location_distributions or {}).get("68"), beam)
    fig.tight_layout()
    return figure_png(fig)


def _file_labels(res):
    """Model DOF -> ``"x = 0.61 m (file DOF 5:+Y)"`` from the measured test's DOF positions (the model DOF where
    the file gave none)."""
    d = (res.get("dof_positions") or {}).get("measured") or {}
    where = {m: (f, x) for f, m, x in zip(d.get("dofs", ()), d.get("model_dofs", ()), d.get("positions_m", ()))}
    return lambda dof: (f"x = {where[dof][1]:.3g} m ({where[dof][0]})" if dof in where else dof)


def _location(ax, res, dist, beam) -> None:
    """Where the verdict's source places the damage: the network's distribution, or the classical method's place;
    nothing when the verdict is undamaged."""
    source = res["verdict_from"]
    if res["damaged"]:
        if source == "network" and dist is not None:
            edges = np.linspace(0, beam.length_m, dist.size + 1)
            ax.bar(edges[:-1], dist, width=np.diff(edges), align="edge", color="tab:red", alpha=0.7,
                   label="the network's location distribution")
        else:
            ax.axvline(res["location_x_m"], color="k", ls="--",
                       label=f"{res['classical']['method']}: x = {res['location_x_m']:.3f} m")
        title = f"Verdict ({source}): damaged near x = {res['location_x_m']:.3f} m"
    else:
        title = f"Verdict ({source}): no damage detected, so no location"
    for x in beam.zone_edges_m[1:-1]:
        ax.axvline(x, color="grey", ls=":")
    _draw_beam(ax, beam)
    ax.legend(fontsize=7)
    ax.set(xlabel="x (m)", ylabel="probability", title=title)


def _draw_beam(ax, beam) -> None:
    """The beam under the location axis: its supports (:attr:`learn.network.features.BeamSpec.support`; clamp: a
    wall; pin: a triangle), sensors (v) and zones."""
    L, sup = beam.length_m, beam.support
    bc = sup.name
    y = ax.get_ylim()[1] if ax.has_data() else 1.0
    ax.plot([0, L], [-0.06 * y] * 2, color="k", lw=3, solid_capstyle="butt")
    sup.draw(ax, L, y)
    ax.plot(beam.sensors_x_m, [-0.02 * y] * len(beam.sensors_x_m), "v", color="tab:blue", ms=7,
            label=f"sensors ({len(beam.sensors_x_m)}), {bc}")
    ax.set_ylim(-0.18 * y, 1.05 * y)
