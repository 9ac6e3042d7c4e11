"""Precision of the identified natural frequencies over repeated tests of an unchanged structure, per method.

Run: ``python -m experiments.benches.bench_precision [--quick] [--reps N] [--real DIR] [--docs]``

Precision is the scatter (standard deviation) of each mode's identified natural frequency over repeated tests of
the same structure. Every output-only method of :data:`physics.identification.METHODS` (``data == "records"``,
found in the table, so a method added there is measured here too; ``fftpeak``, the zero-padded FFT peak, is the
baseline) identifies the same simulated records, with no band and no number of modes given (as ``identify`` runs
them). An identified mode within 3 % of a truth mode is that mode's estimate (the nearest, and no other truth mode
nearer to it); a truth mode without
one, or a record the method refuses, is a **failure**.

Simulated tests, closed-form modal superposition (shares no code with ``physics``):

* **decay**: free decays after an impact (no force recorded) of a small cantilever, modes 12, 75.2 and 210.6 Hz
  (the cantilever's ratios 1 : 6.27 : 17.5) with damping ratios 1, 0.5 and 2 %, acceleration
  ``sum_m A_m phi_m(x) exp(-zeta w t) sin(w_d t)``, amplitudes 1, 0.5, 0.25 at the tip, each hit's amplitudes
  scaled by a random 0.8-1.2; sensors at the tip (1 channel) or at 1/4, 1/2, 3/4 and 1 of the length
  (4 channels, the cantilever's shapes), 1 kHz sampling, white noise of a standard deviation ``noise`` times the
  first mode's tip amplitude; records of 2, 4 and 16 s (24 to 192 periods of mode 1). **8-bit**: the 4 s capture
  quantised by an 8-bit converter whose full scale is 1.05 times the record's peak (an oscilloscope's), on top
  of a 1e-3 analogue noise; and the same oversampled, as a scope takes it: 10 kHz (830 samples per period of mode
  1, each level held over several samples), the tap 0.4 s into the 4 s capture (a pre-trigger of noise).
* **ambient**: a cantilever with modes 3 and 18.8 Hz, 1 % damping, driven at the tip by white noise, acceleration
  at the tip (1 channel) or at 1/4 to 1 of the length (4 channels), 64 Hz sampling, exact zero-order-hold
  discretisation of each mode (``scipy.signal.cont2discrete``), sensor noise 2 % of each channel's standard
  deviation; 1, 5 and 20 min (the shorter records are the first minutes of the 20-min one).

The **Cramér-Rao bound** (CRB), the least standard deviation any unbiased estimator can reach:

* decay: from the Fisher information ``J^T J / sigma^2`` of the damped-sinusoid model (per mode a damped angular
  frequency and decay rate shared by the channels, per channel and mode a cosine and a sine amplitude), ``J`` the
  model's exact Jacobian at the nominal hit, ``sigma^2`` the noise variance plus ``q^2 / 12`` for a quantisation
  step ``q`` (quantisation treated as white noise, optimistic once the decay falls below a step);
* ambient: the asymptotic (Whittle) bound of the centre of an isolated mode's Lorentzian spectrum of half-power
  half-width ``b = zeta f_n`` from a record of length ``T``, ``std >= sqrt(b / (2 pi T))``: the information is
  ``T int (d ln S / d f0)^2 df = 2 pi T / b``; it holds at high SNR and more channels do not lower it (they see
  the same modal response).

Columns: std of the frequency (Hz and relative to the truth), bias (mean minus the truth), CRB, std / CRB,
std / FFT-peak std (the baseline's scatter on the same records: above 1, the method is less precise than the
plainest estimator) and failures over the records. With ``--real DIR`` the bench also reads the real repeated-test
sets of ``experiments/data/real`` (their README says what they are; see :func:`real_rows`). A real set holds a few
tests (five hits: a scatter known to about +-35 %), so its table also compares each method with the FFT peak
test by test: each method's deviations from its own mean over the tests, their correlation with the FFT peak's
(near 1: both follow one change of the structure or the excitation from test to test, not their own noise) and
the tests whose deviation is the smaller.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser, publish, table
from physics.identification.methods import METHODS
from physics.errors import BeamDamageError
from physics.identification.fft_peak import identify_fft_peaks
from physics.estimation import estimate_frf
from physics.identification.lscf import identify_lscf
from physics.io.timedata import TimeRecords
from physics.time_records import estimate_from_records

__all__ = ["AMBIENT", "DECAY", "Case", "ambient_records", "crb_ambient_hz", "crb_decay_hz", "decay_records",
           "identify_modes", "main", "match_modes", "matched_indices", "markdown", "record_methods", "run_case",
           "summarise"]

#: Cantilever eigenvalue parameters beta_m L of the first three bending modes.
BETA_L = np.array([1.87510407, 4.69409113, 7.85475744])
#: Free decays: natural frequencies (Hz), damping ratios, tip amplitudes, sampling rate (Hz).
DECAY_FN_HZ = 12.0 * (BETA_L / BETA_L[0]) ** 2
DECAY_ZETA = np.array([0.01, 0.005, 0.02])
DECAY_AMP = np.array([1.0, 0.5, 0.25])
DECAY_FS_HZ = 1000.0
#: Ambient: natural frequencies (Hz), damping ratio, sampling rate (Hz), sensor noise (fraction of a channel's std).
AMBIENT_FN_HZ = 3.0 * (BETA_L[:2] / BETA_L[0]) ** 2
AMBIENT_ZETA = np.array([0.01, 0.01])
AMBIENT_FS_HZ = 64.0
AMBIENT_NOISE = 0.02
#: Ambient: simulated seconds before the record starts (ten time constants of mode 1).
WARM_UP_S = 60.0
#: Sensor positions (fraction of the length) of the 4-channel cases; the 1-channel case is the tip.
SENSORS = np.array([0.25, 0.5, 0.75, 1.0])
#: An identified mode within this relative distance of a truth mode, and nearer to it than to any other, is its
#: estimate.
MATCH = 0.03
REAL_DIR = Path(__file__).resolve().parents[1] / "data" / "real"


@dataclass(frozen=True)
class Case:
    """One kind of repeated test.

    Attributes
    ----------
    kind : {"decay", "ambient"}
    n_channels : int
    duration_s : float
    noise : float
        Decay: noise std over the first mode's tip amplitude; ambient: over each channel's std.
    bits : int
        Quantiser bits (0: none).
    fs_hz : float
        Decay: sampling rate (Hz).
    pre_s : float
        Decay: the tap's time in the record (s; noise alone before it).
    """

    kind: str
    n_channels: int
    duration_s: float
    noise: float = 1e-3
    bits: int = 0
    fs_hz: float = DECAY_FS_HZ
    pre_s: float = 0.0

    @property
    def label(self) -> str:
        if self.kind == "decay":
            q = f", {self.bits}-bit" if self.bits else ""
            rate = f", {self.fs_hz / 1000:g} kHz" if self.fs_hz != DECAY_FS_HZ else ""
            tap = f", tap at {self.pre_s:g} s" if self.pre_s else ""
            return f"decay {self.noise:.0e}{q}{rate}{tap}"
        return f"ambient {self.noise:.0%}"

    @property
    def length(self) -> str:
        return f"{self.duration_s:g} s" if self.duration_s < 60 else f"{self.duration_s / 60:g} min"


DECAY = (Case("decay", 1, 2.0), Case("decay", 1, 4.0), Case("decay", 1, 16.0), Case("decay", 1, 4.0, 1e-2),
         Case("decay", 1, 4.0, 1e-3, 8), Case("decay", 4, 4.0), Case("decay", 4, 16.0),
         Case("decay", 1, 4.0, 1e-3, 8, 10000.0, 0.4))
AMBIENT = tuple(Case("ambient", n, T, AMBIENT_NOISE) for n in (1, 4) for T in (60.0, 300.0, 1200.0))


def cantilever_shapes(x_over_l, n_modes):
    """Cantilever bending shapes at ``x / L``, shape (n_points, n_modes), each 1 at the tip."""
    b = BETA_L[:n_modes]
    s = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
    z = np.outer(np.atleast_1d(x_over_l), b)
    phi = np.cosh(z) - np.cos(z) - s * (np.sinh(z) - np.sin(z))
    tip = np.cosh(b) - np.cos(b) - s * (np.sinh(b) - np.sin(b))
    return phi / tip


def _positions(n_channels):
    return SENSORS if n_channels == 4 else np.array([1.0])


def decay_records(case: Case, reps: int, seed: int):
    """``reps`` free decays of ``case`` (module docstring): array (reps, n_channels, n_samples)."""
    rng = np.random.default_rng(seed)
    fs, n = case.fs_hz, int(round(case.duration_s * case.fs_hz))
    t = np.maximum(np.arange(n) / fs - case.pre_s, 0.0)                         # zero before the tap
    w = 2 * np.pi * DECAY_FN_HZ
    basis = np.exp(-DECAY_ZETA[:, None] * w[:, None] * t) * np.sin(w[:, None] * np.sqrt(1 - DECAY_ZETA[:, None] ** 2)
                                                                   * t)          # (modes, n)
    amp = DECAY_AMP * cantilever_shapes(_positions(case.n_channels), 3)         # (n_ch, modes)
    hits = rng.uniform(0.8, 1.2, (reps, 1, 3))
    y = np.einsum("rcm,mn->rcn", hits * amp, basis)
    y += case.noise * rng.standard_normal(y.shape)
    if case.bits:
        full = 1.05 * np.abs(y).max(axis=2, keepdims=True)
        q = 2 * full / 2 ** case.bits
        y = np.clip(np.round(y / q), -2 ** (case.bits - 1), 2 ** (case.bits - 1) - 1) * q
    return y


def ambient_records(n_channels: int, duration_s: float, reps: int, seed: int):
    """``reps`` ambient tests (module docstring): array (reps, n_channels, n_samples)."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    fs, n = AMBIENT_FS_HZ, int(round(duration_s * AMBIENT_FS_HZ))
    warm = int(round(WARM_UP_S * fs))                   # dropped: the response from rest is not yet stationary
    phi = cantilever_shapes(_positions(n_channels), AMBIENT_FN_HZ.size)
    force = rng.standard_normal((reps, n + warm))
    q = np.empty((reps, AMBIENT_FN_HZ.size, n + warm))
    for m, (fn, z) in enumerate(zip(AMBIENT_FN_HZ, AMBIENT_ZETA)):     # one exact filter per mode
        wn = 2 * np.pi * fn
        bz, az, _ = signal.cont2discrete(([1.0, 0.0, 0.0], [1.0, 2 * z * wn, wn ** 2]), 1 / fs, "zoh")
        q[:, m] = signal.lfilter(bz.ravel(), az, force, axis=1)      # tip force: phi_m(tip) = 1
    y = np.einsum("cm,rmn->rcn", phi, q[:, :, warm:])
    return y + AMBIENT_NOISE * y.std(axis=2, keepdims=True) * rng.standard_normal(y.shape)


