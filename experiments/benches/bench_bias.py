"""Bias and scatter of ``era``, the zero-padded FFT peak and LSCF on the H1 FRF against closed-form hammer hits
with known modes: which frequency each method returns and how far from it.

Run: ``python -m experiments.benches.bench_bias [--seeds N] [--docs]`` (about 1-2 min).

The records are :mod:`experiments.benches.impact_records`'s: the acceleration of a few modes under one half-sine
force pulse in closed form, pyFRF's sampling (25.6 kHz, 1 s, the pulse 20 samples after the record's start), white
noise of 0.25 (the pyFRF response's floor at 11-12.5 kHz; its modes ring at 40-100 after the hit), ``--seeds``
records per case (default 4, seeds 0, 1, ...). Every method reads the same records:

* ``era``: :func:`~physics.identification.free_decay.identify_era` on the response, the band 0.9-1.1 times the case's
  modes (the same poles as without a band on these records; faster); its natural frequency ``|lambda| / 2 pi``.
* ``fftpeak``: :func:`~physics.identification.fft_peak.fft_peaks` at the true modes (tolerance 3 Hz, the highest
  local maximum there), the records given as accelerations: its ``frequency_hz`` (the peak of the record's spectrum)
  and ``natural_frequencies_hz`` (that peak times ``sqrt(1 - 2 zeta^2)``, the half-power damping).
* ``lscf H1``: :func:`~physics.identification.lscf.identify_lscf` on H1 of the hit's force and response (one average,
  no window: :func:`~physics.estimation.estimate_frf`), the case's modes +- 90 Hz, accelerance; ``lscf
  H1 exp``: the same with both records multiplied by ``exp(-t / tau)`` falling to 0.01 at the record's end, the
  window's decay removed from the poles (:func:`~physics.identification.exponential_window.remove_window_decay`).

Every bias is the mean of ``estimate - f_n`` (Hz) over the records, beside it the standard deviation; NaN where a
method missed the mode in a record (counted). The truth columns: ``f_d - f_n``; the peak of that mode's own
accelerance ``f_n / sqrt(1 - 2 zeta^2) - f_n``; and the peak of ``|A(f) P(f)|`` (the whole structure's accelerance
times the pulse's transform: the spectrum of a noise-free record that lasted for ever) less ``f_n``: what a peak of
the record's spectrum reads before truncation, leakage and noise. ``--docs`` writes the table into
``docs/identification.md``, block ``bias``.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from experiments.benches.bench_precision import REAL_DIR
from experiments.benches.harness import parser, publish, table
from experiments.benches.impact_records import ImpactCase, accelerance, frf_peak_hz, impact_records, pulse_spectrum
from physics.errors import BeamDamageError
from physics.estimation import estimate_frf
from physics.identification.exponential_window import remove_window_decay, tau_from_end_value
from physics.identification.fft_peak import fft_peaks
from physics.identification.free_decay import identify_era
from physics.identification.lscf import identify_lscf

__all__ = ["BiasCase", "CASES", "METHOD_COLUMNS", "REAL_FITS", "band_poles", "estimates", "main", "real_rows",
           "record_peak_hz", "run_case"]

#: The methods' columns, in the table's order, and what each returns.
METHOD_COLUMNS = {
    "era": "natural frequency |lambda| / 2 pi of the decay's pole",
    "fftpeak peak": "peak of the record's |FFT| (FFTPeaks.frequency_hz)",
    "fftpeak natural": "that peak times sqrt(1 - 2 zeta^2), the half-power zeta (FFTPeaks.natural_frequencies_hz "
                       "of an acceleration record)",
    "lscf H1": "natural frequency |lambda| / 2 pi of the FRF's pole",
    "lscf H1 exp": "the same, exponential window, its decay removed from the pole",
}
#: Half-width (Hz) around each true mode in which the FFT peak is sought; an estimate farther is a miss.
TOLERANCE_HZ = 3.0
#: LSCF's band: the case's modes +- this (Hz; 180 lines of 1 Hz at least, for its model order 40).
LSCF_MARGIN_HZ = 90.0
#: The exponential window's value at the record's end (``lscf H1 exp``).
WINDOW_END = 0.01


@dataclass(frozen=True)
class BiasCase:
    """A named :class:`ImpactCase`."""

    name: str
    case: ImpactCase


def _case(name, fn, zeta, amp, **kw):
    return BiasCase(name, ImpactCase(tuple(fn), tuple(zeta), tuple(amp), noise_std=0.25, **kw))


#: The cases: pyFRF-like modes (the triplet's 5969.5 and 5983.5 Hz: the two-pole band fit of the hits, real_rows;
#: the opposite signs: their phases 2.4-2.8 rad apart there; 1518 Hz: its one-pole fit, 13 dB above the floor as on
#: the hits), the pulse 0.15 ms unless named.
CASES = (
    _case("900 Hz alone, 0.145 %", [899.94], [0.00145], [80.0], pulse_s=1.5e-4),
    _case("900 Hz alone, 2 %", [899.94], [0.02], [80.0], pulse_s=1.5e-4),
    _case("pyFRF 5969 Hz triplet", [5969.5, 5983.5, 6077.45], [0.00099, 0.0004, 0.0005], [96.0, -10.5, 37.0],
          pulse_s=1.5e-4),
    _case("the triplet, pulse 0.25 ms (zero at 6 kHz)", [5969.5, 5983.5, 6077.45], [0.00099, 0.0004, 0.0005],
          [96.0, -10.5, 37.0], pulse_s=2.5e-4),
    _case("weak 1518 Hz, 0.019 %, ringing past the record", [1518.08, 2640.27], [0.00019, 0.0001], [0.2, 40.0],
          pulse_s=1.5e-4),
)


def record_peak_hz(case: ImpactCase) -> np.ndarray:
    """Each mode's peak of ``|A(f) P(f)|`` (Hz): the local maximum nearest ``f_n`` (golden-section search within
    +- one half-power half-width, at least 0.05 Hz)."""
    out = []
    for fn, z in zip(case.natural_frequencies_hz, case.damping_ratios):
        b = max(z * fn, 0.05)
        r = minimize_scalar(lambda f: -np.abs(accelerance(case, f) * pulse_spectrum(case, f)),
                            bounds=(fn - b, fn + b), method="bounded", options={"xatol": 1e-7})
        out.append(r.x)
    return np.array(out)


def _nearest(got, truth):
    """Each truth mode's nearest estimate within :data:`TOLERANCE_HZ` (NaN: none)."""
    got = np.asarray(got, float)
    if got.size == 0:
        return np.full(truth.size, np.nan)
    d = np.abs(got[None, :] - truth[:, None])
    j = np.argmin(d, axis=1)
    return np.where(d[np.arange(truth.size), j] <= TOLERANCE_HZ, got[j], np.nan)


