"""Output-only identification against the independent simulator's truth, and pyOMA2 side by side.

Records: the second simulator's nominal cantilever (``experiments.second_sim``, 16 elements, modes 1-4 at
21.7, 136, 381 and 747 Hz, modal damping 1, 0.8, 0.6 and 0.5 %) under random forces, eight accelerometers at
``x = L/8 .. L`` with 2 % noise, 2 kHz sampling. Cases: white force at the tip; coloured forces at two points
(second-order low-pass at 127 Hz); and a short record. Per case and method: modes found of the four, the largest
frequency and damping errors, the smallest MAC with the true shapes, and the wall time of the identification
on the same record. pyOMA2 (``pyoma-2``, optional extra ``compare``) is given the true frequencies to pick its
poles (its ``mpe``); ours selects them automatically.

Run ``python -m experiments.benches.bench_oma [--minutes 10] [--seed 1] [--threads 1] [--no-peer] [--json FILE]
[--docs]``;
``--long-record MINUTES`` instead writes a record of 16 channels at 2 kHz (float32 ``.npy``, built of 5-minute
simulated blocks) to a temporary directory and reports the wall time and the peak of the memory numpy allocates
(``tracemalloc``) while SSI-cov identifies it from the memory-mapped file.
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

from experiments.second_sim.ambient import ambient_record
from experiments.second_sim.fem import Beam
from experiments.second_sim.pairs import EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M
from experiments.benches.harness import emit_json, parser, publish, table
from physics.identification.fdd import identify_fdd
from physics.identification.ssi import identify_ssi
from physics.modal import mac

__all__ = ["CASES", "main", "run", "score"]

FS_HZ = 2000.0
DAMPING = (0.01, 0.008, 0.006, 0.005)
BAND_HZ = (5.0, 800.0)
SENSORS_X_M = LENGTH_M * np.arange(1, 9) / 8
#: name -> (minutes factor, coloured, force positions)
CASES = {"white, tip force": (1.0, False, (LENGTH_M,)),
         "coloured, two forces": (1.0, True, (SENSORS_X_M[2], LENGTH_M)),
         "white, tip force, short": (None, False, (LENGTH_M,))}


def _nanmax(a) -> float:
    return float(np.nanmax(a)) if a and np.any(np.isfinite(a)) else float("nan")


def score(truth, fn, zeta, shapes, tol=0.05) -> dict:
    """Modes found (nearest identified frequency within ``tol`` of a true one), extra modes (within ``tol`` of
    none), largest |frequency| and |damping| relative errors and smallest MAC over the modes found."""
    f_true, z_true, phi = truth
    fn = np.asarray(fn, float)
    found, ef, ez, m = 0, [], [], []
    hit = np.zeros(fn.size, bool)
    for j, f in enumerate(f_true):
        if fn.size == 0:
            break
        k = int(np.argmin(np.abs(fn - f)))
        if abs(fn[k] - f) > tol * f:
            continue
        found += 1
        hit[k] = True
        ef.append(abs(fn[k] / f - 1))
        ez.append(abs(zeta[k] / z_true[j] - 1) if np.isfinite(zeta[k]) else np.nan)
        m.append(float(mac(phi[:, [j]], shapes[:, [k]])[0, 0]))
    return {"found": found, "of": len(f_true), "extra": int((~hit).sum()), "max_freq_err_pct": 100 * _nanmax(ef),
            "max_damping_err_pct": 100 * _nanmax(ez), "min_mac": min(m) if m else float("nan")}


def _ours(rec):
    out = {}
    for name, fit in (("SSI-cov (this package)", lambda: identify_ssi(rec.signals, FS_HZ, BAND_HZ, max_order=40)),
                      ("EFDD (this package)", lambda: identify_fdd(rec.signals, FS_HZ, BAND_HZ))):
        t = time.perf_counter()
        e = fit().estimate
        out[name] = (time.perf_counter() - t, e.natural_frequencies_hz, e.damping_ratios, e.shapes)
    return out


def _peer(rec):
    """pyOMA2 SSI-cov (30 block rows, orders to 40, as ours) and EFDD on the same record, or {} if absent."""
    try:
        from pyoma2.algorithms.fdd import EFDD
        from pyoma2.algorithms.ssi import SSI
        from pyoma2.setup.single import SingleSetup
    except ImportError:
        return {}
    logging.disable(logging.WARNING)
    out = {}
    for name, alg, mpe in (("pyOMA2 SSI-cov (given the true frequencies)", SSI(name="a", method="cov", br=30,
                                                                                 ordmax=40),
                            {"order_in": "find_min"}),
                           ("pyOMA2 EFDD (given the true frequencies)", EFDD(name="a", nxseg=8192), {})):
        t = time.perf_counter()
        ss = SingleSetup(rec.signals.T.copy(), fs=FS_HZ)
        ss.add_algorithms(alg)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ss.run_by_name("a")
            ss.mpe("a", sel_freq=list(rec.frequencies_hz), **mpe)
        r = ss["a"].result
        out[name] = (time.perf_counter() - t, np.asarray(r.Fn), np.asarray(r.Xi), np.asarray(r.Phi))
    return out


def run(minutes=10.0, seed=1, peer=True) -> list[dict]:
    """One row per case and method (see the module docstring)."""
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    rows = []
    for k, (case, (factor, coloured, inputs)) in enumerate(CASES.items()):
        duration = 60 * (minutes * factor if factor else 2.0)
        rec = ambient_record(beam, SENSORS_X_M, duration, FS_HZ, DAMPING, inputs, coloured, 0.02, 4,
                             seed=seed + k)
        truth = (rec.frequencies_hz, rec.damping_ratios, rec.shapes)
        results = {**_ours(rec), **(_peer(rec) if peer else {})}
        for method, (wall, fn, zeta, shapes) in results.items():
            rows.append({"case": case, "minutes": duration / 60, "method": method, "wall_s": wall,
                         **score(truth, fn, zeta, shapes)})
    return rows


def long_record_memory(minutes=60.0, seed=1) -> dict:
    """Wall time, peak allocated memory and modes of SSI-cov on a memory-mapped record of 16 channels at 2 kHz."""
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    x = LENGTH_M * np.arange(1, 17) / 16
    block = int(300 * FS_HZ)
    n = int(minutes * 60 * FS_HZ) // block * block
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.npy"
        y = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(x.size, n))
        for k in range(n // block):
            y[:, k * block:(k + 1) * block] = ambient_record(beam, x, 300.0, FS_HZ, DAMPING, (LENGTH_M,),
                                                             False, 0.02, 4, seed=seed + k).signals
        y.flush()
        del y
        y = np.load(path, mmap_mode="r")
        tracemalloc.start()
        t = time.perf_counter()
        e = identify_ssi(y, FS_HZ, BAND_HZ, max_order=40).estimate
        wall = time.perf_counter() - t
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        size = path.stat().st_size
    return {"channels": int(x.size), "samples": n, "file_bytes": size, "wall_s": wall, "peak_alloc_bytes": peak,
            "frequencies_hz": e.natural_frequencies_hz.tolist(), "damping_ratios": e.damping_ratios.tolist()}


def memory_markdown(r, minutes) -> str:
    """One-row table of :func:`long_record_memory`."""
    return ("| record | file | SSI-cov time | peak allocated | modes found (Hz) |\n| --- | --- | --- | --- | --- |\n"
            f"| {minutes:g} min, {r['channels']} channels, {FS_HZ:g} Hz ({r['samples']} samples) | "
            f"{r['file_bytes'] / 2**20:.0f} MiB float32, memory-mapped | {r['wall_s']:.1f} s | "
            f"{r['peak_alloc_bytes'] / 2**20:.0f} MiB | {', '.join(f'{f:.3f}' for f in r['frequencies_hz'])} |\n")


def markdown(rows) -> str:
    return table(["record", "method", "modes found", "max freq. error", "max damping error", "min MAC", "time"],
                 [[f"{r['case']}, {r['minutes']:g} min", r["method"], f"{r['found']} of {r['of']}",
                   f"{r['max_freq_err_pct']:.3f} %", f"{r['max_damping_err_pct']:.1f} %", f"{r['min_mac']:.5f}",
                   f"{r['wall_s']:.2f} s"] for r in rows]) + "\n"


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md", json="FILE", seed=1)
    p.add_argument("--minutes", type=float, default=10.0, help="record length of the long cases (default 10)")
    p.add_argument("--no-peer", action="store_true", help="leave pyOMA2 out")
    p.add_argument("--long-record", type=float, metavar="MINUTES",
                   help="report the memory and time of SSI-cov on a memory-mapped record of this length instead")
    p.add_argument("--threads", type=int, default=1,
                   help="BLAS/FFT threads of both packages (default 1: timings on a loaded machine stay comparable)")
    args = p.parse_args(argv)
    with threadpool_limits(args.threads):
        return _main(args)


def _main(args) -> int:
    if args.long_record:
        r = long_record_memory(args.long_record, args.seed)
        print(f"SSI-cov on {r['channels']} channels x {r['samples']} samples at {FS_HZ:g} Hz (float32 file "
              f"{r['file_bytes'] / 2**20:.0f} MiB, memory-mapped): {r['wall_s']:.1f} s, peak allocated "
              f"{r['peak_alloc_bytes'] / 2**20:.0f} MiB; modes (Hz) "
              + ", ".join(f"{f:.3f}" for f in r["frequencies_hz"]))
        emit_json(args, {"config": vars(args), "long_record": r})
        publish(args, "oma-memory", memory_markdown(r, args.long_record))
        return 0
    rows = run(args.minutes, args.seed, not args.no_peer)
    md = markdown(rows)
    sys.stdout.write(md)
    ours = {r["case"]: r["wall_s"] for r in rows if r["method"].startswith("SSI-cov")}
    for r in rows:
        if r["method"].startswith("pyOMA2 SSI"):
            print(f"{r['case']}: pyOMA2 SSI-cov / ours wall time = {r['wall_s'] / ours[r['case']]:.1f}")
    emit_json(args, {"config": vars(args), "rows": rows})
    publish(args, "oma", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