def crb_decay_hz(case: Case) -> np.ndarray:
    """Cramér-Rao bound (Hz) of each mode's frequency from one nominal free decay of ``case`` (module
    docstring)."""
    fs, n = case.fs_hz, int(round(case.duration_s * case.fs_hz))
    t = np.arange(int(np.ceil(case.pre_s * fs)), n) / fs - case.pre_s          # the samples after the tap
    wd = 2 * np.pi * DECAY_FN_HZ * np.sqrt(1 - DECAY_ZETA ** 2)
    sig = DECAY_ZETA * 2 * np.pi * DECAY_FN_HZ
    amp = DECAY_AMP * cantilever_shapes(_positions(case.n_channels), 3)         # sine amplitudes b; a = 0
    n_ch, n_m = amp.shape
    env = np.exp(-sig[:, None] * t)
    c, s = env * np.cos(wd[:, None] * t), env * np.sin(wd[:, None] * t)       # (modes, n)
    J = np.zeros((n_ch, t.size, 2 * n_m + 2 * n_m * n_ch))
    for m in range(n_m):                                                       # columns, not samples
        J[:, :, m] = amp[:, m, None] * t * c[m]                                # d/d w_d of b e sin
        J[:, :, n_m + m] = -amp[:, m, None] * t * s[m]                         # d/d sigma
        for ch in range(n_ch):
            J[ch, :, 2 * n_m + 2 * (m * n_ch + ch)] = c[m]
            J[ch, :, 2 * n_m + 2 * (m * n_ch + ch) + 1] = s[m]
    J = J.reshape(n_ch * t.size, -1)
    var = case.noise ** 2
    if case.bits:
        full = 1.05 * np.abs(np.einsum("cm,mn->cn", amp, s)).max()
        var += (2 * full / 2 ** case.bits) ** 2 / 12
    cov = np.linalg.inv(J.T @ J / var)
    return np.sqrt(np.diag(cov)[:n_m]) / (2 * np.pi)


