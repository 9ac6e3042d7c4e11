"""The zero-amplitude frequency (backbone fit) of pyFRF's hammer-hit modes against ``era``'s and the FFT peak's,
over the five hits.

Run: ``python -m experiments.benches.pyfrf_backbone [--data experiments/data/real] [--modes-hz 900 2640 ...]
[--neighbour MODE_HZ NEIGHBOUR_HZ HALF_HZ] [--cache out/pyfrf_era.json]``

Per hit (the response alone, as ``bench_precision`` reads it) and mode (the one nearest each of ``--modes-hz``):

* ``era``: :func:`~physics.identification.free_decay.identify_era` with no band (its estimate);
* ``fftpeak``: :func:`~physics.identification.fft_peak.identify_fft_peaks` (the baseline);
* ``f0``: :func:`~physics.identification.backbone.fit_backbone` of the response from the hit's onset
  (``Decays.onsets``) to the record's end, started at ``era``'s pole: the undamped natural frequency at zero
  amplitude (:attr:`~physics.identification.backbone.Backbone.natural_frequency_hz`, as ``era`` reports a pole);
* ``c``: the frequency at the onset less ``f0``, and its one sigma; ``*`` where significant;
* ``+ neighbour``: for the mode nearest ``MODE_HZ`` (default 900), the same fit in a band of +-``HALF_HZ`` (default
  16) about the mode with a damped exponential started at ``NEIGHBOUR_HZ`` (default 906: the component about 20 dB
  down on the 900-Hz mode's upper flank, on the edge of the default band, which
  ``python -m experiments.benches.pyfrf_mode_drift`` shows).

Then each frequency's standard deviation over the hits and its ratio to the FFT peak's. ``era`` and the FFT peak
take about a minute of CPU per hit; ``--cache FILE`` keeps them (JSON) for reruns.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser, table
from physics.identification.backbone import fit_backbone
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era
from physics.io import atomic_write_text

__all__ = ["backbone_rows", "hits"]

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "pyfrf_hits.npz"
MODES_HZ = (900.0, 2640.0, 3669.0, 4128.0, 5969.0, 6077.0)
#: The mode fitted with a neighbour: its frequency, the neighbour's starting frequency and the band's half-width (Hz).
NEIGHBOUR = (900.0, 906.0, 16.0)
#: The neighbour's starting damping (1/s), as ``pyfrf_mode_drift`` starts it.
NEIGHBOUR_SIGMA = 2 * np.pi * 2.7


def hits(path, cache=None) -> list[dict]:
    """Per hit: ``era``'s poles (real and imaginary parts, rad/s), its onset (sample) and the FFT peaks (Hz); read
    from ``cache`` (JSON) where it exists, else computed and written there."""
    if cache and Path(cache).exists():
        return json.loads(Path(cache).read_text())
    d = np.load(path)
    fs = float(d["sampling_frequency_hz"])
    out = []
    for r in d["response"]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            era = identify_era(r[None], fs)
            fft = identify_fft_peaks(r[None], fs)[0].natural_frequencies_hz
        lam = era.estimate.eigenvalues
        out.append({"era_re": lam.real.tolist(), "era_im": lam.imag.tolist(), "onset": int(era.decays.onsets[0]),
                    "fftpeak": np.asarray(fft, float).tolist()})
    if cache:
        Path(cache).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(cache, json.dumps(out))
    return out


def _row(b, era_hz, fft_hz):
    return {"era": era_hz, "fftpeak": fft_hz, "f0": b.natural_frequency_hz, "f0_std": b.frequency_std_hz,
            "c": b.shift_hz, "c_std": b.shift_std_hz, "significant": b.significant, "amplitude": abs(b.amplitude)}


def backbone_rows(path, modes_hz=MODES_HZ, cache=None, neighbour=NEIGHBOUR) -> dict:
    """Per mode of ``modes_hz`` (and ``"<mode> + neighbour"`` for ``neighbour = (mode_hz, neighbour_hz, half_hz)``),
    one row per hit (module docstring)."""
    d = np.load(path)
    fs, resp = float(d["sampling_frequency_hz"]), d["response"]
    out = {}
    for h, r in zip(hits(path, cache), resp):
        lam = np.asarray(h["era_re"]) + 1j * np.asarray(h["era_im"])
        f_era = np.abs(lam) / (2 * np.pi)
        fft = np.asarray(h["fftpeak"])
        x = r - r.mean()
        for m in modes_hz:
            j = int(np.argmin(np.abs(f_era - m)))
            b = fit_backbone(x[h["onset"]:], fs, lam[j])
            out.setdefault(f"{m:g}", []).append(_row(b, float(f_era[j]), float(fft[np.argmin(np.abs(fft - m))])))
        if neighbour is not None:
            m, f_nb, half = neighbour
            j = int(np.argmin(np.abs(f_era - m)))
            b = fit_backbone(x[h["onset"]:], fs, lam[j], band_hz=(f_era[j] - half, f_era[j] + half),
                             neighbours=[-NEIGHBOUR_SIGMA + 2j * np.pi * f_nb])
            out.setdefault(f"{m:g} + neighbour", []).append(
                _row(b, float(f_era[j]), float(fft[np.argmin(np.abs(fft - m))])))
    return out


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--data", default=str(DATA), help="pyfrf_hits.npz")
    p.add_argument("--modes-hz", type=float, nargs="+", default=list(MODES_HZ))
    p.add_argument("--neighbour", type=float, nargs=3, default=list(NEIGHBOUR),
                   metavar=("MODE_HZ", "NEIGHBOUR_HZ", "HALF_HZ"))
    p.add_argument("--cache", help="JSON file keeping era's poles and the FFT peaks per hit")
    args = p.parse_args(argv)
    rows = backbone_rows(args.data, args.modes_hz, args.cache, tuple(args.neighbour))
    summary = []
    for m, rs in rows.items():
        print(f"\nmode near {m} Hz")
        print(table(["hit", "era (Hz)", "fftpeak (Hz)", "f0 (Hz)", "c (Hz)", "amplitude"],
                    [[i + 1, f"{r['era']:.4f}", f"{r['fftpeak']:.4f}", f"{r['f0']:.4f} +- {r['f0_std']:.4f}",
                      f"{r['c']:+.4f} +- {r['c_std']:.4f}{' *' if r['significant'] else ''}", f"{r['amplitude']:.3g}"]
                     for i, r in enumerate(rs)]))
        sd = {c: float(np.std([r[c] for r in rs], ddof=1)) for c in ("era", "fftpeak", "f0")}
        summary.append([m, *(f"{sd[c]:.4f} ({sd[c] / sd['fftpeak']:.2f}x)" for c in ("era", "fftpeak", "f0")),
                        f"{sum(r['significant'] for r in rs)}/{len(rs)}"])
    print("\nstandard deviation over the hits (ratio to the FFT peak's)")
    print(table(["mode (Hz)", "era", "fftpeak", "f0", "c significant"], summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
