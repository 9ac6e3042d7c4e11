"""Reading and writing measured and modal data (file I/O lives only here).

Measured FRFs
-------------
:class:`MeasuredFRF` holds an FRF matrix ``(n_resp, n_ref, n_lines)`` with its
frequency axis (Hz), DOF labels ``"NODE:+DIR"`` and kind (receptance, mobility,
accelerance). Readers/writers: universal file dataset 58 (ASCII and binary 58b,
through ``pyuff``), a plain CSV layout (see :func:`read_frf_csv`) and ``.npz``;
:func:`read_frf` picks one from the file name or content.

Modal-data JSON
---------------
One object with the keys of a beam state in the thesis fixture ``beams.json``::

    {"natural_frequencies_hz": [f1, ...],            # optional if eigenvalues given
     "damping_ratios": [z1, ...],                    # optional if eigenvalues given
     "eigenvalues": ["-0.21962+135.31j", ...],       # complex strings, upper half-plane
     "eigenvectors": [["0.72+15.0j", ...], ...],     # rows = measured DOFs, cols = modes
     "dofs": ["2:y", "3:y", ...]}                    # optional labels of the rows

Eigenvalues follow the package's conjugate-pair convention: one eigenvalue of
each pair, ``lambda_j = -zeta_j*omega_j + i*omega_j*sqrt(1 - zeta_j**2)``; the
partner is its complex conjugate with the conjugate eigenvector. When only
frequencies and damping ratios are given, the eigenvalues are built from them.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
import warnings
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from physics.errors import FileFormatError, ShapeError


@dataclass(frozen=True)
class ModalData:
    """Measured or computed complex modal data.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        One eigenvalue of each conjugate pair (rad/s), ``Im > 0``.
    eigenvectors : ndarray, complex, shape (n_dofs, n_modes) or None
        Complex mode shapes, columns are modes.
    dofs : tuple of str
        Labels of the rows of ``eigenvectors`` (may be empty).
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray | None
    dofs: tuple = ()

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return np.abs(self.eigenvalues) / (2 * np.pi)

    @property
    def damping_ratios(self) -> np.ndarray:
        return -self.eigenvalues.real / np.abs(self.eigenvalues)


