"""Benchmark: ``monitor`` against the plainest tests on series nobody tuned on, drawn from a seed.

Run: ``python -m experiments.benches.bench_unseen [--seed 0] [--kinds hammer scope frf building] [--quick]
[--rate 0.01] [--out out/bench_unseen] [--docs]``

Four kinds of repeated-test series, each configuration (modes, damping, channels, shapes, rates, damage sizes)
drawn from ``--seed``, unlike the other benches' (their cantilever of 12/75/210 Hz, the 4-mode slit series, the
frequency series): each test written as a test system writes it, ``monitor`` run through the CLI's own entry point
(``beam-damage monitor FILES --baseline-tests N --band F0 F1 --false-alarm-rate RATE --json --out DIR``, in
process), and the plain tests computed on the same records.

* ``hammer``: a lab frame hit by an impact hammer, no force channel: 3-4 accelerometers, 4096 samples at 500 Hz
  (8 s), 2-4 modes in 5-60 Hz (damping 0.5-3 %, random shapes), one hit 0.1-1 s into the record (pre-trigger
  noise), each test's modes scattered by 0.1 % (lab conditions) and the hit's gain by +-30 %, noise 1-3 % of the
  record's standard deviation. 60 baseline, 40 intact, and two damaged groups of 40 in which one drawn mode moves
  down by 1-3 % and by 3-10 %. NPZ (``signals``, ``sampling_frequency_hz``).
* ``scope``: one accelerometer on a small cantilever read by an oscilloscope: 4 s at 1.25-2.5 kHz, 8-bit levels on
  a fixed range per session (the tap's peak at 60-110 levels; about one capture in eight hit hard enough to clip at
  the range's extreme), 2-3 cantilever modes (mode 1 in 15-40 Hz, damping 0.2-1 %; the band ends at 0.4 fs, and a
  mode above it stays in the record but is no true mode of the series). Sessions of 10 tests, each
  session's temperature moving every mode by a common factor of standard deviation 0.5 % (about 1 % between
  sessions); the baseline the first 4 sessions, intact the next 3, two damaged groups of 3 sessions each with one
  mode of the band down by 0.5-1.5 % and 1.5-3 %. CSV (``time_s`` and the channel, in volts), as a scope exports.
* ``frf``: one accelerometer on an aluminium cantilever (:class:`experiments.second_sim.fem.Beam`, a root spring
  re-made +-3 % each test, temperature +-0.3 % on EI, a payload of 10 % of the beam's mass), hammer FRFs
  (accelerance, :func:`experiments.second_sim.response.measure`: 3 % noise, as H1 from a few averages) over its 5
  lowest modes; 35 baseline, 20 intact, two groups of 20 in which the payload loses 1-4 % and 5-9 % of the beam's
  mass (the modes rise). UFF dataset 58.
* ``building``: ambient acceleration of a tall building (closed-form modal superposition, each mode's exact
  zero-order-hold response to white noise): 6 channels (3 levels x 2 directions), 5 min at 40-100 Hz, 5 modes
  (two close bending modes 1-3 % apart at 0.8-2 Hz, torsion at 1.3-1.6 times, the second bending pair at 3-3.5
  times), damping 1-2 %, each test's modes moved by a common 0.3 % (temperature, wind); 40 baseline, 20 intact,
  two groups of 20 in which the second close mode drops 1-2 % and 2-4 %. NPZ in float32.

The plain tests (:mod:`experiments.benches.plain_tests`): each mode's frequency the zero-padded FFT peak of the
record in the mode's window (:func:`experiments.benches.bench_real_series.fft_frequencies`, its modes the baseline
records' clusters of clear peaks), for FRFs the peak of ``|H|`` summed over the channels with a parabola through
the log magnitude at its top; ``plain shift`` (the mean of ``ln f`` over the modes) and ``plain per mode``
(Bonferroni over the modes), both two-sided Gaussian prediction intervals from the baseline, each baseline test held
out, alarmed at p below ``--rate`` (:func:`~experiments.benches.plain_tests.plain_p_values`).

Columns: per kind and group, the tests in which every true mode was found (``monitor`` / FFT peak, matched within
3 %); per true mode, the scatter over the baseline of the estimate less the test's true frequency (relative, %) of
``monitor`` (its chosen estimator) and of the FFT peak, and a Cramér-Rao-like reference (free decays: the damped
sinusoids' bound per channel, combined as independent information, quantisation as white noise; ambient: the
Lorentzian bound ``sqrt(zeta f / (2 pi T))``; FRFs: the modal sum's bound on the first baseline test's accelerance
in the band, its noise 3 % of ``|H|`` plus 0.1 % of the peak per line, the poles, residues and two residuals
unknown); the share flagged (``intact``: false alarms; baseline:
held out) by ``monitor`` (statuses :data:`learn.monitor.alarms.FLAGGED_STATUSES`, its statuses counted beside) and
the two plain tests. A damaged group where ``monitor`` flags a smaller share than a plain test is marked **LOSS**,
and the ``intact`` row where ``monitor`` flags more of the healthy tests (the held-out baseline and ``intact``) than
twice the rate and than a plain test. Writes ``unseen.json`` and ``unseen.md`` in ``--out``/seedN; the records and
``monitor``'s identification cache stay there (``--from-json`` re-scores the saved flags without running).
"""

