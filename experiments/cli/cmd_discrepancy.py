"""``beam-damage discrepancy``: where a beam model misses measured data and which effect it lacks.

Parses, calls :func:`physics.discrepancy.analyse_file` (which reads the measurement, runs
:func:`physics.discrepancy.analyse` and writes the outputs) and prints.
"""

from __future__ import annotations

import sys
from functools import partial
from pathlib import Path

import numpy as np

from experiments.cli import one_line
from experiments.cli.args import add_beam_argument
from learn.pairs.measured import pair_modes_by_frequency
from physics import discrepancy as dsc
from physics.effects import CANDIDATES
from physics.supports import SUPPORTS
from physics.errors import ConfigError, ConvergenceError
from physics.io import FRF, MODAL, accepted, dof_positions_text

__all__ = ["CLASSIFY_PAIRING", "add_parser", "run"]

#: classify's pairing rule (:func:`learn.pairs.measured.modal_pair`'s): several poles in a mode's band, the one the
#: other modes' ratio trend puts nearest
CLASSIFY_PAIRING = partial(pair_modes_by_frequency, trend=True)


def run(args) -> dict:
    for name, v in (("--frequency-noise", args.frequency_noise), ("--shape-noise", args.shape_noise),
                    ("--frf-noise-db", args.frf_noise_db)):
        if v is not None and not (np.isfinite(v) and v > 0):
            raise ConfigError(f"{name} must be a positive number, got {v}")
    if args.max_effects < 0:
        raise ConfigError(f"--max-effects must be >= 0, got {args.max_effects}")
    if args.elements < 4:
        raise ConfigError(f"--elements must be >= 4, got {args.elements}")
    progress = None
    if not args.json:
        def progress(s):
            print(f"  fitting {s} ...", file=sys.stderr, flush=True)
    # a noise not given is of the data or assumed (analyse_file), and assumed ones are scaled to the data
    # (analyse's estimate_noise)
    try:
        out = dsc.analyse_file(args.beam, args.measured, args.out, frequency_noise=args.frequency_noise,
                               shape_noise=args.shape_noise, frf_noise_db=args.frf_noise_db,
                               max_effects=args.max_effects, n_elements=args.elements, seed=args.seed,
                               candidates=None if args.candidates is None else tuple(args.candidates),
                               estimate_noise=args.frequency_noise is None and args.shape_noise is None,
                               progress=progress, pairing=CLASSIFY_PAIRING)
    except dsc.ImplausibleTest as exc:   # before any fit: the result is the pairing and its causes
        _stop(exc.result["stopped"])
        return {**exc.result, "beam_file": None, "exit_code": 2}
    except ConvergenceError as exc:      # e.g. no stable pole in an FRF file: the file named
        if str(args.measured) in str(exc):
            raise
        raise ConvergenceError(f"{args.measured}: {exc}", exc.iterations, exc.residual,
                               parameter=exc.parameter) from None
    res, recal = out.pop("_result")
    if not args.json:
        _print(out, res, recal)
    if out["stopped"]:
        _stop(out["stopped"])
        out["exit_code"] = 2
    return out


def _stop(message: str) -> None:
    """The one line of a stop (exit code 2, nothing written), on stderr (with ``--json`` too)."""
    sys.stderr.write(one_line(f"beam-damage discrepancy: error: {message}") + "\n")


def _print(out, res: dsc.DiscrepancyResult, recal: dsc.ModeResiduals):
    print(dof_positions_text(out["dof_positions"]) if out["dof_positions"] else
          "measured DOFs: none (natural frequencies only)")
    for note in out["notes"]:
        print(f"note: {note}")
    an = out["assumed_noise"]
    f = np.atleast_1d(an["frequency"])
    print("noise (std) whitening the residuals: frequency "
          + (f"{100 * f[0]:.3g} %" if f.size == 1 else f"{100 * f.min():.3g}-{100 * f.max():.3g} %")
          + f" [{an['frequency_source']}]"
          + (f", shapes {an['shape']:.3g} of the largest entry [{an['shape_source']}]" if "shape" in an else "")
          + (f", FRF {an['frf_db']:.3g} dB [{an['frf_db_source']}]" if "frf_db" in an else "")
          + ("; damping ratios: modal damping (one ratio per mode) is the null model" if
             res.final.residuals.measured_damping is not None else ""))
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
    print("candidates (score = sum of chi2 per data block / its c_hat + k ln n, lower is better; "
          "LOMO in noise units):")
    for i, st in enumerate(res.steps):
        print(f" round {i + 1}: current model '{' + '.join(res.named_effects[:i]) or 'EI/m recalibrated'}' "
              f"score {st.score(st.base):.1f}, LOMO {st.base.lomo:.2f}"
              + "".join(f", c_hat({k}) {c:.3g} (the best fit's residual exceeds the noise)"
                        for k, c in st.c_hat.items() if c > 1))
        for f in st.candidates:
            print(f"   {f.effect:18s} score {st.score(f):10.1f}  LOMO {f.lomo:6.2f}  max |error| "
                  f"{f.residuals.max_abs_frequency_error_pct:6.3f} %")
        if st.indistinguishable_from:
            print(f"   -> '{st.named}' indistinguishable from {', '.join(st.indistinguishable_from)}; "
                  f"separate them by: {st.separating_measurement}")
    for k, why in res.untestable.items():
        print(f" not tested: {k} ({why})")
    if res.detection_limits:
        print(" detection limits of the effects not named (with the noise used for the selection):")
        for lim in res.detection_limits.values():
            print(f"   {lim.text()}")
    print(f"named effects: {', '.join(res.named_effects) or 'none'}"
          + "".join(f"; {e}: evidence from {b}" for e, b in res.evidence.items())
          + ("; effects below the detection limits above are not excluded" if res.detection_limits else ""))
    chk = out["noise_check"]
    est = out["estimated_noise"]
    if est["scale"] < 1:
        print(f"noise estimated from the data: x{est['scale']:.3g} of the assumed "
              f"(frequency {100 * np.max(np.atleast_1d(est['frequency'])):.3g} %"
              + (f", shapes {est['shape']:.3g}" if "shape" in est else "")
              + f"; {est['from']}), used for the selection")
    elif est["from"]:
        print(f"noise estimate: {est['from']}")
    print(f"noise check of the final model: chi2 {chk['chi2']:.3g} on {chk['dof']} dof, chi2/dof "
          f"{chk['chi2_per_dof']:.3g}, p = {chk['p_value']:.3g}: {chk['verdict']}; by block: "
          + ", ".join(f"{k} {b['chi2_per_dof']:.3g}" for k, b in chk["blocks"].items()))
    if chk["verdict"] == "residual smaller than the noise" and est["scale"] == 1:
        print("  the data are more precise than assumed: smaller effects become testable with the actual noise "
              "(--frequency-noise, --shape-noise)")
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
    for line in out["pairing_notes"]:
        print(f"pairing: {line}")