def format_complex(z: complex) -> str:
    """Complex number as ``"a+bj"`` with 17 significant digits (round-trips ``complex()``)."""
    z = complex(z)
    return f"{z.real:.17g}{z.imag:+.17g}j"


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file normal permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path, text: str) -> None:
    """Text version of :func:`atomic_write_bytes` (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def _complex_array(values, path, key, ndim):
    try:
        arr = np.array(
            [[complex(str(v).replace(" ", "").replace("i", "j")) for v in row] for row in values]
            if ndim == 2
            else [complex(str(v).replace(" ", "").replace("i", "j")) for v in values],
            dtype=complex,
        )
    except (TypeError, ValueError):
        form = "a list of lists of complex strings such as \"0.72+15.0j\"" if ndim == 2 else \
            "a list of complex strings such as \"-0.22+135.3j\""
        raise FileFormatError(f"{path}: field '{key}' must be {form}") from None
    if arr.ndim != ndim or not np.all(np.isfinite(arr)):
        raise FileFormatError(f"{path}: field '{key}' must be a finite {ndim}-D array")
    return arr


def modal_data_from_dict(obj: dict, source="modal data") -> ModalData:
    """Validate a modal-data mapping (see module docstring) into :class:`ModalData`."""
    if not isinstance(obj, dict):
        raise FileFormatError(f"{source}: expected a JSON object with 'eigenvalues' or "
                              "'natural_frequencies_hz' and 'damping_ratios'")
    if "eigenvalues" in obj:
        lam = _complex_array(obj["eigenvalues"], source, "eigenvalues", 1)
    elif "natural_frequencies_hz" in obj and "damping_ratios" in obj:
        try:
            f = np.asarray(obj["natural_frequencies_hz"], dtype=float)
            z = np.asarray(obj["damping_ratios"], dtype=float)
        except (TypeError, ValueError):
            raise FileFormatError(f"{source}: 'natural_frequencies_hz' and 'damping_ratios' "
                                  "must be lists of numbers") from None
        if f.shape != z.shape or f.ndim != 1 or not (np.all(np.isfinite(f)) and np.all(np.isfinite(z))):
            raise FileFormatError(f"{source}: 'natural_frequencies_hz' and 'damping_ratios' must be "
                                  "finite lists of equal length")
        if np.any(z >= 1) or np.any(f <= 0):
            raise FileFormatError(f"{source}: 'damping_ratios' must be < 1 and frequencies > 0 "
                                  "(underdamped modes)")
        w = 2 * np.pi * f
        lam = -z * w + 1j * w * np.sqrt(1 - z**2)
    else:
        raise FileFormatError(f"{source}: missing key 'eigenvalues' (or 'natural_frequencies_hz' "
                              "with 'damping_ratios')")
    vecs = None
    if obj.get("eigenvectors") is not None:
        vecs = _complex_array(obj["eigenvectors"], source, "eigenvectors", 2)
        if vecs.shape[1] != lam.size:
            raise FileFormatError(f"{source}: field 'eigenvectors' has {vecs.shape[1]} columns "
                                  f"but there are {lam.size} eigenvalues (columns are modes)")
    dofs = tuple(str(d) for d in obj.get("dofs", ()))
    if dofs and vecs is not None and len(dofs) != vecs.shape[0]:
        raise FileFormatError(f"{source}: field 'dofs' has {len(dofs)} labels but "
                              f"'eigenvectors' has {vecs.shape[0]} rows")
    return ModalData(lam, vecs, dofs)


def read_modal_json(path) -> ModalData:
    """Read a modal-data JSON file (see module docstring)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    return modal_data_from_dict(obj, str(path))


def modal_data_to_dict(data: ModalData) -> dict:
    """Inverse of :func:`modal_data_from_dict` (complex values as strings)."""
    fmt = format_complex
    out = {
        "natural_frequencies_hz": data.natural_frequencies_hz.tolist(),
        "damping_ratios": data.damping_ratios.tolist(),
        "eigenvalues": [fmt(z) for z in data.eigenvalues],
    }
    if data.eigenvectors is not None:
        out["eigenvectors"] = [[fmt(z) for z in row] for row in data.eigenvectors]
    if data.dofs:
        out["dofs"] = list(data.dofs)
    return out


def write_modal_json(path, data: ModalData) -> None:
    """Write :class:`ModalData` as modal-data JSON, atomically."""
    atomic_write_text(path, json.dumps(modal_data_to_dict(data), indent=1) + "\n")


# ---------------------------------------------------------------------------
# Measured FRFs
# ---------------------------------------------------------------------------

FRF_KINDS = ("receptance", "mobility", "accelerance")
#: Power of ``i*omega`` that turns a receptance into each kind.
_KIND_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: SI units of each kind.
DEFAULT_UNITS = {"receptance": "m/N", "mobility": "m/s/N", "accelerance": "m/s^2/N"}

_DIRECTIONS = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
_DIRECTION_CODES = {v: k for k, v in _DIRECTIONS.items()}


def dof_label(node: int, direction: int) -> str:
    """Label ``"node:+Y"`` of a UFF node and direction code (1..6 = X, Y, Z, RX, RY, RZ; sign = sense)."""
    node, direction = int(node), int(direction)
    if direction == 0:
        return f"{node}:S"  # scalar DOF
    if abs(direction) not in _DIRECTIONS:
        raise FileFormatError(f"direction code {direction} is not one of 0, +-1..+-6")
    return f"{node}:{'+' if direction > 0 else '-'}{_DIRECTIONS[abs(direction)]}"