def crb_ambient_hz(duration_s: float) -> np.ndarray:
    """Asymptotic bound (Hz) of each ambient mode's frequency: ``sqrt(zeta f_n / (2 pi T))`` (module docstring)."""
    return np.sqrt(AMBIENT_ZETA * AMBIENT_FN_HZ / (2 * np.pi * duration_s))


def record_methods() -> list[str]:
    """The output-only methods of :data:`METHODS`, ``fftpeak`` first."""

    names = [n for n, s in METHODS.items() if s.data == "records"]
    return sorted(names, key=lambda n: n != "fftpeak")


def identify_modes(method: str, signals, fs, truth_hz):
    """Natural frequencies (Hz) of ``method`` nearest each truth mode within :data:`MATCH` (NaN: not found)."""

    spec = METHODS[method]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est, _ = spec.fit(signals, fs, None, None, "record", **{k: None for k in spec.options})
    except BeamDamageError:
        return np.full(len(truth_hz), np.nan)
    return match_modes(est.natural_frequencies_hz, truth_hz)


def match_modes(frequencies_hz, truth_hz):
    """Each truth mode's estimate among ``frequencies_hz``: the nearest, within :data:`MATCH` and with no other
    truth mode nearer to it (NaN: none)."""
    f = np.append(np.asarray(frequencies_hz, float), np.nan)            # index -1: none
    return f[matched_indices(f[:-1], truth_hz, MATCH)]