from __future__ import annotations

import json
import os
from collections import Counter
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from experiments.benches.bench_precision import match_modes  # noqa: E402
from experiments.benches.bench_real_series import fft_frequencies, mode_windows_hz, reference_fft_modes  # noqa: E402
from experiments.benches.bounds import crb_decay_rel, crb_frf_rel  # noqa: E402
from experiments.benches.harness import cli_json, parser, publish, table  # noqa: E402
from experiments.benches.plain_tests import plain_p_values  # noqa: E402
from experiments.second_sim.fem import Beam, PointMass, assemble, modes  # noqa: E402
from experiments.second_sim.response import Damping, Noise, measure, receptance  # noqa: E402
from experiments.second_sim.writers import write_uff  # noqa: E402
from learn.monitor.alarms import FLAGGED_STATUSES  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["KINDS", "Series", "frf_peaks", "main", "plain_flags", "score_series", "simulate"]

#: Cantilever eigenvalue parameters beta_m L of the first bending modes.
BETA_L = np.array([1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839])
PLAIN = ("plain shift", "plain per mode")
#: Short names of ``monitor``'s statuses in the table.
SHORT = {"change or unseen conditions": "unseen conditions", "not identified": "not identified"}


@dataclass(frozen=True)
class Series:
    """One drawn series: its tests (records or FRFs) and their truth.

    Attributes
    ----------
    kind, how : str                      the kind and its drawn configuration, for the report
    data : list                          per test: records (n_channels, n_samples), or FRFs (n_channels, n_lines)
    truth_hz : ndarray (n, m)            each test's true natural frequencies
    groups : tuple of str                per test: ``"baseline"``, ``"intact"`` or the damaged group's name
    n_baseline : int
    band_hz : (float, float)             the band ``monitor`` is given and the FFT peaks are searched in
    sampling_frequency_hz : float        records: the rate; FRFs: 0
    crb_rel : ndarray (m,)               the reference scatter of each mode (relative), NaN where none
    freq_hz : ndarray or None            FRFs: the frequency lines
    extra : dict                         what the writer needs (CSV scale, FRF geometry)
    """

    kind: str
    how: str
    data: list
    truth_hz: np.ndarray
    groups: tuple
    n_baseline: int
    band_hz: tuple
    sampling_frequency_hz: float
    crb_rel: np.ndarray
    freq_hz: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


def _groups(counts: dict) -> tuple:
    return tuple(g for g, n in counts.items() for _ in range(n))


def _decay(fs, n, fn, zeta, amp, t0):
    """Free decays ``sum_j amp[c, j] exp(-zeta w t) sin(w_d t)`` from ``t0`` (s): (n_channels, n) for one test."""
    t = np.arange(n) / fs - t0
    on = t >= 0
    w = 2 * np.pi * fn
    tt = np.where(on, t, 0.0)
    basis = np.exp(-zeta[:, None] * w[:, None] * tt) * np.sin(w[:, None] * np.sqrt(1 - zeta[:, None] ** 2) * tt)
    return amp @ (basis * on)


