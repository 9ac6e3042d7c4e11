"""Output-only identification with the defaults: modes found against modes present, pyOMA2 beside.

Records: the independent simulator's nominal cantilever (``experiments.second_sim``, 16 elements; modes at 21.7,
136, 381, 747 and 1234 Hz, modal damping 1, 0.8, 0.6, 0.5 and 0.5 %) under random forces
(:func:`experiments.second_sim.ambient.ambient_record`), 2 % sensor noise, sampled at 20 to 200 times the lowest
mode's frequency. Every record is simulated at four times its sampling rate with every mode below 0.4 of that
rate and brought down to it through an 8th-order anti-alias low-pass at 0.4 of the sampling rate, or without it
(the modes above the Nyquist frequency fold into the record). The cases vary one thing at a time around 4
channels at the quarter points, white force at the tip: the sampling rate, coloured forces at two points, a
harmonic in the forces (at 1.9 times the lowest mode, 20 times the random force's standard deviation), no
anti-alias filter, 1 channel (the tip) and 16 channels.

*Present*: the true modes below 0.4 of the sampling rate (the default band). Each record is written as ``.npz``
and identified by ``beam-damage identify REC --json`` with nothing else (``experiments.cli.main`` in this
process): *found* is a mode within 1 % of a true one, *extra* a mode within 1 % of none (an aliased mode or the
harmonic), *warned* the clear spectral peaks the command names without a mode, *weak* the modes flagged
``weakly_stable``. Errors and MAC are over the modes found; time and peak memory (``tracemalloc``: what numpy and
Python allocate) of the whole command. pyOMA2 (``pyoma-2``, optional extra ``compare``) runs SSI-cov on the same
array with its default 20 block rows and orders up to 40 (its default highest order fails: ``ordmax=None``), and is
given the true frequencies to pick its poles (``mpe``, at the lowest order holding each, else at the highest order):
it has no automatic selection. It is left out on records of more than :data:`PEER_MAX_VALUES` values (its memory).

Run ``python -m experiments.benches.bench_oma_defaults [--minutes 5] [--seed 1] [--no-peer] [--json FILE] [--docs]``.
"""

from __future__ import annotations

import logging
import sys
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from experiments.benches.bench_oma import score
from experiments.second_sim.ambient import ambient_record, write_npz
from experiments.second_sim.fem import Beam, assemble, modes
from experiments.second_sim.pairs import EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M
from experiments.benches.harness import cli_json, emit_json, parser, publish, table

__all__ = ["CASES", "main", "run_case"]

DAMPING = (0.01, 0.008, 0.006, 0.005, 0.005)
#: pyOMA2 runs on records of at most this many values (its memory: about 1.7 GiB for 4 channels x 1.3 M samples).
PEER_MAX_VALUES = 12_000_000
F1_HZ = 21.706                                    # the lowest mode of the 16-element cantilever
QUARTERS = tuple(LENGTH_M * np.arange(1, 5) / 4)
SIXTEENTHS = tuple(LENGTH_M * np.arange(1, 17) / 16)
#: name -> (fs / f1, sensors, coloured, harmonic, anti-alias)
CASES = {
    "fs = 20 f1": (20, QUARTERS, False, False, True),
    "fs = 50 f1": (50, QUARTERS, False, False, True),
    "fs = 100 f1": (100, QUARTERS, False, False, True),
    "fs = 200 f1": (200, QUARTERS, False, False, True),
    "fs = 100 f1, coloured": (100, QUARTERS, True, False, True),
    "fs = 200 f1, coloured": (200, QUARTERS, True, False, True),
    "fs = 100 f1, harmonic": (100, QUARTERS, False, True, True),
    "fs = 100 f1, no anti-alias": (100, QUARTERS, False, False, False),
    "fs = 50 f1, no anti-alias": (50, QUARTERS, False, False, False),
    "fs = 100 f1, 1 channel": (100, (LENGTH_M,), False, False, True),
    "fs = 200 f1, 1 channel": (200, (LENGTH_M,), False, False, True),
    "fs = 100 f1, 16 channels": (100, SIXTEENTHS, False, False, True),
    "fs = 200 f1, 16 channels": (200, SIXTEENTHS, False, False, True),
}


def _measured(fn):
    """``fn()``'s result, wall time (s) and peak traced memory (bytes)."""
    tracemalloc.start()
    t = time.perf_counter()
    try:
        out = fn()
    finally:
        wall = time.perf_counter() - t
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return out, wall, peak


def _ours(path):
    try:
        r = cli_json(["identify", str(path)])
    except RuntimeError as exc:                       # identify refused the record: a row, not the end of the bench
        return {"error": str(exc)}
    modes = r["modes"]
    shapes = np.array([[complex(z) for z in m["shape"]] for m in modes]).T.reshape(len(r["dofs"]), len(modes))
    return {"fn": [m["frequency_hz"] for m in modes], "zeta": [m["damping_ratio"] for m in modes],
            "shapes": shapes, "weak": sum(bool(m.get("weakly_stable")) for m in modes),
            "warned": sum("clear spectral peak" in w for w in r["warnings"])}


