"""Universal file dataset 58 (function at nodal DOF): FRF records, ASCII and binary 58b, via pyuff."""

from __future__ import annotations

import gc
import re
import warnings
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from physics.io.inputs import check_input_file
from physics.errors import FileFormatError, ShapeError
from physics.io.atomic import atomic_path
from physics.io.geometry import geometry_from_uff_sets
from physics.io.types import DEFAULT_UNITS, MeasuredFRF, dof_label, frf_matrix, parse_dof
from physics.io.units import UnitSystem, frf_unit_factor

__all__ = ["UFF_FUNCTION_NAMES", "UFF_WINDOW_TYPES", "UffFile", "read_uff58", "read_uff_context", "read_uff_geometry",
           "write_uff58"]


#: UFF specific data types of dataset 58 ordinates, and the FRF kind they give.
_UFF_ORDINATE_KIND = {8: "receptance", 11: "mobility", 12: "accelerance"}
_UFF_KIND_ORDINATE = {v: k for k, v in _UFF_ORDINATE_KIND.items()}
#: UFF function types (dataset 58 field 1 of record 6) by number, named in messages.
UFF_FUNCTION_NAMES = {0: "general/unknown", 1: "time response", 2: "auto spectrum",
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
                  82: "trace lines", 151: "header", 164: "units", 1858: "dataset 58 qualifiers", 2411: "nodes",
                  2412: "elements", 2414: "analysis data", 2420: "coordinate systems"}
#: Window types of dataset 1858 (record 2, field 2).
UFF_WINDOW_TYPES = {0: "none or unknown", 1: "Hanning narrow", 2: "Hanning broad", 3: "flattop", 4: "exponential",
                    5: "impact", 6: "impact and exponential"}


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
        start = max(text.rfind(b"    -1\n"), text.rfind(b"    -1\r\n"))     # LF or CRLF lines
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
    path : str, Path or UffFile
        A file name, or a file already opened (:class:`UffFile`).
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
    uf = path if isinstance(path, UffFile) else UffFile(path)
    path = uf.path
    frfs, binary = _frf_records(uf)
    system, geometry = uf.context
    freq, table, ordinates, units_found = None, {}, set(), {}
    for n, s in frfs:
        rec = _frf_record(path, n, s, system, freq)
        freq = rec.frequency_hz if freq is None else freq
        if _is_duplicate(table, rec):
            continue
        table[rec.key] = rec.data
        ordinates.add(rec.ordinate)
        units_found.setdefault(rec.unit_label, []).append(rec.factor)
    file_kind = _file_kind(path, ordinates, kind)
    resp, refs, frf = frf_matrix(table, str(path))
    meta = {"source": str(path), "format": "uff", "binary": binary,
            "id1": str(frfs[0][1].get("id1", "")).strip(),
            "units": {"file": sorted(units_found), "si": DEFAULT_UNITS[file_kind],
                      "factor_to_si": sorted({float(f) for v in units_found.values() for f in v}),
                      "unit_system": system.description}}
    if geometry is not None:
        meta["geometry"] = {"source": geometry.source, "nodes_m": geometry.to_dict()}
    if uf.windows:
        meta["windows"] = uf.windows
    try:
        return MeasuredFRF(freq, frf, tuple(resp), tuple(refs), kind=file_kind, metadata=meta)
    except ShapeError as exc:
        raise FileFormatError(f"{path}: {exc}") from None


def _frf_records(uf: "UffFile") -> tuple:
    """The FRF records (function type 4) of an open universal file, as ``[(index, set), ...]``, and whether the
    first dataset 58 record is binary; other datasets and functions are skipped with a warning.

    Raises
    ------
    FileFormatError
        No dataset 58 record, unreadable records, or no FRF among them.
    """
    path, types = uf.path, uf.types
    idx58 = [i for i, t in enumerate(types) if t == 58]
    others = sorted({t for t in types if t not in _CONTEXT_SETS})
    if not idx58:
        found = ", ".join(f"{t} ({_UFF_SET_NAMES.get(t, 'unsupported/unreadable')})" for t in sorted(set(types)))
        raise FileFormatError(f"{path}: no dataset 58 (function at nodal DOF) record; dataset types "
                              f"found: {found or 'none'}")
    if others:
        warnings.warn(f"{path}: skipped {sum(t in others for t in types)} record(s) of dataset type(s) "
                      f"{', '.join(map(str, others))}", stacklevel=3)
    frfs, skipped = [], {}
    for n, s in uf.records58:
        ft = int(s.get("func_type", -1))
        if ft == 4:
            frfs.append((n, s))
        else:
            skipped[ft] = skipped.get(ft, 0) + 1
    if not frfs:
        found = ", ".join(f"{ft} ({UFF_FUNCTION_NAMES.get(ft, 'unknown')}) x{c}" for ft, c in skipped.items())
        hint = ("; time records need a force channel to give FRFs ('beam-damage estimate FILE --out FRF.uff'); "
                "without one, identify the responses output-only ('beam-damage identify FILE --out DIR') and give "
                "DIR/modal.json") if set(skipped) == {1} else ""
        raise FileFormatError(f"{path}: dataset 58 records hold no FRF (function type 4); function types "
                              f"found: {found}{hint}")
    if skipped:
        found = ", ".join(f"{ft} ({UFF_FUNCTION_NAMES.get(ft, 'unknown')})" for ft in skipped)
        warnings.warn(f"{path}: skipped {sum(skipped.values())} dataset 58 record(s) that are not FRFs: "
                      f"function type(s) {found}", stacklevel=3)
    return frfs, bool(uf.records58[0][1].get("binary", 0))