def matched_indices(frequencies_hz, truth_hz, tolerance: float) -> np.ndarray:
    """Each truth mode's index among ``frequencies_hz``: the nearest, within ``tolerance`` (relative) and with no
    other truth mode nearer to it (-1: none)."""
    f, truth_hz = np.asarray(frequencies_hz, float), np.asarray(truth_hz, float)
    if f.size == 0:
        return np.full(truth_hz.size, -1)
    dist = np.abs(f[None, :] - truth_hz[:, None])
    j = np.argmin(dist, axis=1)
    ok = (np.argmin(dist, axis=0)[j] == np.arange(truth_hz.size)) & (np.abs(f[j] / truth_hz - 1) <= tolerance)
    return np.where(ok, j, -1)


def run_case(case: Case, reps: int, seed: int, methods, records=None, progress=None) -> dict:
    """Frequencies of every method on ``reps`` tests of ``case``: ``{method: (reps, n_modes)}`` and the timing."""
    if records is None:
        records = decay_records(case, reps, seed) if case.kind == "decay" else \
            ambient_records(case.n_channels, case.duration_s, reps, seed)
    truth = DECAY_FN_HZ if case.kind == "decay" else AMBIENT_FN_HZ
    fs = case.fs_hz if case.kind == "decay" else AMBIENT_FS_HZ
    out, seconds = {}, {}
    for m in methods:
        t0 = time.perf_counter()
        out[m] = np.array([identify_modes(m, y, fs, truth) for y in records])
        seconds[m] = (time.perf_counter() - t0) / len(records)
        if progress is not None:
            progress.update(1)
    return {"case": case, "freqs": out, "seconds": seconds}


