"""``beam-damage discrepancy``: where a beam model misses measured data and which effect it lacks.

Parses, reads the measurement, calls :func:`physics.discrepancy.analyse`,
prints, and with ``--out`` writes the calibrated beam file, residual and
candidate tables and figures (all rendered first, then written atomically).
"""

from __future__ import annotations

import csv
import io
import json
import warnings
from pathlib import Path

import numpy as np

from experiments.cmd_model import add_beam_argument
from physics import discrepancy as dsc
from physics.beam import Beam, beam_to_toml, load_beam
from physics.effects import CANDIDATES
from physics.errors import ConfigError, FileFormatError
from physics.io import atomic_write_bytes, modal_data_from_dict, read_frf

EXAMPLE = Path(__file__).parent / "data" / "thesis" / "beam5_table_4_3.json"


def _positions(beam: Beam, labels, n_rows: int, source: str) -> tuple:
    """Positions (m) of measured rows: DOF labels ``"N:y"``/``"N:+Y"`` are nodes of the beam's own mesh."""
    if not labels:
        if n_rows != len(beam.measured_x_m):
            raise FileFormatError(f"{source}: {n_rows} shape rows but the beam has {len(beam.measured_x_m)} "
                                  "measured positions; add 'dofs' labels such as \"2:y\"")
        return beam.measured_x_m
    xs = []
    for lab in labels:
        head, _, direction = str(lab).partition(":")
        try:
            node = int(head)
        except ValueError:
            node = None
        transverse = direction.upper().lstrip("+-") in ("", "Y", "Z")
        if not transverse or node is None or not 1 <= node <= beam.n_elements + 1:
            raise FileFormatError(f"{source}: DOF label {lab!r} must name a node 1..{beam.n_elements + 1} of the "
                                  f"beam's {beam.n_elements}-element mesh (e.g. \"2:y\")")
        xs.append((node - 1) * beam.length_m / beam.n_elements)
    return tuple(xs)


