"""Real repeated-test sets (public, CC BY-SA, not shipped with the project) as groups of repeated records, and the
scatter of every output-only method over each group.

Run: ``python -m experiments.benches.real_sets --report [DIR] [--sets NAME ...] [--methods M,...] [--banded]``

The sets are read from ``DIR`` (default the first of :data:`REAL_DIRS` that exists) when their ``.npz`` is there;
a set whose file is absent is skipped. Each is described in the ``.md`` file beside it:

* ``usc_bridge_a_impacts.npz`` (:func:`usc_bridge`): a pedestrian bridge, 12 impacts without force, 3
  accelerometers (g), 6410.26 Hz, 9.4 s; groups: the 8 records of the "Mode 3" sensor layout, and all 12.
  Reference modes: the FFT-peak check of the set's ``.md`` (sum of the channels after the impact, zero-padded FFT),
  the two close pairs (11.7/11.9 and 31.4/32.1 Hz) as two modes each.
* ``dropbear_roller_steps.npz`` (:func:`dropbear_roller`): a cantilever beam with a movable roller; the free
  decays after each roller step (121 dwell segments of 0.57-1 s at 5 kHz, low-g channel); one group per support
  state (0-5), each with its own reference modes (the ``.md``'s FFT-peak check of that state).

A :class:`RealSet` holds every record of a set once; its :class:`RealGroup` s name the records that are repeated
tests of one unchanged structure (and the modes they are matched to). :func:`group_scatter` runs one method on the
records of a group as ``identify`` runs it (no band unless given, no number of modes) and matches its modes to the
group's reference (:func:`experiments.benches.bench_precision.match_modes`).
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser
from experiments.benches.bench_precision import REAL_DIR, match_modes
from physics.errors import BeamDamageError
from physics.identification.failures import PER_RECORD_ERRORS
from physics.identification.methods import METHODS
from physics.identification.output_only import identify_records
from physics.io.timedata import TimeRecords

__all__ = ["BRIDGE_FILE", "DROPBEAR_FILE", "REAL_DIRS", "REPORT_METHODS", "RealGroup", "RealSet", "group_scatter",
           "identify_frequencies", "load_sets", "main", "report", "dropbear_roller", "usc_bridge"]

#: Where the sets are looked for, first found first.
REAL_DIRS = (Path("/work/realdata"), REAL_DIR)
BRIDGE_FILE, DROPBEAR_FILE = "usc_bridge_a_impacts.npz", "dropbear_roller_steps.npz"
#: Methods the report runs: ``auto`` is ``identify``'s automatic output-only choice (era for a free response).
REPORT_METHODS = ("fftpeak", "era", "ssi", "auto")
#: Bridge reference modes (Hz), from the FFT-peak check of ``usc_bridge_a_impacts.md``, the close pairs split.
BRIDGE_MODES_HZ = np.array([11.7, 11.9, 17.04, 25.29, 28.14, 31.4, 32.1, 33.49])
#: Bridge: the band holding those modes (Hz).
BRIDGE_BAND_HZ = (5.0, 40.0)
#: DROPBEAR modes 1 and 2 (Hz) of each roller state 0-5, from the FFT-peak check of ``dropbear_roller_steps.md``.
DROPBEAR_MODES_HZ = np.array([[25.99, 160.50], [28.09, 177.14], [30.79, 193.86], [33.87, 214.01], [37.60, 235.83],
                              [41.88, 266.88]])
#: DROPBEAR: the band holding both modes of every state (Hz).
DROPBEAR_BAND_HZ = (15.0, 300.0)


@dataclass(frozen=True)
class RealGroup:
    """Records of a :class:`RealSet` that are repeated tests of one unchanged structure.

    Attributes
    ----------
    label : str
    indices : ndarray of int
        Into :attr:`RealSet.records`.
    reference_hz : ndarray, shape (n_modes,)
        The modes each test's identified modes are matched to.
    """

    label: str
    indices: np.ndarray
    reference_hz: np.ndarray


@dataclass(frozen=True)
class RealSet:
    """A real repeated-test set.

    Attributes
    ----------
    name : str
    records : tuple of ndarray, each shape (n_channels, n_samples)
        One per test (lengths may differ), units of the file.
    sampling_frequency_hz : float
    groups : tuple of RealGroup
    band_hz : (float, float)
        The band holding the reference modes (for a banded run).
    source : str
        The ``.npz`` read.
    """

    name: str
    records: tuple
    sampling_frequency_hz: float
    groups: tuple
    band_hz: tuple
    source: str = ""


def usc_bridge(path) -> RealSet:
    """The USC pedestrian bridge A's impact records (``usc_bridge_a_impacts.npz``): all 12 records, groups "Mode 3
    layout" (8 records) and "all" (12)."""
    d = np.load(path)
    records = tuple(np.asarray(r, dtype=np.float64) for r in d["records"])
    layout = np.asarray(d["sensor_layout"]).astype(str)
    groups = (RealGroup("Mode 3 layout", np.flatnonzero(layout == "Mode 3"), BRIDGE_MODES_HZ),
              RealGroup("all layouts", np.arange(len(records)), BRIDGE_MODES_HZ))
    return RealSet("USC bridge A impacts", records, float(d["sampling_frequency_hz"]), groups, BRIDGE_BAND_HZ,
                   str(path))