def summarise(runs: list[dict]) -> list[dict]:
    """One row per case x method x mode (module docstring's columns)."""
    rows = []
    for order, run in enumerate(runs):
        case = run["case"]
        truth = DECAY_FN_HZ if case.kind == "decay" else AMBIENT_FN_HZ
        crb = crb_decay_hz(case) if case.kind == "decay" else crb_ambient_hz(case.duration_s)
        base = run["freqs"].get("fftpeak")
        for m, F in run["freqs"].items():
            for k in range(truth.size):
                ok = np.isfinite(F[:, k])
                std = float(np.std(F[ok, k], ddof=1)) if ok.sum() >= 2 else math.nan
                bok = np.isfinite(base[:, k]) if base is not None else ok[:0]
                bstd = float(np.std(base[bok, k], ddof=1)) if base is not None and bok.sum() >= 2 else math.nan
                rows.append({"order": order, "method": m, "case": case.label, "channels": case.n_channels,
                             "length": case.length, "mode": k + 1, "truth_hz": float(truth[k]), "std_hz": std,
                             "std_rel": std / truth[k], "bias_hz": float(np.mean(F[ok, k]) - truth[k])
                             if ok.any() else math.nan, "crb_hz": float(crb[k]),
                             "std_over_crb": std / crb[k] if std > 0 else math.nan,
                             "std_over_fft": std / bstd if bstd > 0 and std > 0 else math.nan,
                             "failures": int((~ok).sum()), "records": int(ok.size),
                             "seconds": run["seconds"][m]})
    return rows


def _g(v, digits=2):
    return "-" if not np.isfinite(v) else f"{v:.{digits}g}"


def _std(v):
    """A standard deviation; exactly 0 is a method whose frequencies are its spectrum's lines."""
    return "0 (lines)" if v == 0 else _g(v)


def markdown(rows: list[dict], reps: dict, command: str, real: list[dict] | None = None) -> str:
    """The precision table (and the real sets' tables) as Markdown."""
    body = [[r["method"], r["case"], r["channels"], r["length"], f"{r['mode']} ({r['truth_hz']:.4g} Hz)",
             _std(r["std_hz"]), _g(r["std_rel"]), _g(r["bias_hz"]), _g(r["crb_hz"]), _g(r["std_over_crb"]),
             _g(r["std_over_fft"]), f"{r['failures']}/{r['records']}"]
            for r in sorted(rows, key=lambda r: (r["order"], r["mode"], r["method"] != "fftpeak", r["method"]))]
    text = table(["method", "case", "ch", "length", "mode", "std (Hz)", "std / f", "bias (Hz)", "CRB (Hz)",
                  "std / CRB", "std / FFT-peak std", "failures"], body) + (
        f"\n\n{reps['decay']} free decays and {reps['ambient']} ambient records per case, seeded; `{command}`.\n")
    if real:
        text += "\n" + real_markdown(real)
    return text


# ---------------------------------------------------------------------------------------------- real test sets

