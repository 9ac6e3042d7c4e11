"""Hidden support effects on free-free, pinned-pinned and clamped-clamped beams, named by ``discrepancy``.

The truths are a plain Hermite-element model (:mod:`experiments.studies.plain_beam`, 64 elements, not physics/) of
beam 5's section with a random EI error (3 % std) and one hidden effect; five bending modes with 0.2 %
frequency noise (and shapes with 0.01 noise at the sensors); the fits use 24 elements. Prints, per bc, data
kind and truth, the effects named over the seeds, the median relative error of the recovered parameter when
named right and the median max |frequency error| after the EI recalibration -> after the named effect;
``--docs`` writes the table into ``docs/discrepancy.md``::

    python -m experiments.benches.bench_supports --seeds 3 --docs
"""

from __future__ import annotations

import time

import numpy as np

from experiments.benches.harness import parser, publish, table
from experiments.studies.plain_beam import plain_fe
from physics import discrepancy as dsc
from physics.beam import load_beam
from physics.supports import support

__all__ = ["CASES", "main", "markdown", "rows", "run_case"]

BEAM5 = load_beam("beam5")
L, EI, M = BEAM5.length_m, BEAM5.EI_Nm2, BEAM5.mass_per_length_kg_m
NOISE = dsc.Noise(0.002, 0.05, 0.01, 0.5)
W1_FREE = 22.3733 / L**2 * np.sqrt(EI / M)
FREE = tuple(L * k / 8 for k in range(9))
INNER = tuple(L * k / 8 for k in range(1, 8))

#: name -> (bc, truth bc of the plain FE, its keywords, effect, parameter key, true value)
CASES = {
    "free-free: none": ("free-free", "free-free", {}, None, None, None),
    "free-free: suspension, bounce 10 % of f1": ("free-free", "free-free",
                                                 {"k_y": 0.5 * M * L * (0.1 * W1_FREE) ** 2}, "suspension", "k_y_N_m",
                                                 0.5 * M * L * (0.1 * W1_FREE) ** 2),
    "free-free: suspension, bounce 25 % of f1": ("free-free", "free-free",
                                                 {"k_y": 0.5 * M * L * (0.25 * W1_FREE) ** 2}, "suspension",
                                                 "k_y_N_m", 0.5 * M * L * (0.25 * W1_FREE) ** 2),
    "free-free: mass 3 % m L at 3L/4": ("free-free", "free-free", {"mass": (0.03 * M * L, 48)}, "added_mass",
                                        "mass_kg", 0.03 * M * L),
    "pinned-pinned: none": ("pinned-pinned", "pinned-pinned", {}, None, None, None),
    "pinned-pinned: bearing k L/EI = 0.3": ("pinned-pinned", "pinned-pinned", {"k_theta": 0.3 * EI / L},
                                            "bearing_flexibility", "k_theta_Nm_rad", 0.3 * EI / L),
    "pinned-pinned: bearing k L/EI = 3": ("pinned-pinned", "pinned-pinned", {"k_theta": 3.0 * EI / L},
                                          "bearing_flexibility", "k_theta_Nm_rad", 3.0 * EI / L),
    "clamped-clamped: none": ("clamped-clamped", "clamped-clamped", {}, None, None, None),
    # a clamp on a rotational spring is a pin with that spring
    "clamped-clamped: clamp k L/EI = 20": ("clamped-clamped", "pinned-pinned", {"k_theta": 20.0 * EI / L},
                                           "clamp_flexibility", "k_theta_Nm_rad", 20.0 * EI / L),
    "clamped-clamped: clamp k L/EI = 200": ("clamped-clamped", "pinned-pinned", {"k_theta": 200.0 * EI / L},
                                            "clamp_flexibility", "k_theta_Nm_rad", 200.0 * EI / L),
}


