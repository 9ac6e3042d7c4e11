"""``beam-damage inspect``: dataset summary, label distributions, curvature check and FRF overlays."""

from __future__ import annotations

from datagen.inspection import inspect_dataset

__all__ = ["add_parser", "run"]


def add_parser(subparsers):
    p = subparsers.add_parser(
        "inspect",
        description="Summary of a dataset directory (counts, convergence, label ranges), label histograms, the "
                    "frequency shift of each mode versus slit position against the mode's curvature squared "
                    "(single-slit samples of slit datasets), and FRF overlays of the current state vs the baseline.")
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--out", help="directory for figures and tables (default DIR/inspect)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=run)


def run(args) -> dict:
    summary = inspect_dataset(args.dir, args.out)
    if not args.json:
        print(f"{args.dir}: {summary['samples']} samples, {summary['shards']} shards, "
              f"converged {summary['converged_fraction']:.3f}")
        for k, c in summary["curvature_check"].items():
            if c["slope"] is not None:
                print(f"  {k}: shift vs curvature^2 slope {c['slope']:.3f}, R^2 {c['r2']:.4f} (n={c['n']})")
        print(f"  figures in {summary['out']}")
    return summary
