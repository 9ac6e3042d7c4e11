"""FRFs as ``.npz`` of plain arrays (never pickled objects)."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from physics.errors import FileFormatError, ShapeError
from physics.io.atomic import atomic_write_bytes
from physics.io.types import MeasuredFRF

__all__ = ["read_frf_npz", "write_frf_npz"]


_NPZ_KEYS = ("frequency_hz", "frf", "response_dofs", "reference_dofs", "kind", "units", "metadata_json")


def write_frf_npz(path, data: MeasuredFRF) -> None:
    """Write :class:`MeasuredFRF` as ``.npz`` (plain arrays, no pickled objects), atomically."""
    buf = io.BytesIO()
    np.savez(buf, frequency_hz=data.frequency_hz, frf=data.frf,
             response_dofs=np.array(data.response_dofs, dtype=str),
             reference_dofs=np.array(data.reference_dofs, dtype=str),
             kind=np.array(data.kind), units=np.array(data.units),
             metadata_json=np.array(json.dumps(data.metadata, default=str)))
    atomic_write_bytes(path, buf.getvalue())


def read_frf_npz(path) -> MeasuredFRF:
    """Read a file written by :func:`write_frf_npz` (loaded with ``allow_pickle=False``)."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in _NPZ_KEYS[:4] if k not in z.files]
            if missing:
                raise FileFormatError(f"{path}: missing array(s) {', '.join(missing)}; expected "
                                      f"{', '.join(_NPZ_KEYS)}")
            arrays = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, FileFormatError):
            raise
        raise FileFormatError(f"{path}: not a readable .npz of a MeasuredFRF ({exc})") from None
    try:
        meta = json.loads(str(arrays.get("metadata_json", "{}")))
        return MeasuredFRF(arrays["frequency_hz"], arrays["frf"],
                           tuple(arrays["response_dofs"].tolist()), tuple(arrays["reference_dofs"].tolist()),
                           kind=str(arrays.get("kind", "receptance")), units=str(arrays.get("units", "")),
                           metadata={**meta, "source": str(path), "format": "npz"})
    except (ShapeError, json.JSONDecodeError) as exc:
        raise FileFormatError(f"{path}: {exc}") from None


