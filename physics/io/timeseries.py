"""Response time series as ``.npz`` (plain arrays) or CSV text, read as :class:`~physics.io.timedata.TimeRecords`.

NPZ keys: ``signals`` (n_channels, n_samples) real, ``sampling_frequency_hz`` (scalar), optional ``dofs``
(``"NODE:+DIR"`` per channel; without it the channels are ``1:+Z, 2:+Z, ...`` and the metadata's ``dof_labels`` is
``"by position"``) and ``quantity`` (``"displacement"``, ``"velocity"``, ``"acceleration"`` or ``"force"``, SI
units; one for every channel, or one per channel: a force channel makes the file force and responses, whose FRFs
``estimate`` and ``identify`` estimate; default acceleration). CSV: a header ``time_s,<dof>,<dof>,...`` and one row
per sample at a uniform time step (the sampling rate is read from the time column); an optional comment line
``# quantity: velocity`` (or one per channel, ``# quantity: force, acceleration``) sets the quantities.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from physics.io.csv import csv_values
from physics.io.inputs import check_input_file
from physics.errors import FileFormatError
from physics.io.npz import read_npz_arrays
from physics.io.timedata import TimeRecords
from physics.io.types import check_dof_labels

__all__ = ["read_time_csv", "read_time_npz"]

_QUANTITIES = ("displacement", "velocity", "acceleration", "force")


def _records(path, signals, fs, dofs, quantity) -> TimeRecords:
    """``quantity``: one name for every channel, or one per channel."""
    if signals.ndim != 2 or signals.shape[1] < 2 or not np.issubdtype(signals.dtype, np.number) \
            or np.iscomplexobj(signals):
        raise FileFormatError(f"{path}: field 'signals' must be a real (n_channels, n_samples) array of at least 2 "
                              f"samples, got {signals.dtype} of shape {signals.shape}")
    if not (np.isfinite(fs) and fs > 0):
        raise FileFormatError(f"{path}: field 'sampling_frequency_hz' must be a finite number > 0, got {fs:g}")
    quantities = [quantity] if isinstance(quantity, str) else list(quantity)
    if len(quantities) not in (1, signals.shape[0]) or any(q not in _QUANTITIES for q in quantities):
        raise FileFormatError(f"{path}: field 'quantity' {', '.join(quantities)!r} must be one of "
                              f"{', '.join(_QUANTITIES)}, or "
                              f"one of them per channel ({signals.shape[0]})")
    if len(quantities) == 1 and signals.shape[0] > 1 and quantities[0] == "force":
        raise FileFormatError(f"{path}: field 'quantity' 'force' for every channel: no response; give one quantity "
                              "per channel, e.g. force, acceleration, ...")
    labels = {} if dofs is not None else {"dof_labels": "by position"}     # channels 1:+Z, 2:+Z, ... in order
    dofs = tuple(dofs) if dofs is not None else tuple(f"{k + 1}:+Z" for k in range(signals.shape[0]))
    if len(dofs) != signals.shape[0]:
        raise FileFormatError(f"{path}: field 'dofs' has {len(dofs)} labels for {signals.shape[0]} channels")
    check_dof_labels(dofs, f"{path}: field 'dofs'")
    quantities = quantities * len(dofs) if len(quantities) == 1 else quantities
    return TimeRecords(1.0 / fs, np.asarray(signals, dtype=np.float64), dofs, tuple(quantities),
                       {"source": str(path), "format": Path(path).suffix.lstrip("."), **labels})


def read_time_npz(path) -> TimeRecords:
    """Read response time series from ``.npz`` (see module docstring); never unpickles."""
    z = read_npz_arrays(path, "an NPZ time series")
    if "signals" not in z:
        raise FileFormatError(f"{path}: no field 'signals' (n_channels, n_samples); fields: {', '.join(z)}")
    if "sampling_frequency_hz" not in z:
        raise FileFormatError(f"{path}: field 'sampling_frequency_hz' is missing; the sampling rate is "
                              "needed to identify from time series")
    rate = np.asarray(z["sampling_frequency_hz"]).reshape(-1)
    if rate.size != 1 or rate.dtype.kind not in "iuf":
        raise FileFormatError(f"{path}: field 'sampling_frequency_hz' must be one real number (Hz)")
    dofs = [str(d) for d in z["dofs"].reshape(-1)] if "dofs" in z else None
    quantity = [str(q) for q in np.asarray(z["quantity"]).reshape(-1)] if "quantity" in z else ["acceleration"]
    signals = z["signals"]
    if signals.ndim == 2 and signals.shape[0] > signals.shape[1] >= 2:
        raise FileFormatError(f"{path}: field 'signals' of shape {signals.shape} holds more channels than samples; "
                              "expected (n_channels, n_samples), one row per channel (transposed?)")
    return _records(path, signals, float(rate[0]), dofs, quantity)


def read_time_csv(path) -> TimeRecords:
    """Read response time series from CSV text (see module docstring); a UTF-8 byte-order mark (spreadsheets write
    one) is skipped, and a bad row is named by its line number."""
    text = check_input_file(path, "csv", what="a CSV time series").read_text(encoding="utf-8-sig", errors="replace")
    quantity = "acceleration"
    body = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s.startswith("#"):
            if s[1:].strip().lower().startswith("quantity:"):
                quantity = [q.strip() for q in s.split(":", 1)[1].strip().lower().split(",")]
            continue
        if s:
            body.append((lineno, s))
    if not body or not body[0][1].lower().startswith("time_s"):
        raise FileFormatError(f"{path}: expected a header 'time_s,<dof>,...' (a time column in s, then one "
                              "column per channel)")
    if "," not in body[0][1]:
        sep = next((c for c in ";\t " if c in body[0][1]), None)
        raise FileFormatError(f"{path}: line {body[0][0]}: header {body[0][1][:60]!r} has no comma; columns must be "
                              "separated by commas" + (f", not {sep!r}" if sep else ""))
    dofs = [c.strip() for c in body[0][1].split(",")[1:]]
    if len(body) < 3:
        raise FileFormatError(f"{path}: rows must hold {len(dofs) + 1} numbers (time_s and one per channel), at "
                              "least two rows")
    data = csv_values(path, body[1:], len(dofs) + 1)
    dt = np.diff(data[:, 0])
    off = np.flatnonzero(~((dt > 0) & np.isclose(dt, dt[0], rtol=1e-6)))
    if off.size:
        raise FileFormatError(f"{path}: line {body[off[0] + 2][0]}: column 'time_s' must increase by one uniform "
                              f"step (the sampling rate): {data[off[0] + 1, 0]:.9g} s after {data[off[0], 0]:.9g} s, "
                              f"where the first step is {dt[0]:.6g} s")
    return _records(path, data[:, 1:].T.copy(), 1.0 / float(np.mean(dt)), dofs, quantity)
