"""The file formats of this package: one table, :data:`FORMATS`, and the dispatch derived from it.

Each :class:`FileFormat` row names a format, its extensions, what it holds
(:data:`FRF`, :data:`MODAL`, :data:`TIME`) with the reader of each, a sniff of
its first bytes, its writer and a one-line description. :func:`format_of`
chooses a row for a file (extension first, then content), :func:`read` reads
it, and :func:`accepted` and :func:`writable` give the commands their help
texts and ``--format`` choices. A new format is one reader/writer module and
one row here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from physics.io.inputs import check_input_file
from physics.errors import FileFormatError
from physics.io.csv import read_frf_csv, write_frf_csv
from physics.io.modal_json import read_modal_json, write_modal_json
from physics.io.npz import read_frf_npz, write_frf_npz
from physics.io.timedata import read_uff_time_records
from physics.io.timeseries import read_time_csv, read_time_npz
from physics.io.types import MeasuredFRF
from physics.io.uff58 import read_uff58, write_uff58

__all__ = ["FORMATS", "FRF", "MODAL", "SNIFF_BYTES", "TIME", "FileFormat", "accepted", "format_of", "modal_or_frf",
           "read", "read_frf", "writable"]

#: What a file holds: frequency response functions (:class:`~physics.io.types.MeasuredFRF`).
FRF = "FRFs"
#: What a file holds: modal data (:class:`~physics.io.types.ModalData`).
MODAL = "modal data"
#: What a file holds: sampled force and response channels (:class:`~physics.io.timedata.TimeRecords`).
TIME = "time records"
#: Bytes read from the start of a file for :attr:`FileFormat.sniff`.
SNIFF_BYTES = 256


@dataclass(frozen=True)
class FileFormat:
    """One file format: how it is recognised, what it holds, how it is read and written.

    Attributes
    ----------
    name : str
        Short name, the ``--format`` choice of ``beam-damage export`` (``"uff"``).
    extensions : tuple of str
        Lower-case file name suffixes with the dot; the first names written files.
    readers : tuple of (str, callable) pairs
        What the format holds (:data:`FRF`, :data:`MODAL`, :data:`TIME`) and the
        reader of each, ``reader(path, **options)``; FRF readers take ``kind``.
    sniff : callable
        ``sniff(head) -> bool`` on the first :data:`SNIFF_BYTES` bytes of a file
        whose extension is none of the table's.
    writer : callable or None
        ``writer(path, data)`` of what the format holds first, atomic; None if read only.
    description : str
        One line for help texts.
    """

    name: str
    extensions: tuple
    readers: tuple
    sniff: Callable
    writer: Callable | None
    description: str

    @property
    def holds(self) -> tuple:
        """What the format holds, the written content first."""
        return tuple(what for what, _ in self.readers)

    def reader(self, holds: str) -> Callable:
        """The reader of ``holds`` (one of :attr:`holds`)."""
        return dict(self.readers)[holds]

    @property
    def label(self) -> str:
        """``"UFF (.uff/.unv/...)"``: the name and extensions, for help and error texts."""
        return f"{self.name.upper()} ({'/'.join(self.extensions)})"


def _starts_with(*prefixes: bytes) -> Callable:
    return lambda head: head.lstrip().startswith(prefixes)


def _is_text(head: bytes) -> bool:
    """UTF-8 text (a multi-byte character cut at the end of ``head`` allowed)."""
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        return exc.start >= len(head) - 3 and exc.reason == "unexpected end of data"
    return True


#: Every format, in sniffing order (the text formats without a signature last).
FORMATS: dict[str, FileFormat] = {f.name: f for f in (
    FileFormat("uff", (".uff", ".unv", ".uf", ".58", ".58b"), ((FRF, read_uff58), (TIME, read_uff_time_records)),
               _starts_with(b"-1"), write_uff58,
               "universal file: dataset 58 FRFs or time records (ASCII or binary 58b); units (164) and node "
               "geometry (15/2411) read when present, FRFs written as dataset 58 records alone"),
    FileFormat("npz", (".npz",), ((FRF, read_frf_npz), (TIME, read_time_npz)), lambda head: head.startswith(b"PK"),
               write_frf_npz, "NumPy archive of plain arrays: frequency_hz, complex frf, DOF labels, or signals "
                              "and sampling_frequency_hz of response time series (never pickled)"),
    FileFormat("json", (".json",), ((MODAL, read_modal_json),), _starts_with(b"{", b"["), write_modal_json,
               "modal data: complex eigenvalues and eigenvectors (or natural frequencies and damping ratios)"),
    FileFormat("csv", (".csv", ".txt"), ((FRF, read_frf_csv), (TIME, read_time_csv)), _is_text, write_frf_csv,
               "text: a frequency_hz column, then re(RESP/REF) and im(RESP/REF) columns per FRF; or a time_s "
               "column, then one column per response channel"),
)}


def _serving(holds) -> list:
    return [f for f in FORMATS.values() if set(f.holds) & set(holds)]


def accepted(*holds: str) -> str:
    """The formats holding ``holds``, for help and error texts.

    One content: ``"UFF (.uff/...), NPZ (.npz) or CSV (.csv/.txt)"``; several:
    ``"modal data as JSON (.json); FRFs as UFF (.uff/...), NPZ (.npz) or CSV (.csv/.txt)"``.
    """
    def either(labels):
        return labels[0] if len(labels) == 1 else f"{', '.join(labels[:-1])} or {labels[-1]}"

    if len(holds) == 1:
        return either([f.label for f in _serving(holds)])
    return "; ".join(f"{what} as {either([f.label for f in _serving([what])])}" for what in holds)


def writable(holds: str) -> dict:
    """``{name: FileFormat}`` of the formats that write ``holds``."""
    return {f.name: f for f in FORMATS.values() if f.writer is not None and f.holds[0] == holds}


def format_of(path, *holds: str) -> FileFormat:
    """The format of a file that should hold one of ``holds``: by extension, else by its first bytes.

    Raises
    ------
    FileFormatError
        The file is missing or a directory, or its content is of a format that
        holds none of ``holds`` or of no format at all.
    """
    path = Path(path)
    serving = _serving(holds)
    ext = path.suffix.lower()
    by_ext = next((f for f in serving if ext in f.extensions), None)
    if by_ext is not None:
        return by_ext
    check_input_file(path, "uff" if "time" in holds else "csv", what=f"a file of {' or '.join(holds)}")
    try:
        with path.open("rb") as fh:
            head = fh.read(SNIFF_BYTES)
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise FileFormatError(f"{path}: is a directory, expected a file of {' or '.join(holds)}") from None
    found = next((f for f in FORMATS.values() if f.sniff(head)), None)
    if found in serving:
        return found
    what = f"looks like {found.name.upper()} ({' or '.join(found.holds)})" if found else "is of no known format"
    expected = "; ".join(f"{h} as {accepted(h)}" for h in holds)
    raise FileFormatError(f"{path}: {what}; expected {expected}")


def modal_or_frf(path) -> str:
    """What a file of measured data holds: :data:`MODAL` or :data:`FRF` (its format by :func:`format_of`)."""
    return MODAL if MODAL in format_of(path, MODAL, FRF).holds else FRF


def read(path, holds: str, **options):
    """Read what ``path`` holds of ``holds`` with the reader of its format (:func:`format_of`)."""
    return format_of(path, holds).reader(holds)(path, **options)


def read_frf(path, kind=None) -> MeasuredFRF:
    """Read an FRF file of any format of :data:`FORMATS` that holds :data:`FRF`.

    ``kind`` applies where the file does not say (see each reader).
    """
    return read(path, FRF, kind=kind)
