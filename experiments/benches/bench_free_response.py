"""How often :func:`~physics.identification.decays.free_response` judges a record right, and what the misjudged
records lose: a seeded family of realistic hammer-test records and the real sets.

The synthetic records are exact half-sine hammer-pulse responses (:mod:`experiments.benches.impact_records`: the
convolution in closed form, no time stepping) summed over hits and channels, then given what real captures have:
pre-trigger (0 to 50 % of the record), several hits (a roving hammer, a double hit), white noise, quantisation, a DC
offset and a slow drift, clipping at the hit, a sensor far from the hit (a weak first mode). Levels are of the
ringing's peak (the record's peak but the pulse's, whose direct term the truncated modal sum makes a spike); the
quantiser's range and the clipping, of the record's peak. Stationary controls: the same modes driven by white noise
(each mode's impulse-invariant two-pole filter), in steady state or started from rest with the record (a shaker
switched on with the capture: quiet for its first tenths of a second). ``identify``/``monitor`` use era for a record
judged free, SSI-cov otherwise (:mod:`physics.identification.output_only`); a misjudged case is measured by the
scatter of mode 1's frequency over seeds with era and with SSI-cov.

A record free by its lead alone (its decays falling less than 6 dB) is read by SSI-cov first and kept so when its
decays fall more than 6 dB short of what SSI-cov's slowest mode would give (a stationary response started quiet);
``--lead`` prints, for those records of each case (and of the independent simulator's ambient series with
``--series-seeds``), their fall, SSI-cov's modes' least fall and the method ``auto`` uses.

Run: ``python -m experiments.benches.bench_free_response [--seeds N] [--only NAME ...] [--real] [--loss] [--lead]
[--series-seeds 0 1 2 3 4 5 --series-tests 40]``
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from experiments.benches import bench_real_series as brs
from experiments.benches.impact_records import ImpactCase, impact_records
from experiments.second_sim.series import SeriesConfig, simulate_series
from physics.errors import ConvergenceError, ShapeError
from physics.identification.channel_weights import noise_floor_weights, weighted_record
from physics.identification.decays import FREE_DROP_DB, free_response, least_fall_db
from physics.identification.output_only import identify_records
from physics.identification.record_checks import check_records
from physics.identification.ssi import identify_ssi
from physics.io.timedata import TimeRecords

__all__ = ["Family", "CASES", "lead_alone", "record", "verdict", "main"]

#: A lab frame's modes (Hz) and damping ratios, and its four channels' mode shapes at the sensors.
FRAME_FN_HZ = (5.3, 17.0, 31.0, 47.0, 59.0)
FRAME_ZETA = (0.01, 0.005, 0.02, 0.03, 0.015)
FRAME_PHI = np.array([[1.0, 0.8, 0.6, -0.5, 0.4], [0.7, -0.6, -0.9, 1.0, -0.3], [0.4, -1.0, 0.3, -0.8, 0.9],
                      [0.9, 0.4, -0.6, 0.4, -1.0]])


@dataclass(frozen=True)
class Family:
    """One case of the family: a record's make-up (times as fractions of the record, levels of its peak)."""

    name: str
    fs_hz: float = 500.0
    n: int = 4096
    fn_hz: tuple = FRAME_FN_HZ
    zeta: tuple = FRAME_ZETA
    channels: int = 1
    hits: tuple = (0.02,)          # hit times (fraction of the record)
    gains: tuple = (1.0,)
    noise: float = 1e-2            # white noise std / the ringing's peak (the record's peak but the pulse)
    bits: int = 0                  # quantisation over 1.2 x the record's peak (the pulse's, set by the hit; 0: none)
    dc: float = 0.0                # offset / the ringing's peak
    drift: float = 0.0             # slow drift's amplitude / the ringing's peak (a 0.3-cycle sine over the record)
    clip: float = 0.0              # clipped at this fraction of the record's peak (0: not)
    weak_mode1: float = 1.0        # mode 1's amplitude factor (sensor far from the hit)
    stationary: bool = False       # white-noise driven instead of hit
    from_rest: bool = False        # the white-noise forcing starts with the record (else in steady state)
    pulse_samples: float = 2.0     # the half-sine's duration (samples)

    @property
    def truth(self) -> str:
        return "stationary" if self.stationary else "free"


def _phi(fam):
    phi = FRAME_PHI[:fam.channels, :len(fam.fn_hz)].copy()
    phi[:, 0] *= fam.weak_mode1
    return phi