def parse_dof(label: str) -> tuple[int, int]:
    """Inverse of :func:`dof_label`: ``"2:+Y"`` (or ``"2:y"``, ``"2:-RZ"``, ``"2:S"``) -> ``(2, 2)``."""
    text = str(label).strip()
    node, sep, direction = text.partition(":")
    try:
        node_i = int(node)
    except ValueError:
        node_i = None
    direction = direction.strip().upper()
    sign = -1 if direction.startswith("-") else 1
    direction = direction.lstrip("+-")
    if not sep or node_i is None or (direction not in _DIRECTION_CODES and direction != "S"):
        raise FileFormatError(f"DOF label {label!r} must look like 'NODE:+DIR' with an integer node "
                              "and DIR one of X, Y, Z, RX, RY, RZ (e.g. '2:+Y')")
    return node_i, (0 if direction == "S" else sign * _DIRECTION_CODES[direction])


@dataclass(frozen=True)
class MeasuredFRF:
    """A matrix of measured frequency response functions.

    Attributes
    ----------
    frequency_hz : ndarray, float, shape (n_lines,)
        Strictly increasing frequency axis (Hz); need not be evenly spaced.
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        ``frf[s, r, k]`` = response ``s`` over force at reference ``r`` at line ``k``.
    response_dofs, reference_dofs : tuple of str
        DOF labels such as ``"2:+Y"`` (node 2, +Y; see :func:`dof_label`).
    kind : {"receptance", "mobility", "accelerance"}
        Displacement, velocity or acceleration over force.
    units : str
        Units of ``frf`` (SI by default, e.g. ``"m/N"`` for receptance).
    metadata : dict
        Free-form, JSON-serialisable information (source file, test id, ...).
    """

    frequency_hz: np.ndarray
    frf: np.ndarray
    response_dofs: tuple
    reference_dofs: tuple
    kind: str = "receptance"
    units: str = ""
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        f = np.asarray(self.frequency_hz, dtype=np.float64)
        h = np.asarray(self.frf)
        if h.ndim == 1:
            h = h[None, None, :]
        h = h.astype(np.complex128)
        resp = tuple(str(d) for d in self.response_dofs)
        ref = tuple(str(d) for d in self.reference_dofs)
        if f.ndim != 1 or f.size < 2:
            raise ShapeError("MeasuredFRF.frequency_hz must be 1-D with at least 2 lines")
        if h.ndim != 3 or h.shape != (len(resp), len(ref), f.size):
            raise ShapeError(f"MeasuredFRF.frf has shape {h.shape}; expected (n_resp, n_ref, n_lines) = "
                             f"({len(resp)}, {len(ref)}, {f.size})")
        if not np.all(np.isfinite(f)) or np.any(np.diff(f) <= 0) or f[0] < 0:
            raise ShapeError("MeasuredFRF.frequency_hz must be finite, >= 0 and strictly increasing")
        if not np.all(np.isfinite(h)):
            raise ShapeError("MeasuredFRF.frf has NaN or inf entries")
        if len(set(resp)) != len(resp) or len(set(ref)) != len(ref):
            raise ShapeError("MeasuredFRF DOF labels must be unique")
        if self.kind not in FRF_KINDS:
            raise ShapeError(f"MeasuredFRF.kind {self.kind!r} must be one of {', '.join(FRF_KINDS)}")
        f.setflags(write=False)
        h.setflags(write=False)
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "frf", h)
        object.__setattr__(self, "response_dofs", resp)
        object.__setattr__(self, "reference_dofs", ref)
        object.__setattr__(self, "units", self.units or DEFAULT_UNITS[self.kind])
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def omega_rad_s(self) -> np.ndarray:
        """Angular frequency axis (rad/s), shape (n_lines,)."""
        return 2 * np.pi * self.frequency_hz

    @property
    def driving_points(self) -> tuple:
        """``(response_index, reference_index)`` pairs whose DOF labels coincide."""
        return tuple((self.response_dofs.index(d), j) for j, d in enumerate(self.reference_dofs)
                     if d in self.response_dofs)

    def to_kind(self, kind: str) -> "MeasuredFRF":
        """Convert between receptance, mobility and accelerance.

        Mobility = ``i omega`` x receptance and accelerance = ``-omega^2`` x
        receptance. Converting towards receptance divides by ``i omega``, so a
        0 Hz line is then rejected (:class:`ShapeError`). Units become the SI
        units of the new kind.
        """
        if kind not in FRF_KINDS:
            raise ShapeError(f"FRF kind {kind!r} must be one of {', '.join(FRF_KINDS)}")
        power = _KIND_POWER[kind] - _KIND_POWER[self.kind]
        if power == 0:
            return self
        if power < 0 and self.frequency_hz[0] == 0:
            raise ShapeError(f"cannot convert a {self.kind} to a {kind} at 0 Hz: drop the 0 Hz line first")
        factor = (1j * self.omega_rad_s) ** power
        return replace(self, frf=self.frf * factor, kind=kind, units=DEFAULT_UNITS[kind])

    def select_band(self, fmin_hz=None, fmax_hz=None) -> "MeasuredFRF":
        """Lines with ``fmin_hz <= f <= fmax_hz`` (either bound may be None)."""
        keep = np.ones(self.frequency_hz.size, bool)
        if fmin_hz is not None:
            keep &= self.frequency_hz >= fmin_hz
        if fmax_hz is not None:
            keep &= self.frequency_hz <= fmax_hz
        if keep.sum() < 2:
            raise ShapeError(f"band [{fmin_hz}, {fmax_hz}] Hz keeps fewer than 2 of the "
                             f"{self.frequency_hz.size} lines ({self.frequency_hz[0]:g}-"
                             f"{self.frequency_hz[-1]:g} Hz)")
        return replace(self, frequency_hz=self.frequency_hz[keep], frf=self.frf[..., keep])


