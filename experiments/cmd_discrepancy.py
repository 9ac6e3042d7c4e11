"""``beam-damage discrepancy``: where a beam model misses measured data and which effect it lacks.

Parses, calls :func:`experiments.study_discrepancy.run_discrepancy` (which reads the
measurement, runs :func:`physics.discrepancy.analyse` and writes the outputs) and prints.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiments.args import add_beam_argument
from experiments.study_discrepancy import EXAMPLE, run_discrepancy
from physics import discrepancy as dsc
from physics.effects import CANDIDATES
from physics.errors import ConfigError
from physics.io import dof_positions_text


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
    print(dof_positions_text(out["dof_positions"]) if out["dof_positions"] else
          "measured DOFs: none (natural frequencies only)")
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
    p.set_defaults(func=run, flags={"n_elements": "--elements"})
