"""Benchmark: confusion table of the hidden-effect suite of ``physics.discrepancy``.

Each truth is the beam5 preset with one hidden effect (small or large), a random
global EI (3 %) and mass (2 %) error, damping, and noise (frequencies 0.2 %,
damping ratios 5 %, shapes 1 % of the largest entry), simulated on 80 elements
and fitted on 24. Two kinds of data: frequencies + damping ratios, and the same
plus mode shapes at the quarter points. Prints, per data kind, how often each
truth is named as each effect (``~`` marks "named, but reported
indistinguishable from another candidate"), the median relative error of the
recovered parameter, the median gap (max |frequency error| after
recalibration only -> after the named effect) and the same for the damping
ratios (max relative error, Rayleigh damping only -> after).

    python -m experiments.bench_discrepancy [--seeds 3] [--kinds freq shapes] [--truths ...]

The last truth is the same beam 40 mm deep (fitted with that depth): there rotary
inertia is large enough to be seen.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from physics import discrepancy as dsc
from physics.beam import load_beam
from physics.effects import CANDIDATES

BEAM = load_beam("beam5")
L, EI, M = BEAM.length_m, BEAM.EI_Nm2, BEAM.mass_per_length_kg_m
RHO_I = M * BEAM.thickness_m**2 / 12
DAMPING = {"proportional_damping": {"alpha_1_s": 0.4, "beta_s": 2e-6}}
NOISE = dsc.Noise(0.002, 0.05, 0.01, 0.5)

#: name -> (effect, parameters, the parameter checked)
TRUTHS = {
    "none": (None, {}, None),
    "shear small": ("shear_deformation", {"kGA_N": 2e5}, "kGA_N"),
    "shear large": ("shear_deformation", {"kGA_N": 2.5e4}, "kGA_N"),
    "rotary inertia (3x, physical max)": ("rotary_inertia", {"rho_I_kg_m": 3 * RHO_I}, "rho_I_kg_m"),
    "root spring small": ("root_flexibility", {"k_theta_Nm_rad": 50 * EI / L}, "k_theta_Nm_rad"),
    "root spring large": ("root_flexibility", {"k_theta_Nm_rad": 10 * EI / L}, "k_theta_Nm_rad"),
    "tip mass small": ("added_mass", {"mass_kg": 0.03 * M * L, "x_m": L}, "mass_kg"),
    "mass at L/4 large": ("added_mass", {"mass_kg": 0.2 * M * L, "x_m": L / 4}, "mass_kg"),
    "local damping small": ("local_damping", {"c_Ns_m": 0.15, "x_m": L / 4}, "c_Ns_m"),
    "local damping large": ("local_damping", {"c_Ns_m": 0.5, "x_m": L / 4}, "c_Ns_m"),
    # the same beam 40 mm deep (h/L = 0.066, EI and m unchanged): rotary inertia becomes visible
    "thick: rotary inertia (1x)": ("rotary_inertia", {"rho_I_kg_m": M * 0.04**2 / 12}, "rho_I_kg_m"),
}
THICK = BEAM.with_effects({}, thickness_m=0.04, face_thickness_m=0.002)


def run_case(effect, params, seed, shapes, beam=BEAM):
    rng = np.random.default_rng(seed)
    eff = {effect: params} if effect else {}
    truth = beam.with_effects({**eff, **DAMPING}, EI_Nm2=EI * (1 + 0.03 * rng.standard_normal()),
                              mass_per_length_kg_m=M * (1 + 0.02 * rng.standard_normal()))
    meas = dsc.simulate_measurement(truth, seed=seed, noise=NOISE, shapes=shapes)
    return dsc.analyse(beam, meas, NOISE, max_effects=1, n_elements=24, n_starts=3, seed=seed)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="random truths per case (default 3)")
    ap.add_argument("--kinds", nargs="+", default=["freq", "shapes"], choices=["freq", "shapes"])
    ap.add_argument("--truths", nargs="+", default=list(TRUTHS), choices=list(TRUTHS), metavar="TRUTH",
                    help="subset of the truths (default all)")
    args = ap.parse_args(argv)
    cols = ["none", *CANDIDATES]
    short = {"none": "none", "shear_deformation": "shear", "rotary_inertia": "rotary", "root_flexibility": "root",
             "added_mass": "mass", "local_damping": "l.damp"}
    t0 = time.perf_counter()
    for kind in args.kinds:
        print(f"\n== data: frequencies + damping ratios{' + mode shapes' if kind == 'shapes' else ''}, "
              f"{args.seeds} seeds per truth ==")
        print(f"{'truth':34s} " + " ".join(f"{short[c]:>7s}" for c in cols)
              + f" {'param err':>9s} {'gap %':>15s} {'zeta gap %':>15s}")
        for name, (effect, params, key) in tqdm([(t, TRUTHS[t]) for t in args.truths], desc=kind, leave=False):
            counts = {c: 0 for c in cols}
            ties = {c: 0 for c in cols}
            perr, gaps = [], []
            for seed in range(args.seeds):
                res = run_case(effect, params, seed, kind == "shapes", THICK if name.startswith("thick") else BEAM)
                named = res.named_effects[0] if res.named_effects else "none"
                counts[named] += 1
                if res.steps and res.steps[0].indistinguishable_from:
                    ties[named] += 1
                if effect and named == effect:
                    perr.append(abs(res.final.parameters[f"{effect}.{key}"] / params[key] - 1))
                b, a = res.steps[0].base.residuals, res.final.residuals
                gaps.append((b.max_abs_frequency_error_pct, a.max_abs_frequency_error_pct,
                             100 * np.max(np.abs(b.model_damping / b.measured_damping - 1)),
                             100 * np.max(np.abs(a.model_damping / a.measured_damping - 1))))
            cells = " ".join(f"{(str(counts[c]) + ('~' if ties[c] else '')) if counts[c] else '.':>7s}" for c in cols)
            pe = f"{100 * np.median(perr):8.1f}%" if perr else f"{'-':>9s}"
            g = np.median(np.array(gaps), axis=0)
            print(f"{name:34s} {cells} {pe} {g[0]:6.2f} -> {g[1]:5.2f} {g[2]:6.1f} -> {g[3]:5.1f}")
    print(f"\n{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