def real_rows(real_dir) -> list[dict]:
    """Rows of the real repeated-test sets found in ``real_dir`` (none found: no rows).

    * ``pyfrf_hits.npz``: five hammer hits of one structure (force and one response, 25.6 kHz, 1 s): each output-only
      method on the response alone, and LSCF on each hit's FRF: H1 of the hit's force and response
      (:func:`physics.estimation.estimate_frf` with one frame of the whole record, no window), and H1 of the
      impact estimate ``estimate --excitation impact --averages 1 --decay 1``
      (:func:`physics.time_records.estimate_from_records`: the force kept over its pulse, no exponential window);
      per mode (the fftpeak modes of the first hit) the mean and the scatter over the five hits.
    * ``hct_setups.npz``: the Heritage Court Tower's four ambient setups (40 Hz): each method on each setup; per
      mode (the fftpeak modes of setup 1) the mean and the scatter over the setups.
    """
    real_dir = Path(real_dir)
    rows = []
    if (real_dir / "pyfrf_hits.npz").is_file():
        rows += _pyfrf_rows(real_dir / "pyfrf_hits.npz")
    if (real_dir / "hct_setups.npz").is_file():
        rows += _hct_rows(real_dir / "hct_setups.npz")
    return rows


def _scatter_rows(set_name, tests, freqs_by_method, reference, by):
    """Per method and mode: mean and scatter over the tests, and the paired comparison with ``fftpeak`` on the
    tests both found the mode in (each method's deviations from its own mean: their correlation, and the tests
    whose deviation is the smaller)."""
    rows = []
    base = freqs_by_method.get("fftpeak")
    for m, F in freqs_by_method.items():
        for k, f0 in enumerate(reference):
            v = F[:, k]
            ok = np.isfinite(v)
            row = {"set": set_name, "method": m, "mode": k + 1, "reference_hz": float(f0), "by": by,
                   "mean_hz": float(np.mean(v[ok])) if ok.any() else math.nan,
                   "std_hz": float(np.std(v[ok], ddof=1)) if ok.sum() >= 2 else math.nan,
                   "found": int(ok.sum()), "tests": tests, "std_over_fft": math.nan, "corr_fft": math.nan,
                   "closer": 0, "paired": 0}
            both = ok & np.isfinite(base[:, k]) if base is not None else ok[:0]
            if base is not None and m != "fftpeak" and both.sum() >= 3:
                d, d0 = v[both] - v[both].mean(), base[both, k] - base[both, k].mean()
                s0 = np.std(d0, ddof=1)
                row.update(std_over_fft=float(np.std(d, ddof=1) / s0) if s0 > 0 else math.nan,
                           corr_fft=float(np.corrcoef(d, d0)[0, 1]) if np.std(d) > 0 and s0 > 0 else math.nan,
                           closer=int(np.sum(np.abs(d) < np.abs(d0))), paired=int(both.sum()))
            rows.append(row)
    return rows


def _reference_modes(method, signals, fs, n_max=6):
    """The modes the others are matched to: ``method``'s on one test (its ``n_max`` most prominent for fftpeak)."""

    if method == "fftpeak":
        return identify_fft_peaks(signals, fs, n_modes=n_max)[0].natural_frequencies_hz
    spec = METHODS[method]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return spec.fit(signals, fs, None, None, "reference", **{k: None for k in spec.options})[0] \
            .natural_frequencies_hz


def _pyfrf_rows(path):

    d = np.load(path)
    fs, force, resp = float(d["sampling_frequency_hz"]), d["force"], d["response"]
    ref = _reference_modes("fftpeak", resp[0][None], fs)
    freqs = {m: np.array([identify_modes(m, r[None], fs, ref) for r in resp]) for m in record_methods()}
    lscf, windowed = [], []
    for fo, r in zip(force, resp):
        est = estimate_frf(fo[None], r[None], fs, nperseg=fo.size, window="boxcar")
        hit = TimeRecords(1.0 / fs, np.stack([fo, r]), ("1:+Z", "2:+Z"), ("force", "acceleration"))
        impact = estimate_from_records(hit, excitation="impact", averages=1, decay=1.0).frf
        for out, (f, h) in ((lscf, (est.frequency_hz, est.h1)), (windowed, (impact.frequency_hz, impact.frf))):
            band = (f > 0.9 * ref.min()) & (f < 1.1 * ref.max())
            try:
                got = identify_lscf(f[band], h[..., band], kind="accelerance").estimate.natural_frequencies_hz
            except BeamDamageError:                             # a failure is counted, not raised
                got = np.zeros(0)
            out.append(match_modes(got, ref))
    freqs["lscf (FRF)"] = np.array(lscf)
    freqs["lscf (FRF, force window)"] = np.array(windowed)
    return _scatter_rows("pyFRF hits", resp.shape[0], freqs, ref, "fftpeak, hit 1")


