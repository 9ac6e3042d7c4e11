"""Benchmark: confusion table of the hidden-effect suite of ``physics.discrepancy``.

Each truth is the beam5 preset with one hidden effect (small or large), a random
global EI (3 %) and mass (2 %) error, damping, and noise (frequencies 0.2 %,
damping ratios 5 %, shapes 1 % of the largest entry), simulated on 80 elements
and fitted on 24. Two kinds of data: frequencies + damping ratios, and the same
plus mode shapes at the quarter points. Prints, per data kind, how often each
truth is named as each effect (``~`` marks "named, but reported
indistinguishable from another candidate"), the median relative error of the
recovered parameter and the median gap (max |frequency error| after
recalibration only -> after the named effect). Damping ratios are modal
damping (the null model), so a dashpot is tested only on the complex shapes.

    python -m experiments.benches.bench_discrepancy [--seeds 3] [--kinds freq shapes] [--truths ...] [--estimate-noise]

``--estimate-noise`` treats the (correct) noise given as only assumed and scales it to
the data as the command does when no noise is given: a check that the estimate does
not name effects a correct noise would not.

The last truth is the same beam 40 mm deep (fitted with that depth): there rotary
inertia is large enough to be seen.
"""

from __future__ import annotations

import time

from experiments.benches.harness import parser, publish, table
from experiments.studies.study_discrepancy import BEAM, SHORT, TRUTHS, confusion
from physics.effects import candidates_for

__all__ = ["main"]


def main(argv=None):
    ap = parser(__file__, __doc__, docs="discrepancy.md")
    ap.add_argument("--seeds", type=int, default=3, help="random truths per case (default 3)")
    ap.add_argument("--kinds", nargs="+", default=["freq", "shapes"], choices=["freq", "shapes"])
    ap.add_argument("--truths", nargs="+", default=list(TRUTHS), choices=list(TRUTHS), metavar="TRUTH",
                    help="subset of the truths (default all)")
    ap.add_argument("--estimate-noise", action="store_true",
                    help="scale the given noise to the data (physics.discrepancy.analyse's estimate_noise)")
    args = ap.parse_args(argv)
    cols = [SHORT[c] for c in ("none", *candidates_for(BEAM.bc))]
    t0 = time.perf_counter()
    rows = confusion(args.seeds, args.kinds, args.truths, progress=True, estimate_noise=args.estimate_noise)
    for kind in args.kinds:
        print(f"\n== data: frequencies + damping ratios{' + mode shapes' if kind == 'shapes' else ''}, "
              f"{args.seeds} seeds per truth ==")
        print(f"{'truth':34s} " + " ".join(f"{c:>7s}" for c in cols)
              + f" {'param err':>9s} {'gap %':>15s}")
        for r in (r for r in rows if r["kind"] == kind):
            cells = " ".join(f"{str(r[c]) if r[c] else '.':>7s}" for c in cols)
            pe = f"{100 * r['param_error']:8.1f}%" if r["param_error"] is not None else f"{'-':>9s}"
            print(f"{r['truth']:34s} {cells} {pe} {r['gap_before_pct']:6.2f} -> {r['gap_after_pct']:5.2f}")
    print(f"\n{time.perf_counter() - t0:.0f} s")
    publish(args, "discrepancy-confusion", docs_table(rows, args.kinds, cols))


def docs_table(rows, kinds, cols) -> str:
    """Markdown table for docs/discrepancy.md: per truth and data kind, the effects named and how often."""
    head = {"freq": "named (freq + damping)", "shapes": "named (+ shapes)"}

    def cell(r):
        named = sorted((c for c in cols if r[c]), key=lambda c: -int(str(r[c]).rstrip("~")))
        return ", ".join(f"{c} {r[c]}" for c in named)

    by = {(r["truth"], r["kind"]): r for r in rows}
    return table(["truth", *(head[k] for k in kinds)], [[truth, *(cell(by[truth, k]) for k in kinds)]
                                                         for truth in dict.fromkeys(r["truth"] for r in rows)]) + "\n"


if __name__ == "__main__":
    main()
