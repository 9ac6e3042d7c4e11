"""``python -m experiments.second_sim pairs|effects ...``: write test files of the independent simulator."""

from __future__ import annotations

import argparse
import os
import sys
import time

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
    pe = sub.add_parser("effects", help="hidden-effect cases (modal JSON, frequency JSON, UFF) with cases.json")
    pe.add_argument("--seed", type=int, default=0)
    pe.add_argument("--out", required=True)
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    try:
        if args.command == "pairs":
            from experiments.second_sim.pairs import simulate_pairs, write_pairs

            if args.n < 1:
                raise ValueError(f"--n must be >= 1, got {args.n}")
            out = write_pairs(simulate_pairs(args.set_name, args.n, args.seed), args.out)
            what = f"{args.n} pairs of set {args.set_name}"
        else:
            from experiments.second_sim.effects import effect_cases, write_effect_cases

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
