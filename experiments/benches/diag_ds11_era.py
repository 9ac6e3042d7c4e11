"""Diagnosis: ``era`` against the zero-padded FFT peak on the baseline impacts of the Dataset-11 boards (the series
``ds11-b4.3``, ``ds11-b4.4``, ``ds11-b4.6`` of :mod:`experiments.benches.bench_real_series`).

Run: ``python -m experiments.benches.diag_ds11_era [--sets ds11-b4.4 ...] [--cache out/diag_ds11_era]``

Each baseline record is identified by ``era`` over the series' band as ``monitor`` runs it (first pass: no
narrow-band re-identification), the reference modes are :func:`learn.monitor.tracking.reference_modes` of those
identifications, and each test's FFT peak is read in each mode's tracking band
(:func:`learn.monitor.tracking.narrow_bands_hz`), as ``monitor``'s estimator choice reads it. Printed per mode: the
robust scatter (Hz: ``f_ref`` times the 1.4826 MAD of ``ln f``) of both over the tests holding both, each test's
two readings, and per test what the band refinement did: the poles it merged into one (their frequencies), the
one-sigma ``era`` reports, and the warnings ``era`` gave (a gliding mode read as one pole,
:mod:`physics.identification.glide`). The identifications are cached as JSON in ``--cache`` (keyed by the set and
the monitor cache format), so a second run prints at once.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.bench_real_series import DATA, LOADERS  # noqa: E402
from experiments.benches.harness import parser  # noqa: E402
from learn.monitor import IdentifiedModes, reference_modes  # noqa: E402
from learn.monitor.identification import CACHE_FORMAT, IdentificationSettings  # noqa: E402
from learn.monitor.tracking import narrow_bands_hz, track_modes  # noqa: E402
from physics.identification.fft_peak import fft_peaks  # noqa: E402
from physics.identification.free_decay import identify_era  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["SETS", "identify_baseline", "main", "robust_scatter_hz"]

SETS = ("ds11-b4.3", "ds11-b4.4", "ds11-b4.6")


def robust_scatter_hz(values_hz, reference_hz: float) -> float:
    """``reference_hz`` times the 1.4826 MAD of ``ln f`` (the scatter ``monitor``'s estimator choice compares)."""
    v = np.log(np.asarray(values_hz, float))
    return float(reference_hz * 1.4826 * np.median(np.abs(v - np.median(v)))) if v.size else float("nan")


def identify_baseline(name: str, data: str = DATA) -> tuple:
    """``(records, fs, band, per-test dicts)`` of the series' baseline: ``era``'s modes, the band refinement's
    merged poles and their partners, and the warnings."""
    file, load = LOADERS[name]
    s = load(Path(data) / file, False)
    settings = IdentificationSettings(tuple(s.band_hz))
    out = []
    for y, fs in zip(s.records[:s.n_baseline], s.sampling_frequency_hz[:s.n_baseline]):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = identify_era(y, float(fs), s.band_hz, None, settings.records_max_order)
        e, b = r.estimate, r.bands
        merged = [] if b is None else [[float(b.natural_frequencies_hz[i]), float(b.merged_with_hz[i])]
                                       for i in np.flatnonzero(b.merged)]
        out.append({"f": e.natural_frequencies_hz.tolist(), "zeta": e.damping_ratios.tolist(),
                    "f_std": e.frequency_std_hz.tolist(), "merged": merged,
                    "warnings": [str(w.message) for w in caught if "glides" in str(w.message)]})
    return s.records[:s.n_baseline], s.sampling_frequency_hz[:s.n_baseline], s.band_hz, out


def _report(name: str, records, fs, tests: list) -> None:
    modes = [IdentifiedModes("response records", "era", np.array(t["f"]), np.array(t["zeta"]),
                             np.ones((1, len(t["f"])), complex), ("1:+Z",)) for t in tests]
    ref = reference_modes(modes)
    bands = narrow_bands_hz(ref)
    F = track_modes(modes, ref)[0]
    P = np.array([fft_peaks(y, f, bands.mean(axis=1), 0.5 * (bands[:, 1] - bands[:, 0])).frequency_hz
                  for y, f in zip(records, fs)])
    print(f"== {name}: {len(tests)} baseline tests, reference modes "
          f"{', '.join(f'{v:.1f}' for v in ref.frequencies_hz)} Hz")
    for k, f_ref in enumerate(ref.frequencies_hz):
        both = np.isfinite(F[:, k]) & np.isfinite(P[:, k])
        print(f"mode {k + 1} ({f_ref:.1f} Hz, band {bands[k, 0]:.0f}-{bands[k, 1]:.0f}): era "
              f"{robust_scatter_hz(F[both, k], f_ref):.3g} Hz, FFT peak {robust_scatter_hz(P[both, k], f_ref):.3g} Hz "
              f"over {int(both.sum())} tests")
        for i, t in enumerate(tests):
            j = int(np.nanargmin(np.abs(np.array(t["f"]) - F[i, k]))) if np.isfinite(F[i, k]) else None
            sd = f" +- {t['f_std'][j]:.2g}" if j is not None else ""
            pairs = [f"{a:.1f}>{b:.1f}" for a, b in t["merged"] if bands[k, 0] <= b <= bands[k, 1]]
            print(f"   test {i:2d}: era {F[i, k]:8.1f}{sd:9s} FFT {P[i, k]:8.1f}"
                  + (f"  merged {' '.join(pairs)}" if pairs else ""))
    for i, t in enumerate(tests):
        for w in t["warnings"]:
            print(f"   test {i}: {w}")


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("--sets", nargs="+", choices=SETS, default=list(SETS))
    p.add_argument("--data", default=DATA)
    p.add_argument("--cache", default="out/diag_ds11_era", help="folder of the cached identifications")
    a = p.parse_args(argv)
    cache = Path(a.cache)
    for name in a.sets:
        if not (Path(a.data) / LOADERS[name][0]).is_file():
            print(f"{name}: {Path(a.data) / LOADERS[name][0]} absent, skipped")
            continue
        path = cache / f"{name}.json"
        d = json.loads(path.read_text()) if path.is_file() else None
        if d is None or d.get("format") != CACHE_FORMAT:
            records, fs, _, tests = identify_baseline(name, a.data)
            cache.mkdir(parents=True, exist_ok=True)
            atomic_write_text(path, json.dumps({"format": CACHE_FORMAT, "tests": tests}))
        else:
            file, load = LOADERS[name]
            s = load(Path(a.data) / file, False)
            records, fs, tests = s.records[:s.n_baseline], s.sampling_frequency_hz[:s.n_baseline], d["tests"]
        _report(name, records, fs, tests)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
