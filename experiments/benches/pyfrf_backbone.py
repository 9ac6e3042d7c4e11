"""The zero-amplitude frequency (backbone fit, neighbours found automatically) of pyFRF's hammer-hit modes against
``era``'s and the FFT peak's over the five hits, and the same fit on simulated linear decays.

Run: ``python -m experiments.benches.pyfrf_backbone [--data experiments/data/real/pyfrf_hits.npz]
[--modes-hz 900 2640 ...] [--cache out/pyfrf_era.json] [--simulated]``

Per hit (the response alone, as ``bench_precision`` reads it) and mode (the one nearest each of ``--modes-hz``):

* ``era``: :func:`~physics.identification.free_decay.identify_era` with no band (its estimate);
* ``fftpeak``: :func:`~physics.identification.fft_peak.identify_fft_peaks` (the baseline);
* ``alone``: :func:`~physics.identification.backbone.fit_backbone` of the response from the hit's onset
  (``Decays.onsets``) to the record's end in the mode's own band, started at ``era``'s pole: the undamped natural
  frequency at zero amplitude (:attr:`~physics.identification.backbone.Backbone.natural_frequency_hz`);
* ``f0``: :func:`~physics.identification.amplitude_frequency.backbone_with_neighbours` (the neighbours found by
  its model-order test, listed per hit), its natural frequency at zero amplitude;
* ``f(a_med)``: its natural frequency at the median over the hits of the mode's onset amplitude ``|A|``;
* ``c``: the frequency at the onset less ``f0``, and its one sigma; ``*`` where significant;
* ``if c significant``: ``f0`` where ``c`` is significant, ``era``'s estimate elsewhere (the rule that would use
  the backbone automatically).

Then each frequency's standard deviation over the hits and its ratio to the FFT peak's. ``era`` and the FFT peak
take about a minute of CPU per hit; ``--cache FILE`` keeps them (JSON) for reruns.

``--simulated``: ``bench_precision``'s one-channel free-decay cases (linear: no stiffening, no neighbour), 12
decays each, seed 0, each mode started at its true pole: the linear band fit's scatter
(:func:`~physics.identification.band_refine.refine_in_bands`), ``f0``'s, and how many fits keep a neighbour or a
significant ``c``.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from experiments.benches.bench_precision import DECAY, DECAY_FN_HZ, DECAY_ZETA, decay_records
from experiments.benches.harness import parser, table
from physics.identification.amplitude_frequency import backbone_with_neighbours
from physics.identification.backbone import fit_backbone
from physics.identification.band_refine import refine_in_bands
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era
from physics.io import atomic_write_text

__all__ = ["backbone_rows", "hits", "simulated_rows"]

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "pyfrf_hits.npz"
MODES_HZ = (900.0, 2640.0, 3669.0, 4128.0, 5969.0, 6077.0)
#: Simulated decays per case, and their seed.
SIMULATED_REPS, SIMULATED_SEED = 12, 0


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


def _at(b, amplitude):
    """The backbone's undamped natural frequency at envelope ``amplitude`` (Hz)."""
    return float(np.hypot(b.frequency_hz + b.shift_hz * amplitude / abs(b.amplitude), b.decay_rate / (2 * np.pi)))


def backbone_rows(path, modes_hz=MODES_HZ, cache=None) -> dict:
    """Per mode of ``modes_hz``, one row per hit (module docstring)."""
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
            alone = fit_backbone(x[h["onset"]:], fs, lam[j])
            b = backbone_with_neighbours(x[h["onset"]:], fs, lam[j])
            out.setdefault(f"{m:g}", []).append({
                "era": float(f_era[j]), "fftpeak": float(fft[np.argmin(np.abs(fft - m))]),
                "alone": alone.natural_frequency_hz, "f0": b.natural_frequency_hz, "f0_std": b.frequency_std_hz,
                "c": b.shift_hz, "c_std": b.shift_std_hz, "significant": b.significant, "backbone": b,
                "neighbours_hz": (b.neighbours.imag / (2 * np.pi)).tolist(), "amplitude": abs(b.amplitude)})
    for rs in out.values():
        a_med = float(np.median([r["amplitude"] for r in rs]))
        for r in rs:
            r["f(a_med)"] = _at(r.pop("backbone"), a_med)
            r["if c significant"] = r["f0"] if r["significant"] else r["era"]
    return out