@dataclass(frozen=True)
class _Record:
    """One FRF record of a universal file, in SI units."""

    where: str              # the record, for messages
    key: tuple              # (response DOF, reference DOF) labels
    frequency_hz: np.ndarray
    data: np.ndarray        # complex FRF values, SI
    ordinate: int           # ordinate specific data type (from the unit label where the type is unset)
    unit_label: str         # the file's unit text
    factor: float           # file unit -> SI


def _frf_record(path: Path, n: int, s: dict, system: UnitSystem, freq) -> _Record:
    """Check one dataset 58 FRF record ``s`` (record ``n``, 0-based) and convert it to SI units and Hz.

    ``freq`` (Hz) is the first record's frequency axis, which this record must share (None for the first).
    """
    where = f"{path}: record {n + 1} (dataset 58, response {s.get('rsp_node')}/{s.get('rsp_dir')}, " \
            f"reference {s.get('ref_node')}/{s.get('ref_dir')})"
    try:
        data = np.asarray(s.get("data", []))
        x = np.asarray(s.get("x", []), dtype=float)
        n_pts = int(s.get("num_pts", data.size))
    except (TypeError, ValueError):
        raise FileFormatError(f"{where}: unreadable data or frequency values") from None
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
    x = x * _abscissa_factor(s, where)
    try:
        factor, label_kind, found = frf_unit_factor(s.get("ordinate_axis_units_lab"),
                                                    s.get("orddenom_axis_units_lab"), system)
    except FileFormatError as exc:
        raise FileFormatError(f"{where}: {exc}") from None
    ordinate = int(s.get("ordinate_spec_data_type", 0))
    ord_kind = _UFF_ORDINATE_KIND.get(ordinate)
    if label_kind and ord_kind and label_kind != ord_kind:
        raise FileFormatError(f"{where}: unit label {s.get('ordinate_axis_units_lab')!r} is a {label_kind} "
                              f"unit but the ordinate type says {ord_kind}; refusing to guess")
    if freq is not None and (x.size != freq.size or not np.allclose(x, freq, rtol=1e-6, atol=1e-9)):
        raise FileFormatError(f"{where}: frequency axis ({x.size} lines, {x[0]:g}-{x[-1]:g} Hz) differs "
                              f"from the first record's ({freq.size} lines, {freq[0]:g}-{freq[-1]:g} Hz); "
                              "all FRFs must share one axis")
    try:
        key = (dof_label(s["rsp_node"], s["rsp_dir"]), dof_label(s["ref_node"], s["ref_dir"]))
    except FileFormatError as exc:
        raise FileFormatError(f"{where}: {exc}") from None
    if ordinate not in _UFF_ORDINATE_KIND and label_kind:
        ordinate = _UFF_KIND_ORDINATE[label_kind]
    return _Record(where, key, x, data * factor, ordinate, found, factor)


def _is_duplicate(table: dict, rec: _Record) -> bool:
    """Whether an earlier record has the DOF pair of ``rec`` (warned of; the first is kept)."""
    if rec.key not in table:
        return False
    if not np.allclose(table[rec.key], rec.data):
        warnings.warn(f"{rec.where}: duplicate of an earlier record with different values; kept the first",
                      stacklevel=3)
    else:
        warnings.warn(f"{rec.where}: duplicated record dropped", stacklevel=3)
    return True


