"""Time records of universal-file dataset 58 (function type 1): forces and responses in SI units."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from physics.errors import FileFormatError
from physics.io.types import MAX_MAGNITUDE, dof_label
from physics.io.units import parse_force_unit, parse_response_unit
from physics.io.uff58 import UFF_FUNCTION_NAMES, UffFile

__all__ = ["QUANTITIES", "TimeRecords", "read_uff_time_records"]

#: Quantity of each dataset 58 ordinate type a time record can hold, and its SI unit.
QUANTITIES = {13: ("force", "N"), 8: ("displacement", "m"), 11: ("velocity", "m/s"), 12: ("acceleration", "m/s^2")}
_KIND_QUANTITY = {"receptance": "displacement", "mobility": "velocity", "accelerance": "acceleration"}
#: Largest record this reader loads (samples x channels); beyond it the file is refused with the numbers.
MAX_SAMPLES = 50_000_000


@dataclass(frozen=True)
class TimeRecords:
    """Sampled channels of one test, SI units.

    Attributes
    ----------
    time_step_s : float
    signals : ndarray, shape (n_channels, n_samples)
    dofs : tuple of str
        ``"NODE:+DIR"`` of each channel.
    quantities : tuple of str
        ``"force"``, ``"displacement"``, ``"velocity"`` or ``"acceleration"`` per channel.
    metadata : dict
    """

    time_step_s: float
    signals: np.ndarray
    dofs: tuple
    quantities: tuple
    metadata: dict = field(default_factory=dict)

    @property
    def sampling_frequency_hz(self) -> float:
        return 1.0 / self.time_step_s

    @property
    def forces(self) -> list:
        return [i for i, q in enumerate(self.quantities) if q == "force"]

    @property
    def responses(self) -> list:
        return [i for i, q in enumerate(self.quantities) if q != "force"]


def read_uff_time_records(path) -> TimeRecords:
    """Read the time records (dataset 58, function type 1) of a universal file.

    Each channel's quantity comes from its ordinate type (13 force, 8
    displacement, 11 velocity, 12 acceleration) or its unit label; values are
    converted to SI with the labels or the dataset 164 unit system. All records
    must share one time step and length. ``path`` is a file name or a file already
    opened (:class:`~physics.io.uff58.UffFile`).

    Raises
    ------
    FileFormatError
        No time record, an unknown quantity, unequal sampling, NaN values.
    """
    uf = path if isinstance(path, UffFile) else UffFile(path)
    path = uf.path
    system, _ = uf.context
    recs = [(n, s) for n, s in uf.records58 if int(s.get("func_type", -1)) == 1]
    if not recs:
        found = sorted(uf.function_types)
        raise FileFormatError(f"{path}: no time record (dataset 58, function type 1); function types found: "
                              + (", ".join(f"{f} ({UFF_FUNCTION_NAMES.get(f, 'unknown')})" for f in found)
                                 or "none"))
    dt, n_pts = None, None
    signals, dofs, quantities, labels = [], [], [], []
    for n, s in recs:
        where = f"{path}: record {n + 1} (time record, node {s.get('rsp_node')}/{s.get('rsp_dir')})"
        data = np.asarray(s.get("data", []))
        if np.iscomplexobj(data) or data.ndim != 1:
            raise FileFormatError(f"{where}: a time record must hold real samples")
        if data.size * max(len(recs), 1) > MAX_SAMPLES:
            raise FileFormatError(f"{where}: {data.size} samples x {len(recs)} channels exceed the "
                                  f"{MAX_SAMPLES} this reader loads")
        if not np.all(np.isfinite(data)):
            raise FileFormatError(f"{where}: contains NaN or inf samples")
        if data.size and np.max(np.abs(data)) > MAX_MAGNITUDE:
            raise FileFormatError(f"{where}: a sample of magnitude {np.max(np.abs(data)):.3g}, beyond the "
                                  f"{MAX_MAGNITUDE:g} this package accepts (a unit or export error?)")
        step = float(s.get("abscissa_inc", 0.0))
        if not step > 0 or not np.isfinite(step):
            raise FileFormatError(f"{where}: time step (abscissa increment) {step:g} s must be > 0")
        if dt is None:
            dt, n_pts = step, data.size
        elif not np.isclose(step, dt, rtol=1e-9) or data.size != n_pts:
            raise FileFormatError(f"{where}: sampled at {1 / step:g} Hz with {data.size} samples, unlike the first "
                                  f"record ({1 / dt:g} Hz, {n_pts} samples)")
        code = int(s.get("ordinate_spec_data_type", 0))
        label = str(s.get("ordinate_axis_units_lab", "") or "")
        try:
            force = parse_force_unit(label) if code == 13 or _is_force_label(label) else None
            resp = None if force is not None or code == 13 else parse_response_unit(label)
        except FileFormatError as exc:
            raise FileFormatError(f"{where}: {exc}") from None
        if code == 13 or force is not None:
            q, factor = "force", force if force is not None else 1.0 / system.force
        elif resp is not None:
            q, factor = _KIND_QUANTITY[resp[0]], resp[1]
            if code in QUANTITIES and QUANTITIES[code][0] != q:
                raise FileFormatError(f"{where}: unit label {label!r} is a {q} unit but the ordinate type "
                                      f"{code} says {QUANTITIES[code][0]}; refusing to guess")
        elif code in QUANTITIES:
            q, factor = QUANTITIES[code][0], 1.0 / system.length
        else:
            raise FileFormatError(f"{where}: quantity unknown (ordinate type {code}, unit label {label!r}); "
                                  "expected force (13), displacement (8), velocity (11) or acceleration (12)")
        signals.append(data.astype(float) * factor)
        dofs.append(dof_label(s.get("rsp_node", 0), s.get("rsp_dir", 0)))
        quantities.append(q)
        labels.append(label.strip() or QUANTITIES.get(code, ("", "?"))[1])
    return TimeRecords(dt, np.array(signals), tuple(dofs), tuple(quantities),
                       {"source": str(path), "labels": labels})


def _is_force_label(label) -> bool:
    try:
        return parse_force_unit(label) is not None
    except FileFormatError:
        return False