# ----------------------------------------------------------------- UFF 58 --

#: UFF specific data types of dataset 58 ordinates, and the FRF kind they give.
_UFF_ORDINATE_KIND = {8: "receptance", 11: "mobility", 12: "accelerance"}
_UFF_KIND_ORDINATE = {v: k for k, v in _UFF_ORDINATE_KIND.items()}
_UFF_FUNCTION_NAMES = {0: "general/unknown", 1: "time response", 2: "auto spectrum",
                       3: "cross spectrum", 4: "frequency response function", 5: "transmissibility",
                       6: "coherence", 7: "auto correlation", 8: "cross correlation",
                       9: "power spectral density", 10: "energy spectral density",
                       11: "probability density function", 12: "spectrum", 13: "cumulative frequency",
                       14: "peaks valley", 15: "stress/cycles", 16: "strain/cycles", 17: "orbit",
                       18: "mode indicator function", 19: "force pattern", 20: "partial power",
                       21: "partial coherence", 22: "eigenvalue", 23: "eigenvector",
                       24: "shock response spectrum", 25: "finite impulse response filter",
                       26: "multiple coherence", 27: "order function"}
_UFF_SET_NAMES = {15: "nodes", 55: "data at nodes (modes)", 58: "function at nodal DOF",
                  82: "trace lines", 151: "header", 164: "units", 2411: "nodes",
                  2412: "elements", 2414: "analysis data", 2420: "coordinate systems"}


