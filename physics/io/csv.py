"""FRFs as plain CSV text (layout in :func:`read_frf_csv`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from physics.io.inputs import check_input_file
from physics.errors import FileFormatError, ShapeError
from physics.io.atomic import atomic_write_text
from physics.io.types import FRF_KINDS, UNNAMED_REFERENCE, MeasuredFRF, check_dof_labels, frf_matrix
from physics.io.units import stated_units_factor

__all__ = ["csv_values", "read_frf_csv", "write_frf_csv"]


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
    ``"ref"``, :data:`~physics.io.types.UNNAMED_REFERENCE`); labels are DOFs such as ``2:+Y``
    (:func:`~physics.io.types.parse_dof`). ``kind`` overrides the ``# kind:`` line (default receptance).
    """
    path = Path(path)
    meta, header, header_line, rows = _csv_lines(path)
    pairs = _header_pairs(path, header, header_line)
    values = csv_values(path, rows, len(header))
    f = values[:, 0]
    if np.any(np.diff(f) <= 0):
        raise FileFormatError(f"{path}: column 'frequency_hz' must be strictly increasing")
    if len(set(pairs)) != len(pairs):
        raise FileFormatError(f"{path}: line {header_line}: the same response/reference pair appears twice")
    resp, refs, frf = frf_matrix({p: values[:, 1 + 2 * k] + 1j * values[:, 2 + 2 * k] for k, p in enumerate(pairs)},
                                 f"{path}: line {header_line}")
    file_kind = kind or meta.get("kind", "receptance")
    if file_kind not in FRF_KINDS:
        raise FileFormatError(f"{path}: '# kind: {file_kind}' must be one of {', '.join(FRF_KINDS)}")
    units = meta.get("units", "")
    frf = frf * stated_units_factor(units, file_kind, f"{path}: '# units: {units}'")
    try:
        return MeasuredFRF(f, frf, tuple(resp), tuple(refs), kind=file_kind,
                           metadata={"source": str(path), "format": "csv"})
    except ShapeError as exc:
        raise FileFormatError(f"{path}: {exc}") from None


_HEADER_FORM = "'frequency_hz,re(RESP/REF),im(RESP/REF),...'"


def _csv_lines(path: Path) -> tuple:
    """The ``# key: value`` comments (keys lower case), the header's cells and line number, and the data rows
    as ``[(line number, text), ...]`` of a CSV file; blank lines skipped."""
    check_input_file(path, "csv", what="a CSV file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not a UTF-8 text CSV file") from None
    except IsADirectoryError:
        raise FileFormatError(f"{path}: is a directory, not a CSV file") from None
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
    if header is None or not rows:
        raise FileFormatError(f"{path}: no header and data rows; expected a header {_HEADER_FORM} then numbers")
    return meta, header, header_line, rows


def _header_pairs(path: Path, header: list, header_line: int) -> list:
    """``[(response DOF, reference DOF), ...]`` of the header's ``re(...)``/``im(...)`` column pairs."""
    if header[0].lower().startswith("time"):
        raise FileFormatError(f"{path}: line {header_line}: a time series' first column must be 'time_s' (seconds), "
                              f"got {header[0]!r}")
    if header[0].lower() not in ("frequency_hz", "frequency", "freq_hz", "f_hz") or len(header) < 3 \
            or len(header) % 2 != 1:
        raise FileFormatError(f"{path}: line {header_line}: header must be {_HEADER_FORM} (a frequency column "
                              f"and pairs of real/imaginary columns), got {len(header)} columns")
    pairs = []
    for k in range(1, len(header), 2):
        re_name, im_name = header[k], header[k + 1]
        if not (re_name.lower().startswith("re(") and re_name.endswith(")")
                and im_name.lower().startswith("im(") and im_name[3:] == re_name[3:]):
            raise FileFormatError(f"{path}: line {header_line}: columns {k + 1}-{k + 2} ({re_name!r}, "
                                  f"{im_name!r}) must be 're(RESP/REF)' and 'im(RESP/REF)' of one FRF")
        resp, _, ref = re_name[3:-1].partition("/")
        pairs.append((resp.strip(), ref.strip() or UNNAMED_REFERENCE))
        where = f"{path}: line {header_line}: column {k + 1} {re_name!r}"
        check_dof_labels(pairs[-1][:1], where)
        check_dof_labels(pairs[-1][1:], where, unnamed_reference=True)
    return pairs


def csv_values(path: Path, rows: list, ncol: int) -> np.ndarray:
    """The data rows ``[(line number, text), ...]`` of a CSV file as a finite float64 array ``(n_rows, ncol)``
    (the FRF and the time-series readers' parser); raises :class:`~physics.errors.FileFormatError` naming ``path``
    and the first row with another field count, a non-numeric field or a NaN or inf value."""
    counts = [r[1].count(",") + 1 for r in rows]
    bad = next((i for i, c in enumerate(counts) if c != ncol), None)
    if bad is not None:
        raise FileFormatError(f"{path}: line {rows[bad][0]}: {counts[bad]} fields, expected {ncol} like the "
                              "header (truncated file?)")
    body = ",".join(r[1] for r in rows)
    if "_" in body:  # Python's float() reads "1_000" as 1000; a CSV number never has underscores
        bad = next(i for i, r in enumerate(rows) if "_" in r[1])
        raise FileFormatError(f"{path}: line {rows[bad][0]}: non-numeric field (underscore); expected {ncol} "
                              "numbers")
    try:
        values = np.array(body.split(","), dtype=float).reshape(len(rows), ncol)
    except ValueError:
        for lineno, s_ in rows:  # find the offending line for the message
            try:
                [float(p) for p in s_.split(",")]
            except ValueError:
                raise FileFormatError(f"{path}: line {lineno}: non-numeric field; expected {ncol} numbers") \
                    from None
        raise
    if not np.all(np.isfinite(values)):
        bad = rows[int(np.nonzero(~np.all(np.isfinite(values), axis=1))[0][0])][0]
        raise FileFormatError(f"{path}: line {bad}: NaN or inf value")
    return values
