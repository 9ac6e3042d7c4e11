"""What the exponential window of an impact estimate costs: pyFRF's five hammer hits identified as ``identify`` reads
them, per hit and mode, beside the FFT peak of the same responses.

Run: ``python -m experiments.benches.pyfrf_window [--data experiments/data/real] [--decay E]``

Each hit is estimated as ``beam-damage estimate HIT --excitation impact --averages 1`` does
(:func:`~physics.time_records.estimate_from_records`; ``--decay E``: an exponential window to ``E`` at the block end,
default the estimate's own choice, :func:`~physics.time_records.window_end_value`) and identified as ``identify
FRF.npz --band 500 5000`` does (:func:`~physics.identification.lscf.identify_lscf`, accelerance, the window's decay
rate then removed from the poles). Per mode of :data:`MODES_HZ` and hit: the LSCF pole before the band refinement,
the pole reported (refined where the LSCF pole lies outside the band fit's three-sigma region: ``M``; refined and
kept: ``c``; not refined: ``-``) with the band fit's one sigma (Hz), and the FFT peak of the hit's response
(``fftpeak``, as ``bench_precision`` reads it). Then each column's mean and standard deviation over the hits and the
correlation of the reported frequencies with the FFT peak's.
"""

from __future__ import annotations

import importlib
import warnings
from pathlib import Path

import numpy as np

from experiments.benches.bench_precision import identify_modes
from experiments.benches.harness import parser, table
from physics.io.timedata import TimeRecords
from physics.time_records import estimate_from_records

__all__ = ["MODES_HZ", "hit_modes", "main"]

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "pyfrf_hits.npz"
#: The modes read (Hz): the FFT peaks of 500-5000 Hz that every hit's model holds.
MODES_HZ = np.array([810.3, 851.4, 899.9, 2640.2, 3007.5, 3669.0, 4127.8, 4163.6, 4391.9, 4470.0])
#: A mode of the model farther than this (Hz) from a mode of :data:`MODES_HZ` is not it.
MATCH_HZ = 2.0


def hit_modes(force, response, fs, decay=None) -> dict:
    """One hit's rows (module docstring): ``{"lscf", "reported", "sigma", "state", "fftpeak"}``, each shape
    (n_modes,) over :data:`MODES_HZ` (NaN, ``" "``: not in the model), and ``"others"``: the model's other modes
    (Hz)."""
    lscf_module = importlib.import_module("physics.identification.lscf")
    hit = TimeRecords(1.0 / fs, np.stack([force, response]), ("1:+Z", "2:+Z"), ("force", "acceleration"))
    est = estimate_from_records(hit, excitation="impact", averages=1, decay=decay)
    frf, added = est.frf, est.added_decay_rate_1_s
    band = (frf.frequency_hz >= 500) & (frf.frequency_hz <= 5000)
    seen = {}
    refine = lscf_module.refine_frf_poles

    def keep(*args, **kwargs):
        seen["start"], seen["fit"] = np.asarray(args[2]), refine(*args, **kwargs)
        return seen["fit"]

    lscf_module.refine_frf_poles = keep
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            n_in = lscf_module.identify_lscf(frf.frequency_hz[band], frf.frf[..., band],
                                             kind="accelerance").estimate.natural_frequencies_hz.size
    finally:
        lscf_module.refine_frf_poles = refine
    fit = seen["fit"]
    start = np.abs(seen["start"][:n_in] + added) / (2 * np.pi)
    final = np.abs(fit.eigenvalues[:n_in] + added) / (2 * np.pi)
    j = np.argmin(np.abs(final[None, :] - MODES_HZ[:, None]), axis=1)
    ok = np.abs(final[j] - MODES_HZ) < MATCH_HZ
    state = np.where(fit.moved[j], "M", np.where(fit.converged[j], "c", "-"))
    return {"lscf": np.where(ok, start[j], np.nan), "reported": np.where(ok, final[j], np.nan),
            "sigma": np.where(ok, fit.frequency_std_hz[j], np.nan), "state": np.where(ok, state, " "),
            "fftpeak": identify_modes("fftpeak", response[None], fs, MODES_HZ),
            "others": np.delete(final, j[ok]), "end_value": est.window_end_value}


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--data", default=str(DATA), help="pyfrf_hits.npz")
    p.add_argument("--decay", type=float, default=None,
                   help="exponential window value at the block end (default: the estimate's choice)")
    args = p.parse_args(argv)
    d = np.load(args.data)
    fs = float(d["sampling_frequency_hz"])
    hits = [hit_modes(fo, r, fs, args.decay) for fo, r in zip(d["force"], d["response"])]
    print(table(["mode (Hz)", *(f"hit {i + 1}: lscf, reported +- sigma, fftpeak" for i in range(len(hits)))],
                [[f"{m:.0f}", *(f"{h['lscf'][k]:.3f}, {h['reported'][k]:.3f} +- {h['sigma'][k]:.3f} {h['state'][k]}, "
                                f"{h['fftpeak'][k]:.3f}" for h in hits)] for k, m in enumerate(MODES_HZ)]))
    for i, h in enumerate(hits):
        print(f"hit {i + 1}: window end value {h['end_value']:.3g}; other modes (Hz) "
              + (", ".join(f"{x:.2f}" for x in h["others"]) or "none"))
    cols = {c: np.array([h[c] for h in hits]) for c in ("lscf", "reported", "fftpeak")}
    rows = []
    for k, m in enumerate(MODES_HZ):
        r, f = cols["reported"][:, k], cols["fftpeak"][:, k]
        both = np.isfinite(r) & np.isfinite(f)
        corr = np.corrcoef(r[both], f[both])[0, 1] if both.sum() > 2 else np.nan
        rows.append([f"{m:.0f}", *(f"{np.nanmean(v[:, k]):.2f} +- {np.nanstd(v[:, k], ddof=1):.3f}"
                                   for v in cols.values()), f"{corr:.2f}"])
    print(table(["mode (Hz)", "LSCF (Hz)", "reported (Hz)", "FFT peak (Hz)", "correlation reported/FFT peak"], rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