def _file_kind(path: Path, ordinates: set, kind) -> str:
    """The FRF kind of a file from its records' ordinate types, else ``kind``, else receptance (warned)."""
    known = ordinates & set(_UFF_ORDINATE_KIND)
    if len(known) > 1:
        raise FileFormatError(f"{path}: records mix ordinate types {sorted(known)} (8 displacement, "
                              "11 velocity, 12 acceleration); expected one FRF kind per file")
    if known:
        return _UFF_ORDINATE_KIND[known.pop()]
    if kind is not None:
        return kind
    warnings.warn(f"{path}: ordinate type not set (found {sorted(ordinates)}); assuming receptance "
                  "(displacement/force)", stacklevel=3)
    return "receptance"


#: Dataset types read as context of the FRFs (header, units, coordinate systems, nodes, trace lines, elements).
_CONTEXT_SETS = {58, 151, 164, 15, 18, 82, 1858, 2411, 2412, 2420}
#: Dataset 164 unit codes.
_UNIT_CODES = {1: "SI: m (N)", 2: "BG: ft (lbf)", 3: "MG: m (kgf)", 4: "BA: ft (poundal)", 5: "MM: mm (mN)",
               6: "CM: cm (cN)", 7: "IN: in (lbf)", 8: "GM: mm (kgf)", 9: "user defined"}


def _short(exc) -> str:
    return " ".join(str(exc).split())[:200]