def _impacts(fam, rng):
    """Noise-free acceleration of every channel: each hit's exact half-sine response, shape (channels, n)."""
    y = np.zeros((fam.channels, fam.n))
    for t, g in zip(fam.hits, fam.gains):
        for c, shape in enumerate(_phi(fam)):
            case = ImpactCase(fam.fn_hz, fam.zeta, tuple(g * shape), fam.fs_hz, fam.n, t * fam.n / fam.fs_hz
                              + rng.uniform(0, 1) / fam.fs_hz, fam.pulse_samples / fam.fs_hz, 1.0, 0.0)
            y[c] += impact_records(case, 1, 0)[1][0]
    return y


def _ambient(fam, rng):
    """Noise-free acceleration of every channel under white-noise forcing: each mode's exact impulse-invariant
    response (a two-pole filter of the mode's poles), shape (channels, n)."""
    from scipy import signal

    warm = 0 if fam.from_rest else 4 * int(fam.fs_hz / (min(fam.zeta) * 2 * np.pi * min(fam.fn_hz)))
    w = rng.standard_normal(fam.n + warm)
    q = np.zeros((len(fam.fn_hz), fam.n))
    for j, (f, z) in enumerate(zip(fam.fn_hz, fam.zeta)):
        lam = 2 * np.pi * f * (-z + 1j * np.sqrt(1 - z * z))
        p = np.exp(lam / fam.fs_hz)
        q[j] = signal.lfilter([0.0, 1.0], [1.0, -2 * p.real, abs(p) ** 2], w)[warm:] * (2 * np.pi * f) ** 1.5
    return _phi(fam) @ q


def record(fam: Family, seed: int) -> np.ndarray:
    """A seeded record of ``fam``: shape (channels, n)."""
    rng = np.random.default_rng(seed)
    y = _ambient(fam, rng) if fam.stationary else _impacts(fam, rng)
    full = np.abs(y).max()
    ring = np.ones(fam.n, bool)                       # the ringing: the record but the pulses
    for t in fam.hits:
        k = int(t * fam.n)
        ring[k:k + int(fam.pulse_samples) + 3] = False
    peak = np.abs(y[:, ring]).max()
    y = y + fam.noise * peak * rng.standard_normal(y.shape)
    t = np.arange(fam.n) / fam.n
    y = y + peak * (fam.dc + fam.drift * np.sin(2 * np.pi * 0.3 * t + rng.uniform(0, 2 * np.pi)))
    if fam.clip:
        y = np.clip(y, -fam.clip * full, fam.clip * full)
    if fam.bits:
        lsb = 2.4 * full / 2 ** fam.bits
        y = np.round(y / lsb) * lsb
    return y


def _checked(y, fs_hz, band_hz=None):
    """The record as ``identify``/``monitor`` take it: checked, and with several channels weighted."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        checked = check_records(y, fs_hz, band_hz)
        if y.shape[0] > 1:
            weights = noise_floor_weights(checked, "bench")
            if weights is not None:
                checked = weighted_record(checked, weights)
        return checked


def verdict(y, fs_hz) -> bool:
    """``free_response``'s verdict as ``identify``/``monitor`` take it: on the channel-weighted checked record."""
    return free_response(_checked(y, fs_hz)).free