def add_parser(sub):
    p = sub.add_parser(
        "discrepancy",
        description="Pair measured and model modes, recalibrate EI (and mass with FRFs), "
                    "then fit each candidate effect of the beam's supports (shear deformation, rotary inertia, "
                    "added mass, local damping, and the supports' own: root flexibility of a clamped-free beam, "
                    "clamp flexibility of a clamped-clamped one, bearing flexibility of a pinned-pinned one, the "
                    "suspension of a free-free one) with the globals, score by BIC with the measurement noise and a "
                    "leave-one-mode-out check, name the winner only when significant, and repeat once. "
                    "Damping ratios are modal (one per mode, the null model): a dashpot is named only from "
                    "complex mode shapes or FRFs. "
                    f"Example: --beam beam5 --measured {dsc.EXAMPLE.relative_to(Path(__file__).resolve().parents[2])}")
    add_beam_argument(p)
    p.add_argument("--measured", required=True, metavar="FILE",
                   help=f"{accepted(MODAL, FRF)}. Modal data: natural_frequencies_hz alone, or with "
                        "damping_ratios / eigenvalues and eigenvectors + dofs; FRFs: identified by LSCF/LSFD first")
    p.add_argument("--out", metavar="DIR", help="write beam.toml (calibrated), residuals.csv/json, "
                                                "candidates.csv/json, summary.json and figures")
    p.add_argument("--frequency-noise", type=float, default=None,
                   help="relative std of measured frequencies (default: 0.003 assumed, scaled down to the data's "
                        "residual when neither noise option is given; FRF input: the identification's)")
    p.add_argument("--shape-noise", type=float, default=None,
                   help="std of shape entries relative to the largest (default: 0.02 assumed, scaled as "
                        "--frequency-noise)")
    p.add_argument("--frf-noise-db", type=float, default=None,
                   help="FRF magnitude std in dB (default: estimated from the FRF's line-to-line scatter)")
    p.add_argument("--max-effects", type=int, default=2, help="most effects to name (default 2)")
    p.add_argument("--candidates", nargs="+", default=None, choices=CANDIDATES, metavar="EFFECT",
                   help="effects to test (default: all that fit the beam's supports: "
                        + " ".join(c for c in CANDIDATES if c not in {s.effect for s in SUPPORTS.values()})
                        + " on every beam, plus " + ", ".join(f"{s.effect} ({s.name})" for s in SUPPORTS.values())
                        + "); one that does not fit the supports is refused")
    p.add_argument("--elements", type=int, default=40, help="elements of the fitted models (default 40)")
    p.add_argument("--seed", type=int, default=0, help="seed of the multi-start fits")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: named_effect, effects, evidence, parameters, parameter_std, "
                        "indistinguishable_from, separating_measurement, gap_before, gap_after, assumed_noise, "
                        "estimated_noise, chi2_per_dof, noise_consistent, noise_check, not_tested, "
                        "detection_limits, candidates, beam_file, notes, drive_x_m_from_file, pairing, "
                        "pairing_notes, stopped, causes. Exit code 2 with one line on stderr (and stopped, causes, "
                        "pairing in the JSON), nothing written, when a measured mode pairs with no model mode "
                        "(classify's rule: frequency order, never beyond 35 %%) or the calibrated model's chi2/dof "
                        f"exceeds {dsc.STOP_CHI2_PER_DOF:g}")
    p.set_defaults(func=run, flags={"n_elements": "--elements"})