def hammer_series(seed: int, counts: dict) -> Series:
    """``hammer`` (module docstring)."""
    rng = np.random.default_rng([seed, 1])
    fs, n = 500.0, 4096
    n_ch, m = int(rng.integers(3, 5)), int(rng.integers(2, 5))
    while True:
        fn = np.sort(rng.uniform(5.0, 60.0, m))
        if m == 1 or np.min(np.diff(np.log(fn))) > np.log(1.15):
            break
    zeta = rng.uniform(0.005, 0.03, m)
    shapes = rng.uniform(0.2, 1.0, (n_ch, m)) * rng.choice([-1.0, 1.0], (n_ch, m))
    amp = shapes * (fn[0] / fn) ** 0.5                         # higher modes weaker at the same hit
    noise = rng.uniform(0.01, 0.03)
    target = int(rng.integers(m))
    d1, d2 = rng.uniform(0.01, 0.03), rng.uniform(0.03, 0.10)
    g1, g2 = f"mode {target + 1} -{100 * d1:.1f} %", f"mode {target + 1} -{100 * d2:.1f} %"
    groups = _groups({"baseline": counts["baseline"], "intact": counts["intact"], g1: counts["damaged"],
                      g2: counts["damaged"]})
    nt = len(groups)
    drop = np.array([{g1: d1, g2: d2}.get(g, 0.0) for g in groups])
    F = fn * (1 + 0.001 * rng.standard_normal((nt, 1)) + 0.0003 * rng.standard_normal((nt, m)))
    F[:, target] *= 1 - drop
    t0 = rng.uniform(0.1, 1.0, nt)
    gain = rng.uniform(0.7, 1.3, nt)
    data = []
    for i in range(nt):
        y = _decay(fs, n, F[i], zeta, gain[i] * amp, t0[i])
        data.append(y + noise * y.std() * rng.standard_normal(y.shape))
    clean = _decay(fs, n, fn, zeta, amp, 0.55)
    crb = crb_decay_rel(fs, n, 0.55, fn, zeta, amp, noise * clean.std())
    how = (f"{n_ch} channels, modes " + ", ".join(f"{f:.1f}" for f in fn) + " Hz (damping "
           + ", ".join(f"{100 * z:.1f}" for z in zeta) + f" %), noise {100 * noise:.1f} %")
    return Series("hammer", how, data, F, groups, counts["baseline"], (2.0, 80.0), fs, crb)


def scope_series(seed: int, counts: dict, per_session: int = 10) -> Series:
    """``scope`` (module docstring); ``counts`` in tests, rounded to whole sessions."""
    rng = np.random.default_rng([seed, 2])
    fs = float(rng.choice([1250.0, 2500.0]))
    n = int(4 * fs)
    m = int(rng.integers(2, 4))
    fn = rng.uniform(15.0, 40.0) * (BETA_L[:m] / BETA_L[0]) ** 2
    zeta = rng.uniform(0.002, 0.01, m)
    amp = np.array([1.0, 0.6, 0.4][:m])[None, :] * (fn[0] / fn)[None, :] ** 0.3
    hi = min(0.4 * fs, 1.3 * fn[-1])
    keep = fn < hi                      # a mode above 0.4 fs stays in the record, beyond the band monitor is given
    target = min(int(rng.integers(m)), int(keep.sum()) - 1)      # the damaged mode one of the band's
    d1, d2 = rng.uniform(0.005, 0.015), rng.uniform(0.015, 0.03)
    g1, g2 = f"mode {target + 1} -{100 * d1:.2f} %", f"mode {target + 1} -{100 * d2:.2f} %"
    ses = {k: max(1, round(v / per_session)) for k, v in counts.items()}
    groups = _groups({"baseline": ses["baseline"] * per_session, "intact": ses["intact"] * per_session,
                      g1: ses["damaged"] * per_session, g2: ses["damaged"] * per_session})
    nt = len(groups)
    session = np.arange(nt) // per_session
    temp = 0.005 * rng.standard_normal(session.max() + 1)[session]
    F = fn * (1 + temp[:, None] + 0.0002 * rng.standard_normal((nt, m)))
    drop = np.array([{g1: d1, g2: d2}.get(g, 0.0) for g in groups])
    F[:, target] *= 1 - drop
    peak_levels = rng.uniform(60.0, 110.0)                   # the tap's usual peak, in levels
    scale = 1.0 / 128                                        # volts per level (range +-1 V)
    t0 = rng.uniform(0.2, 0.6, nt)
    gain = rng.uniform(0.8, 1.2, nt) * np.where(rng.random(nt) < 0.125, rng.uniform(1.3, 2.0, nt), 1.0)
    ref = _decay(fs, n, fn, zeta, amp, 0.4)
    level = peak_levels / np.abs(ref).max()
    data = []
    for i in range(nt):
        y = level * _decay(fs, n, F[i], zeta, gain[i] * amp, t0[i]) + 0.4 * rng.standard_normal(n)[None]
        data.append(np.clip(np.round(y), -128, 127) * scale)
    crb = crb_decay_rel(fs, n, 0.4, fn, zeta, level * amp, np.sqrt(0.4 ** 2 + 1 / 12))
    clipped = sum(bool(np.any(np.abs(np.asarray(d) / scale) >= 127.5 - 1)) for d in data)
    how = (f"{fs:g} Hz, modes " + ", ".join(f"{f:.1f}" for f in fn) + " Hz (damping "
           + ", ".join(f"{100 * z:.2f}" for z in zeta) + f" %), peak {peak_levels:.0f} levels, {clipped} captures "
           f"at the range's extreme, sessions of {per_session}")
    return Series("scope", how, data, F[:, keep], groups, ses["baseline"] * per_session, (0.5 * fn[0], hi), fs,
                  crb[keep], extra={"scale": scale})


