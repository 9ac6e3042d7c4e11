"""Modes found against modes present on wide-band impact tests of cantilevers, per identification method.

Run: ``python -m experiments.benches.bench_wideband [--seeds 5] [--seed 0] [--out out/wideband] [--docs]``

Each file is one impact test of a clamped cantilever simulated by the independent simulator
(:mod:`experiments.second_sim`, which shares no code with ``physics`` or ``datagen``): Euler-Bernoulli FE beam of
112 elements, steel or aluminium, length 0.3-1 m, 20-50 mm wide and 5-12 mm thick, modal damping ratios drawn
per mode log-uniformly in 0.1-2 %. The hammer hits the tip; sensor 1 is at the tip (the driving point), sensors 2
and 3 at nodes in 35-65 % and 70-90 % of the length. FRFs, in the file's kind (accelerance or mobility), on
6400 lines 0.3125-2000 Hz, carry:

* **hammer double hit**: a second hit ``a`` = 0.05-0.3 times the first, ``dt`` = 0.5-3 ms later, outside the force
  window (cut off from the force channel, present in the response): the FRF is the true one times
  ``1 + a exp(-i w dt)``, a ripple of period ``1/dt``;
* **noise**: 1 % of ``|H|`` (complex Gaussian, as an H1 estimate's random error) plus a floor
  ``e (1 + (f_c/f)^2)`` times the FRF's peak, ``e`` 3e-5-3e-4 log-uniform and ``f_c`` 3-15 Hz: it rises as
  ``1/f^2`` below ``f_c``;
* **DC offset**: a real constant 1e-3-5e-3 times the peak added to every line.

Each file is written as UFF 58 (with units and node geometry) and identified by ``beam-damage identify FILE --json``
(the CLI's own entry point, in this process) with ``--method lscf``, ``peak`` and ``circle``, no band (the file's).

A truth mode is **present** when the file shows its peak: the RMS magnitude over the FRFs, at its largest on the
lines within 1 % of the mode, is at least 3 times the median of the lines within +-15 % (a mode of up to ~2.5 %
damping; a noise line exceeds it with probability 2e-3); **5x** counts those at least 5 times, the prominence of
the ``identify`` warning (:data:`physics.identification.lscf.CLEAR_PEAK_PROMINENCE`). A present mode is
**found** when an identified mode lies within 1 % (and 0.1 %) of it, each identified mode matched to one truth mode
at most; a present mode not found is **warned** when a warning names a peak within 2 % of it, else **silent**
(**silent 5x**: a peak the warning should have named). An identified mode within 1 % of no truth mode in the band
is **spurious**. Frequency and damping errors are medians over the modes found within 1 % (damping:
``|zeta_id / zeta - 1|``). A run that raises is counted as a crash (a traceback: a failure); a clean error exits 2.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import sys
import traceback
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from experiments.cli import main as cli
from experiments.second_sim.fem import Beam, assemble, modes
from experiments.second_sim.response import Damping, complex_normal, receptance
from experiments.second_sim.writers import convert_receptance, write_uff
from experiments.benches.harness import parser, publish, table
from physics.io import atomic_write_text

__all__ = ["CASES", "METHODS", "WideBandTest", "main", "markdown", "peak_prominence", "run_identify", "score",
           "simulate_test", "summarise"]

#: (FRF kind, number of sensors) of each case.
CASES = tuple((kind, n) for kind in ("accelerance", "mobility") for n in (1, 2, 3))
#: Identification methods compared.
METHODS = ("lscf", "peak", "circle")
#: Frequency lines (Hz): 6400 lines 0.3125 Hz apart, as a 2000 Hz impact test of 3.2 s blocks.
FREQUENCY_HZ = 0.3125 * np.arange(1, 6401)
#: Young's modulus (Pa) and density (kg/m^3).
MATERIALS = {"steel": (210e9, 7850.0), "aluminium": (70e9, 2700.0)}
#: A truth mode is present when its peak is this many times the median within +-15 % (a noise floor's line exceeds
#: it with probability 2e-3, one of a mode of 2.5 % damping stands out as much).
PRESENT = 3.0
#: The identify warning's prominence: a present mode missed with a peak this prominent and not named is a bug.
LOUD = 5.0


@dataclass(frozen=True)
class WideBandTest:
    """One simulated file and its truth.

    Attributes
    ----------
    path : str
    kind : str
    n_sensors : int
    seed : int
    material : str
    length_m, width_m, thickness_m : float
    sensor_x_m : tuple of float
        Sensor positions from the clamp; the first is the tip (the hammer point).
    truth_hz : tuple of float
        Natural frequencies of the model below 2000 Hz.
    truth_zeta : tuple of float
        Their damping ratios.
    prominence : tuple of float
        How far each truth mode's peak stands out in the file (:func:`peak_prominence`).
    double_hit_ratio : float
        Second hit over first, ``a``.
    double_hit_delay_s : float
        Delay ``dt`` of the second hit.
    """

    path: str
    kind: str
    n_sensors: int
    seed: int
    material: str
    length_m: float
    width_m: float
    thickness_m: float
    sensor_x_m: tuple
    truth_hz: tuple
    truth_zeta: tuple
    prominence: tuple
    double_hit_ratio: float
    double_hit_delay_s: float


def _loguniform(rng, lo, hi, size=None):
    return np.exp(rng.uniform(math.log(lo), math.log(hi), size))


def peak_prominence(frequency_hz, frf, truth_hz) -> np.ndarray:
    """How far each truth mode's peak stands out in ``frf`` (n_resp, n_lines), shape (n_truth,).

    The RMS magnitude over the responses at its largest within 1 % of the mode (at least the nearest line) over its
    median on the lines within +-15 % of the mode (0 with fewer than 5 such lines).
    """
    f = np.asarray(frequency_hz, float)
    mag = np.sqrt(np.mean(np.abs(np.asarray(frf)) ** 2, axis=0))
    out = []
    for fr in np.asarray(truth_hz, float):
        near = np.abs(f / fr - 1) <= 0.01
        near[np.argmin(np.abs(f - fr))] = True
        window = mag[np.abs(f / fr - 1) <= 0.15]
        out.append(mag[near].max() / np.median(window) if window.size >= 5 else 0.0)
    return np.array(out)


def simulate_test(kind: str, n_sensors: int, seed: int, out_dir) -> WideBandTest:
    """Draw one cantilever and write its impact test as ``out_dir/<kind>-<n>s-<seed>.uff`` (module docstring)."""
    rng = np.random.default_rng([seed, CASES.index((kind, n_sensors))])
    material = ("steel", "aluminium")[int(rng.integers(2))]
    E_Pa, rho_kg_m3 = MATERIALS[material]
    L, b, h = rng.uniform(0.3, 1.0), rng.uniform(0.02, 0.05), rng.uniform(0.005, 0.012)
    beam = Beam(L, E_Pa * b * h ** 3 / 12, rho_kg_m3 * b * h)
    asm = assemble(beam)
    md = modes(asm, n_refine=30)
    n_el = beam.n_elements
    nodes = [n_el, int(rng.integers(round(0.35 * n_el), round(0.65 * n_el) + 1)),
             int(rng.integers(round(0.70 * n_el), round(0.90 * n_el) + 1))][:n_sensors]
    x_m = asm.node_x_m[nodes]
    zeta = _loguniform(rng, 0.001, 0.02, md.omega_rad_s.size)
    f = FREQUENCY_HZ
    w = 2 * math.pi * f
    H = receptance(asm, md, Damping("modal", tuple(zeta)), f, asm.translation_dofs(x_m), asm.translation_dofs(L)[0])
    X = convert_receptance(H, f, kind)
    a, dt = rng.uniform(0.05, 0.3), rng.uniform(0.5e-3, 3e-3)
    X = X * (1 + a * np.exp(-1j * w * dt))
    peak = np.abs(X).max()
    floor = _loguniform(rng, 3e-5, 3e-4) * peak * (1 + (rng.uniform(3.0, 15.0) / f) ** 2)
    X = X + 0.01 * np.abs(X) * complex_normal(rng, X.shape) + floor * complex_normal(rng, X.shape) \
        + rng.uniform(1e-3, 5e-3) * peak
    path = Path(out_dir) / f"{kind}-{n_sensors}s-{seed:03d}.uff"
    write_uff(path, f, X / convert_receptance(np.ones(1), f, kind), x_m, list(range(1, n_sensors + 1)), 1, kind,
              description=f"{material} cantilever {L:.3f} m, impact at the tip, seed {seed}")
    in_band = md.frequencies_hz < f[-1]
    truth = md.frequencies_hz[in_band]
    return WideBandTest(str(path), kind, n_sensors, seed, material, float(L), float(b), float(h),
                        tuple(float(x) for x in x_m), tuple(truth.tolist()), tuple(zeta[in_band].tolist()),
                        tuple(peak_prominence(f, X, truth).tolist()), float(a), float(dt))


def run_identify(path: str, method: str) -> dict:
    """``beam-damage identify PATH --method METHOD --json`` in this process: ``{"exit", "result", "stderr",
    "traceback"}`` (``traceback`` set when the command raised instead of exiting)."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli(["identify", path, "--method", method, "--json"])
    except Exception:  # noqa: BLE001 - a traceback is what this records
        return {"exit": None, "result": None, "stderr": err.getvalue(), "traceback": traceback.format_exc()}
    result = json.loads(out.getvalue()) if code == 0 else None
    return {"exit": code, "result": result, "stderr": err.getvalue(), "traceback": None}