def run_case(name: str, seed: int, shapes: bool) -> dsc.DiscrepancyResult:
    """One hidden-effect analysis (module docstring)."""
    bc, truth_bc, kw, _, _, _ = CASES[name]
    xs = INNER if support(bc).constrained_dofs(2) else FREE        # sensors at the ends only where they move
    rng = np.random.default_rng(seed)
    f, sh = plain_fe(truth_bc, L, EI * (1 + 0.03 * rng.standard_normal()), M, x_sensors=xs, **kw)
    f = f * (1 + NOISE.frequency * rng.standard_normal(f.size))
    if shapes:
        sh = sh / np.max(np.abs(sh), axis=0) + NOISE.shape * rng.standard_normal(sh.shape)
        meas = dsc.Measurement(f, None, sh, xs)
    else:
        meas = dsc.Measurement(f)
    beam = BEAM5.with_effects({}, bc=bc, measured_x_m=xs, n_elements=8)
    return dsc.analyse(beam, meas, NOISE, max_effects=1, n_elements=24, n_starts=3, seed=seed)


def rows(seeds: int, cases) -> list[dict]:
    """One row per case and data kind: ``truth``, ``data``, ``named`` (effect -> count; ``a~b``: named a,
    reported indistinguishable from b), ``param_error`` (median, or None) and ``gap_pct`` (median
    max |frequency error| after the EI recalibration, after the named effect)."""
    out = []
    for name in cases:
        _, _, _, effect, key, value = CASES[name]
        for shapes in (False, True):
            named, perr, gaps = {}, [], []
            for seed in range(seeds):
                res = run_case(name, seed, shapes)
                n = res.named_effects[0] if res.named_effects else "none"
                if res.steps and res.steps[0].indistinguishable_from:
                    n += "~" + "/".join(res.steps[0].indistinguishable_from)
                named[n] = named.get(n, 0) + 1
                if effect and res.named_effects[:1] == (effect,):
                    perr.append(abs(res.final.parameters[f"{effect}.{key}"] / value - 1))
                recal = res.steps[0].base.residuals if res.steps else res.final.residuals
                gaps.append((recal.max_abs_frequency_error_pct, res.final.residuals.max_abs_frequency_error_pct))
            out.append({"truth": name, "data": "shapes" if shapes else "freq", "named": named,
                        "param_error": float(np.median(perr)) if perr else None,
                        "gap_pct": tuple(float(g) for g in np.median(np.array(gaps), axis=0))})
            r = out[-1]
            print(f"{name:44s} {r['data']:7s} {_named(r):40s} {_err(r):>9s} "
                  f"{r['gap_pct'][0]:6.2f} -> {r['gap_pct'][1]:5.2f}", flush=True)
    return out


def _named(r: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in r["named"].items())


def _err(r: dict) -> str:
    return "-" if r["param_error"] is None else f"{100 * r['param_error']:.1f} %"


def markdown(rows: list[dict], seeds: int) -> str:
    """The docs table of :func:`rows`."""
    return (f"Hidden support effects, {seeds} seeds per truth (`python -m experiments.benches.bench_supports "
            f"--seeds {seeds} --docs`; truths from the plain Hermite FE of `experiments/studies/plain_beam.py`, "
            "not physics/):\n\n"
            + table(["truth", "data", "named", "parameter error", "max \\|f error\\| % recal. -> named"],
                    [[r["truth"], r["data"], _named(r), _err(r), f"{r['gap_pct'][0]:.2f} -> {r['gap_pct'][1]:.2f}"]
                     for r in rows]))


def main(argv=None):
    ap = parser(__file__, __doc__, docs="discrepancy.md")
    ap.add_argument("--seeds", type=int, default=3, help="random truths per case (default 3)")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES), metavar="CASE")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    print(f"{'truth':44s} {'data':7s} {'named (over seeds)':40s} {'param err':>9s} {'gap %':>15s}")
    found = rows(args.seeds, args.cases)
    print(f"\n{time.perf_counter() - t0:.0f} s")
    publish(args, "supports", markdown(found, args.seeds))


if __name__ == "__main__":
    main()