def frf_series(seed: int, counts: dict) -> Series:
    """``frf`` (module docstring)."""
    rng = np.random.default_rng([seed, 3])
    L = float(rng.uniform(0.4, 0.7))
    b, h = 0.03, float(rng.uniform(0.004, 0.008))
    EI, mu = 70e9 * b * h ** 3 / 12, 2700.0 * b * h
    beam_mass = mu * L
    payload_x = float(rng.uniform(0.5, 0.9)) * L
    sensor_x, hammer_x = L, float(rng.uniform(0.25, 0.45)) * L
    kroot = float(rng.uniform(20.0, 80.0)) * EI / L
    nel = 60
    grid = np.linspace(0, L, nel + 1)
    payload_x, hammer_x = (float(grid[np.argmin(np.abs(grid - x))]) for x in (payload_x, hammer_x))
    zeta = tuple(rng.uniform(0.003, 0.015, 5))
    l1, l2 = rng.uniform(0.01, 0.04), rng.uniform(0.05, 0.09)
    g1, g2 = f"payload -{100 * l1:.1f} % of the beam's mass", f"payload -{100 * l2:.1f} % of the beam's mass"
    groups = _groups({"baseline": counts["baseline"], "intact": counts["intact"], g1: counts["damaged"],
                      g2: counts["damaged"]})
    loss = np.array([{g1: l1, g2: l2}.get(g, 0.0) for g in groups])
    nom = Beam(L, EI, mu, root_k_theta_Nm_rad=kroot, masses=(PointMass(payload_x, 0.1 * beam_mass),),
               n_elements=nel)
    f5 = modes(assemble(nom)).frequencies_hz[:5]
    df = float(rng.choice([0.25, 0.5, 1.0]) if f5[-1] > 400 else 0.25)
    freq = np.arange(1, int(1.25 * f5[-1] / df) + 1) * df
    w2 = (2 * np.pi * freq) ** 2
    nt = len(groups)
    ei = 1 + 0.003 * rng.standard_normal(nt)
    root = 1 + rng.uniform(-0.03, 0.03, nt)
    noise = Noise(0.03, 1e-3)
    data, F = [], []
    for i in range(nt):
        beam = Beam(L, EI * ei[i], mu, root_k_theta_Nm_rad=kroot * root[i],
                    masses=(PointMass(payload_x, (0.1 - loss[i]) * beam_mass),), n_elements=nel)
        asm = assemble(beam)
        md = modes(asm)
        dofs = asm.translation_dofs([sensor_x])
        ref = asm.translation_dofs([hammer_x])[0]
        H = receptance(asm, md, Damping("modal", zeta), freq, dofs, ref)
        data.append(measure(-w2 * H, noise, rng) / -w2)                 # receptance; written as accelerance
        F.append(md.frequencies_hz[:5])
        if i == 0:                                                      # the bound of the first baseline test
            band = (freq >= 0.7 * f5[0]) & (freq <= 1.15 * f5[-1])
            crb = crb_frf_rel(freq[band], (-w2 * H)[0, band], F[0], np.array(zeta), noise)
    how = (f"L {L:.2f} m, h {1000 * h:.1f} mm, modes " + ", ".join(f"{f:.0f}" for f in f5)
           + f" Hz, lines of {df:g} Hz, payload at {payload_x / L:.2f} L, hammer at {hammer_x / L:.2f} L")
    return Series("frf", how, data, np.array(F), groups, counts["baseline"], (0.7 * f5[0], 1.15 * f5[-1]), 0.0,
                  crb, freq_hz=freq,
                  extra={"geometry": [0.0, hammer_x, sensor_x], "resp": [3], "ref": 2})