def _check_uff_complete(path: Path, raw: bytes) -> None:
    """Reject a universal file whose last block has no closing ``-1`` line (truncation)."""
    text = raw.rstrip()
    if not text:
        raise FileFormatError(f"{path}: file is empty; expected a universal file with dataset 58 records")
    if not raw.lstrip()[:2] == b"-1":
        raise FileFormatError(f"{path}: not a universal file: it must start with a '    -1' delimiter line")
    # a complete file ends with a closing delimiter preceded by data (binary 58b data run
    # straight into it); an opening delimiter alone at the end means a cut at a record start
    if not text.endswith(b"    -1") or text[:-6].rstrip().endswith(b"    -1"):
        start = text.rfind(b"    -1\n")
        raise FileFormatError(f"{path}: truncated universal file: the last record (from byte "
                              f"{max(start, 0)}) has no closing '    -1' delimiter line")


def read_uff58(path, kind=None) -> MeasuredFRF:
    """Read FRF records (dataset 58, function type 4) of a universal file.

    ASCII and binary (58b) records are read through ``pyuff``. Records of other
    dataset types and dataset-58 functions that are not FRFs are skipped with a
    warning; a file without any FRF record is rejected. Records are arranged
    into a ``(n_resp, n_ref, n_lines)`` matrix by their response and reference
    node/direction; repeated records of the same pair are dropped with a warning.

    Parameters
    ----------
    path : str or Path
    kind : {"receptance", "mobility", "accelerance"}, optional
        Used only when the ordinate type of the records is not set (0); the
        ordinate types 8 (displacement), 11 (velocity) and 12 (acceleration)
        otherwise decide. Without either, receptance is assumed with a warning.

    Returns
    -------
    MeasuredFRF

    Raises
    ------
    FileFormatError
        Missing, truncated or malformed file; no FRF record; unequal frequency
        axes; NaN/inf values; mixed ordinate types; an incomplete
        response x reference matrix.
    """
    import pyuff

    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    _check_uff_complete(path, raw)
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception
        raise FileFormatError(f"{path}: not a readable universal file ({exc})") from None
    idx58 = [i for i, t in enumerate(types) if t == 58]
    others = sorted({t for t in types if t != 58})
    if not idx58:
        found = ", ".join(f"{t} ({_UFF_SET_NAMES.get(t, 'unsupported/unreadable')})" for t in others) or "none"
        raise FileFormatError(f"{path}: no dataset 58 (function at nodal DOF) record; dataset types "
                              f"found: {found}")
    if others:
        warnings.warn(f"{path}: skipped {len(types) - len(idx58)} record(s) of dataset type(s) "
                      f"{', '.join(map(str, others))}", stacklevel=2)
    try:
        sets = uff.read_sets(idx58)
    except Exception as exc:
        raise FileFormatError(f"{path}: cannot read dataset 58 records ({exc})") from None
    if isinstance(sets, dict):
        sets = [sets]
    frfs, skipped = [], {}
    for n, s in zip(idx58, sets):
        ft = int(s.get("func_type", -1))
        if ft == 4:
            frfs.append((n, s))
        else:
            skipped[ft] = skipped.get(ft, 0) + 1
    if not frfs:
        found = ", ".join(f"{ft} ({_UFF_FUNCTION_NAMES.get(ft, 'unknown')}) x{c}" for ft, c in skipped.items())
        raise FileFormatError(f"{path}: dataset 58 records hold no FRF (function type 4); function types "
                              f"found: {found}")
    if skipped:
        found = ", ".join(f"{ft} ({_UFF_FUNCTION_NAMES.get(ft, 'unknown')})" for ft in skipped)
        warnings.warn(f"{path}: skipped {sum(skipped.values())} dataset 58 record(s) that are not FRFs: "
                      f"function type(s) {found}", stacklevel=2)

    freq = None
    table = {}
    ordinates = set()
    for n, s in frfs:
        where = f"{path}: record {n + 1} (dataset 58, response {s.get('rsp_node')}/{s.get('rsp_dir')}, " \
                f"reference {s.get('ref_node')}/{s.get('ref_dir')})"
        data = np.asarray(s.get("data", []))
        x = np.asarray(s.get("x", []), dtype=float)
        n_pts = int(s.get("num_pts", data.size))
        if data.size != n_pts or x.size != n_pts:
            raise FileFormatError(f"{where}: holds {data.size} values but its header announces {n_pts} "
                                  "(truncated record)")
        if not np.iscomplexobj(data):
            raise FileFormatError(f"{where}: ordinate data are real (ordinate data type "
                                  f"{s.get('ord_data_type')}); an FRF needs complex data (type 5 or 6)")
        if not (np.all(np.isfinite(data)) and np.all(np.isfinite(x))):
            raise FileFormatError(f"{where}: contains NaN or inf values")
        if np.any(np.diff(x) <= 0):
            raise FileFormatError(f"{where}: frequency axis is not strictly increasing")
        if freq is None:
            freq = x
        elif x.size != freq.size or not np.allclose(x, freq, rtol=1e-6, atol=1e-9):
            raise FileFormatError(f"{where}: frequency axis ({x.size} lines, {x[0]:g}-{x[-1]:g} Hz) differs "
                                  f"from the first record's ({freq.size} lines, {freq[0]:g}-{freq[-1]:g} Hz); "
                                  "all FRFs must share one axis")
        try:
            key = (dof_label(s["rsp_node"], s["rsp_dir"]), dof_label(s["ref_node"], s["ref_dir"]))
        except FileFormatError as exc:
            raise FileFormatError(f"{where}: {exc}") from None
        if key in table:
            if not np.allclose(table[key], data):
                warnings.warn(f"{where}: duplicate of an earlier record with different values; "
                              "kept the first", stacklevel=2)
            else:
                warnings.warn(f"{where}: duplicated record dropped", stacklevel=2)
            continue
        table[key] = data
        ordinates.add(int(s.get("ordinate_spec_data_type", 0)))
    known = ordinates & set(_UFF_ORDINATE_KIND)
    if len(known) > 1:
        raise FileFormatError(f"{path}: records mix ordinate types {sorted(known)} (8 displacement, "
                              "11 velocity, 12 acceleration); expected one FRF kind per file")
    if known:
        file_kind = _UFF_ORDINATE_KIND[known.pop()]
    elif kind is not None:
        file_kind = kind
    else:
        file_kind = "receptance"
        warnings.warn(f"{path}: ordinate type not set (found {sorted(ordinates)}); assuming receptance "
                      "(displacement/force)", stacklevel=2)
    resp = list(dict.fromkeys(k[0] for k in table))
    refs = list(dict.fromkeys(k[1] for k in table))
    missing = [(a, b) for a in resp for b in refs if (a, b) not in table]
    if missing:
        a, b = missing[0]
        raise FileFormatError(f"{path}: no FRF for response {a} and reference {b} ({len(missing)} missing "
                              f"of {len(resp)}x{len(refs)}); every response needs a record for every reference")
    frf = np.array([[table[(a, b)] for b in refs] for a in resp])
    return MeasuredFRF(freq, frf, tuple(resp), tuple(refs), kind=file_kind,
                       metadata={"source": str(path), "format": "uff58",
                                 "binary": bool(sets[0].get("binary", 0)),
                                 "id1": str(frfs[0][1].get("id1", "")).strip()})


