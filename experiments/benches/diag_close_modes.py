"""Synthetic check of `era` on a DS5-like shared band: 1.2 %-damped modes close enough to be fitted in one band,
0.1 s at 50 kHz, white noise; each mode's scatter over the records against its Cramér-Rao bound and the FFT peak's.

``python -m experiments.benches.diag_close_modes [--reps 12] [--pair 3909 4768]``
"""

from __future__ import annotations

import warnings

import numpy as np

from experiments.benches.harness import parser
from experiments.benches.bench_precision import match_modes
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era

__all__ = ["crb_hz", "main", "records"]

FS_HZ, DURATION_S, NOISE = 50000.0, 0.1, 2e-3
BAND_HZ = (500.0, 5500.0)


def _modes(pair_hz):
    """(frequencies (Hz), damping ratios, sine amplitudes) of the record: a strong 804-Hz mode and the pair."""
    return np.r_[804.0, pair_hz], np.array([0.005, 0.012, 0.012]), np.array([1.0, 0.3, 0.3])


def records(pair_hz, reps, seed):
    """``reps`` free decays, shape (reps, n_samples), each mode's amplitude scaled by U(0.8, 1.2)."""
    rng = np.random.default_rng(seed)
    f, z, a = _modes(pair_hz)
    t = np.arange(int(round(DURATION_S * FS_HZ))) / FS_HZ
    w = 2 * np.pi * f
    basis = np.exp(-(z * w)[:, None] * t) * np.sin((w * np.sqrt(1 - z ** 2))[:, None] * t)
    y = (rng.uniform(0.8, 1.2, (reps, f.size)) * a) @ basis
    return y + NOISE * rng.standard_normal(y.shape)


def crb_hz(pair_hz) -> np.ndarray:
    """Cramér-Rao bound (Hz) of each mode's frequency from one nominal record (sine amplitudes, phases unknown)."""
    f, z, a = _modes(pair_hz)
    t = np.arange(int(round(DURATION_S * FS_HZ))) / FS_HZ
    wd, sig = 2 * np.pi * f * np.sqrt(1 - z ** 2), z * 2 * np.pi * f
    env = np.exp(-sig[:, None] * t)
    c, s = env * np.cos(wd[:, None] * t), env * np.sin(wd[:, None] * t)
    J = np.concatenate([(a[:, None] * t * c), -(a[:, None] * t * s), c, s]).T
    return np.sqrt(np.diag(np.linalg.inv(J.T @ J / NOISE ** 2))[:f.size]) / (2 * np.pi)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, seed=0)
    p.add_argument("--reps", type=int, default=12)
    p.add_argument("--pair", type=float, nargs=2, default=(3909.0, 4768.0), help="the close pair (Hz)")
    args = p.parse_args(argv)
    truth = _modes(args.pair)[0]
    got = {"era": [], "fftpeak": []}
    for y in records(args.pair, args.reps, args.seed):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            got["era"].append(match_modes(identify_era(y[None], FS_HZ, BAND_HZ).estimate.natural_frequencies_hz,
                                          truth))
            got["fftpeak"].append(match_modes(identify_fft_peaks(y[None], FS_HZ, BAND_HZ)[0].natural_frequencies_hz,
                                              truth))
    crb = crb_hz(args.pair)
    print("modes (Hz)", truth, "CRB (Hz)", np.round(crb, 3))
    for m, v in got.items():
        v = np.array(v)
        std = np.nanstd(v, axis=0, ddof=1)
        print(f"{m:8s} found {np.isfinite(v).sum(0)} bias {np.round(np.nanmean(v, 0) - truth, 2)} std "
              f"{np.round(std, 3)} std/CRB {np.round(std / crb, 2)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