def dropbear_roller(path, channel=0) -> RealSet:
    """The DROPBEAR beam's dwell segments (``dropbear_roller_steps.npz``): each segment (as long as it was
    recorded) of ``channel`` (0: low-g accelerometer), one group per support state."""
    d = np.load(path)
    rec = d["records"]
    segs = tuple(np.asarray(rec[t, channel:channel + 1, a:b], dtype=np.float64)
                 for t, a, b in zip(d["segment_test"], d["segment_start"], d["segment_stop"]))
    state = np.asarray(d["segment_state"], int)
    groups = tuple(RealGroup(f"state {s}", np.flatnonzero(state == s), DROPBEAR_MODES_HZ[s])
                   for s in range(DROPBEAR_MODES_HZ.shape[0]) if np.any(state == s))
    return RealSet("DROPBEAR roller steps", segs, float(d["sampling_frequency_hz"]), groups, DROPBEAR_BAND_HZ,
                   str(path))


#: Loaders by file name.
LOADERS = {BRIDGE_FILE: usc_bridge, DROPBEAR_FILE: dropbear_roller}


def load_sets(directory=None) -> list[RealSet]:
    """The sets of :data:`LOADERS` whose file is in ``directory`` (default: the first of :data:`REAL_DIRS` that
    exists); none found: an empty list."""
    if directory is None:
        directory = next((d for d in REAL_DIRS if d.is_dir()), REAL_DIRS[-1])
    directory = Path(directory)
    return [load(directory / name) for name, load in LOADERS.items() if (directory / name).is_file()]


def identify_frequencies(method, signals, fs, band_hz=None) -> np.ndarray:
    """Natural frequencies (Hz) ``method`` identifies in one record (``"auto"``: ``identify``'s choice); a
    refusal (or a numerical failure on the record, :data:`~physics.identification.failures.PER_RECORD_ERRORS`): none."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if method == "auto":
                rec = TimeRecords(1.0 / fs, signals, tuple(f"{i + 1}:+Z" for i in range(signals.shape[0])),
                                  ("acceleration",) * signals.shape[0])
                return identify_records(rec, "auto", band_hz).estimate.natural_frequencies_hz
            spec = METHODS[method]
            est, _ = spec.fit(signals, fs, band_hz, None, "record", **{k: None for k in spec.options})
            return est.natural_frequencies_hz
    except (BeamDamageError, *PER_RECORD_ERRORS):      # a numerical failure on the record counts as a refusal
        return np.zeros(0)


def group_scatter(real: RealSet, group: RealGroup, method, band_hz=None) -> np.ndarray:
    """Each test's estimate of each reference mode, shape (n_tests, n_modes) (NaN: not found)."""
    fs = real.sampling_frequency_hz
    return np.array([match_modes(identify_frequencies(method, real.records[i], fs, band_hz), group.reference_hz)
                     for i in group.indices])


def _std(F):
    ok = np.isfinite(F)
    return np.array([np.std(F[ok[:, k], k], ddof=1) if ok[:, k].sum() >= 2 else math.nan for k in range(F.shape[1])])


def report(sets, methods=REPORT_METHODS, banded=False, groups=None, out=sys.stdout) -> list[dict]:
    """Print, per set, group and method: found/total per mode, the scatter (Hz) and its ratio to the FFT peak's
    (``fftpeak`` is run first when asked for); returns the rows."""
    rows = []
    for real in sets:
        band = real.band_hz if banded else None
        for g in real.groups:
            if groups and g.label not in groups:
                continue
            print(f"== {real.name}, {g.label}: {g.indices.size} tests, band {band or 'default'}, reference "
                  f"{', '.join(f'{v:g}' for v in g.reference_hz)} Hz", file=out)
            base = None
            for m in sorted(methods, key=lambda m: m != "fftpeak"):
                t0 = time.perf_counter()
                F = group_scatter(real, g, m, band)
                std = _std(F)
                if m == "fftpeak":
                    base = std
                ratio = std / base if base is not None else np.full(std.size, np.nan)
                found = np.isfinite(F).sum(axis=0)
                cells = "  ".join(f"{f}/{F.shape[0]} {s:.3g}" + (f" ({r:.2g}x)" if np.isfinite(r) and m != "fftpeak"
                                                                 else "")
                                  for f, s, r in zip(found, std, ratio))
                print(f"{m:8s} {cells}   [{time.perf_counter() - t0:.0f} s]", file=out)
                rows += [{"set": real.name, "group": g.label, "method": m, "mode": k + 1,
                          "reference_hz": float(g.reference_hz[k]), "found": int(found[k]), "tests": F.shape[0],
                          "std_hz": float(std[k]), "std_over_fft": float(ratio[k]), "band": band}
                         for k in range(std.size)]
    return rows


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("directory", nargs="?", default=None, help="folder of the .npz sets (default: /work/realdata, "
                   "else experiments/data/real)")
    p.add_argument("--report", action="store_true", help="identify every group by every method and print the "
                   "scatter")
    p.add_argument("--methods", default=",".join(REPORT_METHODS), help="comma-separated (default: %(default)s)")
    p.add_argument("--sets", nargs="*", default=None, help="set names to run (default: every set found)")
    p.add_argument("--groups", nargs="*", default=None, help="group labels to run, e.g. 'state 2' (default: all)")
    p.add_argument("--banded", action="store_true", help="identify in each set's band instead of the default band")
    args = p.parse_args(argv)
    sets = load_sets(args.directory)
    if args.sets:
        sets = [s for s in sets if s.name in args.sets]
    if not sets:
        print(f"no real set found in {args.directory or ' or '.join(map(str, REAL_DIRS))}", file=sys.stderr)
        return 0
    for s in sets:
        print(f"{s.name}: {len(s.records)} records at {s.sampling_frequency_hz:g} Hz, groups "
              f"{', '.join(f'{g.label} ({g.indices.size})' for g in s.groups)} ({s.source})")
    if args.report:
        report(sets, [m.strip() for m in args.methods.split(",") if m.strip()], args.banded, args.groups)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
