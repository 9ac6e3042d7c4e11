"""The clear peaks of the real free-decay records that no mode of ``era`` explains: how many records of each
repeated set draw the warning (``clear spectral peak(s) without an identified mode``), and at which peaks.

Run: ``python -m experiments.benches.bench_era_unexplained [--data DIR] [--sets pyfrf bridge ds5 dropbear]
[--banded] [--every N] [--docs]``

Each record is identified as ``identify --method era FILE`` does (:func:`~physics.identification.identify_records`,
no band unless ``--banded``, no number of modes): the pyFRF hits' responses (5), the USC bridge's impacts (12, 3
channels), the DS5 PCB shocks from 20 samples after the clipped peak (51, as ``bench_real_series`` cuts them), the
DROPBEAR dwell segments of the low-g channel (121). The peaks named are gathered over a set's records into groups
within 1 % of each other: frequency range, records naming it, height range above the floor (dB). ``--docs`` writes
the table into ``docs/identification.md``, block ``era-unexplained`` (``era-unexplained-banded`` with ``--banded``).
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

from experiments.benches.bench_precision import REAL_DIR
from experiments.benches.harness import parser, publish, table
from experiments.benches.real_sets import BRIDGE_BAND_HZ, DROPBEAR_BAND_HZ, dropbear_roller, usc_bridge
from physics.errors import BeamDamageError
from physics.identification.failures import PER_RECORD_ERRORS
from physics.identification.output_only import identify_records
from physics.io.timedata import TimeRecords

__all__ = ["SETS", "WARNING", "main", "peak_groups", "run_set", "set_records"]

#: The sets: name, file in ``--data``.
SETS = {"pyfrf": "pyfrf_hits.npz", "bridge": "usc_bridge_a_impacts.npz", "ds5": "ds5_pcb_repeated_shock.npz",
        "dropbear": "dropbear_roller_steps.npz"}
#: The band of each set's reference modes (``--banded``).
BANDS_HZ = {"pyfrf": None, "bridge": BRIDGE_BAND_HZ, "ds5": (500.0, 5500.0), "dropbear": DROPBEAR_BAND_HZ}
#: The warning counted.
WARNING = "clear spectral peak(s) without an identified mode"


def set_records(name, path):
    """The records of a set: a list of ``(label, signals (n_channels, n_samples), sampling_frequency_hz)``."""
    if name == "pyfrf":
        z = np.load(path)
        return [(f"hit {k}", r[None], float(z["sampling_frequency_hz"])) for k, r in enumerate(z["response"])]
    if name == "bridge":
        s = usc_bridge(path)
        return [(f"record {k}", r, s.sampling_frequency_hz) for k, r in enumerate(s.records)]
    if name == "ds5":
        z = np.load(path)
        return [(f"shock {k + 1}", y[None, 520:], float(fs))
                for k, (y, fs) in enumerate(zip(z["pcb_records"], z["pcb_sampling_frequency_hz"]))]
    s = dropbear_roller(path)
    return [(f"segment {k}", r, s.sampling_frequency_hz) for k, r in enumerate(s.records)]


def run_set(name, records, band_hz=None, out=sys.stdout) -> list[dict]:
    """``era`` on each record: a row per record (label, modes, the peaks warned of and their heights, refused)."""
    rows = []
    for label, y, fs in records:
        rec = TimeRecords(1.0 / fs, y, tuple(f"{i + 1}:+Z" for i in range(y.shape[0])), ("acceleration",) * y.shape[0],
                          {"source": f"{name} {label}"})
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                fn = identify_records(rec, "era", band_hz).estimate.natural_frequencies_hz
            except (BeamDamageError, *PER_RECORD_ERRORS) as e:
                rows.append({"set": name, "record": label, "modes": 0, "warned": [], "refused": str(e)})
                print(f"{name} {label}: refused ({e})", file=out, flush=True)
                continue
        text = [str(w.message) for w in caught if WARNING in str(w.message)]
        peaks = [p.strip() for t in text for p in t.split(": ", 2)[2].split(" above the floor")[0].split(", ")]
        rows.append({"set": name, "record": label, "modes": int(fn.size), "warned": peaks, "refused": ""})
        print(f"{name} {label}: {fn.size} modes; {', '.join(peaks) or 'no warning'} "
              f"[{time.perf_counter() - t0:.0f} s]", file=out, flush=True)
    return rows


def peak_groups(rows) -> list[tuple]:
    """The peaks warned of over ``rows``, grouped within 1 %: ``(f_lo, f_hi, n_records, db_lo, db_hi)``."""
    got = sorted((float(p.split(" Hz")[0]), float(p.split("(")[1].split(" dB")[0]), r["record"])
                 for r in rows for p in r["warned"])
    groups = []
    for f, db, rec in got:
        if groups and f <= 1.01 * groups[-1][0][0]:
            groups[-1].append((f, db, rec))
        else:
            groups.append([(f, db, rec)])
    return [(g[0][0], g[-1][0], len({rec for _, _, rec in g}), min(d for _, d, _ in g), max(d for _, d, _ in g))
            for g in groups]


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="identification.md")
    p.add_argument("--data", default=str(REAL_DIR), help=f"folder of the sets' .npz (default {REAL_DIR})")
    p.add_argument("--sets", nargs="+", choices=list(SETS), default=list(SETS), help="sets to run (default all)")
    p.add_argument("--banded", action="store_true", help="each set in the band of its reference modes")
    p.add_argument("--every", type=int, default=1, help="every N-th record of each set (default 1: all)")
    args = p.parse_args(argv)
    summary = []
    for name in args.sets:
        path = Path(args.data) / SETS[name]
        if not path.is_file():
            print(f"{name}: {path} absent, skipped")
            continue
        band = BANDS_HZ[name] if args.banded else None
        rows = run_set(name, set_records(name, path)[::args.every], band)
        groups = "; ".join(f"{lo:.4g}" + (f"-{hi:.4g}" if hi > lo else "") + f" Hz in {n} ({d0:.0f}"
                           + (f"-{d1:.0f}" if d1 > d0 else "") + " dB)" for lo, hi, n, d0, d1 in peak_groups(rows))
        summary.append([name, band or "default", len(rows), sum(bool(r["refused"]) for r in rows),
                        sum(bool(r["warned"]) for r in rows), groups or "-"])
    md = table(["set", "band (Hz)", "records", "refused", "warned",
                "peaks named (records, height above the floor)"], summary)
    print(md)
    publish(args, "era-unexplained-banded" if args.banded else "era-unexplained", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
