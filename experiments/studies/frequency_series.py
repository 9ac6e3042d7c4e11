"""A monitoring series published as a table of identified natural frequencies, as test files ``monitor`` reads.

Run: ``python -m experiments.studies.frequency_series TABLE --out DIR [--key NAME] [--tests-per-day N]``

``TABLE`` is a MATLAB ``.mat`` file holding a matrix ``--key`` (modes x tests, or tests x modes: the shorter axis is
the modes), or a CSV with one row per test and one column per mode (a header row is skipped). Each test becomes
``DIR/test-NNN.json``, modal data with ``natural_frequencies_hz`` alone (the project's modal-data JSON, see
``docs/data-formats.md``), and ``DIR/conditions.csv`` lists them in order with their time in hours (``N`` tests a
day, default 1). A test whose frequencies are not all finite and positive is left out and named.

For example the Yonghe bridge's FDD frequencies (4 modes, 24 tests a day over 8 intact days and one damaged day;
Daneshvar & Sarmadi 2022, Engineering Structures 256:114059)::

    python -m experiments.studies.frequency_series Yonghe_Modal_FDD.mat --key freq_fdd --tests-per-day 24 --out yonghe
    beam-damage monitor --conditions yonghe/conditions.csv --baseline-tests 144 --json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from physics.errors import BeamDamageError, FileFormatError
from physics.io import atomic_write_text

__all__ = ["main", "read_frequency_table", "write_frequency_series"]


def read_frequency_table(path, key: str | None = None) -> np.ndarray:
    """The table of a ``.mat`` (matrix ``key``) or CSV file as an array of shape (n_tests, n_modes) in Hz."""
    path = Path(path)
    if path.suffix.lower() == ".mat":
        import scipy.io

        try:
            data = scipy.io.loadmat(path)
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{path}: not a MATLAB file scipy reads ({exc})") from None
        names = [k for k in data if not k.startswith("__")]
        if key is None and len(names) == 1:
            key = names[0]
        if key not in data:
            raise FileFormatError(f"{path}: no matrix {key!r}; it holds {', '.join(names) or 'nothing'} (--key)")
        F = np.asarray(data[key], dtype=float)
    else:
        try:
            F = np.genfromtxt(path, delimiter=",", dtype=float, skip_header=0)
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{path}: not a CSV of numbers ({exc})") from None
        if F.ndim == 2 and np.isnan(F[0]).all():
            F = F[1:]
    if F.ndim != 2 or min(F.shape) < 1:
        raise FileFormatError(f"{path}: expected a 2-D table of frequencies (modes x tests), got shape {F.shape}")
    return F.T if F.shape[0] < F.shape[1] else F


def write_frequency_series(F: np.ndarray, out_dir, tests_per_day: int = 1) -> list[int]:
    """One modal-data JSON per test and ``conditions.csv`` (file, time in hours); returns the tests left out."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    width = max(3, len(str(F.shape[0] - 1)))
    rows, skipped = ["file,time"], []
    for k, f in enumerate(F):
        if not np.all(np.isfinite(f) & (f > 0)):
            skipped.append(k)
            continue
        name = f"test-{k:0{width}d}.json"
        atomic_write_text(out / name, json.dumps({"natural_frequencies_hz": [float(v) for v in f]}) + "\n")
        rows.append(f"{name},{k * 24.0 / tests_per_day:g}")
    atomic_write_text(out / "conditions.csv", "\n".join(rows) + "\n")
    return skipped


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.studies.frequency_series",
                                description=__doc__.split("\n")[0])
    p.add_argument("table", help=".mat (with --key) or .csv table of frequencies (Hz)")
    p.add_argument("--key", default=None, help="the matrix of a .mat file (default: its only one)")
    p.add_argument("--tests-per-day", type=int, default=1)
    p.add_argument("--out", required=True)
    a = p.parse_args(argv)
    try:
        if a.tests_per_day < 1:
            raise BeamDamageError(f"--tests-per-day must be >= 1, got {a.tests_per_day}")
        F = read_frequency_table(a.table, a.key)
        skipped = write_frequency_series(F, a.out, a.tests_per_day)
    except BeamDamageError as exc:
        print(f"frequency_series: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {F.shape[0] - len(skipped)} tests of {F.shape[1]} modes to {a.out}"
          + (f"; left out tests {skipped} (frequencies not all finite and positive)" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
