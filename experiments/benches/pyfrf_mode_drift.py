"""Why ``era``'s 900-Hz mode scatters more than the FFT peak's over pyFRF's five hammer hits: each hit's estimates.

Run: ``python -m experiments.benches.pyfrf_mode_drift [--data experiments/data/real] [--mode-hz 900]``

Per hit (the response alone, as ``bench_precision`` reads it), the mode nearest ``--mode-hz``:

* ``era``: :func:`~physics.identification.free_decay.identify_era` with no band (its estimate);
* ``fftpeak``: :func:`~physics.identification.fft_peak.identify_fft_peaks` (the baseline);
* ``1 pole``: one pole fitted alone in its narrow band from the hit's onset to the record's end
  (:func:`~physics.identification.band_refine.refine_in_bands`, started at ``era``'s pole): what ``era`` reports
  when its band holds no other mode;
* ``2 poles``: the same band fit with a second pole started at ``--neighbour-hz`` (a component about 20 dB down on
  the mode's upper flank, which no model holds and the band's linear background cannot take);
* ``amplitude``: the mode's amplitude at the onset from the one-pole fit (the record's units);
* ``f(beat k)``: the mode's instantaneous frequency averaged over the ``k``-th period of its beat with the neighbour
  (the phase slope of the analytic signal of the record band-passed to +-20 Hz about the mode, from 12 ms after the
  onset), and the mean envelope there: how the frequency moves as the amplitude falls within a decay.

Then each column's standard deviation over the hits and its ratio to the FFT peak's.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser, table
from physics.identification.band_refine import refine_in_bands
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era

__all__ = ["main", "mode_drift"]

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "pyfrf_hits.npz"
#: Band-pass half-width (Hz) about the mode for its instantaneous frequency, and the samples skipped after the onset
#: (the filter's response to the hit).
PASS_HALF_HZ, SKIP_S = 20.0, 0.012


def _nearest(f, f0):
    f = np.asarray(f, float)
    return int(np.argmin(np.abs(f - f0)))


def mode_drift(path, mode_hz=900.0, neighbour_hz=906.0, beats=3) -> list[dict]:
    """One row per hit (module docstring)."""
    from scipy import signal  # scipy.signal: only this diagnostic

    d = np.load(path)
    fs, resp = float(d["sampling_frequency_hz"]), d["response"]
    rows = []
    for r in resp:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            era = identify_era(r[None], fs)
            fft = identify_fft_peaks(r[None], fs)[0].natural_frequencies_hz
        e = era.estimate
        j = _nearest(e.natural_frequencies_hz, mode_hz)
        x = r - r.mean()
        onset = int(era.decays.onsets[0])
        lam = e.eigenvalues[j]
        one = refine_in_bands([x[None, onset:]], fs, [lam])
        two = refine_in_bands([x[None, onset:]], fs, [lam, -2 * np.pi * 2.7 + 2j * np.pi * neighbour_hz])
        f_mode = one.natural_frequencies_hz[0]
        sos = signal.butter(4, [f_mode - PASS_HALF_HZ, f_mode + PASS_HALF_HZ], btype="band", fs=fs, output="sos")
        z = signal.hilbert(signal.sosfiltfilt(sos, x))
        phase, env = np.unwrap(np.angle(z)), np.abs(z)
        w = int(round(fs / abs(neighbour_hz - f_mode)))
        a0 = onset + int(SKIP_S * fs)
        beat = []
        for k in range(beats):
            s = slice(a0 + k * w, a0 + (k + 1) * w)
            t = np.arange(s.start, s.stop) / fs
            beat.append((float(np.polyfit(t, phase[s], 1)[0] / (2 * np.pi)), float(env[s].mean())))
        rows.append({"era": float(e.natural_frequencies_hz[j]), "fftpeak": float(fft[_nearest(fft, mode_hz)]),
                     "1 pole": float(f_mode), "2 poles": float(two.natural_frequencies_hz[0]),
                     "neighbour": float(two.natural_frequencies_hz[1]),
                     "amplitude": float(np.abs(one.amplitudes[0, 0, 0])), "beats": beat})
    return rows


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--data", default=str(DATA), help="pyfrf_hits.npz")
    p.add_argument("--mode-hz", type=float, default=900.0)
    p.add_argument("--neighbour-hz", type=float, default=906.0)
    args = p.parse_args(argv)
    rows = mode_drift(args.data, args.mode_hz, args.neighbour_hz)
    cols = ["era", "fftpeak", "1 pole", "2 poles"]
    print(table(["hit", *(f"{c} (Hz)" for c in cols), "neighbour (Hz)", "amplitude",
                 *(f"f (Hz) @ envelope, beat {k + 1}" for k in range(len(rows[0]["beats"])))],
                [[i + 1, *(f"{r[c]:.4f}" for c in cols), f"{r['neighbour']:.2f}", f"{r['amplitude']:.1f}",
                  *(f"{f:.3f} @ {a:.1f}" for f, a in r["beats"])] for i, r in enumerate(rows)]))
    base = np.std([r["fftpeak"] for r in rows], ddof=1)
    amp = np.array([r["amplitude"] for r in rows])
    for c in cols:
        v = np.array([r[c] for r in rows])
        print(f"{c}: std {np.std(v, ddof=1):.4f} Hz, {np.std(v, ddof=1) / base:.2f}x the FFT peak's; "
              f"correlation with the amplitude {np.corrcoef(v, amp)[0, 1]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