def _lscf(force, response, fs, truth, window):
    """LSCF natural frequencies on H1 (module docstring), matched to ``truth``."""
    n = force.size
    tau = tau_from_end_value(n / fs, WINDOW_END)
    w = np.exp(-np.arange(n) / fs / tau) if window else np.ones(n)
    est = estimate_frf((force * w)[None], (response * w)[None], fs, nperseg=n, window="boxcar")
    f = est.frequency_hz
    band = (f > truth.min() - LSCF_MARGIN_HZ) & (f < truth.max() + LSCF_MARGIN_HZ)
    try:
        e = identify_lscf(f[band], est.h1[..., band], kind="accelerance").estimate
    except BeamDamageError:
        return np.full(truth.size, np.nan)
    fn = remove_window_decay(e.eigenvalues, tau).natural_frequencies_hz if window else e.natural_frequencies_hz
    return _nearest(fn, truth)


def estimates(case: ImpactCase, force, response) -> dict:
    """Every method's frequency (Hz) of each mode on one record: ``{column: (n_modes,)}``."""
    fs = case.sampling_frequency_hz
    truth = np.asarray(case.natural_frequencies_hz, float)
    out = {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e = identify_era(response[None], fs, band_hz=(0.9 * truth.min(), 1.1 * truth.max())).estimate
        out["era"] = _nearest(e.natural_frequencies_hz, truth)
    except BeamDamageError:
        out["era"] = np.full(truth.size, np.nan)
    p = fft_peaks(response[None], fs, truth, TOLERANCE_HZ, quantity="acceleration")
    out["fftpeak peak"], out["fftpeak natural"] = p.frequency_hz, p.natural_frequencies_hz
    out["lscf H1"] = _lscf(force, response, fs, truth, False)
    out["lscf H1 exp"] = _lscf(force, response, fs, truth, True)
    return out


def run_case(bc: BiasCase, seeds: int) -> list[dict]:
    """One row per mode of ``bc``: the truth columns and each method's bias, scatter and misses."""
    c = bc.case
    force, resp = impact_records(c, seeds, seed=0)
    per = [estimates(c, f, r) for f, r in zip(force, resp)]
    fn = np.asarray(c.natural_frequencies_hz, float)
    z = np.asarray(c.damping_ratios, float)
    peak = record_peak_hz(c)
    rows = []
    for m in range(fn.size):
        row = {"case": bc.name, "f_n": fn[m], "zeta": z[m], "fd": fn[m] * np.sqrt(1 - z[m] ** 2) - fn[m],
               "own_peak": frf_peak_hz(fn[m], z[m]) - fn[m], "record_peak": peak[m] - fn[m]}
        for col in METHOD_COLUMNS:
            v = np.array([p[col][m] for p in per]) - fn[m]
            ok = v[np.isfinite(v)]
            row[col] = (float(ok.mean()) if ok.size else np.nan, float(ok.std(ddof=1)) if ok.size > 1 else np.nan,
                        int(v.size - ok.size))
        rows.append(row)
    return rows


def _cell(b):
    mean, std, miss = b
    if not np.isfinite(mean):
        return "missed"
    s = f"{mean:+.3g} ± {std:.2g}" if np.isfinite(std) else f"{mean:+.3g}"
    return s + (f" ({miss} missed)" if miss else "")


#: The pyFRF fits (``real_rows``): a name, the band's lines (Hz, the record's 1-Hz lines), starting poles
#: ``(f_hz, sigma_1_s)``.
REAL_FITS = (
    ("5969 Hz, one pole, era's band", (5939, 6002), ((5969.5, 35.0),)),
    ("5969 Hz, one pole, 5940-6010 Hz", (5940, 6010), ((5969.5, 35.0),)),
    ("5969 Hz, two poles, 5940-6010 Hz", (5940, 6010), ((5969.5, 35.0), (5983.7, 40.0))),
    ("1518 Hz, one pole, +-8 lines", (1510, 1526), ((1518.1, 0.6),)),
    ("1518 Hz, one pole, +-18 lines", (1500, 1536), ((1518.1, 0.6),)),
)


def band_poles(y, fs, lines_hz, starts) -> tuple[np.ndarray, float]:
    """Poles of damped exponentials fitted to one decay's DFT lines ``lines_hz`` (inclusive, the record's 1/T grid):
    the closed form ``c (1 - z^N) / (1 - z w_k) + conj(c) (1 - conj(z)^N) / (1 - conj(z) w_k)`` of each pole and a
    complex level and slope, the amplitudes projected out, the poles by ``scipy.optimize.least_squares``: a fit
    written apart from :mod:`physics.identification.band_refine`. Returns the poles ``(f_hz, sigma_1_s)`` (m, 2) and
    the residual's rms per line."""
    n = y.size
    k = np.arange(int(round(lines_hz[0] * n / fs)), int(round(lines_hz[1] * n / fs)) + 1)
    target = np.fft.fft(y)[k]
    wk, x = np.exp(-2j * np.pi * k / n), (k - k.mean()) / max(k.size - 1, 1)

    def basis(p):
        cols = []
        for f, sig in p.reshape(-1, 2):
            z = np.exp((-sig + 2j * np.pi * f) / fs)
            g, gc = (1 - z ** n) / (1 - z * wk), (1 - np.conj(z) ** n) / (1 - np.conj(z) * wk)
            cols += [g + gc, 1j * (g - gc)]                    # Re(c), Im(c) as real unknowns
        cols += [np.ones(k.size), 1j * np.ones(k.size), x, 1j * x]
        b = np.array(cols).T
        return np.vstack([b.real, b.imag])

    rhs = np.r_[target.real, target.imag]

    def residual(p):
        b = basis(p)
        return rhs - b @ np.linalg.lstsq(b, rhs, rcond=None)[0]

    r = least_squares(residual, np.asarray(starts, float).ravel(), x_scale="jac")
    return r.x.reshape(-1, 2), float(np.sqrt(np.mean(r.fun ** 2)))


def real_rows(path) -> list[dict]:
    """On each pyFRF hit's response from the force's first sample: the FFT peak (acceleration) and the fits of
    :data:`REAL_FITS`; a row per fit: the first pole's frequency and damping per hit, the second pole's, the rms."""
    d = np.load(path)
    fs, resp, force = float(d["sampling_frequency_hz"]), d["response"], d["force"]
    onsets = [int(np.argmax(np.abs(f) > 0.05 * np.abs(f).max())) for f in force]
    rows = []
    for target in (5969.45, 1518.05):
        got = [fft_peaks(r[None], fs, [target], TOLERANCE_HZ, quantity="acceleration").frequency_hz[0] for r in resp]
        rows.append({"fit": f"{target:.0f} Hz, FFT peak", "f": np.array(got), "zeta": None, "second": None,
                     "rms": None})
    for name, lines, starts in REAL_FITS:
        fits = [band_poles(r[o:], fs, lines, starts) for r, o in zip(resp, onsets)]
        p = np.array([f[0] for f in fits])                                  # (hits, poles, 2)
        rows.append({"fit": name, "f": p[:, 0, 0], "zeta": p[:, 0, 1] / (2 * np.pi * p[:, 0, 0]),
                     "second": p[:, 1] if p.shape[1] > 1 else None, "rms": np.array([f[1] for f in fits])})
    return rows


def real_markdown(rows) -> str:
    body = []
    for r in rows:
        f = r["f"]
        second = "" if r["second"] is None else \
            (f"{r['second'][:, 0].min():.2f}-{r['second'][:, 0].max():.2f} Hz, ζ "
             f"{100 * (r['second'][:, 1] / (2 * np.pi * r['second'][:, 0])).mean():.3f} %")
        body.append([r["fit"], " ".join(f"{v:.3f}" for v in f), f"{f.mean():.3f}", f"{f.std(ddof=1):.3f}",
                     "" if r["zeta"] is None else f"{100 * r['zeta'].mean():.4f}", second,
                     "" if r["rms"] is None else f"{r['rms'].mean():.0f}"])
    return table(["pyFRF", "hits 1-5 (Hz)", "mean", "std", "ζ (%)", "second pole", "residual rms"], body)


def markdown(rows, seeds) -> str:
    header = ["case", "f_n (Hz)", "ζ (%)", "f_d − f_n", "own |A| peak − f_n", "|A·P| peak − f_n",
              *METHOD_COLUMNS]
    body = [[r["case"], f"{r['f_n']:g}", f"{100 * r['zeta']:.3g}", f"{r['fd']:+.3g}", f"{r['own_peak']:+.3g}",
             f"{r['record_peak']:+.3g}", *(_cell(r[c]) for c in METHOD_COLUMNS)] for r in rows]
    legend = "; ".join(f"`{k}`: {v}" for k, v in METHOD_COLUMNS.items())
    return (table(header, body) + f"\n\nHz; each method's cell: mean ± standard deviation of `estimate − f_n` over "
            f"{seeds} records. {legend}.")


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="identification.md")
    ap.add_argument("--seeds", type=int, default=4, help="records per case (default 4)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = []
    for bc in CASES:
        rows += run_case(bc, args.seeds)
        print(f"{bc.name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    md = markdown(rows, args.seeds)
    real = REAL_DIR / "pyfrf_hits.npz"
    if real.is_file():
        md += "\n\n" + real_markdown(real_rows(real))
    print(md)
    publish(args, "bias", md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