def _warned_hz(warnings_text) -> np.ndarray:
    """Frequencies (Hz) the missed-peak warning names."""
    hz = []
    for msg in warnings_text:
        m = re.search(r"show (?:a peak|peaks) at (.*?) Hz", msg)
        if m:
            hz += [float(x) for x in m.group(1).split(",")]
    return np.array(hz)


def score(test: WideBandTest, run: dict) -> dict:
    """Counts of one file's identification (module docstring): present, found within 1 % and 0.1 %, missed and
    warned, missed silently, spurious, and the relative errors of the modes found."""
    truth, zeta = np.array(test.truth_hz), np.array(test.truth_zeta)
    prominence = np.array(test.prominence)
    present, loud = prominence >= PRESENT, prominence >= LOUD
    row = {"present": int(present.sum()), "loud": int(loud.sum()), "crash": run["traceback"] is not None,
           "exit": run["exit"]}
    if run["result"] is None:
        return {**row, "found": 0, "found_01": 0, "warned": 0, "silent": 0, "silent_loud": 0, "spurious": 0,
                "identified": 0, "freq_err": [], "zeta_err": [], "missed_hz": truth[present].tolist()}
    got = np.array([m["frequency_hz"] for m in run["result"]["modes"]])
    got_zeta = np.array([m["damping_ratio"] for m in run["result"]["modes"]])
    rel = np.abs(got[None, :] / truth[:, None] - 1) if got.size else np.zeros((truth.size, 0))
    match = np.full(truth.size, -1)
    used = np.zeros(got.size, bool)
    for t, j in sorted(((t, j) for t in range(truth.size) for j in range(got.size) if rel[t, j] <= 0.01),
                       key=lambda tj: rel[tj]):
        if match[t] < 0 and not used[j]:
            match[t], used[j] = j, True
    found = present & (match >= 0)
    warned_hz = _warned_hz(run["result"]["warnings"])
    missed = present & (match < 0)
    warned = missed & np.array([warned_hz.size > 0 and np.min(np.abs(warned_hz / t - 1)) <= 0.02 for t in truth])
    near_any = rel.min(axis=0) <= 0.01 if truth.size and got.size else np.zeros(got.size, bool)
    jf = match[found]
    return {**row, "found": int(found.sum()), "found_01": int(np.sum(rel[found, jf] <= 0.001)),
            "warned": int(warned.sum()), "silent": int((missed & ~warned).sum()),
            "silent_loud": int((missed & ~warned & loud).sum()),
            "spurious": int(np.sum(~near_any)), "identified": int(got.size),
            "freq_err": rel[found, jf].tolist(), "zeta_err": np.abs(got_zeta[jf] / zeta[found] - 1).tolist(),
            "missed_hz": truth[missed & ~warned].tolist()}


