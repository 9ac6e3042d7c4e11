"""Per-shock diagnosis of `era` on the DS5 board's baseline shocks (the 3909-Hz mode): era's poles, the FFT peak,
the band refinement's groups and bands, and a fit of the 3.6-5.1 kHz band alone with two and three poles;
``--models``: the 3909-Hz mode's scatter over the shocks for other models of that band (poles, background order),
the three-pole fit's residual against the pre-trigger noise, and shock 1's pole against the first sample fitted.

``python -m experiments.benches.diag_ds5_era [--brief] [--start 520] [--models]``
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser
from experiments.benches.bench_precision import match_modes
from physics.identification.band_refine import refine_in_bands
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era

__all__ = ["main"]

REF_HZ = np.array([804.0, 2392.0, 3909.0, 4768.0])
BAND_HZ = (500.0, 5500.0)
DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "ds5_pcb_repeated_shock.npz"


def shocks(n=15, start=520):
    """The baseline shocks as ``_ds5_shock`` cuts them (from sample ``start``; the clipped peak is sample 500):
    (records (n, samples), fs (n,))."""
    z = np.load(DATA)
    return z["pcb_records"][:n, start:].astype(float), np.asarray(z["pcb_sampling_frequency_hz"], float)[:n]


def _lam(f_hz, zeta):
    w = 2 * np.pi * np.asarray(f_hz, float)
    return -np.asarray(zeta) * w + 1j * w * np.sqrt(1 - np.asarray(zeta) ** 2)


def _details(k, r, fft_hz, y, fs):
    """One shock's lines: era's poles in 3.5-5.2 kHz, the band refinement's, the seeded, the band fitted alone."""
    f = r.estimate.natural_frequencies_hz
    b = r.bands
    sel = (f > 3500) & (f < 5200)
    print(f"shock {k + 1:2d}: era 3.5-5.2k {np.round(f[sel], 1)} std {np.round(r.estimate.frequency_std_hz[sel], 1)}"
          f" zeta% {np.round(100 * r.estimate.damping_ratios[sel], 2)}; fft {np.round(fft_hz[2:], 1)}")
    if b is not None:
        fb = b.natural_frequencies_hz
        s = (fb > 3500) & (fb < 5200)
        print(f"    kept poles {np.round(fb[s], 1)} group {b.group[s]} merged {b.merged[s]} conv {b.converged[s]}"
              f" bands {np.round(b.bands_hz[s], 0).tolist()}")
    sd = r.seeded.eigenvalues
    if sd.size:
        print(f"    seeded {np.round(np.abs(sd) / 2 / np.pi, 1)}")
    x = y[None] - y.mean()
    for start in ([3909, 4768], [3909, 4768, 4900]):
        try:
            bf = refine_in_bands([x], fs, _lam(start, 0.012))
            print(f"    alone {len(start)} poles: {np.round(bf.natural_frequencies_hz, 1)} "
                  f"std {np.round(bf.frequency_std_hz, 1)} zeta% {np.round(100 * bf.damping_ratios, 2)} "
                  f"merged {bf.merged} conv {bf.converged}")
        except Exception as err:                        # a diagnostic: print, go on
            print(f"    alone {len(start)}: {err}")


#: Models of the band 3.6-5.1 kHz: starting frequencies (Hz) and damping ratios.
MODELS = {"2 poles": ([3909, 4768], [0.012, 0.012]), "3 poles": ([3909, 4768, 4900], [0.012, 0.012, 0.005]),
          "3 poles (4.3k)": ([3909, 4300, 4768], [0.012, 0.03, 0.012]),
          "4 poles (4.3k)": ([3909, 4300, 4768, 4900], [0.012, 0.03, 0.012, 0.005])}