def write_uff58(path, data: MeasuredFRF, binary=False) -> None:
    """Write each FRF of ``data`` as one dataset 58 record (function type 4), atomically.

    Parameters
    ----------
    path : str or Path
    data : MeasuredFRF
        DOF labels must be ``"NODE:+DIR"`` (see :func:`parse_dof`).
    binary : bool
        Binary 58b (little/native byte order, double precision) instead of ASCII.
        ASCII files of unevenly spaced lines keep 6 significant digits of the
        frequencies (a limit of the format's E13.5 abscissa field).
    """
    import pyuff

    path = Path(path)
    resp = [parse_dof(d) for d in data.response_dofs]
    refs = [parse_dof(d) for d in data.reference_dofs]
    f = data.frequency_hz
    df = np.diff(f)
    even = bool(np.allclose(df, df[0], rtol=1e-9, atol=0))
    sets = []
    for i, (rn, rd) in enumerate(resp):
        for j, (qn, qd) in enumerate(refs):
            sets.append(pyuff.prepare_58(
                binary=int(bool(binary)), id1=str(data.metadata.get("id1", "beam-damage FRF"))[:80] or "NONE",
                func_type=4, rsp_node=rn, rsp_dir=rd, ref_node=qn, ref_dir=qd,
                data=np.ascontiguousarray(data.frf[i, j]), x=f, abscissa_spacing=int(even),
                abscissa_spec_data_type=18, ordinate_spec_data_type=_UFF_KIND_ORDINATE[data.kind],
                orddenom_spec_data_type=13, abscissa_axis_units_lab="Hz",
                ordinate_axis_units_lab=data.units[:20]))
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    os.unlink(tmp)  # pyuff creates the file; binary records need mode "add" on a fresh file
    try:
        pyuff.UFF(tmp).write_sets(sets, mode="add")
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# -------------------------------------------------------------------- CSV --