def summarise(rows: list[dict]) -> list[dict]:
    """One line per method x case: sums of the counts and medians of the errors."""
    out = []
    for method in METHODS:
        for kind, n in CASES:
            sel = [r for r in rows if r["method"] == method and r["kind"] == kind and r["n_sensors"] == n]
            fe = [e for r in sel for e in r["freq_err"]]
            ze = [e for r in sel for e in r["zeta_err"]]
            out.append({"method": method, "kind": kind, "n_sensors": n, "files": len(sel),
                        **{k: sum(r[k] for r in sel) for k in ("present", "loud", "found", "found_01", "warned",
                                                               "silent", "silent_loud", "spurious")},
                        "failed": sum(1 for r in sel if r["exit"] != 0),
                        "crashes": sum(1 for r in sel if r["crash"]),
                        "median_freq_err": float(np.median(fe)) if fe else math.nan,
                        "median_zeta_err": float(np.median(ze)) if ze else math.nan})
    return out


def markdown(summary: list[dict], args) -> str:
    """The table of :func:`summarise` and a line on how it was made."""
    def crashed(s):
        return f" ({s['crashes']} crashed)" if s["crashes"] else ""

    def pct(v, digits):
        return "-" if not np.isfinite(v) else f"{100 * v:.{digits}f} %"

    head = ["method", "kind", "sensors", "present (5x)", "found 1 %", "found 0.1 %", "missed, warned",
            "missed, silent (5x)", "spurious", "median freq. error", "median damping error", "exit != 0"]
    return table(head, [[s["method"], s["kind"], s["n_sensors"], f"{s['present']} ({s['loud']})", s["found"],
                         s["found_01"], s["warned"], f"{s['silent']} ({s['silent_loud']})", s["spurious"],
                         pct(s["median_freq_err"], 3), pct(s["median_zeta_err"], 0), f"{s['failed']}{crashed(s)}"]
                        for s in summary], ["---"] * 2 + ["---:"] * 10) + (
        f"\n\n{args.seeds} files per case (seeds {args.seed}-{args.seed + args.seeds - 1}), counts summed over "
        "them; `python -m experiments.benches.bench_wideband` (module docstring: the simulator, the artefacts and the "
        "counting rules).\n")


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md", out="out/wideband", seed=0)
    p.add_argument("--seeds", type=int, default=5, help="files per case (default 5)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for kind, n in CASES:
        for seed in range(args.seed, args.seed + args.seeds):
            test = simulate_test(kind, n, seed, out)
            for method in METHODS:
                run = run_identify(test.path, method)
                r = {**asdict(test), "method": method, **score(test, run), "stderr": run["stderr"],
                     "traceback": run["traceback"]}
                rows.append(r)
                if r["crash"] or r["silent_loud"]:
                    sys.stderr.write(f"{Path(test.path).name} {method}: "
                                     + ("crashed\n" + run["traceback"] if r["crash"] else
                                        f"missed silently {', '.join(f'{x:.4g}' for x in r['missed_hz'])} Hz\n"))
    summary = summarise(rows)
    md = markdown(summary, args)
    sys.stdout.write(md)

    atomic_write_text(out / "wideband.json", json.dumps({"config": vars(args), "summary": summary, "rows": rows},
                                                        indent=1) + "\n")
    publish(args, "wideband", md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
