"""``python -m experiments.second_sim pairs|kinds|effects|beams|bolted|series ...``: test files of the independent
simulator."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from experiments.second_sim.beams import CATALOGUE, simulate_beam_pairs, write_beam_pairs
from experiments.second_sim.bolted import MASS_KG, write_bolted_test, write_mass_change_pairs
from experiments.second_sim.effects import effect_cases, write_effect_cases
from experiments.second_sim.kind_pairs import CHANGES, simulate_kind_pairs
from experiments.second_sim.pairs import simulate_pairs, write_pairs
from experiments.second_sim.series import SLIT_SIZES, SeriesConfig, simulate_series, write_series

__all__ = ["main"]


# the matrices are small (~230 DOFs): one BLAS thread is fastest, and several stall on a shared machine
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.second_sim",
                                description="Independent beam simulator writing UFF/JSON test files.")
    sub = p.add_subparsers(dest="command", required=True)
    pp = sub.add_parser("pairs", help="baseline/current UFF pairs with truth.csv/json")
    pp.add_argument("--set", dest="set_name", choices=("easy", "eb", "timoshenko"), default="easy")
    pp.add_argument("--n", type=int, default=24)
    pp.add_argument("--seed", type=int, default=0)
    pp.add_argument("--out", required=True)
    pp.add_argument("--band-hz", type=float, nargs=2, default=(2.0, 800.0), metavar=("F_MIN", "F_MAX"),
                    help="first and last frequency line (Hz; default 2 800)")
    pp.add_argument("--df-hz", type=float, default=0.5, help="line spacing (Hz; default 0.5)")
    pp.add_argument("--mode4-drop", type=float, default=None,
                    help="timoshenko set: shear drop of mode 4 vs Euler-Bernoulli (default 0.08; 0.1475 gives "
                         "kGA ~27.5 kN and the measured beam-5 frequencies)")
    pk = sub.add_parser("kinds", help="beam-5 pairs with a face-core debond, a slit, a mass added or none: "
                                      "baseline/current UFF and modal JSON, truth.csv/json")
    pk.add_argument("--n", type=int, default=10, help="pairs of each change (default 10)")
    pk.add_argument("--seed", type=int, default=0)
    pk.add_argument("--changes", nargs="+", default=None, metavar="CHANGE",
                    help="some of debond slit mass intact (default: all)")
    pk.add_argument("--tied-tips", action="store_true",
                    help="debonds whose tips hold the face (closed debonds) instead of a face sliding over them")
    pk.add_argument("--out", required=True)
    pe = sub.add_parser("effects", help="hidden-effect cases (modal JSON, frequency JSON, UFF) with cases.json")
    pe.add_argument("--seed", type=int, default=0)
    pe.add_argument("--out", required=True)
    pb = sub.add_parser("beams", help="per catalogue beam: beam.toml, baseline/current UFF pairs, truth.csv/json")
    pb.add_argument("--out", required=True)
    pb.add_argument("--n", type=int, default=40, help="pairs per beam (default 40)")
    pb.add_argument("--seed", type=int, default=0)
    pb.add_argument("--only", default=None, help="one catalogue beam by name (default: every beam)")
    po = sub.add_parser("bolted", help="a steel cantilever with six bolted masses: baseline/current modal JSON, "
                                       "bar.toml (masses left out), bolted.toml, truth.json")
    po.add_argument("--out", required=True)
    po.add_argument("--seed", type=int, default=0)
    po.add_argument("--removed-kg", type=float, default=0.005,
                    help="mass taken off the bolted mass nearest --damage-x-m (kg; default 0.005)")
    po.add_argument("--damage-x-m", type=float, default=0.23, help="where (m; default 0.23)")
    po.add_argument("--pairs", type=int, default=0,
                    help="instead: this many specimen pairs with masses added (1-20 %% of the bar's mass) or lost "
                         "(1-8 %%), pair-KK_baseline/current.json and truth.json")
    ps = sub.add_parser("series", help="a monitoring series of one cantilever: a test a day, temperature, re-mounting, "
                                       "a re-placed mass, a slit from a known day; conditions.csv, truth.json, "
                                       "beam.toml")
    ps.add_argument("--out", required=True)
    ps.add_argument("--kind", choices=("frf", "output-only"), default="frf",
                    help="FRFs (UFF58 accelerance, hammer) or output-only records (NPZ of acceleration)")
    ps.add_argument("--n-tests", type=int, default=365, help="tests (default 365)")
    ps.add_argument("--days", type=float, default=365.0, help="days the tests span (default 365)")
    ps.add_argument("--seed", type=int, default=0)
    ps.add_argument("--damage-day", type=float, default=270.0, help="day the slit appears (default 270; < 0: none)")
    ps.add_argument("--slit-size", default="medium",
                    help="slit EI loss (4 mm wide at 0.15 L): small, medium, large or a number in [0, 1)")
    ps.add_argument("--growth-day", type=float, default=None,
                    help="a second slit (0.55 L) whose EI loss grows linearly from this day to 0.6 at the end")
    ps.add_argument("--sensors", type=float, nargs="+", default=None, metavar="X_OVER_L",
                    help="accelerometer positions as fractions of the length (default 1/3 2/3 1)")
    ps.add_argument("--hammer", type=float, default=None, metavar="X_OVER_L",
                    help="hammer position as a fraction of the length (default 1, the tip)")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    try:
        if args.command == "pairs":
            if args.n < 1:
                raise ValueError(f"--n must be >= 1, got {args.n}")
            f0, f1 = args.band_hz
            if not (0 < f0 < f1 and 0 < args.df_hz <= f1 - f0):
                raise ValueError(f"--band-hz must be 0 < F_MIN < F_MAX and --df-hz in (0, F_MAX - F_MIN], "
                                 f"got {f0} {f1} and {args.df_hz}")
            freq_hz = f0 + args.df_hz * np.arange(int(round((f1 - f0) / args.df_hz)) + 1)
            out = write_pairs(simulate_pairs(args.set_name, args.n, args.seed, freq_hz, args.mode4_drop), args.out)
            what = f"{args.n} pairs of set {args.set_name}"
        elif args.command == "kinds":
            changes = tuple(args.changes or CHANGES)
            if args.n < 1 or not set(changes) <= set(CHANGES):
                raise ValueError(f"--n must be >= 1 and --changes some of {' '.join(CHANGES)}, got {args.n} and "
                                 f"{' '.join(changes)}")
            out = write_pairs(simulate_kind_pairs(args.n, args.seed, changes, args.tied_tips), args.out)
            what = f"{args.n} pairs of each of {', '.join(changes)}"
        elif args.command == "beams":
            names = [c.name for c in CATALOGUE]
            if args.only is not None and args.only not in names:
                raise ValueError(f"--only: unknown beam {args.only!r}; expected one of {', '.join(names)}")
            if args.n < 1:
                raise ValueError(f"--n must be >= 1, got {args.n}")
            chosen = [c for c in CATALOGUE if args.only in (None, c.name)]
            for cb in chosen:
                write_beam_pairs(cb, simulate_beam_pairs(cb, args.n, args.seed), Path(args.out) / cb.name, args.seed)
            out = args.out
            what = f"{args.n} pairs of {len(chosen)} beam(s)"
        elif args.command == "bolted":
            if not 0 <= args.removed_kg < MASS_KG:
                raise ValueError(f"--removed-kg must lie in [0, {MASS_KG}) kg, got {args.removed_kg}")
            if args.pairs < 0:
                raise ValueError(f"--pairs must be >= 0, got {args.pairs}")
            if args.pairs:
                out = write_mass_change_pairs(args.out, args.pairs, args.seed)
                what = f"{args.pairs} bolted-cantilever pairs with mass changes"
            else:
                out = write_bolted_test(args.out, args.seed, args.removed_kg, args.damage_x_m)
                what = "the bolted cantilever"
        elif args.command == "series":
            size = SLIT_SIZES.get(args.slit_size)
            if size is None:
                try:
                    size = float(args.slit_size)
                except ValueError:
                    raise ValueError(f"--slit-size must be one of {', '.join(SLIT_SIZES)} or a number in [0, 1), "
                                     f"got {args.slit_size!r}") from None
            kw = {"sensors_x_over_L": tuple(args.sensors)} if args.sensors else {}
            if args.hammer is not None:
                kw["hammer_x_over_L"] = args.hammer
            cfg = SeriesConfig(n_tests=args.n_tests, days=args.days, seed=args.seed, kind=args.kind,
                               damage_day=None if args.damage_day < 0 else args.damage_day, slit_ei_loss=size,
                               growth_day=args.growth_day, **kw)
            out = write_series(cfg, simulate_series(cfg), args.out)
            what = f"a series of {args.n_tests} {args.kind} tests"
        else:
            cases = effect_cases(args.seed)
            out = write_effect_cases(cases, args.out)
            what = f"{len(cases)} effect cases"
    except (ValueError, OSError) as exc:
        print(f"second_sim: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {what} to {out} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
