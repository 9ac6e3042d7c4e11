"""Read an FRF file of any supported format, chosen from its name or content."""

from __future__ import annotations

from pathlib import Path

from physics.errors import FileFormatError
from physics.io.csv import read_frf_csv
from physics.io.npz import read_frf_npz
from physics.io.types import MeasuredFRF
from physics.io.uff58 import read_uff58

__all__ = ["read_frf"]

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