_CSV_MAGIC = "# beam-damage FRF csv v1"


def write_frf_csv(path, data: MeasuredFRF) -> None:
    """Write FRFs as CSV (layout in :func:`read_frf_csv`), atomically, 17 significant digits."""
    cols = [f"re({a}/{b}),im({a}/{b})" for a in data.response_dofs for b in data.reference_dofs]
    lines = [_CSV_MAGIC, f"# kind: {data.kind}", f"# units: {data.units}",
             "frequency_hz," + ",".join(cols)]
    h = data.frf.reshape(-1, data.frequency_hz.size)
    table = np.empty((data.frequency_hz.size, 1 + 2 * h.shape[0]))
    table[:, 0] = data.frequency_hz
    table[:, 1::2] = h.real.T
    table[:, 2::2] = h.imag.T
    body = "\n".join(",".join(f"{v:.17g}" for v in row) for row in table)
    atomic_write_text(path, "\n".join(lines) + "\n" + body + "\n")


def read_frf_csv(path, kind=None) -> MeasuredFRF:
    """Read FRFs from CSV.

    Layout: optional ``#`` comment lines (``# kind: receptance|mobility|accelerance``
    and ``# units: m/N`` are recognised), then a header row, then one row per
    frequency line::

        # kind: receptance
        frequency_hz,re(2:+Y/1:+Y),im(2:+Y/1:+Y),re(3:+Y/1:+Y),im(3:+Y/1:+Y)
        0.5,1.2e-05,-3.0e-08,...

    The first column is the frequency in Hz; then a real and an imaginary
    column per FRF, named ``re(RESPONSE/REFERENCE)`` and ``im(RESPONSE/REFERENCE)``.
    The ``/REFERENCE`` part may be omitted for a single reference (label
    ``"ref"``). ``kind`` overrides the ``# kind:`` line (default receptance).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not a UTF-8 text CSV file") from None
    meta, rows, header, header_line = {}, [], None, 0
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            key, sep, val = s.lstrip("# ").partition(":")
            if sep:
                meta[key.strip().lower()] = val.strip()
            continue
        if header is None:
            header, header_line = [c.strip() for c in s.split(",")], lineno
        else:
            rows.append((lineno, s))
    form = "'frequency_hz,re(RESP/REF),im(RESP/REF),...'"
    if header is None or not rows:
        raise FileFormatError(f"{path}: no header and data rows; expected a header {form} then numbers")
    if header[0].lower() not in ("frequency_hz", "frequency", "freq_hz", "f_hz") or len(header) < 3 \
            or len(header) % 2 != 1:
        raise FileFormatError(f"{path}: line {header_line}: header must be {form} (a frequency column and "
                              f"pairs of real/imaginary columns), got {len(header)} columns")
    pairs = []
    for k in range(1, len(header), 2):
        re_name, im_name = header[k], header[k + 1]
        if not (re_name.lower().startswith("re(") and re_name.endswith(")")
                and im_name.lower().startswith("im(") and im_name[3:] == re_name[3:]):
            raise FileFormatError(f"{path}: line {header_line}: columns {k + 1}-{k + 2} ({re_name!r}, "
                                  f"{im_name!r}) must be 're(RESP/REF)' and 'im(RESP/REF)' of one FRF")
        resp, _, ref = re_name[3:-1].partition("/")
        pairs.append((resp.strip(), ref.strip() or "ref"))
    ncol = len(header)
    values = np.empty((len(rows), ncol))
    for i, (lineno, s) in enumerate(rows):
        parts = s.split(",")
        if len(parts) != ncol:
            raise FileFormatError(f"{path}: line {lineno}: {len(parts)} fields, expected {ncol} like the "
                                  "header (truncated file?)")
        try:
            values[i] = [float(p) for p in parts]
        except ValueError:
            raise FileFormatError(f"{path}: line {lineno}: non-numeric field; expected {ncol} numbers") from None
    if not np.all(np.isfinite(values)):
        bad = rows[int(np.nonzero(~np.all(np.isfinite(values), axis=1))[0][0])][0]
        raise FileFormatError(f"{path}: line {bad}: NaN or inf value")
    f = values[:, 0]
    if np.any(np.diff(f) <= 0):
        raise FileFormatError(f"{path}: column 'frequency_hz' must be strictly increasing")
    if len(set(pairs)) != len(pairs):
        raise FileFormatError(f"{path}: line {header_line}: the same response/reference pair appears twice")
    resp = list(dict.fromkeys(p[0] for p in pairs))
    refs = list(dict.fromkeys(p[1] for p in pairs))
    if len(pairs) != len(resp) * len(refs):
        raise FileFormatError(f"{path}: line {header_line}: {len(pairs)} FRFs do not form a full "
                              f"{len(resp)} responses x {len(refs)} references matrix")
    frf = np.empty((len(resp), len(refs), f.size), complex)
    for k, (a, b) in enumerate(pairs):
        frf[resp.index(a), refs.index(b)] = values[:, 1 + 2 * k] + 1j * values[:, 2 + 2 * k]
    file_kind = kind or meta.get("kind", "receptance")
    if file_kind not in FRF_KINDS:
        raise FileFormatError(f"{path}: '# kind: {file_kind}' must be one of {', '.join(FRF_KINDS)}")
    return MeasuredFRF(f, frf, tuple(resp), tuple(refs), kind=file_kind, units=meta.get("units", ""),
                       metadata={"source": str(path), "format": "csv"})


# -------------------------------------------------------------------- NPZ --

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


def read_frf(path, kind=None) -> MeasuredFRF:
    """Read an FRF file, choosing the reader from the extension, else the content.

    ``.uff .unv .uf .58 .58b`` -> :func:`read_uff58`; ``.csv .txt`` ->
    :func:`read_frf_csv`; ``.npz`` -> :func:`read_frf_npz`. Other names are
    sniffed: a zip header means NPZ, a first line ``-1`` means UFF, else CSV.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext in (".uff", ".unv", ".uf", ".58", ".58b"):
        return read_uff58(path, kind=kind)
    if ext in (".csv", ".txt"):
        return read_frf_csv(path, kind=kind)
    if ext == ".npz":
        return read_frf_npz(path)
    try:
        head = path.read_bytes()[:256]
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    if head.startswith(b"PK"):
        return read_frf_npz(path)
    if head.lstrip().startswith(b"-1"):
        return read_uff58(path, kind=kind)
    if head.lstrip().startswith(b"{"):
        raise FileFormatError(f"{path}: looks like JSON (modal data?); expected an FRF file "
                              "(UFF58, CSV or .npz)")
    return read_frf_csv(path, kind=kind)
