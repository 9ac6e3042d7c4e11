"""Speed of free-decay identification (``era``) on 1-s hammer hits at 25.6 kHz (pyFRF hits and a simulated one), and
of SSI-cov's stabilisation diagram on a simulated ambient record.

Timed, each the median of ``--repeat`` runs of ``METHODS["era"].fit`` (all defaults) under ``--threads`` BLAS
threads, after one untimed run (imports, caches):

* ``pyFRF hit k``: the first ``--hits`` responses of ``experiments/data/real/pyfrf_hits.npz`` (25 600 samples, one
  channel; skipped with a message when the set is absent, see that folder's README);
* ``simulated``: :func:`simulated_hit`, eight modes 810-6080 Hz (damping 0.05-0.3 %) hit 10 ms into a 1-s record at
  25.6 kHz, white noise of ``--noise`` of the response's peak, ``--seed``;
* ``ambient (ssi)``: ``METHODS["ssi"].fit`` on :func:`ambient_case`, a 5-min record of the second simulator's
  cantilever (``experiments.second_sim``, four modes 21.7-747 Hz) at four accelerometers ``x = L/4 .. L`` under a
  white tip force, 2 kHz, 2 % noise, ``--seed``.

Printed per record: CPU and wall seconds, samples per CPU second, the seconds spent in the variable-projection
fit of damped sinusoids (:func:`~physics.identification.damped_sinusoids.fit_damped_sinusoids`, timed by wrapping
the name ``free_decay`` calls) with its number of calls, and those spent in the stabilisation diagram
(:func:`~physics.identification.subspace.subspace_diagram`, wrapped where ``free_decay`` and ``ssi`` call it).

Run ``python -m experiments.benches.bench_era_speed [--repeat N] [--threads N] [--hits N] [--noise X] [--seed S]
[--no-ambient] [--json F]``.
"""

from __future__ import annotations

import contextlib
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import physics.identification.free_decay as free_decay
import physics.identification.ssi as ssi
from experiments.benches.harness import emit_json, parser, table
from experiments.second_sim.ambient import ambient_record
from experiments.second_sim.fem import Beam
from experiments.second_sim.pairs import EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M
from physics.identification.methods import METHODS

__all__ = ["PYFRF", "ambient_case", "main", "simulated_hit"]

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


def ambient_case(seed=0, minutes=5.0):
    """A simulated ambient record, shape (4, n), and its sampling rate (Hz): see the module docstring."""
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    rec = ambient_record(beam, LENGTH_M * np.arange(1, 5) / 4, 60.0 * minutes, 2000.0, (0.01, 0.008, 0.006, 0.005),
                         (LENGTH_M,), False, 0.02, 4, seed=seed)
    return rec.signals, 2000.0


@contextlib.contextmanager
def _timer(acc, module, name, key):
    """Add the CPU seconds and calls of ``module.name`` to ``acc[key + "_s"]``, ``acc[key + "_calls"]`` while
    inside."""
    inner = getattr(module, name)

    def timed(*args, **kwargs):
        t0 = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            acc[key + "_s"] += time.process_time() - t0
            acc[key + "_calls"] += 1

    setattr(module, name, timed)
    try:
        yield acc
    finally:
        setattr(module, name, inner)


def _run(y, fs, method="era"):
    spec = METHODS[method]
    acc = {"fit_s": 0.0, "fit_calls": 0, "diagram_s": 0.0, "diagram_calls": 0}
    with warnings.catch_warnings(), _timer(acc, free_decay, "fit_damped_sinusoids", "fit"), \
            _timer(acc, free_decay, "subspace_diagram", "diagram"), _timer(acc, ssi, "subspace_diagram", "diagram"):
        warnings.simplefilter("ignore")
        c0, w0 = time.process_time(), time.perf_counter()
        est, _ = spec.fit(y, fs, None, None, "record", **{k: None for k in spec.options})
        acc.update(cpu_s=time.process_time() - c0, wall_s=time.perf_counter() - w0)
    acc["modes"] = int(est.natural_frequencies_hz.size)
    return acc


def time_case(name, y, fs, repeat, method="era") -> dict:
    """Median CPU/wall seconds of ``repeat`` runs of ``method`` on ``y`` (after one untimed run)."""
    _run(y, fs, method)
    runs = [_run(y, fs, method) for _ in range(repeat)]
    med = {k: float(np.median([r[k] for r in runs])) for k in ("cpu_s", "wall_s", "fit_s", "diagram_s")}
    return {"case": name, "samples": int(y.size), "modes": runs[-1]["modes"], "fit_calls": runs[-1]["fit_calls"],
            "diagram_calls": runs[-1]["diagram_calls"], **med, "samples_per_cpu_s": y.size / med["cpu_s"]}


def main(argv=None) -> int:
    p = parser(__file__, __doc__, json="FILE", seed=0)
    p.add_argument("--repeat", type=int, default=3, help="timed runs per case, the median kept (default 3)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--noise", type=float, default=1e-3, help="simulated noise, of the peak (default 1e-3)")
    p.add_argument("--hits", type=int, default=1, help="pyFRF hits timed, from the first (default 1)")
    p.add_argument("--no-ambient", action="store_true", help="leave out the simulated ambient record (ssi)")
    args = p.parse_args(argv)
    rows = []
    with threadpool_limits(args.threads):
        if PYFRF.is_file():
            with np.load(PYFRF) as d:
                for k in range(min(args.hits, d["response"].shape[0])):
                    rows.append(time_case(f"pyFRF hit {k + 1}", d["response"][k][None].astype(np.float64),
                                          float(d["sampling_frequency_hz"]), args.repeat))
        else:
            print(f"skipped pyFRF hits: {PYFRF} is absent (see experiments/data/real/README.md)", file=sys.stderr)
        rows.append(time_case("simulated", simulated_hit(noise=args.noise, seed=args.seed), 25600.0, args.repeat))
        if not args.no_ambient:
            rows.append(time_case("ambient (ssi)", *ambient_case(args.seed), args.repeat, method="ssi"))
    print(table(["record", "samples", "modes", "CPU s", "wall s", "samples / CPU s", "fit s (calls)",
                 "diagram s (calls)"],
                [[r["case"], r["samples"], r["modes"], f"{r['cpu_s']:.2f}", f"{r['wall_s']:.2f}",
                  f"{r['samples_per_cpu_s']:.0f}", f"{r['fit_s']:.2f} ({r['fit_calls']})",
                  f"{r['diagram_s']:.3f} ({r['diagram_calls']})"] for r in rows],
                ["---", "---:", "---:", "---:", "---:", "---:", "---:", "---:"]))
    emit_json(args, {"args": vars(args), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