def _peer(rec):
    """pyOMA2 SSI-cov with its defaults, given the true frequencies; None when pyOMA2 is absent."""
    try:
        from pyoma2.algorithms.ssi import SSI
        from pyoma2.setup.single import SingleSetup
    except ImportError:
        return None
    logging.disable(logging.WARNING)
    ss = SingleSetup(rec.signals.T.copy(), fs=rec.sampling_frequency_hz)
    ordmax = min(40, 20 * len(rec.sensor_x_m))
    ss.add_algorithms(SSI(name="a", method="cov", ordmax=ordmax))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ss.run_by_name("a")
            for order_in in ("find_min", ordmax):     # the lowest order holding each pole, else the highest
                ss.mpe("a", sel_freq=list(rec.frequencies_hz), order_in=order_in)
                if np.size(ss["a"].result.Fn):
                    break
    except Exception as exc:                          # a failure of the peer is a row, not the end of the bench
        return {"error": f"{type(exc).__name__}: {exc}"[:120]}
    r = ss["a"].result
    return {"fn": np.asarray(r.Fn), "zeta": np.asarray(r.Xi), "shapes": np.asarray(r.Phi).reshape(len(rec.sensor_x_m),
                                                                                                    -1)}


def run_case(name, minutes=5.0, seed=1, peer=True, tmp=None) -> list[dict]:
    """Rows of one case: ours through the CLI with the defaults, and pyOMA2 on the same record."""
    ratio, sensors, coloured, harmonic, anti_alias = CASES[name]
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    fs = round(ratio * F1_HZ)
    n_modes = int(np.sum(modes(assemble(beam)).omega_rad_s / (2 * np.pi) < 0.4 * fs))
    inputs = (QUARTERS[2], LENGTH_M) if coloured else (LENGTH_M,)
    rec = ambient_record(beam, sensors, 60 * minutes, fs, DAMPING, inputs, coloured, 0.02, n_modes, seed=seed,
                         harmonics=((1.9 * F1_HZ, 20.0),) if harmonic else (), oversample=4, anti_alias=anti_alias)
    truth = (rec.frequencies_hz, rec.damping_ratios, rec.shapes)
    path = Path(tmp) / "rec.npz"
    write_npz(path, rec)
    base = {"case": name, "fs_hz": float(fs), "lowest_fraction_of_fs": 1 / ratio, "channels": len(sensors),
            "minutes": minutes}
    rows = []
    ours, wall, peak = _measured(lambda: _ours(path))
    rows.append({**base, "method": "identify (defaults)", "wall_s": wall, "peak_mib": peak / 2**20,
                 "error": ours.get("error"), "weak": ours.get("weak", 0), "warned": ours.get("warned", 0),
                 **(score(truth, ours["fn"], np.asarray(ours["zeta"]), ours["shapes"], 0.01) if "fn" in ours
                    else score(truth, [], [], None, 0.01))})
    if peer and rec.signals.size <= PEER_MAX_VALUES:
        theirs, wall, peak = _measured(lambda: _peer(rec))
        if theirs is not None:
            rows.append({**base, "method": "pyOMA2 SSI-cov (defaults, given the true frequencies)", "wall_s": wall,
                         "peak_mib": peak / 2**20, "error": theirs.get("error"), "weak": None, "warned": None,
                         **(score(truth, theirs["fn"], theirs["zeta"], theirs["shapes"], 0.01) if "fn" in theirs
                            else score(truth, [], [], None, 0.01))})
    return rows


def markdown(rows) -> str:
    def n(v, fmt):
        return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, fmt)

    head = ["record", "method", "found", "extra", "warned", "weak", "max freq. error", "max damping error", "min MAC",
            "time", "peak memory"]
    return table(head, [[f"{r['case']} ({r['fs_hz']:g} Hz, {r['channels']} ch)", r["method"],
                         f"{r['found']} of {r['of']}{' (failed)' if r['error'] else ''}", r["extra"],
                         n(r["warned"], "d"), n(r["weak"], "d"), f"{n(r['max_freq_err_pct'], '.3f')} %",
                         f"{n(r['max_damping_err_pct'], '.1f')} %", n(r["min_mac"], ".4f"), f"{r['wall_s']:.2f} s",
                         f"{r['peak_mib']:.0f} MiB"] for r in rows], ["---"] * 2 + ["---:"] * 9) + "\n"


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md", json="FILE", seed=1)
    p.add_argument("--minutes", type=float, default=5.0, help="record length (default 5)")
    p.add_argument("--case", action="append", choices=list(CASES), help="run only these cases (repeatable)")
    p.add_argument("--no-peer", action="store_true", help="leave pyOMA2 out")
    p.add_argument("--threads", type=int, default=1, help="BLAS/FFT threads of both packages (default 1)")
    args = p.parse_args(argv)

    rows = []
    with threadpool_limits(args.threads), tempfile.TemporaryDirectory() as tmp:
        for k, name in enumerate(args.case or CASES):
            new = run_case(name, args.minutes, args.seed + k, not args.no_peer, tmp)
            sys.stdout.write(markdown(new).split("\n", 2)[2])
            sys.stdout.flush()
            rows += new
    md = markdown(rows)
    sys.stdout.write("\n" + md)
    emit_json(args, {"config": vars(args), "rows": rows}, default=str)
    publish(args, "oma-defaults", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