def _hct_rows(path):
    d = np.load(path)
    fs = float(d["sampling_frequency_hz"])
    setups = [d[k] for k in sorted(d.files) if k.startswith("setup")]
    ref = _reference_modes("ssi", setups[0], fs)
    freqs = {m: np.array([identify_modes(m, y, fs, ref) for y in setups]) for m in record_methods()}
    return _scatter_rows("HCT setups", len(setups), freqs, ref, "ssi, setup 1")


def real_markdown(rows) -> str:
    """The real sets' table: per mode and method the mean and scatter over the tests, and the paired comparison
    with the FFT peak (:func:`_scatter_rows`)."""
    body = [[r["set"], r["method"], f"{r['mode']}: {r['reference_hz']:.5g} ({r['by']})", _g(r["mean_hz"], 6),
             _std(r["std_hz"]), _g(r.get("std_over_fft", math.nan)), _g(r.get("corr_fft", math.nan)),
             f"{r['closer']}/{r['paired']}" if r.get("paired") else "-", f"{r['found']}/{r['tests']}"]
            for r in sorted(rows, key=lambda r: (r["set"], r["mode"], r["method"] != "fftpeak"))]
    return table(["set", "method", "mode: reference (Hz)", "mean (Hz)", "std over tests (Hz)", "std / fftpeak std",
                  "correlation with fftpeak", "closer than fftpeak", "found"], body) + "\n"


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md", seed=0)
    p.add_argument("--quick", action="store_true", help="a tiny run (2 cases, 3 records each)")
    p.add_argument("--reps", type=int, default=None, help="free decays per case (default 12; ambient: a third)")
    p.add_argument("--real", default=str(REAL_DIR), help="folder of the real repeated-test sets ('' for none)")
    p.add_argument("--only", default="", help="run only the cases whose label holds this text (e.g. '10 kHz')")
    args = p.parse_args(argv)
    if args.only and args.docs:
        p.error("--only writes part of the table: run --docs without it")
    from tqdm import tqdm

    if args.quick:
        cases, reps = (DECAY[1], AMBIENT[0]), {"decay": args.reps or 3, "ambient": args.reps or 3}
    else:
        r = args.reps or 12
        cases, reps = DECAY + AMBIENT, {"decay": r, "ambient": max(3, r // 3)}
    cases = tuple(c for c in cases if args.only in c.label)
    methods = record_methods()
    runs = []
    long_amb = {}
    with tqdm(total=len(cases) * len(methods), desc="precision", file=sys.stderr) as bar:
        for i, case in enumerate(cases):
            records = None
            if case.kind == "ambient":                  # shorter records: the first minutes of the longest
                longest = max(c.duration_s for c in cases if c.kind == "ambient" and c.n_channels == case.n_channels)
                key = case.n_channels
                if key not in long_amb:
                    long_amb[key] = ambient_records(case.n_channels, longest, reps["ambient"], args.seed + 100 + key)
                records = long_amb[key][:, :, :int(round(case.duration_s * AMBIENT_FS_HZ))]
            else:
                records = decay_records(case, reps["decay"], args.seed + (DECAY.index(case) if case in DECAY else i))
            runs.append(run_case(case, len(records), args.seed, methods, records, bar))
    rows = summarise(runs)
    real = real_rows(args.real) if args.real and not args.quick else []
    command = "python -m experiments.benches.bench_precision" + (" --quick" if args.quick else "") + \
        (f" --reps {args.reps}" if args.reps else "") + (f" --only '{args.only}'" if args.only else "")
    md = markdown(rows, reps, command, real)
    print(md)
    publish(args, "precision", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
