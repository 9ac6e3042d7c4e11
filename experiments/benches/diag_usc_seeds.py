"""Diagnosis: the USC bridge A impacts ("Mode 3" layout) per record: the modes the zero-padded FFT peak reports,
those ``era`` holds (within 2 %), and each clear peak seeded beside the model
(:mod:`physics.identification.peak_seeds`): its band fit across the whole decay, the rises of its band's energy
(:func:`~physics.identification.peak_seeds.band_rises`) and its fit on the decays cut there.

The seeds are fitted here with the held modes (``era``'s estimate less its seeded modes) fixed at their bands' linear
amplitudes (:func:`~physics.identification.band_amplitudes.band_amplitudes`), where ``era`` passes its band fits'
amplitudes: a seed's numbers here can differ from ``era``'s by a few of its sigmas.

Run: ``python -m experiments.benches.diag_usc_seeds [DIR] [--default-band]`` (about 20 s; the set is read as
:mod:`experiments.benches.real_sets` reads it).
"""

from __future__ import annotations

import sys
import warnings

import numpy as np

from experiments.benches.harness import parser
from experiments.benches.real_sets import BRIDGE_FILE, identify_frequencies, load_sets
from physics.identification.band_refine import mode_bands
from physics.identification.decay_peaks import decay_peaks
from physics.identification.decays import decay_spectrum
from physics.identification.free_decay import identify_era
from physics.identification.peak_seeds import band_rises, cut_at_rises, seed_fit, seed_poles
from physics.identification.record_checks import check_records

__all__ = ["main", "record_rows"]

#: A mode the FFT peak reports is held when ``era`` has one within this relative distance.
HELD_RTOL = 0.02


def _fit_text(fit, j):
    return (f"{fit.natural_frequencies_hz[j]:.3f} +- {fit.frequency_std_hz[j]:.3f} Hz, damping "
            f"{fit.damping_ratios[j]:.4f} +- {fit.damping_std[j]:.4f}" if fit.converged[j] else "not converged")


def record_rows(signals, fs, band_hz):
    """Lines describing one record (see the module docstring)."""
    fft = identify_frequencies("fftpeak", signals, fs, band_hz)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify_era(signals, fs, band_hz)
    era = res.estimate.natural_frequencies_hz
    lost = [f for f in fft if not np.any(np.abs(era - f) <= HELD_RTOL * f)]
    lines = [f"  fftpeak {np.round(fft, 2).tolist()}", f"  era     {np.round(era, 2).tolist()} (seeded kept "
             f"{np.round(res.seeded.peak_hz, 2).tolist()} of {np.round(res.seeded.tried_hz, 2).tolist()})",
             f"  not held within {HELD_RTOL:.0%}: {np.round(lost, 2).tolist()}"]
    x = np.asarray(signals, float) - np.mean(signals, axis=1, keepdims=True)
    full = [x[:, o:b] for o, b in zip(res.decays.onsets, res.decays.stops)]
    peaks = decay_peaks(decay_spectrum(check_records(signals, fs, band_hz)))
    held = res.estimate.eigenvalues[~res.estimate.weakly_stable]
    longest_s = max(d.shape[1] for d in full) / fs
    for f0 in res.seeded.tried_hz:
        k = int(np.argmin(np.abs(peaks.frequency_hz - f0)))
        start = seed_poles(peaks.frequency_hz[[k]], peaks.tolerance_hz[[k]], longest_s)
        band = mode_bands(np.concatenate([held, start]), longest_s, fs / 2)[0][-1]
        fit, j = seed_fit(full, fs, held, start, None)
        rises = [np.round(band_rises(d, fs, band) / fs, 2).tolist() for d in full]
        lines.append(f"  seed {f0:.2f} Hz, band {band[0]:.2f}-{band[1]:.2f} Hz: whole decay {_fit_text(fit, j[0])}; "
                     f"band rises (s after onset) {rises}")
        pieces, _ = cut_at_rises(full, fs, band[None], start)
        if pieces is not None:
            fit, j = seed_fit(pieces, fs, held, start, None)
            lines.append(f"    cut there: {_fit_text(fit, j[0])}")
    return lines


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("directory", nargs="?", default=None, help="folder of the .npz sets (as real_sets)")
    p.add_argument("--default-band", action="store_true", help="identify in the default band (not 5-40 Hz)")
    args = p.parse_args(argv)
    sets = [s for s in load_sets(args.directory) if s.source.endswith(BRIDGE_FILE)]
    if not sets:
        print(f"{BRIDGE_FILE} not found", file=sys.stderr)
        return 0
    real = sets[0]
    group = next(g for g in real.groups if g.label == "Mode 3 layout")
    band = None if args.default_band else real.band_hz
    for i in group.indices:
        print(f"record {i} ({real.records[i].shape[1] / real.sampling_frequency_hz:.1f} s), band "
              f"{band or 'default'}")
        print("\n".join(record_rows(real.records[i], real.sampling_frequency_hz, band)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