def simulated_rows(reps=SIMULATED_REPS, seed=SIMULATED_SEED) -> list[list]:
    """Per one-channel decay case of ``bench_precision`` and mode: the linear band fit's and ``f0``'s scatter (Hz),
    and the fits keeping a neighbour or a significant ``c`` (module docstring)."""
    lam0 = -DECAY_ZETA * 2 * np.pi * DECAY_FN_HZ + 2j * np.pi * DECAY_FN_HZ * np.sqrt(1 - DECAY_ZETA ** 2)
    out = []
    for case in (c for c in DECAY if c.n_channels == 1):
        fs, start = case.fs_hz, int(round(case.pre_s * case.fs_hz))
        lin, f0, nb, sig = [], [], [], []
        for y in decay_records(case, reps, seed):
            x = y[0, start:] - y[0, start:].mean()
            lin.append(refine_in_bands([x[None]], fs, lam0).natural_frequencies_hz)
            bs = [backbone_with_neighbours(x, fs, lam) for lam in lam0]
            f0.append([b.natural_frequency_hz for b in bs])
            nb.append([b.neighbours.size > 0 for b in bs])
            sig.append([b.significant for b in bs])
        s_lin, s_f0 = np.std(lin, axis=0, ddof=1), np.std(f0, axis=0, ddof=1)
        for j in range(lam0.size):
            out.append([f"{case.label}, {case.length}", f"{DECAY_FN_HZ[j]:.1f}", f"{s_lin[j]:.2g}", f"{s_f0[j]:.2g}",
                        f"{s_f0[j] / s_lin[j]:.2f}", f"{np.sum(np.asarray(nb)[:, j])}/{reps}",
                        f"{np.sum(np.asarray(sig)[:, j])}/{reps}"])
    return out


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--data", default=str(DATA), help="pyfrf_hits.npz")
    p.add_argument("--modes-hz", type=float, nargs="+", default=list(MODES_HZ))
    p.add_argument("--cache", help="JSON file keeping era's poles and the FFT peaks per hit")
    p.add_argument("--simulated", action="store_true", help="bench_precision's one-channel linear decays instead")
    args = p.parse_args(argv)
    if args.simulated:
        print(table(["case", "mode (Hz)", "linear std (Hz)", "f0 std (Hz)", "ratio", "neighbour kept",
                     "c significant"], simulated_rows()))
        return 0
    rows = backbone_rows(args.data, args.modes_hz, args.cache)
    cols = ("era", "fftpeak", "alone", "f0", "f(a_med)", "if c significant")
    summary = []
    for m, rs in rows.items():
        print(f"\nmode near {m} Hz")
        print(table(["hit", "era (Hz)", "fftpeak (Hz)", "alone (Hz)", "neighbours (Hz)", "f0 (Hz)", "c (Hz)",
                     "amplitude"],
                    [[i + 1, f"{r['era']:.4f}", f"{r['fftpeak']:.4f}", f"{r['alone']:.4f}",
                      " ".join(f"{f:.2f}" for f in r["neighbours_hz"]) or "-", f"{r['f0']:.4f} +- {r['f0_std']:.4f}",
                      f"{r['c']:+.4f} +- {r['c_std']:.4f}{' *' if r['significant'] else ''}", f"{r['amplitude']:.3g}"]
                     for i, r in enumerate(rs)]))
        sd = {c: float(np.std([r[c] for r in rs], ddof=1)) for c in cols}
        summary.append([m, *(f"{sd[c]:.4f} ({sd[c] / sd['fftpeak']:.2f}x)" for c in cols),
                        f"{sum(bool(r['neighbours_hz']) for r in rs)}/{len(rs)}",
                        f"{sum(r['significant'] for r in rs)}/{len(rs)}"])
    print("\nstandard deviation over the hits (ratio to the FFT peak's)")
    print(table(["mode (Hz)", *cols, "neighbour kept", "c significant"], summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
