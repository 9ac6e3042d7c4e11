"""Speed of free-decay identification (``era``) on one 1-s hammer hit at 25.6 kHz: the pyFRF hit 1 and a simulated one.

Timed, each the median of ``--repeat`` runs of ``METHODS["era"].fit`` (all defaults) under ``--threads`` BLAS
threads, after one untimed run (imports, caches):

* ``pyFRF hit 1``: the first response of ``experiments/data/real/pyfrf_hits.npz`` (25 600 samples, one channel;
  skipped with a message when the set is absent, see that folder's README);
* ``simulated``: :func:`simulated_hit`, eight modes 810-6080 Hz (damping 0.05-0.3 %) hit 10 ms into a 1-s record at
  25.6 kHz, white noise of ``--noise`` of the response's peak, ``--seed``.

Printed per record: CPU and wall seconds, samples per CPU second, and the seconds spent in the variable-projection
fit of damped sinusoids (:func:`~physics.identification.damped_sinusoids.fit_damped_sinusoids`, timed by wrapping
the name ``free_decay`` calls) with its number of calls.

Run ``python -m experiments.benches.bench_era_speed [--repeat N] [--threads N] [--noise X] [--seed S] [--json F]``.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import physics.identification.free_decay as free_decay
from experiments.benches.harness import parser, table
from physics.identification.methods import METHODS
from physics.io import atomic_write_text

__all__ = ["PYFRF", "main", "simulated_hit"]

#: The real set (absent: the case is skipped).
PYFRF = Path(__file__).resolve().parents[1] / "data" / "real" / "pyfrf_hits.npz"
#: The simulated hit's modes (Hz) and damping ratios.
SIM_FN_HZ = np.array([810.0, 900.0, 2640.0, 3008.0, 3669.0, 3690.0, 4128.0, 6077.0])
SIM_ZETA = np.array([0.0012, 0.0014, 0.0005, 0.0014, 0.0005, 0.0005, 0.001, 0.003])


def simulated_hit(fs_hz=25600.0, duration_s=1.0, noise=1e-3, seed=0) -> np.ndarray:
    """A hammer hit's response, shape (1, n): unit-force impulse response of :data:`SIM_FN_HZ` modes (random
    amplitudes of one sign pattern, ``seed``) from 10 ms on, plus white noise of ``noise`` times its peak."""
    rng = np.random.default_rng(seed)
    n = int(round(fs_hz * duration_s))
    t = np.arange(n) / fs_hz - 0.01
    wn = 2 * np.pi * SIM_FN_HZ
    amp = rng.uniform(0.3, 1.0, SIM_FN_HZ.size) * rng.choice([-1.0, 1.0], SIM_FN_HZ.size)
    on = t >= 0
    y = np.zeros(n)
    y[on] = (np.exp(-np.outer(t[on], SIM_ZETA * wn)) * np.sin(np.outer(t[on], wn * np.sqrt(1 - SIM_ZETA ** 2)))) @ amp
    return (y + noise * np.abs(y).max() * rng.normal(size=n))[None, :]


@contextlib.contextmanager
def _fit_timer(acc):
    """Add the CPU seconds and calls of ``free_decay.fit_damped_sinusoids`` to ``acc`` while inside."""
    inner = free_decay.fit_damped_sinusoids

    def timed(*args, **kwargs):
        t0 = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            acc["fit_s"] += time.process_time() - t0
            acc["fit_calls"] += 1

    free_decay.fit_damped_sinusoids = timed
    try:
        yield acc
    finally:
        free_decay.fit_damped_sinusoids = inner


def _run(y, fs):
    spec = METHODS["era"]
    acc = {"fit_s": 0.0, "fit_calls": 0}
    with warnings.catch_warnings(), _fit_timer(acc):
        warnings.simplefilter("ignore")
        c0, w0 = time.process_time(), time.perf_counter()
        est, _ = spec.fit(y, fs, None, None, "record", **{k: None for k in spec.options})
        acc.update(cpu_s=time.process_time() - c0, wall_s=time.perf_counter() - w0)
    acc["modes"] = int(est.natural_frequencies_hz.size)
    return acc


def time_case(name, y, fs, repeat) -> dict:
    """Median CPU/wall seconds of ``repeat`` era runs on ``y`` (after one untimed run)."""
    _run(y, fs)
    runs = [_run(y, fs) for _ in range(repeat)]
    med = {k: float(np.median([r[k] for r in runs])) for k in ("cpu_s", "wall_s", "fit_s")}
    return {"case": name, "samples": int(y.size), "modes": runs[-1]["modes"], "fit_calls": runs[-1]["fit_calls"],
            **med, "samples_per_cpu_s": y.size / med["cpu_s"]}


def main(argv=None) -> int:
    p = parser(__file__, __doc__, json="FILE", seed=0)
    p.add_argument("--repeat", type=int, default=3, help="timed runs per case, the median kept (default 3)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--noise", type=float, default=1e-3, help="simulated noise, of the peak (default 1e-3)")
    args = p.parse_args(argv)
    rows = []
    with threadpool_limits(args.threads):
        if PYFRF.is_file():
            with np.load(PYFRF) as d:
                rows.append(time_case("pyFRF hit 1", d["response"][0][None].astype(np.float64),
                                      float(d["sampling_frequency_hz"]), args.repeat))
        else:
            print(f"skipped pyFRF hit 1: {PYFRF} is absent (see experiments/data/real/README.md)", file=sys.stderr)
        rows.append(time_case("simulated", simulated_hit(noise=args.noise, seed=args.seed), 25600.0, args.repeat))
    print(table(["record", "samples", "modes", "CPU s", "wall s", "samples / CPU s", "fit s (calls)"],
                [[r["case"], r["samples"], r["modes"], f"{r['cpu_s']:.2f}", f"{r['wall_s']:.2f}",
                  f"{r['samples_per_cpu_s']:.0f}", f"{r['fit_s']:.2f} ({r['fit_calls']})"] for r in rows],
                ["---", "---:", "---:", "---:", "---:", "---:", "---:"]))
    if args.json:
        atomic_write_text(args.json, json.dumps({"args": vars(args), "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