def _transform(n, fs, eigenvalues, amplitudes):
    """The DFT (lines 0 .. n // 2) of the modes ``Re(a z^t)`` of one channel over ``n`` samples, summed (the closed
    form of :mod:`physics.identification.band_refine`)."""
    w = np.exp(-2j * np.pi * np.arange(n // 2 + 1) / n)[:, None]
    z = np.exp(np.asarray(eigenvalues, complex) / fs)[None, :]
    g, gc = (1 - z ** n) / (1 - z * w), (1 - np.conj(z) ** n) / (1 - np.conj(z) * w)
    return g @ (0.5 * amplitudes) + gc @ (0.5 * np.conj(amplitudes))


def _nearest(f_hz, converged, to_hz):
    f = np.where(converged, f_hz, np.nan)
    return np.array([f[np.nanargmin(np.abs(f - t))] if np.isfinite(f).any() else np.nan for t in to_hz])


def models(start=520):
    """Print the 3909- and 4768-Hz modes' scatter over the shocks for each model of the band fitted alone, the
    three-pole fit's residual (linear background removed) against the pre-trigger noise, and shock 1's pole
    against the first sample fitted."""
    y, fs = shocks(start=start)
    pre = shocks(start=0)[0][:, :400]
    for name, (f0, z0) in MODELS.items():
        for order in ((1, 2, 3, 4, 6) if name in ("2 poles", "3 poles") else (1,)):
            v = np.array([_nearest(bf.natural_frequencies_hz, bf.converged, REF_HZ[2:]) for bf in
                          (refine_in_bands([(x - x.mean())[None]], f, _lam(f0, z0), background_order=order)
                           for x, f in zip(y, fs))])
            print(f"{name}, background order {order}: std 3909/4768 Hz {np.round(np.nanstd(v, 0, ddof=1), 2)}, "
                  f"without shock 12 {np.round(np.nanstd(np.delete(v, 11, 0), 0, ddof=1), 2)}")
    for k, (x, f) in enumerate(zip(y, fs)):
        x = x - x.mean()
        bf = refine_in_bands([x[None]], f, _lam(*MODELS["3 poles"]))
        n = x.size
        Y = np.fft.rfft(x)
        R = Y - _transform(n, f, bf.eigenvalues, bf.amplitudes[0, 0])
        line = np.arange(Y.size) * f / n
        b = (line > 3600) & (line < 5150)
        A = np.c_[np.ones(b.sum()), line[b]]
        Rb = R[b] - A @ np.linalg.lstsq(A, R[b], rcond=None)[0]
        print(f"shock {k + 1}: residual {np.linalg.norm(Rb) / np.linalg.norm(Y[b]):.3f} of the band's transform, "
              f"{np.sqrt(np.mean(np.abs(Rb) ** 2)) / (pre[k].std() * np.sqrt(n)):.1f}x the pre-trigger noise")
    x = y[0] - y[0].mean()
    for a in range(0, 700, 100):
        bf = refine_in_bands([x[None, a:]], fs[0], _lam(*MODELS["3 poles"]))
        print(f"shock 1 from sample {start + a}: {bf.natural_frequencies_hz[0]:.0f} Hz, "
              f"{100 * bf.damping_ratios[0]:.2f} %")


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--start", type=int, default=520, help="first sample of each record (default 520)")
    p.add_argument("--brief", action="store_true", help="the summary only")
    p.add_argument("--models", action="store_true", help="other models of the band 3.6-5.1 kHz (no era run)")
    args = p.parse_args(argv)
    if args.models:
        models(args.start)
        return 0
    y, fs = shocks(start=args.start)
    era, fft = [], []
    for k in range(y.shape[0]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = identify_era(y[k][None], fs[k], BAND_HZ)
            e = identify_fft_peaks(y[k][None], fs[k], BAND_HZ)[0]
        f = r.estimate.natural_frequencies_hz
        era.append(match_modes(f, REF_HZ))
        fft.append(match_modes(e.natural_frequencies_hz, REF_HZ))
        if not args.brief:
            _details(k, r, fft[-1], y[k], fs[k])
    era, fft = np.array(era), np.array(fft)
    s_e, s_f = np.nanstd(era, axis=0, ddof=1), np.nanstd(fft, axis=0, ddof=1)
    print("found era", np.isfinite(era).sum(0), "fft", np.isfinite(fft).sum(0))
    print("std era", np.round(s_e, 2), "fft", np.round(s_f, 2), "ratio", np.round(s_e / s_f, 2))
    both = np.all(np.isfinite(era) & np.isfinite(fft), axis=1)
    print("both", both.sum(), "ratio", np.round(np.std(era[both], 0, ddof=1) / np.std(fft[both], 0, ddof=1), 2))
    print("mean era-fft", np.round(np.nanmean(era - fft, axis=0), 1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