def building_series(seed: int, counts: dict, duration_s: float = 300.0) -> Series:
    """``building`` (module docstring)."""
    rng = np.random.default_rng([seed, 4])
    fs = float(rng.choice([40.0, 50.0, 100.0]))
    f1 = rng.uniform(0.8, 2.0)
    gap = rng.uniform(0.01, 0.03)
    second = rng.uniform(3.0, 3.5)
    fn = np.array([f1, f1 * (1 + gap), f1 * rng.uniform(1.3, 1.6), f1 * second, f1 * second * (1 + gap)])
    fn = np.sort(fn)
    zeta = rng.uniform(0.01, 0.02, fn.size)
    h = np.array([1 / 3, 2 / 3, 1.0])
    first, second_shape = np.sin(np.pi / 2 * h), np.sin(3 * np.pi / 2 * h)
    theta = rng.uniform(-0.3, 0.3, 2)                         # the close pairs' principal directions
    shapes = np.zeros((6, 5))                                 # rows: x at 3 levels, y at 3 levels
    shapes[:3, 0], shapes[3:, 0] = first * np.cos(theta[0]), first * np.sin(theta[0])
    shapes[:3, 1], shapes[3:, 1] = -first * np.sin(theta[0]), first * np.cos(theta[0])
    shapes[:3, 2], shapes[3:, 2] = 0.3 * h, -0.3 * h          # torsion read by offset sensors
    shapes[:3, 3], shapes[3:, 3] = second_shape * np.cos(theta[1]), second_shape * np.sin(theta[1])
    shapes[:3, 4], shapes[3:, 4] = -second_shape * np.sin(theta[1]), second_shape * np.cos(theta[1])
    target = 1
    d1, d2 = rng.uniform(0.01, 0.02), rng.uniform(0.02, 0.04)
    g1, g2 = f"mode 2 -{100 * d1:.1f} %", f"mode 2 -{100 * d2:.1f} %"
    groups = _groups({"baseline": counts["baseline"], "intact": counts["intact"], g1: counts["damaged"],
                      g2: counts["damaged"]})
    nt = len(groups)
    F = fn * (1 + 0.003 * rng.standard_normal((nt, 1)) + 0.0003 * rng.standard_normal((nt, fn.size)))
    drop = np.array([{g1: d1, g2: d2}.get(g, 0.0) for g in groups])
    F[:, target] *= 1 - drop
    n, warm = int(duration_s * fs), int(10 / (zeta.min() * 2 * np.pi * f1) * fs)
    data = []
    for i in range(nt):
        force = rng.standard_normal((fn.size, n + warm))
        q = np.empty((fn.size, n))
        for j in range(fn.size):                              # one exact filter per mode
            wn = 2 * np.pi * F[i, j]
            bz, az, _ = signal.cont2discrete(([1.0, 0.0, 0.0], [1.0, 2 * zeta[j] * wn, wn ** 2]), 1 / fs, "zoh")
            q[j] = signal.lfilter(bz.ravel(), az, force[j])[warm:]
        y = shapes @ q
        y += 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
        data.append(y.astype(np.float32))
    crb = np.sqrt(zeta * fn / (2 * np.pi * duration_s)) / fn
    how = (f"{fs:g} Hz, {duration_s / 60:g} min, modes " + ", ".join(f"{f:.3f}" for f in fn)
           + " Hz (damping " + ", ".join(f"{100 * z:.1f}" for z in zeta) + " %)")
    return Series("building", how, data, F, groups, counts["baseline"], (0.5 * fn[0], min(0.4 * fs, 1.3 * fn[-1])),
                  fs, crb)


#: Each kind: its series and its group sizes (full, quick).
KINDS = {"hammer": (hammer_series, {"baseline": 60, "intact": 40, "damaged": 40},
                    {"baseline": 30, "intact": 15, "damaged": 15}),
         "scope": (scope_series, {"baseline": 40, "intact": 30, "damaged": 30},
                   {"baseline": 30, "intact": 10, "damaged": 10}),
         "frf": (frf_series, {"baseline": 35, "intact": 20, "damaged": 20},
                 {"baseline": 25, "intact": 10, "damaged": 10}),
         "building": (building_series, {"baseline": 40, "intact": 20, "damaged": 20},
                      {"baseline": 25, "intact": 10, "damaged": 10})}


def simulate(kind: str, seed: int, quick: bool = False) -> Series:
    """The series of ``kind`` drawn from ``seed`` (``quick``: fewer tests per group)."""
    make, full, small = KINDS[kind]
    return make(seed, small if quick else full)


# ---------------------------------------------------------------------------------------------------- files

