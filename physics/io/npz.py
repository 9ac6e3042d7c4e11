"""``.npz`` files of plain arrays (never pickled objects): the one guarded reader of every NPZ input
(:func:`read_npz_arrays`), and FRFs as NPZ."""

from __future__ import annotations

import io
import json
import zipfile
import zlib

import numpy as np

from physics.io.inputs import check_input_file
from physics.errors import FileFormatError, ShapeError
from physics.io.atomic import atomic_write_bytes
from physics.io.types import FRF_KINDS, MeasuredFRF, check_dof_labels
from physics.io.units import stated_units_factor

__all__ = ["read_frf_npz", "read_npz_arrays", "write_frf_npz"]


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


#: Largest array this reader loads from an .npz (elements), checked in the member headers before loading.
MAX_ARRAY_ELEMENTS = 200_000_000


#: What a damaged NPZ raises while it is opened or its members read (truncated, bad CRC, bad compression ...).
NPZ_ERRORS = (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, MemoryError, KeyError, SyntaxError)


def _check_members(path, z, what):
    """Every member must be a .npy whose header announces at most MAX_ARRAY_ELEMENTS elements."""
    for name in z.namelist():
        if not name.endswith(".npy"):
            raise FileFormatError(f"{path}: member {name!r} is not a .npy array; not {what}")
        with z.open(name) as fh:
            try:
                version = np.lib.format.read_magic(fh)
                reader = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                    np.lib.format.read_array_header_2_0
                shape, _, dtype = reader(fh, max_header_size=10000)
            except (ValueError, SyntaxError, EOFError) as exc:
                raise FileFormatError(f"{path}: member {name!r} has a bad .npy header ({exc})") from None
        size = int(np.prod(shape, dtype=object))
        if size > MAX_ARRAY_ELEMENTS:
            raise FileFormatError(f"{path}: array {name[:-4]!r} announces shape {shape} ({size} elements, "
                                  f"{size * dtype.itemsize / 2**30:.3g} GiB); refusing more than {MAX_ARRAY_ELEMENTS}")


def read_npz_arrays(path, what="an NPZ file of plain arrays") -> dict:
    """Every array of an ``.npz`` file, loaded with ``allow_pickle=False`` after its member headers are checked
    (only .npy members, at most :data:`MAX_ARRAY_ELEMENTS` elements each).

    Raises
    ------
    FileFormatError
        One line naming the file and ``what`` it should be: missing, not a regular file, too large, not a zip
        archive, truncated or damaged (bad CRC, bad compression), a member that is not a .npy array.
    """
    path = check_input_file(path, "npz", what=what)
    try:
        with zipfile.ZipFile(path) as zf:
            _check_members(path, zf, what)
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except FileFormatError:
        raise
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found; expected {what}") from None
    except NPZ_ERRORS as exc:
        raise FileFormatError(f"{path}: not a readable .npz ({type(exc).__name__}: "
                              f"{' '.join(str(exc).split())[:150]}); expected {what}") from None


def read_frf_npz(path, kind=None) -> MeasuredFRF:
    """Read a file written by :func:`write_frf_npz` (loaded with ``allow_pickle=False``).

    Member headers are checked before anything is loaded (only .npy members, at
    most :data:`MAX_ARRAY_ELEMENTS` elements each); the FRF must be complex, the
    frequencies real, the DOF labels 1-D lists of strings, the metadata a JSON object.
    ``kind`` applies to a file without a ``kind`` array (default receptance).
    """
    arrays = read_npz_arrays(path, "an .npz of FRFs (frequency_hz, frf, ...) or of time series (signals, ...)")
    missing = [k for k in _NPZ_KEYS[:4] if k not in arrays]
    if missing and "signals" in arrays:
        raise FileFormatError(f"{path}: holds response time series (array 'signals'), not FRFs (arrays "
                              f"{', '.join(_NPZ_KEYS[:4])}); identify its modes first (beam-damage identify FILE "
                              "--out DIR) and give DIR/modal.json")
    if missing:
        raise FileFormatError(f"{path}: missing array(s) {', '.join(missing)}; expected {', '.join(_NPZ_KEYS)}; "
                              "or, for response time series, signals and sampling_frequency_hz")
    for key in ("response_dofs", "reference_dofs"):
        a = arrays[key]
        if a.ndim != 1 or a.dtype.kind != "U":
            raise FileFormatError(f"{path}: array '{key}' must be a 1-D array of DOF labels (strings), got "
                                  f"{a.dtype} of shape {a.shape}")
        check_dof_labels(a.tolist(), f"{path}: array '{key}'", unnamed_reference=key == "reference_dofs")
    for key in ("kind", "units", "metadata_json"):
        if key in arrays and (arrays[key].ndim != 0 or arrays[key].dtype.kind != "U"):
            raise FileFormatError(f"{path}: array '{key}' must be a single string")
    if arrays["frf"].dtype.kind != "c":
        raise FileFormatError(f"{path}: array 'frf' is {arrays['frf'].dtype}; an FRF must be complex")
    if arrays["frequency_hz"].dtype.kind not in "iuf":
        raise FileFormatError(f"{path}: array 'frequency_hz' is {arrays['frequency_hz'].dtype}; frequencies must "
                              "be real numbers (Hz)")
    try:
        meta = json.loads(str(arrays.get("metadata_json", "{}")))
    except (json.JSONDecodeError, RecursionError):
        raise FileFormatError(f"{path}: array 'metadata_json' is not valid JSON") from None
    if not isinstance(meta, dict):
        raise FileFormatError(f"{path}: array 'metadata_json' must hold a JSON object, got {type(meta).__name__}")
    file_kind, units = str(arrays.get("kind", kind or "receptance")), str(arrays.get("units", ""))
    factor = stated_units_factor(units, file_kind, f"{path}: array 'units' ({units!r})") if file_kind in FRF_KINDS \
        else 1.0                                    # an unknown kind: MeasuredFRF names it
    try:
        return MeasuredFRF(arrays["frequency_hz"], arrays["frf"] * factor,
                           tuple(arrays["response_dofs"].tolist()), tuple(arrays["reference_dofs"].tolist()),
                           kind=file_kind, metadata={**meta, "source": str(path), "format": "npz"})
    except ShapeError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
