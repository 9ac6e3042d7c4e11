"""``beam-damage train``: train the damage classifier on generated datasets."""

from __future__ import annotations

from physics.errors import BeamDamageError
from datagen.store import read_manifest
from learn.network.mode_count import require_test_modes

__all__ = ["add_parser", "run"]


def add_parser(sub):
    p = sub.add_parser("train",
                       description="Train the network on pairs (baseline, current) of one or more datasets written by "
                                   "'beam-damage generate --config training --n N --out DIR' (intact and damaged "
                                   "specimens, temperature and re-clamping between the test days), split by specimen "
                                   "(85 % train incl. validation, 15 % test), calibrate its probabilities (a logit "
                                   "scale and bias), score it and the classical methods on the "
                                   "test split and write a model directory (config.json, weights-*.npz, metrics.csv).")
    p.add_argument("--data", required=True, nargs="+", metavar="DIR",
                   help="dataset directories of one beam (beam-damage generate --config training)")
    p.add_argument("--out", required=True, metavar="MODEL_DIR", help="model directory to write")
    p.add_argument("--epochs", type=int, default=60, help="training epochs (default 60)")
    p.add_argument("--seed", type=int, default=0, help="random seed of split, augmentation and network (default 0)")
    p.add_argument("--route", choices=("modal", "updated", "measured"), default=None,
                   help="input route (default: the benchmark's winner, learn.network.model_dir.DEFAULT_ROUTE)")
    p.add_argument("--threads", type=int, default=1,
                   help="torch CPU threads of the networks (default 1: fastest for this small network, and more "
                        "threads were up to 10x slower on a machine shared with other jobs)")
    p.add_argument("--json", action="store_true", help="print the training summary as JSON")
    p.set_defaults(func=run)


def run(args) -> dict:
    from learn.network.training import train  # torch: the network

    if args.epochs < 1:
        raise BeamDamageError(f"--epochs must be >= 1, got {args.epochs}")
    if args.seed < 0:
        raise BeamDamageError(f"--seed must be >= 0, got {args.seed}")
    if args.threads < 1:
        raise BeamDamageError(f"--threads must be >= 1, got {args.threads}")
    for root in args.data:
        _check_test_modes(root)
    out = train(args.data, args.out, epochs=args.epochs, seed=args.seed, route=args.route, progress=True,
                threads=args.threads)
    if not args.json:
        m = out["test_metrics"][0]
        print(f"{args.out}: {out['route']} route, {out['train_pairs']} training pairs, "
              f"{sum(out['train_seconds'].values()):.0f} s of training; test split ({out['test_pairs']} pairs): "
              f"ROC AUC {m['roc_auc']:.4f}, element accuracy {m['element_accuracy']:.3f}, "
              f"median location error {m['median_location_error_mm']:.1f} mm, "
              f"false alarms {m['false_alarm_rate']:.3f}; best classical method {out['best_classical']}")
    return out


def _check_test_modes(root) -> None:
    """Refuse, before reading the samples, a dataset whose test band holds fewer modes than classify needs
    (:func:`learn.network.mode_count.require_test_modes`); a directory that is not a dataset is left to ``train``."""
    from learn.network.features import beam_of_manifest  # pandas: only here

    try:
        test = beam_of_manifest(read_manifest(root)).test
    except (BeamDamageError, OSError, KeyError, TypeError, ValueError):
        return
    require_test_modes(test, f"{root} (its manifest's layout)")
