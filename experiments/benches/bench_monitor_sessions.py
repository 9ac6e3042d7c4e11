"""Benchmark: a baseline period from one session, later tests from others. Does ``monitor`` name the baseline too
narrow?

Run: ``python -m experiments.benches.bench_monitor_sessions --out out/bench_monitor_sessions
[--offsets 0 0.0003 0.0006 0.001 0.003] [--seeds 0 1 2 3]``

Modal data of 4 modes (21.6, 135.4, 379, 742 Hz; 0.03 % noise per test): 30 baseline tests of session 0, then 6
sessions of 15 tests each, every later session's frequencies offset per mode by ``N(0, s^2)`` (no damage).
``monitor --baseline-tests 30`` (``pca``, 1 % false alarms) per offset ``s`` and seed: the later tests alarmed and
extrapolated, the scatter ratio of the later tests without an alarm against the baseline's
(:func:`learn.monitor.coverage.baseline_scatter`) and whether it warns. Seed 0 draws the offsets for every ``s``
(the offsets scale with ``s``); the other seeds run ``s = 0`` only (the ratio's spread without sessions).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments.benches.harness import cli_json, parser

__all__ = ["main", "session_series"]

F0_HZ = np.array([21.6, 135.4, 379.0, 742.0])


def session_series(out: Path, offset: float, seed: int, n_base: int = 30, sessions: int = 6, per: int = 15,
                   noise: float = 3e-4) -> list:
    """The modal JSON files of one series (module docstring), in time order."""
    rng = np.random.default_rng(seed)
    which = [0] * n_base + [s for s in range(1, sessions + 1) for _ in range(per)]
    shift = {s: (0.0 if s == 0 else offset) * rng.standard_normal(4) for s in range(sessions + 1)}
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for k, s in enumerate(which):
        f = F0_HZ * (1 + shift[s] + noise * rng.standard_normal(4))
        path = out / f"t{k:03d}.json"
        path.write_text(json.dumps({"natural_frequencies_hz": f.tolist()}))
        files.append(str(path))
    return files


def main(argv=None) -> list:

    p = parser(__file__, __doc__, out="out/bench_monitor_sessions")
    p.add_argument("--offsets", type=float, nargs="+", default=[0.0, 3e-4, 6e-4, 1e-3, 3e-3])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    a = p.parse_args(argv)
    runs = [(s, 0) for s in a.offsets] + [(0.0, seed) for seed in a.seeds if seed != 0]
    rows = []
    print("| session offset | seed | later tests alarmed (of 90) | extrapolated | scatter ratio | warned |")
    print("| --- | --- | --- | --- | --- | --- |")
    for offset, seed in runs:
        files = session_series(Path(a.out) / f"s{offset:g}-seed{seed}", offset, seed)
        d = cli_json(["monitor", *files, "--baseline-tests", "30"])
        sc = d["baseline_scatter"]
        row = {"offset": offset, "seed": seed, "alarms": d["counts"]["alarm"],
               "extrapolated": d["counts"]["extrapolated"], "ratio": sc["ratio"], "warned": bool(sc["warning"])}
        rows.append(row)
        ratio = "–" if row["ratio"] is None else f"{row['ratio']:.2f}"
        print(f"| {100 * offset:g} % | {seed} | {row['alarms']} | {row['extrapolated']} | {ratio} | "
              f"{'yes' if row['warned'] else 'no'} |")
    return rows


if __name__ == "__main__":
    main()
