"""The tests of a series: their order, times and measured conditions (a CSV), and whether each test belongs to
the series of the baseline period (one kind, band and beam)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from learn.monitor.identification import IdentifiedModes
from physics.errors import BeamDamageError
from physics.io.inputs import check_input_file, repeated_files

__all__ = ["SeriesInput", "check_series", "read_conditions"]


@dataclass(frozen=True)
class SeriesInput:
    """The tests of a series in time order.

    Attributes
    ----------
    files : list of str
    times : list              as given (ISO dates or numbers); None without times
    time_values : ndarray (n,)    days since the first test for dates, the numbers as given, else 0..n-1
    conditions : ndarray (n, q) or None     measured conditions (NaN where not measured)
    condition_names : tuple of str
    where : tuple of str          per test, where it is listed (``"series.csv line 4"``; empty: given as files)
    """

    files: list
    times: list
    time_values: np.ndarray
    conditions: np.ndarray | None = None
    condition_names: tuple = ()
    where: tuple = ()

    @classmethod
    def from_files(cls, files) -> "SeriesInput":
        files = [str(f) for f in files]
        return cls(files, [None] * len(files), np.arange(len(files), dtype=float))


def _time_value(text: str, where: str):

    try:
        return float(text), False
    except ValueError:
        pass
    try:
        t = datetime.fromisoformat(text.strip())
    except ValueError:
        raise BeamDamageError(f"{where}: time {text!r} is neither a number nor an ISO date (2024-03-01 or "
                              "2024-03-01T12:00)") from None
    return t.timestamp() / 86400.0 if t.tzinfo else (t - datetime(1970, 1, 1)).total_seconds() / 86400.0, True


def read_conditions(csv_path) -> SeriesInput:
    """A series from a CSV file: columns ``file`` (relative to the CSV or absolute), ``time`` (an ISO date or a
    number) and any measured conditions (numbers, e.g. ``temperature_c``); rows sorted by time (stable)."""
    path = check_input_file(csv_path, "csv", BeamDamageError, "a CSV of file,time[,condition...]")
    with open(path, newline="", encoding="utf-8-sig") as fh:       # a spreadsheet's byte-order mark skipped
        rows = list(csv.DictReader(fh))
    if not rows:
        raise BeamDamageError(f"{csv_path}: no rows; expected a header file,time[,condition...] and one row per test")
    head = list(rows[0].keys())
    missing = [c for c in ("file", "time") if c not in head]
    if missing:
        sep = next((c for c in ";\t" if len(head) == 1 and c in str(head[0])), None)
        raise BeamDamageError(f"{csv_path}: column(s) {', '.join(missing)} missing; expected file,time"
                              f"[,condition...], got {','.join(map(str, head))}"
                              + (f" (columns must be separated by commas, not {sep!r})" if sep else ""))
    names = tuple(c for c in head if c not in ("file", "time") and c)
    files, times, values, conds, dates, lines = [], [], [], [], set(), []
    for k, r in enumerate(rows, 2):
        where = f"{csv_path} line {k}"
        lines.append(where)
        if None in r or not r["file"]:
            raise BeamDamageError(f"{where}: expected {len(head)} fields with a file name")
        f = Path(r["file"])
        files.append(str(f if f.is_absolute() else Path(csv_path).parent / f))
        times.append(r["time"])
        v, is_date = _time_value(r["time"], where)
        values.append(v)
        dates.add(is_date)
        row = []
        for c in names:
            text = (r[c] or "").strip()
            try:
                row.append(float(text) if text else math.nan)
            except ValueError:
                raise BeamDamageError(f"{where}: {c} = {text!r} is not a number") from None
        conds.append(row)
    if len(dates) > 1:
        raise BeamDamageError(f"{csv_path}: column time mixes ISO dates and numbers")
    order = np.argsort(np.asarray(values), kind="stable")
    t = np.asarray(values)[order]
    if dates == {True}:
        t = t - t[0]
    C = np.asarray(conds, float)[order] if names else None
    return SeriesInput([files[i] for i in order], [times[i] for i in order], t, C, names,
                       tuple(lines[i] for i in order))


def _layout(m: IdentifiedModes) -> dict:
    return {"kind": m.kind, "dofs": tuple(sorted(m.dofs)), "references": tuple(sorted(m.references))}


def check_series(tests: list, n_baseline: int, files: list) -> list:
    """Per test, None or why it does not belong to the series of the first identified baseline test: another kind
    (FRF, response records, modal data), band (a band edge more than 2 lines away) or beam (other measured or
    reference DOFs). Raises :class:`BeamDamageError` when a baseline test differs (the baseline must be one
    beam's)."""
    first = next((i for i, t in enumerate(tests[:n_baseline]) if t is not None), None)
    if first is None:
        raise BeamDamageError(f"none of the {n_baseline} baseline tests could be identified")
    ref = tests[first]
    lay = _layout(ref)
    out = []
    for i, t in enumerate(tests):
        why = None
        if t is not None:
            other = _layout(t)
            if other["kind"] != lay["kind"]:
                why = f"mixed kinds: {files[i]} holds {t.kind}, {files[first]} {ref.kind}"
            elif other["dofs"] != lay["dofs"] or other["references"] != lay["references"]:
                why = (f"mixed beams: {files[i]} measures DOFs {', '.join(t.dofs)} (references "
                       f"{', '.join(t.references) or 'none'}), {files[first]} {', '.join(ref.dofs)} (references "
                       f"{', '.join(ref.references) or 'none'})")
            elif ref.band_hz is not None and t.band_hz is not None:
                line = 2 * max(ref.line_hz or 0.0, t.line_hz or 0.0)
                if max(abs(a - b) for a, b in zip(ref.band_hz, t.band_hz)) > line:
                    why = (f"mixed bands: {files[i]} spans {t.band_hz[0]:g}-{t.band_hz[1]:g} Hz, {files[first]} "
                           f"{ref.band_hz[0]:g}-{ref.band_hz[1]:g} Hz")
        if why and i < n_baseline:
            raise BeamDamageError(f"baseline test {why}")
        out.append(why)
    return out


def repeated_tests_warning(files: list, n_baseline: int) -> str:
    """A warning naming the tests that repeat an earlier one (:func:`physics.io.inputs.repeated_files`), empty when
    none does."""
    pairs = repeated_files(files)
    if not pairs:
        return ""
    named = "; ".join(f"test {j + 1} ({files[j]}) " + (f"repeats test {i + 1} ({files[i]})" if files[i] != files[j]
                                                          else f"is test {i + 1} listed again")
                      for i, j in pairs[:3]) + ("; ..." if len(pairs) > 3 else "")
    base = sum(j < n_baseline for _, j in pairs)
    return (f"{len(pairs)} test(s) repeat an earlier one (the same file, or the same bytes): {named}; a repeated "
            "test is no new test" + (f": {base} of them in the baseline period, where they understate the normal "
                                     "variation" if base else ""))