def lead_alone(y, fs_hz, band_hz=None):
    """For a record free by its lead alone: ``(its fall (dB), the least fall of the modes SSI-cov reads in it as a
    stationary response (dB; NaN when it finds none), the method auto reads it with)``; None for any other record."""
    checked = _checked(y, fs_hz, band_hz)
    v = free_response(checked)
    if not (v.free and v.decays.drop_db < FREE_DROP_DB):
        return None
    recs = TimeRecords(1 / fs_hz, y, tuple(f"{k + 1}:+X" for k in range(y.shape[0])), ("acceleration",) * y.shape[0],
                       {"source": "bench"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            est = identify_ssi(checked, fs_hz, band_hz, refine_decays=False, free=False).estimate
            least = least_fall_db(v.decays, est.natural_frequencies_hz, est.damping_ratios, fs_hz)
        except (ConvergenceError, ShapeError):             # SSI-cov finds no mode
            least = np.nan
        method = identify_records(recs, "auto", band_hz).estimate.method
    return v.decays.drop_db, least, method


def _lead_row(name, found) -> str:
    found = [r for r in found if r is not None]
    if not found:
        return f"| {name} | 0 | | | |"
    drop, least, method = (np.array(c) for c in zip(*found))
    reads = ", ".join(f"{m} {int(np.sum(method == m))}" for m in sorted(set(method)))
    return (f"| {name} | {len(found)} | {drop.min():.1f} to {drop.max():.1f} | {np.nanmin(least):.1f} to "
            f"{np.nanmax(least):.1f} | {reads} |")


B = Family("base: 1 ch, 1 hit, 2 % pre-trigger, noise 1e-2")
CASES = [
    B,
    replace(B, name="hit at sample 0", hits=(0.0,)),
    replace(B, name="pre-trigger 10 %", hits=(0.10,)),
    replace(B, name="pre-trigger 25 %", hits=(0.25,)),
    replace(B, name="pre-trigger 50 % (mid-record)", hits=(0.50,)),
    replace(B, name="4 channels", channels=4),
    replace(B, name="4 channels, pre-trigger 50 %", channels=4, hits=(0.5,)),
    replace(B, name="roving hammer, 3 hits", hits=(0.05, 0.37, 0.69), gains=(1.0, -0.7, 1.3)),
    replace(B, name="roving hammer, 5 hits", hits=(0.03, 0.22, 0.41, 0.6, 0.79), gains=(1.0, -0.7, 1.3, 0.6, -1.1)),
    replace(B, name="roving, 4 ch, 3 hits", channels=4, hits=(0.05, 0.37, 0.69), gains=(1.0, -0.7, 1.3)),
    replace(B, name="double hit (+10 ms, 0.3)", hits=(0.02, 0.02 + 0.01 * 500 / 4096), gains=(1.0, 0.3)),
    replace(B, name="light damping 0.05 %", zeta=(0.0005,) * 5),
    replace(B, name="light damping 0.05 %, hit at 0", zeta=(0.0005,) * 5, hits=(0.0,)),
    replace(B, name="light damping 0.05 %, pre-trigger 25 %", zeta=(0.0005,) * 5, hits=(0.25,)),
    replace(B, name="heavy damping 5 %", zeta=(0.05,) * 5),
    replace(B, name="heavy damping 5 %, pre-trigger 50 %", zeta=(0.05,) * 5, hits=(0.5,)),
    replace(B, name="noise 1e-4", noise=1e-4),
    replace(B, name="noise 1e-3", noise=1e-3),
    replace(B, name="noise 1e-1", noise=1e-1),
    replace(B, name="noise 1e-1, pre-trigger 25 %", noise=1e-1, hits=(0.25,)),
    replace(B, name="noise 1e-1, light damping", noise=1e-1, zeta=(0.0005,) * 5),
    replace(B, name="8-bit", bits=8, noise=1e-4),
    replace(B, name="12-bit", bits=12, noise=1e-4),
    replace(B, name="DC offset 5x peak", dc=5.0),
    replace(B, name="slow drift 0.3 peak", drift=0.3),
    replace(B, name="DC + drift, 12-bit, pre-trigger 25 %", dc=2.0, drift=0.1, bits=12, hits=(0.25,)),
    replace(B, name="clipped at 30 % of peak", clip=0.3),
    replace(B, name="weak mode 1 (0.02)", weak_mode1=0.02),
    replace(B, name="weak mode 1, noise 1e-1", weak_mode1=0.02, noise=1e-1),
    replace(B, name="hammer rig 5120 Hz, 8192, 40-1500 Hz", fs_hz=5120.0, n=8192,
            fn_hz=(40.0, 180.0, 420.0, 800.0, 1500.0), zeta=(0.01, 0.008, 0.01, 0.02, 0.02)),
    replace(B, name="ambient (stationary)", stationary=True, hits=(), noise=1e-2),
    replace(B, name="ambient, 4 ch", stationary=True, hits=(), channels=4),
    replace(B, name="ambient, light damping 0.5 %", stationary=True, hits=(), zeta=(0.005,) * 5),
    replace(B, name="ambient, 8-bit, drift", stationary=True, hits=(), bits=8, drift=0.2),
    replace(B, name="ambient, noise 0.3", stationary=True, hits=(), noise=0.3),
    replace(B, name="ambient, noise 1", stationary=True, hits=(), noise=1.0),
    replace(B, name="ambient, 4 ch, noise 1", stationary=True, hits=(), channels=4, noise=1.0),
    replace(B, name="ambient started from rest", stationary=True, hits=(), from_rest=True),
    replace(B, name="ambient from rest, 4 ch", stationary=True, hits=(), channels=4, from_rest=True),
    replace(B, name="ambient from rest, light damping 0.5 %", stationary=True, hits=(), zeta=(0.005,) * 5,
            from_rest=True),
    replace(B, name="ambient from rest, 60 s at 1 kHz", stationary=True, hits=(), fs_hz=1000.0, n=60000,
            from_rest=True),
]


def mode1_std_hz(fam: Family, seeds, method: str) -> float:
    """Scatter (std over ``seeds``) of mode 1's frequency identified by ``method`` (nearest to the truth)."""
    f = []
    for s in seeds:
        y = record(fam, s)
        recs = TimeRecords(1 / fam.fs_hz, y, tuple(f"{k + 1}:+X" for k in range(y.shape[0])),
                           ("acceleration",) * y.shape[0], {"source": "bench"})
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fn = identify_records(recs, method).estimate.natural_frequencies_hz
            f.append(fn[np.argmin(np.abs(fn - fam.fn_hz[0]))])
        except Exception:                               # a method that finds no mode: counted as missing
            f.append(np.nan)
    f = np.asarray(f)
    return float(np.nanstd(f, ddof=1)) if np.sum(np.isfinite(f)) > 1 else np.nan


def real_verdicts(directory=None):
    """``(set, n_free, n_records, truth)`` of every real set found."""
    directory = Path(directory or brs.DATA)
    rows = []
    for key in ("ds5-shock", "ds5-impedance", "bridge", "dropbear", "ds11-b4.6", "ds11-b3.4"):
        file, load = brs.LOADERS[key]
        if not (directory / file).is_file():
            continue
        s = load(directory / file, False)
        v = [verdict(np.asarray(r, float), float(fs)) for r, fs in zip(s.records, s.sampling_frequency_hz)]
        rows.append((key, int(np.sum(v)), len(v), "free"))
    if (directory / "pyfrf_hits.npz").is_file():
        z = np.load(directory / "pyfrf_hits.npz")
        v = [verdict(r[None], float(z["sampling_frequency_hz"])) for r in z["response"]]
        rows.append(("pyfrf", int(np.sum(v)), len(v), "free"))
    if (directory / "hct_setups.npz").is_file():
        z = np.load(directory / "hct_setups.npz")
        v = [verdict(z[f"setup{k}"], float(z["sampling_frequency_hz"])) for k in range(1, 5)]
        rows.append(("hct setups", int(np.sum(v)), len(v), "stationary"))
    if (directory / "usc_bridge_a_impacts.npz").is_file():
        z = np.load(directory / "usc_bridge_a_impacts.npz")
        v = [verdict(r[None], float(z["ambient_sampling_frequency_hz"])) for r in z["ambient_records"]]
        rows.append(("bridge ambient (footfall-like events)", int(np.sum(v)), len(v), "ambient"))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--only", nargs="*", default=None, help="case names containing any of these")
    ap.add_argument("--real", action="store_true", help="the real sets too")
    ap.add_argument("--loss", action="store_true", help="mode 1 scatter with era and SSI-cov of misjudged cases")
    ap.add_argument("--lead", action="store_true", help="the records free by their lead alone: their fall, SSI-cov's "
                                                          "least fall and the method auto uses")
    ap.add_argument("--series-seeds", type=int, nargs="*", default=[],
                    help="with --lead: the independent simulator's ambient series of these seeds too")
    ap.add_argument("--series-tests", type=int, default=40, help="tests of each simulator series (default 40)")
    a = ap.parse_args(argv)
    print("| case | truth | free / stationary | method used | mode 1 std era / used (Hz) |")
    print("|---|---|---|---|---|")
    for fam in CASES:
        if a.only and not any(o in fam.name for o in a.only):
            continue
        v = np.array([verdict(record(fam, s), fam.fs_hz) for s in range(a.seeds)])
        used = "era" if v.all() else "SSI-cov" if not v.any() else "era / SSI-cov"
        wrong = np.mean(v != (fam.truth == "free"))
        loss = ""
        if a.loss and wrong > 0 and not fam.stationary:
            seeds = range(6)
            loss = f"{mode1_std_hz(fam, seeds, 'era'):.2g} / {mode1_std_hz(fam, seeds, 'ssi'):.2g}"
        print(f"| {fam.name} | {fam.truth} | {v.sum()} / {v.size - v.sum()} | {used} | {loss} |", flush=True)
    if a.real:
        for name, k, m, truth in real_verdicts():
            print(f"| real: {name} | {truth} | {k} / {m - k} | | |", flush=True)
    if a.lead:
        print("\n| case | free by its lead alone | their fall (dB) | SSI-cov's modes' least fall (dB) | auto reads |")
        print("|---|---|---|---|---|")
        for fam in CASES:
            if a.only and not any(o in fam.name for o in a.only):
                continue
            print(_lead_row(fam.name, [lead_alone(record(fam, s), fam.fs_hz) for s in range(a.seeds)]), flush=True)
        for seed in a.series_seeds:
            tests = simulate_series(SeriesConfig(n_tests=a.series_tests, kind="output-only", damage_day=None,
                                                 seed=seed))
            found = [lead_alone(t.record.signals, t.record.sampling_frequency_hz, (5.0, 400.0)) for t in tests]
            print(_lead_row(f"simulator's ambient series, seed {seed} ({a.series_tests} tests)", found), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
