"""Free-decay identification (``era``) against the Cramer-Rao bound, a zero-padded FFT peak and SSI-cov.

Run: ``python -m experiments.benches.bench_free_decay [--draws 50] [--seeds 20]
[--cases decay,scope,rates,detune,frame]``

Five simulated cases, each a sum of closed-form damped sinusoids after hits plus white noise (seeded):

* **decay**: one channel, 2 s at 1 kHz, one hit at 0.1 s, modes 23/61/97 Hz (damping 1/2/1.5 %), noise 5 % of the
  record's standard deviation; ``--draws`` noise draws. Per mode: the standard deviation of the natural frequency
  over the draws for ``era`` (through :func:`identify_era`), a zero-padded (16x) FFT peak with parabolic
  interpolation of the log magnitude, and SSI-cov, against the Cramer-Rao bound (the Fisher information of the
  damped-sinusoid model, one sigma of the natural frequency) and the mean one sigma ``era`` reports.
* **scope**: one channel, a 2500-point capture of 4 s (625 Hz, 10 % pre-trigger), a tap's 12 Hz mode (damping
  0.1 %) and a 71 Hz mode, quantised to integer levels with the peak at 60 levels and 0.4 level of noise (an 8-bit
  scope not using its full range); ``--seeds`` captures. The first frequency's scatter over the captures by the
  automatic choice, SSI-cov and the FFT peak; how many captures the former count rule (more than 0.1 % of the
  samples plus 2 at the extreme values) and the run rule of ``check_records`` call clipped.
* **rates**: the scope capture taken at 625 Hz and oversampled at 2.5, 5 and 10 kHz (4 s: 2500 to 40 000 points, the
  tap, the levels and the noise per sample unchanged); ``--seeds`` captures each. Per rate, the method the automatic
  choice picks and, per mode, the bias and scatter over the captures of its frequency and of the zero-padded FFT
  peak of :func:`~physics.identification.fft_peak.fft_peaks` (no window, as for a free response), against the
  Cramer-Rao bound (white noise: the 0.4 level drawn and the rounding's 1/12 level^2).
* **detune**: the scope capture at 625 Hz with its second mode moved over 70.9-71.1 Hz in steps of 0.025 Hz;
  ``--seeds`` captures each. Per frequency, the bias, scatter and rms error of ``era`` (:func:`identify_era`) and of
  the zero-padded FFT peak, and both rms errors over every frequency: the 12 Hz mode, still ringing when the capture
  ends, puts a comb of side lobes 1/3.6 s apart under the 71 Hz peak, whose FFT peak sits on a tooth of it.
* **frame**: four channels, 4096 samples at 500 Hz (8 s), three hits at random times and gains, modes at a random
  first frequency in 3.5-6 Hz and 3.1, 7.1 and 10.7 times it (damping 1.5-2 %); ``--seeds`` records. Records
  identified with every mode within 1 % by the automatic choice and by SSI-cov.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser, table
from physics.errors import BeamDamageError
from physics.identification.fft_peak import fft_peaks
from physics.identification.free_decay import identify_era
from physics.identification.output_only import identify_records
from physics.identification.record_checks import check_records
from physics.identification.ssi import identify_ssi
from physics.io.timedata import TimeRecords

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from impact_records import crb_frequency_std_hz, fft_peak_hz, impact_record, poles  # noqa: E402

__all__ = ["decay_case", "detune_case", "frame_case", "main", "rates_case", "scope_case"]

#: The scope capture's modes (Hz), damping ratios and shape, its tap (s), peak and noise (levels), and its rates (Hz).
SCOPE_FN, SCOPE_ZETA, SCOPE_SHAPE = np.array([12.0, 71.0]), np.array([0.001, 0.005]), [[1.0, 0.3]]
SCOPE_TAP_S, SCOPE_PEAK, SCOPE_NOISE = 0.4, 60.0, 0.4
SCOPE_RATES_HZ = (625.0, 2500.0, 5000.0, 10000.0)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def _nearest(found, truth):
    found = np.asarray(found, float)
    if found.size == 0:
        return np.full(len(truth), np.nan)
    return found[np.argmin(np.abs(found[:, None] - np.asarray(truth)[None, :]), axis=0)]


def decay_case(draws):
    fs, n, t0 = 1000.0, 2000, 0.1
    fn, zeta = np.array([23.0, 61.0, 97.0]), np.array([0.01, 0.02, 0.015])
    shape = np.array([[1.0, -0.6, 0.4]])
    era, era_std, fft, ssi = [], [], [], []
    for seed in range(draws):
        y, _, sd = impact_record(fs, n, fn, zeta, shape, [t0], 0.05, seed)
        e = _quiet(identify_era, y, fs).estimate
        nearest = np.argmin(np.abs(e.natural_frequencies_hz[:, None] - fn[None, :]), axis=0)
        era.append(e.natural_frequencies_hz[nearest])
        era_std.append(e.frequency_std_hz[nearest])
        fft.append(fft_peak_hz(y[0], fs, fn))
        try:
            ssi.append(_nearest(_quiet(identify_ssi, y, fs).estimate.natural_frequencies_hz, fn))
        except BeamDamageError:
            ssi.append(np.full(3, np.nan))
    lam = poles(fn, zeta)
    k0 = int(np.ceil(t0 * fs))
    crb = crb_frequency_std_hz(fs, n - k0, fn, zeta, shape[0] / (1j * lam.imag) * np.exp(lam * (k0 / fs - t0)), sd)
    era, fft, ssi, s = np.array(era), np.array(fft), np.array(ssi), np.nanstd(era, axis=0, ddof=1)
    reported, fft_std, ssi_std = np.mean(era_std, axis=0), np.std(fft, axis=0, ddof=1), np.nanstd(ssi, axis=0, ddof=1)
    return table(["mode (Hz)", "CRB (Hz)", "era std (Hz)", "era / CRB", "era reported 1-sigma (Hz)",
                  "FFT peak std (Hz)", "SSI-cov std (Hz)"],
                 [[f"{f:g}", f"{crb[j]:.2g}", f"{s[j]:.2g}", f"{s[j] / crb[j]:.2f}", f"{reported[j]:.2g}",
                   f"{fft_std[j]:.2g}", f"{ssi_std[j]:.2g}"] for j, f in enumerate(fn)], ["---:"] * 7)


def _scope(seed, fs=625.0, fn_hz=SCOPE_FN):
    n = int(4 * fs)
    y = impact_record(fs, n, fn_hz, SCOPE_ZETA, SCOPE_SHAPE, [SCOPE_TAP_S], 0.0, seed)[0][0]
    return np.round(SCOPE_PEAK * y / np.abs(y).max() + SCOPE_NOISE * np.random.default_rng(seed).standard_normal(n)), fs


def _scope_crb(fs):
    n, k0 = int(4 * fs), int(np.ceil(SCOPE_TAP_S * fs))
    clean = impact_record(fs, n, SCOPE_FN, SCOPE_ZETA, SCOPE_SHAPE, [SCOPE_TAP_S], 0.0, 0)[1][0]
    lam = poles(SCOPE_FN, SCOPE_ZETA)
    amp = SCOPE_PEAK / np.abs(clean).max() * np.array(SCOPE_SHAPE[0]) / (1j * lam.imag) \
        * np.exp(lam * (k0 / fs - SCOPE_TAP_S))
    return crb_frequency_std_hz(fs, n - k0, SCOPE_FN, SCOPE_ZETA, amp, np.sqrt(SCOPE_NOISE ** 2 + 1 / 12))


def rates_case(seeds, rates=SCOPE_RATES_HZ):
    rows = []
    for fs in rates:
        auto, fft, picked = [], [], {}
        for seed in range(seeds):
            y, _ = _scope(seed, fs)
            res = _quiet(identify_records, TimeRecords(1 / fs, y[None], ("1:+Z",), ("acceleration",), {}))
            picked[res.estimate.method] = picked.get(res.estimate.method, 0) + 1
            auto.append(_nearest(res.estimate.natural_frequencies_hz, SCOPE_FN))
            fft.append(fft_peaks(y[None], fs, SCOPE_FN, 0.03 * SCOPE_FN, window="none").natural_frequencies_hz)
        auto, fft, crb = np.array(auto) - SCOPE_FN, np.array(fft) - SCOPE_FN, _scope_crb(fs)
        for j, f in enumerate(SCOPE_FN):
            a, b = auto[:, j], fft[:, j]
            rows.append([f"{fs:g}", f"{f:g}", ", ".join(f"{k} {v}" for k, v in sorted(picked.items())),
                         f"{np.nanmean(a):+.2g}", f"{np.nanstd(a, ddof=1):.2g}", f"{np.nanmean(b):+.2g}",
                         f"{np.std(b, ddof=1):.2g}", f"{crb[j]:.2g}", f"{np.sqrt(np.nanmean(a ** 2)):.2g}",
                         f"{np.sqrt(np.mean(b ** 2)):.2g}"])
    return table(["rate (Hz)", "mode (Hz)", "picked", "bias (Hz)", "std (Hz)", "FFT peak bias (Hz)",
                  "FFT peak std (Hz)", "CRB (Hz)", "rms error (Hz)", "FFT peak rms error (Hz)"],
                 rows, ["---:", "---:", "---"] + ["---:"] * 7)


def detune_case(seeds, fs=625.0):
    rows, era_all, fft_all = [], [], []
    for f2 in np.round(np.arange(70.9, 71.1001, 0.025), 3):
        fn = np.array([SCOPE_FN[0], f2])
        e, p = [], []
        for seed in range(seeds):
            y, _ = _scope(seed, fs, fn)
            e.append(_nearest(_quiet(identify_era, y[None], fs).estimate.natural_frequencies_hz, [f2])[0] - f2)
            p.append(fft_peaks(y[None], fs, fn, 0.03 * fn, window="none").natural_frequencies_hz[1] - f2)
        e, p = np.array(e), np.array(p)
        era_all.append(e)
        fft_all.append(p)
        rows.append([f"{f2:g}", f"{e.mean():+.2g}", f"{e.std(ddof=1):.2g}", f"{np.sqrt(np.mean(e ** 2)):.2g}",
                     f"{p.mean():+.2g}", f"{p.std(ddof=1):.2g}", f"{np.sqrt(np.mean(p ** 2)):.2g}"])
    e, p = np.concatenate(era_all), np.concatenate(fft_all)
    rows.append(["all", f"{e.mean():+.2g}", f"{e.std(ddof=1):.2g}", f"{np.sqrt(np.mean(e ** 2)):.2g}",
                 f"{p.mean():+.2g}", f"{p.std(ddof=1):.2g}", f"{np.sqrt(np.mean(p ** 2)):.2g}"])
    return table(["second mode (Hz)", "era bias (Hz)", "era std (Hz)", "era rms error (Hz)", "FFT peak bias (Hz)",
                  "FFT peak std (Hz)", "FFT peak rms error (Hz)"], rows, ["---:"] * 7)


def scope_case(seeds):
    auto, ssi, fft, old_clipped, new_clipped, methods = [], [], [], 0, 0, set()
    for seed in range(seeds):
        y, fs = _scope(seed)
        old_clipped += int(np.sum((y == y.max()) | (y == y.min())) > 1e-3 * y.size + 2)
        try:
            if check_records(y[None], fs).crop is not None:
                new_clipped += 1                        # identified after its clipping
        except BeamDamageError:
            new_clipped += 1
            continue
        rec = TimeRecords(1 / fs, y[None], ("1:+Z",), ("strain",), {})
        res = _quiet(identify_records, rec)
        methods.add(res.estimate.method)
        auto.append(_nearest(res.estimate.natural_frequencies_hz, [12.0])[0])
        try:
            ssi.append(_nearest(_quiet(identify_ssi, y[None], fs).estimate.natural_frequencies_hz, [12.0])[0])
        except BeamDamageError:
            ssi.append(np.nan)
        fft.append(fft_peak_hz(y, fs, [12.0])[0])
    return table(["captures", "called clipped (former count rule)", "called clipped (run rule)", "automatic choice",
                  "12 Hz scatter: automatic (Hz)", "SSI-cov (Hz)", "FFT peak (Hz)"],
                 [[seeds, old_clipped, new_clipped, ", ".join(sorted(methods)), f"{np.nanstd(auto, ddof=1):.2g}",
                   f"{np.nanstd(ssi, ddof=1):.2g}", f"{np.std(fft, ddof=1):.2g}"]],
                 ["---:"] * 3 + ["---"] + ["---:"] * 3)


def frame_case(seeds):
    fs, n = 500.0, 4096
    ok_auto = ok_ssi = 0
    picked = {}
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        f1 = rng.uniform(3.5, 6.0)
        fn = f1 * np.array([1.0, 3.1, 7.1, 10.7])
        zeta = rng.uniform(0.015, 0.02, 4)
        phi = rng.standard_normal((4, 4))
        hits = np.sort(rng.uniform(0.2, 6.5, 3))
        hits = hits if np.all(np.diff(hits) > 1.0) else np.array([0.3, 2.9, 5.6])
        y = impact_record(fs, n, fn, zeta, phi, hits, 0.02, seed, hit_gains=rng.uniform(0.5, 1.5, 3))[0]
        rec = TimeRecords(1 / fs, y, ("1:+X", "2:+X", "3:+X", "4:+X"), ("acceleration",) * 4, {})
        try:
            res = _quiet(identify_records, rec)
            picked[res.estimate.method] = picked.get(res.estimate.method, 0) + 1
            ok_auto += int(np.all(np.abs(_nearest(res.estimate.natural_frequencies_hz, fn) / fn - 1) < 0.01))
        except BeamDamageError:
            pass
        try:
            f = _quiet(identify_ssi, y, fs).estimate.natural_frequencies_hz
            ok_ssi += int(np.all(np.abs(_nearest(f, fn) / fn - 1) < 0.01))
        except BeamDamageError:
            pass
    return table(["records", "every mode within 1 %: automatic choice", "SSI-cov", "picked"],
                 [[seeds, ok_auto, ok_ssi, ", ".join(f"{k} {v}" for k, v in sorted(picked.items()))]],
                 ["---:"] * 3 + ["---"])


def main(argv=None):
    p = parser(__file__, __doc__)
    p.add_argument("--draws", type=int, default=50, help="noise draws of the decay case (default 50)")
    p.add_argument("--seeds", type=int, default=20, help="captures of the scope case, records of the frame case "
                                                           "(default 20)")
    p.add_argument("--cases", default="decay,scope,rates,detune,frame", help="the cases to run, comma-separated")
    args = p.parse_args(argv)
    runs = {"decay": lambda: decay_case(args.draws), "scope": lambda: scope_case(args.seeds),
            "rates": lambda: rates_case(args.seeds), "detune": lambda: detune_case(args.seeds),
            "frame": lambda: frame_case(args.seeds)}
    for name in args.cases.split(","):
        print(f"{name}\n{runs[name]()}\n")


if __name__ == "__main__":
    main()