def write_tests(series: Series, folder: Path) -> list:
    """Every test's file as a test system writes it (module docstring): the paths, in order. A file already there
    is replaced when its bytes differ (a rerun after the simulator changed), else kept (the cache reads it)."""
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for k, d in enumerate(series.data):
        suffix = {"frf": "uff", "scope": "csv"}.get(series.kind, "npz")
        path = folder / f"test_{k:03d}.{suffix}"
        tmp = folder / f".test_{k:03d}.tmp.{suffix}"
        if series.kind == "frf":
            g = series.extra["geometry"]
            write_uff(tmp, series.freq_hz, d, g, series.extra["resp"], series.extra["ref"], kind="accelerance",
                      description=f"bench_unseen frf test {k}")
        elif series.kind == "scope":
            t = np.arange(d.shape[1]) / series.sampling_frequency_hz
            body = "\n".join(f"{a:.6f},{v:.7g}" for a, v in zip(t, d[0]))
            tmp.write_text("# quantity: acceleration\ntime_s,1:+Y\n" + body + "\n")
        else:
            np.savez(tmp, signals=d, sampling_frequency_hz=np.float64(series.sampling_frequency_hz))
        if path.is_file() and path.read_bytes() == tmp.read_bytes():
            tmp.unlink()
        else:
            os.replace(tmp, path)
        files.append(str(path))
    return files


# ---------------------------------------------------------------------------------------------- plain tests

def frf_peaks(H, freq_hz, windows_hz) -> np.ndarray:
    """``(m,)`` frequency (Hz) of each mode from FRFs ``H`` (n_channels, n_lines): the line of the largest
    ``sum |H|`` in the mode's window, refined by the parabola through ``ln sum |H|`` at it and its two neighbours;
    NaN where the largest line is the window's edge (no peak there)."""
    mag = np.log(np.sum(np.abs(H), axis=0))
    out = np.full(len(windows_hz), np.nan)
    df = freq_hz[1] - freq_hz[0]
    for j, (lo, hi) in enumerate(windows_hz):               # one slice per mode
        idx = np.flatnonzero((freq_hz >= lo) & (freq_hz <= hi))
        k = idx[np.argmax(mag[idx])]
        if k in (idx[0], idx[-1]) or k in (0, mag.size - 1):
            continue
        a, b, c = mag[k - 1], mag[k], mag[k + 1]
        out[j] = freq_hz[k] + df * (0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0)
    return out


def frf_reference(data, freq_hz, band_hz) -> np.ndarray:
    """The baseline's modes on the FRF peaks: the prominent local maxima of the baseline's mean ``ln sum |H|``."""
    mag = np.mean([np.log(np.sum(np.abs(H), axis=0)) for H in data], axis=0)
    sel = (freq_hz >= band_hz[0]) & (freq_hz <= band_hz[1])
    peaks, _ = signal.find_peaks(np.where(sel, mag, -np.inf), prominence=1.0)
    return freq_hz[peaks]


def plain_frequencies(series: Series) -> tuple:
    """``(reference modes (Hz), (n, m) frequencies)`` of the FFT (FRF) peaks on every test."""
    nb = series.n_baseline
    if series.kind == "frf":
        ref = frf_reference(series.data[:nb], series.freq_hz, series.band_hz)
        win = mode_windows_hz(ref, series.band_hz)
        return ref, np.array([frf_peaks(H, series.freq_hz, win) for H in series.data])
    fs = np.full(len(series.data), series.sampling_frequency_hz)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = reference_fft_modes(series.data[:nb], fs[:nb], series.band_hz)
        return ref, fft_frequencies(series.data, fs, mode_windows_hz(ref, series.band_hz))


def plain_flags(F, n_baseline: int, rate: float) -> dict:
    """The two plain tests' alarms (bool (n,)): two-sided p-value below ``rate``
    (:func:`~experiments.benches.plain_tests.plain_p_values`, each baseline test held out)."""
    p = plain_p_values(F, n_baseline)
    return {k: np.isfinite(v) & (v < rate) for k, v in p.items()}


# ---------------------------------------------------------------------------------------------- scoring

def _matched(F, truth) -> np.ndarray:
    """Each test's estimate of each true mode (n, m_true): the estimate matched within 3 % (NaN: none)."""
    return np.array([match_modes(f[np.isfinite(f)], t) for f, t in zip(F, truth)])


