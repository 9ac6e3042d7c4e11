"""Speed of LSCF + LSFD identification beside sdypy-EMA, on the same UFF file in one run.

The test file (:func:`write_test_file`): receptances of the beam-5 preset cantilever
(8-element FE model, EI scaled by ``EI_SCALE`` so that the first mode sits near 21 Hz,
Rayleigh damping, ratios 0.2-0.8 %) at the four quarter-point translations to a tip
force, 0.5 Hz lines 2-800 Hz (1597 lines, four modes in the band), complex Gaussian
noise of standard deviation ``noise |H|`` with a seed, written as UFF 58 (binary).

Timed, each the median of ``--repeat`` runs on the FRFs read once from that file:

* ``identify_frf(frf, method="lscf", n_modes=4)`` (this package, fully automatic);
* ``identify_frfs`` on ``--batch`` copies of the file (the batched entry point, per file);
* sdypy-EMA (optional extra ``compare``): ``Model(..., pol_order_high=60)``, ``get_poles("lscf")``,
  ``select_closest_poles`` at the peaks of the sum of ``|H|^2`` (no user picking) and
  ``get_constants("lsfd")``, timed with the default BLAS threads and with one thread (this
  package runs LSCF/LSFD under one BLAS thread), the faster compared; skipped with a message
  when not installed.

Run ``python -m experiments.benches.bench_identify_speed [--repeat N] [--noise X] [--seed S] [--json F] [--csv F]``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from experiments.benches.bench_identification import sdypy_lscf
from experiments.benches.harness import emit_json, parser
from physics.beam import preset_beam
from physics.frf import receptance
from physics.identification import find_peaks_indicator, identify_frf, identify_frfs
from physics.io import MeasuredFRF, atomic_write_text, read_frf, write_uff58
from physics.noise import complex_normal

__all__ = ["EI_SCALE", "RAYLEIGH", "main", "write_test_file"]


#: Multiplier of the beam-5 preset's EI (first mode near 21 Hz).
EI_SCALE = 1.11
#: Rayleigh damping ``C = a M + b K`` (1/s, s): ratios 0.78, 0.22, 0.34, 0.59 % for modes 1-4.
RAYLEIGH = (2.0, 2.5e-6)


def simulate_file_frf(noise=0.015, seed=0, df_hz=0.5, band_hz=(2.0, 800.0)) -> MeasuredFRF:
    """Noisy receptances (m/N) of the scaled beam-5 cantilever, shape (4, 1, n_lines).

    Responses at the quarter-point translations ``2:y .. 5:y`` (labels ``2:+Y`` ..),
    reference DOF the tip ``5:y``; noise of standard deviation ``noise |H|`` on each
    line, split evenly over real and imaginary parts.
    """
    beam = preset_beam("beam5")
    fe = beam.fe_model(8, EI_scale=EI_SCALE)
    a, b = RAYLEIGH
    idx = fe.index(beam.masters)
    f = np.arange(band_hz[0], band_hz[1] + df_hz / 2, df_hz)
    H = receptance(fe.M, a * fe.M + b * fe.K, fe.K, 2 * np.pi * f, response=idx, reference=idx[-1:])
    rng = np.random.default_rng(seed)
    H = H + complex_normal(rng, H.shape, noise * np.abs(H))
    dofs = tuple(d.replace(":y", ":+Y") for d in beam.masters)
    return MeasuredFRF(f, H, dofs, (dofs[-1],), metadata={"source": f"beam5-like cantilever, seed {seed}"})


def write_test_file(path, noise=0.015, seed=0) -> Path:
    """Write :func:`simulate_file_frf` as a binary UFF 58 file; returns the path."""
    write_uff58(path, simulate_file_frf(noise, seed), binary=True)
    return Path(path)


def _median_time(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def run_sdypy(frf: MeasuredFRF, n_modes=4):
    """sdypy-EMA LSCF, automatic pole choice and LSFD; ``(frequency_hz, damping)`` or None if not installed.

    The poles are those nearest the ``n_modes`` highest peaks of the sum of ``|H|^2``
    (:func:`physics.identification.find_peaks_indicator`), which sdypy-EMA's
    ``select_closest_poles`` takes without user interaction.
    """
    f = frf.frequency_hz
    fit = sdypy_lscf(frf, f[find_peaks_indicator(f, frf.frf, n_modes)],
                     list(frf.response_dofs).index(frf.reference_dofs[0]))
    return None if fit is None else (np.asarray(fit[0].nat_freq, float), np.asarray(fit[0].nat_xi, float))


def bench(repeat=5, noise=0.015, seed=0, batch=8):
    """Timings (s) and frequencies of both packages on one written-and-read test file."""
    with tempfile.TemporaryDirectory() as tmp:
        path = write_test_file(Path(tmp) / "beam5_like.uff", noise, seed)
        frf = read_frf(path)
    out = {"file": f"{frf.frequency_hz.size} lines {frf.frequency_hz[0]:g}-{frf.frequency_hz[-1]:g} Hz, "
                   f"{len(frf.response_dofs)} responses, receptance, noise {100 * noise:g} %, seed {seed}",
           "repeat": repeat}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        identify_frf(frf, method="lscf", n_modes=4)  # warm-up (imports, caches)
        t_ours, ident = _median_time(lambda: identify_frf(frf, method="lscf", n_modes=4), repeat)
        t_batch, _ = _median_time(lambda: identify_frfs([frf] * batch, method="lscf", n_modes=4),
                                  max(1, repeat // 2))
    est = ident.estimate
    out["ours"] = {"seconds": t_ours, "frequency_hz": est.natural_frequencies_hz.tolist(),
                   "damping_ratio": est.damping_ratios.tolist()}
    out["ours_batched"] = {"files": batch, "seconds_per_file": t_batch / batch}
    try:
        import sdypy.EMA  # noqa: F401
        have = True
    except ImportError:
        have = False
    if not have:
        out["sdypy"] = None
        out["note"] = "sdypy-EMA not installed (pip install 'beam-damage[compare]'): comparison skipped"
        return out

    run_sdypy(frf)  # warm-up
    t_default, (fs, zs) = _median_time(lambda: run_sdypy(frf), repeat)
    with threadpool_limits(1):
        t_one, _ = _median_time(lambda: run_sdypy(frf), repeat)
    t_sd = min(t_default, t_one)  # the faster BLAS setting: the ratio does not flatter this package
    out["sdypy"] = {"seconds": t_sd, "seconds_default_threads": t_default, "seconds_one_blas_thread": t_one,
                    "frequency_hz": fs.tolist(), "damping_ratio": zs.tolist()}
    out["ratio_ours_over_sdypy"] = t_ours / t_sd
    out["ratio_batched_over_sdypy"] = t_batch / batch / t_sd
    if fs.size == est.natural_frequencies_hz.size:
        out["frequency_difference_hz"] = (est.natural_frequencies_hz - np.sort(fs)).tolist()
    return out


def format_bench(out) -> str:
    fmt = lambda xs: "  ".join(f"{x:9.3f}" for x in xs)  # noqa: E731
    lines = [out["file"], f"median of {out['repeat']} runs",
             f"beam-damage identify_frf lscf   {out['ours']['seconds']:8.3f} s   "
             f"f (Hz) {fmt(out['ours']['frequency_hz'])}",
             f"beam-damage identify_frfs       {out['ours_batched']['seconds_per_file']:8.3f} s per file "
             f"({out['ours_batched']['files']} files)"]
    if out.get("sdypy") is None:
        lines.append(out["note"])
        return "\n".join(lines)
    sd = out["sdypy"]
    lines += [f"sdypy-EMA lscf+lsfd             {sd['seconds']:8.3f} s   f (Hz) {fmt(sd['frequency_hz'])}",
              f"  (default BLAS threads {sd['seconds_default_threads']:.3f} s, one thread "
              f"{sd['seconds_one_blas_thread']:.3f} s: the faster is compared)",
              f"ratio ours / sdypy-EMA          {out['ratio_ours_over_sdypy']:8.2f}   "
              f"(batched {out['ratio_batched_over_sdypy']:.2f})"]
    if "frequency_difference_hz" in out:
        lines.append(f"frequency difference (Hz)                  {fmt(out['frequency_difference_hz'])}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, json="FILE", seed=0)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--noise", type=float, default=0.015)
    p.add_argument("--batch", type=int, default=8, help="files in the identify_frfs timing")
    p.add_argument("--csv")
    a = p.parse_args(argv)
    out = bench(a.repeat, a.noise, a.seed, a.batch)
    print(format_bench(out))
    emit_json(a, out)
    if a.csv:
        rows = ["package,seconds,mode,frequency_hz,damping_ratio"]
        for name in ("ours", "sdypy"):
            r = out.get(name)
            if r:
                for j, (fj, zj) in enumerate(zip(r["frequency_hz"], r["damping_ratio"])):
                    rows.append(f"{name},{r['seconds']:.6g},{j + 1},{fj:.6f},{zj:.6g}")
        atomic_write_text(a.csv, "\n".join(rows) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