def load_measurement(path, beam: Beam, n_modes=None) -> tuple[dsc.Measurement, object]:
    """Modal JSON (frequencies alone, or with damping and shapes) or an FRF file identified by LSCF/LSFD.

    Returns the measurement and the relative frequency std of an identification (or None).
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        try:
            obj = json.loads(path.read_bytes().decode("utf-8"))
        except FileNotFoundError:
            raise FileFormatError(f"{path}: file not found") from None
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise FileFormatError(f"{path}: not valid UTF-8 JSON ({exc})") from None
        if isinstance(obj, dict) and "natural_frequencies_hz" in obj and "damping_ratios" not in obj \
                and "eigenvalues" not in obj:
            try:
                f = np.asarray(obj["natural_frequencies_hz"], dtype=float)
            except (TypeError, ValueError):
                raise FileFormatError(f"{path}: 'natural_frequencies_hz' must be a list of numbers") from None
            try:
                return dsc.Measurement(f), None
            except ValueError as exc:
                raise FileFormatError(f"{path}: field 'natural_frequencies_hz': {exc}") from None
        data = modal_data_from_dict(obj, str(path))
        shapes = data.eigenvectors
        xs = _positions(beam, data.dofs, shapes.shape[0], str(path)) if shapes is not None else ()
        try:
            return dsc.Measurement(data.natural_frequencies_hz, data.damping_ratios, shapes, xs), None
        except ValueError as exc:
            raise FileFormatError(f"{path}: {exc}") from None
    from experiments.cmd_identify import identify_frf

    frf = read_frf(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ident = identify_frf(frf, n_modes=n_modes)
    est = ident.estimate
    rec = ident.frf  # receptance, band-limited as identified
    resp = _positions(beam, rec.response_dofs, len(rec.response_dofs), str(path))
    ref = _positions(beam, rec.reference_dofs, len(rec.reference_dofs), str(path))
    order = np.argsort(est.natural_frequencies_hz)
    meas = dsc.Measurement(est.natural_frequencies_hz[order], est.damping_ratios[order], est.shapes[:, order], resp,
                           rec.frf, rec.frequency_hz, resp, ref, rec.kind)
    rel_std = np.asarray(est.frequency_std_hz)[order] / meas.frequencies_hz
    return meas, rel_std


def _residual_rows(label: str, r: dsc.ModeResiduals) -> list[dict]:
    rows = []
    for j in range(r.measured_hz.size):
        rows.append({
            "model": label, "mode": j + 1, "measured_hz": float(r.measured_hz[j]), "model_hz": float(r.model_hz[j]),
            "frequency_error_pct": float(r.frequency_error_pct[j]),
            "measured_damping": None if r.measured_damping is None else float(r.measured_damping[j]),
            "model_damping": None if r.model_damping is None else float(r.model_damping[j]),
            "mac": None if r.mac is None else float(r.mac[j]),
            "frf_band_error_db": None if r.frf_band_error_db is None else float(r.frf_band_error_db[j]),
        })
    return rows


def _csv(rows: list[dict]) -> bytes:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    return buf.getvalue().encode()


def _candidate_rows(res: dsc.DiscrepancyResult) -> list[dict]:
    rows = []
    for i, st in enumerate(res.steps):
        prefix = " + ".join(res.named_effects[:i])
        if i == 0:
            rows.append({"effect": "none", "score": st.base.bic, "max_abs_frequency_error_pct":
                         st.base.residuals.max_abs_frequency_error_pct, "parameters": st.base.parameters,
                         "round": 1, "lomo": st.base.lomo, "n_params": st.base.n_params})
        for f in st.candidates:
            rows.append({"effect": f"{prefix} + {f.effect}" if prefix else f.effect, "score": f.bic,
                         "max_abs_frequency_error_pct": f.residuals.max_abs_frequency_error_pct,
                         "parameters": f.parameters, "round": i + 1, "lomo": f.lomo, "n_params": f.n_params})
    return rows


def _figures(res: dsc.DiscrepancyResult, recal: dsc.ModeResiduals, meas: dsc.Measurement,
             before_frf, after_frf) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def png(fig):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        plt.close(fig)
        return buf.getvalue()

    out = {}
    fig, ax = plt.subplots(figsize=(7, 4))
    modes = np.arange(1, meas.n_modes + 1)
    width = 0.27
    after_label = "after: " + (" + ".join(res.named_effects) if res.named_effects else "recalibrated only")
    for k, (r, lab) in enumerate(((res.nominal, "before (beam as given)"), (recal, "EI/m recalibrated only"),
                                  (res.final.residuals, after_label))):
        ax.bar(modes + (k - 1) * width, r.frequency_error_pct, width, label=lab)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(modes)
    ax.set_xlabel("measured mode")
    ax.set_ylabel("frequency error, model vs measured (%)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out["frequency_error.png"] = png(fig)
    if meas.frf is not None:
        n_resp, n_ref = meas.frf.shape[:2]
        fig, axes = plt.subplots(n_resp, n_ref, figsize=(4 + 3 * n_ref, 2.2 * n_resp), squeeze=False, sharex=True)
        f = meas.frf_frequency_hz
        for s in range(n_resp):
            for r in range(n_ref):
                ax = axes[s, r]
                ax.semilogy(f, np.abs(meas.frf[s, r]), "k", lw=1, label="measured")
                ax.semilogy(f, np.abs(before_frf[s, r]), "tab:red", lw=0.8, ls="--", label="before")
                ax.semilogy(f, np.abs(after_frf[s, r]), "tab:blue", lw=0.8, label="after")
                ax.set_title(f"x = {meas.frf_response_x_m[s]:.3g} m / x = {meas.frf_reference_x_m[r]:.3g} m",
                             fontsize=8)
        axes[0, 0].legend(fontsize=7)
        for ax in axes[-1]:
            ax.set_xlabel("frequency (Hz)")
        fig.tight_layout()
        out["frf_overlay.png"] = png(fig)
    return out


def run_discrepancy(beam_spec, measured, out_dir=None, *, noise=None, max_effects=2, n_elements=40, seed=0,
                    candidates=CANDIDATES, progress=None) -> dict:
    """The command without printing: returns the JSON result (issue 9 keys) plus ``"_result"`` objects."""
    beam = beam_spec if isinstance(beam_spec, Beam) else load_beam(beam_spec)
    meas, rel_std = load_measurement(measured, beam)
    noise = noise or dsc.Noise()
    if rel_std is not None and noise.frequency == dsc.Noise().frequency:
        # identified from FRFs: the identification's frequency std, floored at 0.1 %
        noise = dsc.Noise(np.maximum(rel_std, 1e-3), noise.damping, noise.shape, noise.frf_db)
    if out_dir is not None:
        out_dir = Path(out_dir)
        if out_dir.exists() and not out_dir.is_dir():
            raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    res = dsc.analyse(beam, meas, noise, candidates=candidates, max_effects=max_effects, n_elements=n_elements,
                      seed=seed, progress=progress)
    first = res.steps[0] if res.steps else None
    cand = _candidate_rows(res)
    out = {
        "named_effect": res.named_effects[0] if res.named_effects else "none",
        "effects": list(res.named_effects),
        "parameters": res.final.parameters,
        "parameter_std": res.final.parameter_std,
        "indistinguishable_from": list(first.indistinguishable_from) if first else [],
        "gap_before": res.nominal.gap(),
        "gap_after": res.final.residuals.gap(),
        "candidates": [{k: c[k] for k in ("effect", "score", "max_abs_frequency_error_pct", "parameters")}
                       for c in cand],
        "beam_file": None,
    }
    recal = first.base.residuals if first else res.final.residuals
    if out_dir is not None:
        before_frf = after_frf = None
        if meas.frf is not None:
            before_frf = dsc.predict(beam, meas, n_elements).frf
            after_frf = dsc.predict(res.final.beam, meas, n_elements).frf
        files = _figures(res, recal, meas, before_frf, after_frf)
        rows = (_residual_rows("before", res.nominal) + _residual_rows("recalibrated", recal)
                + _residual_rows("after", res.final.residuals))
        files["residuals.csv"] = _csv(rows)
        files["residuals.json"] = (json.dumps(rows, indent=1) + "\n").encode()
        flat = [{**{k: v for k, v in c.items() if k != "parameters"},
                 "parameters": json.dumps(c["parameters"], sort_keys=True)} for c in cand]
        files["candidates.csv"] = _csv(flat)
        from experiments.cli import to_jsonable

        files["candidates.json"] = (json.dumps(to_jsonable(cand), indent=1) + "\n").encode()
        steps = [{"round": i + 1, "named": st.named, "indistinguishable_from": list(st.indistinguishable_from),
                  "separating_measurement": st.separating_measurement} for i, st in enumerate(res.steps)]
        calibrated = res.final.beam.with_effects(res.final.beam.effects_dict(),
                                                 name=f"{beam.name}-calibrated")
        comment = (f"calibrated by 'beam-damage discrepancy --beam {beam.name} --measured {measured}'\n"
                   f"named effects: {', '.join(res.named_effects) or 'none'}; seed {seed}; "
                   f"noise: frequency {np.max(np.asarray(noise.frequency)):.3g} (relative)")
        summary = dict(out, beam_file=str(out_dir / "beam.toml"), steps=steps,
                       noise={"frequency": noise.frequency, "damping": noise.damping, "shape": noise.shape,
                              "frf_db": noise.frf_db}, seed=seed, untestable=res.untestable)
        files["summary.json"] = (json.dumps(to_jsonable(summary), indent=1) + "\n").encode()

        files["beam.toml"] = beam_to_toml(calibrated, comment).encode()
        for name, data in files.items():
            atomic_write_bytes(out_dir / name, data)
        out["beam_file"] = str(out_dir / "beam.toml")
    out["_result"] = (res, recal)
    return out


def run(args) -> dict:
    noise = dsc.Noise(args.frequency_noise, args.damping_noise, args.shape_noise, args.frf_noise_db)
    for name, v in (("--frequency-noise", args.frequency_noise), ("--damping-noise", args.damping_noise),
                    ("--shape-noise", args.shape_noise), ("--frf-noise-db", args.frf_noise_db)):
        if not (np.isfinite(v) and v > 0):
            raise ConfigError(f"{name} must be a positive number, got {v}")
    if args.max_effects < 0:
        raise ConfigError(f"--max-effects must be >= 0, got {args.max_effects}")
    if args.elements < 4:
        raise ConfigError(f"--elements must be >= 4, got {args.elements}")
    progress = None
    if not args.json:
        def progress(s):
            print(f"  fitting {s} ...", flush=True)
    out = run_discrepancy(args.beam, args.measured, args.out, noise=noise, max_effects=args.max_effects,
                          n_elements=args.elements, seed=args.seed, candidates=tuple(args.candidates),
                          progress=progress)
    res, recal = out.pop("_result")
    if not args.json:
        _print(out, res, recal)
    return out


def _print(out, res: dsc.DiscrepancyResult, recal: dsc.ModeResiduals):
    print(f"{'mode':>4} {'measured Hz':>12} {'before %':>9} {'recal. %':>9} {'after %':>9}"
          + (f" {'zeta meas':>10} {'zeta after':>10}" if res.final.residuals.measured_damping is not None else "")
          + (f" {'MAC after':>9}" if res.final.residuals.mac is not None else ""))
    a = res.final.residuals
    for j in range(a.measured_hz.size):
        line = (f"{j + 1:4d} {a.measured_hz[j]:12.3f} {res.nominal.frequency_error_pct[j]:9.3f} "
                f"{recal.frequency_error_pct[j]:9.3f} {a.frequency_error_pct[j]:9.3f}")
        if a.measured_damping is not None:
            line += f" {a.measured_damping[j]:10.5f} {a.model_damping[j]:10.5f}"
        if a.mac is not None:
            line += f" {a.mac[j]:9.4f}"
        print(line)
    print("candidates (score = BIC, lower is better; LOMO in noise units):")
    for i, st in enumerate(res.steps):
        print(f" round {i + 1}: current model '{' + '.join(res.named_effects[:i]) or 'EI/m recalibrated'}' "
              f"BIC {st.base.bic:.1f}, LOMO {st.base.lomo:.2f}")
        for f in st.candidates:
            print(f"   {f.effect:18s} BIC {f.bic:10.1f}  LOMO {f.lomo:6.2f}  max |error| "
                  f"{f.residuals.max_abs_frequency_error_pct:6.3f} %")
        if st.indistinguishable_from:
            print(f"   -> '{st.named}' indistinguishable from {', '.join(st.indistinguishable_from)}; "
                  f"separate them by: {st.separating_measurement}")
    for k, why in res.untestable.items():
        print(f" not tested: {k} ({why})")
    print(f"named effects: {', '.join(res.named_effects) or 'none'}")
    for k, v in out["parameters"].items():
        print(f"  {k:36s} {v:12.5g} +- {out['parameter_std'].get(k, float('nan')):.3g}")
    gb, ga = out["gap_before"], out["gap_after"]
    print(f"gap: max |frequency error| {gb['max_abs_frequency_error_pct']:.3f} % -> "
          f"{ga['max_abs_frequency_error_pct']:.3f} %, mean {gb['mean_abs_frequency_error_pct']:.3f} % -> "
          f"{ga['mean_abs_frequency_error_pct']:.3f} %"
          + (f", FRF {gb['frf_error_db']:.2f} dB -> {ga['frf_error_db']:.2f} dB" if gb["frf_error_db"] is not None
             else ""))
    if out["beam_file"]:
        print(f"wrote {out['beam_file']} and tables/figures beside it")


def add_parser(sub):
    p = sub.add_parser(
        "discrepancy", help="find where the model misses measured data and name the missing effect",
        description="Pair measured and model modes, recalibrate EI (and mass with FRFs) and Rayleigh damping, "
                    "then fit each candidate effect (shear deformation, rotary inertia, root flexibility, added "
                    "mass, local damping) with the globals, score by BIC with the measurement noise and a "
                    "leave-one-mode-out check, name the winner only when significant, and repeat once. "
                    f"Example: --beam beam5 --measured {EXAMPLE.relative_to(Path(__file__).parent.parent)}")
    add_beam_argument(p)
    p.add_argument("--measured", required=True, metavar="FILE",
                   help="modal JSON (natural_frequencies_hz alone, or with damping_ratios / eigenvalues and "
                        "eigenvectors + dofs) or FRFs (.uff/.unv, .csv, .npz; identified by LSCF/LSFD first)")
    p.add_argument("--out", metavar="DIR", help="write beam.toml (calibrated), residuals.csv/json, "
                                                "candidates.csv/json, summary.json and figures")
    p.add_argument("--frequency-noise", type=float, default=dsc.Noise().frequency,
                   help="relative std of measured frequencies (default 0.003; FRF input: the identification's)")
    p.add_argument("--damping-noise", type=float, default=dsc.Noise().damping,
                   help="relative std of damping ratios (default 0.1)")
    p.add_argument("--shape-noise", type=float, default=dsc.Noise().shape,
                   help="std of shape entries relative to the largest (default 0.02)")
    p.add_argument("--frf-noise-db", type=float, default=dsc.Noise().frf_db, help="FRF magnitude std in dB (1)")
    p.add_argument("--max-effects", type=int, default=2, help="most effects to name (default 2)")
    p.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=CANDIDATES, metavar="EFFECT",
                   help=f"effects to test (default all: {' '.join(CANDIDATES)})")
    p.add_argument("--elements", type=int, default=40, help="elements of the fitted models (default 40)")
    p.add_argument("--seed", type=int, default=0, help="seed of the multi-start fits")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: named_effect, effects, parameters, parameter_std, "
                        "indistinguishable_from, gap_before, gap_after, candidates, beam_file")
    p.set_defaults(func=run)