def _scatter_pct(E, truth, nb) -> np.ndarray:
    """Per true mode: 100 x the std over the baseline tests of ``E / truth - 1`` (NaN with fewer than 3)."""
    r = E[:nb] / truth[:nb] - 1
    ok = np.isfinite(r)
    return np.array([100 * np.std(r[ok[:, j], j], ddof=1) if ok[:, j].sum() >= 3 else np.nan
                     for j in range(r.shape[1])])


def score_series(series: Series, flags: dict, mon_F, fft_F, rate: float) -> list:
    """One row per group: the tests with every true mode found (monitor / FFT), each method's flagged share, and
    the loss marks (module docstring): on a damaged group, the plain tests flagging a larger share than
    ``monitor``; on ``intact``, those flagging a smaller share of the healthy tests (the held-out baseline and
    ``intact``) where ``monitor`` flags more than twice ``rate`` of them."""
    groups = np.asarray(series.groups)
    mon_E, fft_E = _matched(mon_F, series.truth_hz), _matched(fft_F, series.truth_hz)
    healthy = np.isin(groups, ("baseline", "intact"))
    fa = {k: float(v[healthy].mean()) for k, v in flags.items()}
    rows = []
    for g in dict.fromkeys(series.groups):
        sel = groups == g
        row = {"group": g, "n": int(sel.sum()), "monitor found": int(np.isfinite(mon_E[sel]).all(axis=1).sum()),
               "fft found": int(np.isfinite(fft_E[sel]).all(axis=1).sum()),
               **{k: float(v[sel].mean()) for k, v in flags.items()}}
        if g == "intact":
            row["healthy flagged"] = fa
            row["loss"] = [k for k in PLAIN if fa["monitor"] > max(2 * rate, fa[k])]
        elif g == "baseline":
            row["loss"] = []
        else:
            row["loss"] = [k for k in PLAIN if row["monitor"] < row[k]]
        rows.append(row)
    return rows


def run_series(series: Series, out: Path, rate: float) -> dict:
    """``monitor`` through the CLI and the plain tests on one series; the per-test results and the rows."""
    t0 = time.perf_counter()
    folder = out / series.kind
    files = write_tests(series, folder / "tests")
    t_write = time.perf_counter() - t0
    argv = ["monitor", *files, "--baseline-tests", str(series.n_baseline), "--band", f"{series.band_hz[0]:.6g}",
            f"{series.band_hz[1]:.6g}", "--false-alarm-rate", str(rate), "--chart", "none", "--out",
            str(folder / "monitor")]
    error = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = cli_json(argv)
    except RuntimeError as exc:
        error, res = str(exc), {"tests": []}
    t_mon = time.perf_counter() - t0 - t_write
    n = len(files)
    status = [r["status"] for r in res["tests"]] or ["refused"] * n
    mon_F = np.array([[np.nan if v is None else v for v in r["frequencies_hz"]] for r in res["tests"]]) \
        if res["tests"] else np.full((n, 0), np.nan)
    ref, fft_F = plain_frequencies(series)
    flags = {"monitor": np.array([s in FLAGGED_STATUSES for s in status]),
             **plain_flags(fft_F, series.n_baseline, rate)}
    truth, nb = series.truth_hz, series.n_baseline
    mon_E, fft_E = _matched(mon_F, truth), _matched(fft_F, truth)
    nv = res.get("normal_variation") or {}
    return {"kind": series.kind, "how": series.how, "n": n, "n_baseline": nb, "band_hz": list(series.band_hz),
            "monitor_error": error, "monitor_reference_hz": nv.get("reference_frequencies_hz"),
            "frequency_estimators": (nv.get("frequency_estimators") or {}).get("texts"),
            "fft_reference_hz": ref.tolist(), "truth_nominal_hz": np.median(truth[:nb], axis=0).tolist(),
            "scatter_pct": {"monitor": _scatter_pct(mon_E, truth, nb).tolist(),
                            "fft": _scatter_pct(fft_E, truth, nb).tolist(),
                            "crb": (100 * series.crb_rel).tolist()},
            "status": status, "groups": list(series.groups), "errors": [r.get("error") for r in res["tests"]],
            "flags": {k: v.tolist() for k, v in flags.items()}, "rows": score_series(series, flags, mon_F, fft_F, rate),
            "monitor_frequencies_hz": mon_F.tolist(), "fft_frequencies_hz": fft_F.tolist(),
            "seconds": {"write": t_write, "monitor": t_mon, "total": time.perf_counter() - t0}}


def _g(v, fmt="{:.2g}") -> str:
    return "-" if v is None or not np.isfinite(v) else fmt.format(v)