#: Numeric fields of a dataset 58 header: (line after the dataset-number line, or -1 for that line itself;
#: field name; first and last column, 1-based; "int" or "float"; required by the reader; allowed values).
_HEADER_FIELDS = (
    (-1, "byte ordering", 8, 13, "int", True, (1, 2)),
    (-1, "floating-point format", 14, 19, "int", True, (2,)),
    (-1, "ASCII header lines", 20, 31, "int", True, None),
    (-1, "binary bytes", 32, 43, "int", True, None),
    (5, "function type", 1, 5, "int", True, None),
    (5, "function id", 6, 15, "int", False, None),
    (5, "version number", 16, 20, "int", False, None),
    (5, "load case", 21, 30, "int", False, None),
    (5, "response node", 42, 51, "int", True, None),
    (5, "response direction", 52, 55, "int", True, None),
    (5, "reference node", 67, 76, "int", True, None),
    (5, "reference direction", 77, 80, "int", True, None),
    (6, "ordinate data type", 1, 10, "int", True, (2, 4, 5, 6)),
    (6, "number of points", 11, 20, "int", True, None),
    (6, "abscissa spacing", 21, 30, "int", True, (0, 1)),
    (6, "abscissa minimum", 31, 43, "float", True, None),
    (6, "abscissa increment", 44, 56, "float", True, None),
    (6, "z-axis value", 57, 69, "float", True, None),
    *((k, f"{axis} {name}", a, b, "int", True, None)
      for k, axis in ((7, "abscissa"), (8, "ordinate"), (9, "ordinate denominator"), (10, "z-axis"))
      for name, a, b in (("data type", 1, 10), ("length exponent", 11, 15), ("force exponent", 16, 20),
                         ("temperature exponent", 21, 25))),
)
_NUMBER = {"int": (r"[+-]?\d+", "an integer"),
           "float": (r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", "a number such as 2.00000E+00")}
_FIELD_NOTES = {"byte ordering": " (1 little-endian, 2 big-endian)",
                "floating-point format": " (2 IEEE 754; 1 DEC VMS and 3 IBM 370 are not read)",
                "ordinate data type": " (2/4 real single/double, 5/6 complex single/double)",
                "abscissa spacing": " (0 uneven, 1 even)"}


def _check_header_fields(path: Path, raw: bytes) -> None:
    """Every numeric field of every dataset 58 header must hold a number of its form (and a known code).

    pyuff reads a letter in an optional field (a node such as ``B``) as 0, which would silently put the
    record at node 0, and fails on one in a required field with a message that names neither.
    """
    for k, m in enumerate(re.finditer(rb"(?m)^ {4}-1[ \t]*\r?\n( {4}58b?)[^\n]*\n", raw), 1):
        binary = m.group(1).endswith(b"b")
        first = raw[m.start(1):m.end()].decode("latin1").rstrip("\r\n")
        lines = [first] + [ln.decode("latin1").rstrip("\r") for ln in raw[m.end():m.end() + 1200].split(b"\n")[:11]]
        for line_no, name, a, b, form, required, allowed in _HEADER_FIELDS:
            if line_no == -1 and not binary:
                continue
            line = lines[line_no + 1] if line_no + 1 < len(lines) else ""
            field = line[a - 1:b].strip()
            record = "the '58b' line" if line_no == -1 else f"header record {line_no + 1}"
            where = f"{path}: dataset 58 record {k}: {name} field {field!r} ({record}, columns {a}-{b})"
            pattern, expected = _NUMBER[form]
            if not field and not required:
                continue
            if not re.fullmatch(pattern, field):
                raise FileFormatError(f"{where} is not {expected}{_FIELD_NOTES.get(name, '')}")
            if allowed is not None and int(field) not in allowed:
                raise FileFormatError(f"{where} must be one of {', '.join(map(str, allowed))}"
                                      f"{_FIELD_NOTES.get(name, '')}")


_NODE_FIELDS = ("node label", "definition coordinate system", "displacement coordinate system", "colour",
                "x coordinate", "y coordinate", "z coordinate")


def _check_context_fields(path: Path, raw: bytes) -> None:
    """Numbers of the node (15, 2411) and units (164) datasets, which pyuff reads as whitespace-separated tokens.

    pyuff fails on a letter there with a message that names neither the field nor the line.
    """
    numbers = {True: re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eEdD][+-]?\d+)?"),   # pyuff reads D exponents ...
               False: re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")}    # ... except in dataset 15
    for m in re.finditer(rb"(?m)^ {4}-1[ \t]*\r?\n *(15|2411|164)[ \t]*\r?\n", raw):
        kind = int(m.group(1))
        stop = raw.find(b"\n    -1", m.end())
        lines = raw[m.end():len(raw) if stop < 0 else stop].decode("latin1").splitlines()
        name = "units" if kind == 164 else "nodes"
        if kind == 164:
            head = lines[0] if lines else ""
            for field, a, b in (("units code", 1, 10), ("temperature mode", 31, 40)):
                text = head[a - 1:b].strip()
                if text and not re.fullmatch(r"[+-]?\d+", text):
                    raise FileFormatError(f"{path}: dataset 164 (units) {field} field {text!r} (record 1, columns "
                                          f"{a}-{b}) is not an integer")
            fields = ("length factor", "force factor", "temperature factor", "temperature offset")
            rows = [(k + 2, tok) for k, line in enumerate(lines[1:]) for tok in line.split()]
            named = [(ln, fields[i] if i < len(fields) else "extra value", tok) for i, (ln, tok) in enumerate(rows)]
        else:
            rows = [(k + 1, tok) for k, line in enumerate(lines) for tok in line.split()]
            named = [(ln, _NODE_FIELDS[i % 7], tok) for i, (ln, tok) in enumerate(rows)]
        for ln, field, tok in named:
            if not numbers[kind != 15].fullmatch(tok):
                raise FileFormatError(f"{path}: dataset {kind} ({name}) line {ln}: {field} field {tok!r} is not a "
                                      "number such as 1.52400E+02")


def _open_uff(path: Path):
    """Check a universal file is complete and list its dataset types."""
    import pyuff

    check_input_file(path, "uff", what="a universal file")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    _check_uff_complete(path, raw)
    _check_header_fields(path, raw)
    _check_context_fields(path, raw)
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception
        raise FileFormatError(f"{path}: not a readable universal file ({_short(exc)})") from None
    return uff, types


class UffFile:
    """A universal file opened and checked once (:func:`_open_uff`), for the readers of its FRFs and time records.

    Its dataset 58 records and its context (units, geometry) are read on first use and kept.

    Attributes
    ----------
    path : Path
    uff : pyuff.UFF
    types : list of int
        Dataset type of each block, in file order.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.uff, self.types = _open_uff(self.path)

    def _first_unreadable(self, indices) -> str:
        """``"; the first unreadable: dataset 58 record K (block B of the file; ...)"``: the first of ``indices``
        pyuff cannot read alone; empty when each reads alone."""
        for n, i in enumerate(indices):
            try:
                self.uff.read_sets(i)
            except Exception as exc:
                return (f"; the first unreadable: dataset 58 record {n + 1} (block {i + 1} of the file; "
                        f"{_short(exc)}): a value that is no number (e.g. '****' of a field too narrow, or an "
                        "unpadded NaN) or a record cut short")
        return ""

    @cached_property
    def records58(self) -> list:
        """``[(index, set), ...]`` of the dataset 58 records (``index`` 0-based among all blocks)."""
        idx58 = [i for i, t in enumerate(self.types) if t == 58]
        if not idx58:
            return []
        try:
            sets = self.uff.read_sets(idx58)
        except Exception as exc:
            raise FileFormatError(f"{self.path}: cannot read dataset 58 records ({_short(exc)})"
                                  + self._first_unreadable(idx58)) from None
        return list(zip(idx58, [sets] if isinstance(sets, dict) else sets))

    @property
    def function_types(self) -> set:
        """Function types of the dataset 58 records (1 time response, 4 FRF, ...)."""
        return {int(s.get("func_type", -1)) for _, s in self.records58}

    @cached_property
    def windows(self) -> list:
        """The distinct windows the dataset 1858 records (qualifiers of the dataset 58 records) name:
        ``[{"window_type": code, "window": name, "exponential_window_damping_factor": value, "records": n}, ...]``
        (empty without dataset 1858). The format does not define the damping factor's unit; it is passed on as
        written."""
        idx = [i for i, t in enumerate(self.types) if t == 1858]
        if not idx:
            return []
        try:
            sets = self.uff.read_sets(idx)
            rows = [(int(s["window_type"]), float(s["exponential_window_damping_factor"]))
                    for s in ([sets] if isinstance(sets, dict) else sets)]
        except Exception as exc:  # pyuff raises bare Exception
            raise FileFormatError(f"{self.path}: cannot read the dataset 1858 (dataset 58 qualifiers) records "
                                  f"({_short(exc)})") from None
        return [{"window_type": code, "window": UFF_WINDOW_TYPES.get(code, f"code {code}"),
                 "exponential_window_damping_factor": factor, "records": rows.count((code, factor))}
                for code, factor in dict.fromkeys(rows)]

    @cached_property
    def context(self) -> tuple:
        """``(UnitSystem, NodeGeometry or None)`` (:func:`read_uff_context`)."""
        return read_uff_context(self.path, self.uff, self.types)


def read_uff_context(path, uff, types):
    """The unit system (dataset 164) and node geometry (datasets 15/2411, 18) of an open universal file."""
    def read(idx, name):
        if not idx:
            return []
        try:
            out = uff.read_sets(idx)
        except Exception as exc:
            raise FileFormatError(f"{path}: cannot read the {name} dataset(s) ({_short(exc)})") from None
        return [out] if isinstance(out, dict) else list(out)

    system = UnitSystem()
    units = read([i for i, t in enumerate(types) if t == 164], "units (164)")
    if units:
        u = units[0]
        try:
            length, force = float(u["length"]), float(u["force"])
        except (KeyError, TypeError, ValueError):
            raise FileFormatError(f"{path}: dataset 164 (units) lacks its length and force factors") from None
        if not (np.isfinite(length) and np.isfinite(force) and length > 0 and force > 0):
            raise FileFormatError(f"{path}: dataset 164 (units) has length factor {length:g} and force factor "
                                  f"{force:g}; both must be finite and > 0")
        code = int(u.get("units_code", 9))
        system = UnitSystem(length, force, f"dataset 164 {_UNIT_CODES.get(code, f'code {code}')}, "
                                           f"length factor {length:g}, force factor {force:g}", True)
    nodes = read([i for i, t in enumerate(types) if t in (15, 2411)], "node (15/2411)")
    cs = read([i for i, t in enumerate(types) if t == 18], "coordinate system (18)")
    unit_text = "file units" if system.from_file else "file units (no dataset 164: m assumed)"
    geometry = geometry_from_uff_sets(nodes, cs, system.length, str(path), unit_text)
    return system, geometry


def read_uff_geometry(path):
    """Node geometry (datasets 15/2411, in metres, global system) of a universal file, or None."""
    return UffFile(path).context[1]


def _abscissa_factor(s, where) -> float:
    """Factor to Hz of an FRF record's abscissa from its unit label."""
    lab = str(s.get("abscissa_axis_units_lab", "") or "").strip().lower().replace(" ", "")
    if lab in ("", "none", "hz", "1/s", "cps", "hertz"):
        return 1.0
    if lab in ("rad/s", "rad/sec"):
        return 1.0 / (2.0 * np.pi)
    raise FileFormatError(f"{where}: abscissa unit {s.get('abscissa_axis_units_lab')!r} is not a frequency "
                          "unit (Hz or rad/s)")


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
    with atomic_path(path) as tmp:  # pyuff creates the file; binary records need mode "add" on a fresh file
        with warnings.catch_warnings():
            # pyuff's binary dataset-58 writer leaves a text handle of the file to the garbage collector, which
            # flushes and closes it; collected here, before the rename, so the file is complete
            warnings.simplefilter("ignore", ResourceWarning)
            pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
            gc.collect()