def markdown(results: list, rate: float, command: str) -> str:
    """The table (module docstring) and each series' configuration under it."""
    head = ["series", "group", "n", "all modes found: monitor / FFT", "scatter (%): monitor / FFT / CRB",
            "monitor", "monitor's statuses", *PLAIN, "loss"]
    lines, notes = [], []
    for res in results:
        sc = res["scatter_pct"]
        scatter = "; ".join(f"{f:.4g} Hz: {_g(a)} / {_g(b)} / {_g(c)}" for f, a, b, c in
                            zip(res["truth_nominal_hz"], sc["monitor"], sc["fft"], sc["crb"]))
        groups = np.asarray(res["groups"])
        for k, r in enumerate(res["rows"]):
            base = r["group"] == "baseline"
            st = Counter(s for s, g in zip(res["status"], groups) if g == r["group"])
            statuses = ", ".join(f"{SHORT.get(s, s)} {c}" for s, c in st.most_common())
            loss = ("**LOSS** (" + ", ".join(r["loss"]) + ")") if r["loss"] else ""
            lines.append([res["kind"] if k == 0 else "", "baseline (held out)" if base else r["group"], r["n"],
                          f"{r['monitor found']} / {r['fft found']}", scatter if base else "",
                          f"{100 * r['monitor']:.0f} %", statuses, *(f"{100 * r[c]:.0f} %" for c in PLAIN), loss])
        notes.append(f"{res['kind']}: {res['how']}; band {res['band_hz'][0]:.3g}-{res['band_hz'][1]:.3g} Hz; "
                     f"monitor's modes " + ", ".join(f"{v:.4g}" for v in res["monitor_reference_hz"] or [])
                     + " Hz; FFT peaks' modes " + ", ".join(f"{v:.4g}" for v in res["fft_reference_hz"]) + " Hz"
                     + (f"; monitor refused: {res['monitor_error']}" if res["monitor_error"] else "")
                     + (f"; estimators: {'; '.join(res['frequency_estimators'])}" if res["frequency_estimators"]
                        else ""))
    return (table(head, lines) + "\n\n" + "\n\n".join(notes)
            + f"\n\nShare of each group flagged at {rate:g} false alarms (`intact`: false alarms; baseline: held "
            "out). Scatter: the std over the baseline tests of each true mode's estimate less its true frequency, "
            f"relative. `{command}`")


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_unseen", seed=0)
    p.add_argument("--kinds", nargs="+", choices=list(KINDS), default=list(KINDS))
    p.add_argument("--quick", action="store_true", help="fewer tests per group (under 2 minutes)")
    p.add_argument("--rate", type=float, default=0.01, help="false-alarm rate (default 0.01)")
    p.add_argument("--from-json", action="store_true", help="only re-write the table from OUT's unseen.json")
    a = p.parse_args(argv)
    out = Path(a.out) / (f"seed{a.seed}" + ("-quick" if a.quick else ""))
    results = []
    if a.from_json:
        saved = json.loads((out / "unseen.json").read_text())
        results = [r for r in saved["series"] if r["kind"] in a.kinds]
        for r in results:                               # the rows again, at this code's marks (the truth re-drawn)
            series = simulate(r["kind"], a.seed, a.quick)
            flags = {k: np.asarray(v, bool) for k, v in r["flags"].items()}
            r["rows"] = score_series(series, flags, np.array(r["monitor_frequencies_hz"], float),
                                     np.array(r["fft_frequencies_hz"], float), a.rate)
    for kind in [] if a.from_json else a.kinds:
        t0 = time.perf_counter()
        series = simulate(kind, a.seed, a.quick)
        t_sim = time.perf_counter() - t0
        res = run_series(series, out, a.rate)
        res["seconds"]["simulate"] = t_sim
        print(f"{kind}: {res['n']} tests, simulated {t_sim:.0f} s, written {res['seconds']['write']:.0f} s, "
              f"monitor {res['seconds']['monitor']:.0f} s", flush=True)
        results.append(res)
    command = "python -m experiments.benches.bench_unseen" + (" --quick" if a.quick else "") + \
        (f" --seed {a.seed}" if a.seed else "") + \
        (f" --kinds {' '.join(a.kinds)}" if list(a.kinds) != list(KINDS) else "")
    md = markdown(results, a.rate, command)
    print(md)
    atomic_write_text(out / "unseen.json", json.dumps({"rate": a.rate, "seed": a.seed, "quick": a.quick,
                                                       "series": results}, indent=1, default=float))
    atomic_write_text(out / "unseen.md", md + "\n")
    publish(a, "unseen", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
