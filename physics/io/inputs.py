"""What a user's input file may be before a reader opens it: a regular file of bounded size.

Every reader of a user file calls :func:`check_input_file` first. It only
``stat`` s the path (never opens it), so a FIFO with no writer cannot hang a
command and a device such as ``/dev/zero`` cannot be read until memory runs out.
The caps (:data:`MAX_BYTES`) bound what a reader holds in memory: a universal
file or CSV text is read whole and parsed into arrays a few times its size.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

from physics.errors import FileFormatError

__all__ = ["MAX_BYTES", "check_input_file", "repeated_files"]

#: Largest input file per kind (bytes).
MAX_BYTES = {
    "uff": 512 * 2**20,      # universal file (FRFs or time records), ASCII or binary
    "csv": 512 * 2**20,      # FRFs or time series as CSV text
    "npz": 2 * 2**30,        # NPZ: members are checked before loading (physics.io.npz)
    "json": 64 * 2**20,      # modal data, model and dataset metadata
    "toml": 2**20,           # beam files and generator configs
}

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def check_input_file(path, kind: str, error=FileFormatError, what: str | None = None) -> Path:
    """``path`` as a :class:`~pathlib.Path` when it is a regular file of at most ``MAX_BYTES[kind]`` bytes.

    Symbolic links are followed (a link to a device is refused as the device).

    Raises
    ------
    error (default :class:`FileFormatError`)
        One line naming the file: missing, not a regular file (directory, device, FIFO, socket), empty (but a
        TOML file), or larger than the cap of its kind. ``what`` names the expected content (default: ``kind``
        upper-cased).
    """
    path = Path(path)
    expected = what or f"{'an' if kind[0] in 'aefhilmnorsx' else 'a'} {kind.upper()} file"   # letters read so
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: file not found; expected {expected}") from None
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror}); expected {expected}") from None
    for test, name in _KINDS:
        if test(st.st_mode):
            raise error(f"{path}: is {name}, not a regular file; expected {expected}")
    if st.st_size == 0 and kind != "toml":                # an empty TOML file is a config of defaults
        raise error(f"{path}: file is empty; expected {expected}")
    cap = MAX_BYTES[kind]
    if st.st_size > cap:
        raise error(f"{path}: {st.st_size} bytes, more than the {cap} bytes ({cap / 2**20:g} MiB) a "
                    f"{kind.upper()} input may hold; expected {expected}")
    return path


def _digest(path, limit=None):
    """SHA-256 of the file's first ``limit`` bytes (None: all), or None when it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            left = limit
            for block in iter(lambda: fh.read(1 << 20 if left is None else min(1 << 20, left)), b""):
                h.update(block)
                if left is not None:
                    left -= len(block)
                    if left <= 0:
                        break
    except OSError:
        return None
    return h.digest()


def repeated_files(files: list) -> list:
    """``[(i, j), ...]``: test ``j`` repeats the earlier test ``i``: the same file listed again, or a file of the
    same bytes (files of equal size and equal first 64 KiB compared whole by their SHA-256: records of one shape,
    all of a size, are read once in part). A file that cannot be read is left out (its test is refused by the
    identification)."""
    first, groups, out = {}, {}, []
    for j, f in enumerate(files):
        real = os.path.realpath(f)
        if real in first:
            out.append((first[real], j))
            continue
        first[real] = j
        try:
            groups.setdefault(os.stat(real).st_size, []).append(j)
        except OSError:
            continue
    for limit in (1 << 16, None):                   # the first 64 KiB, then the whole file
        refined = {}
        for key, group in groups.items():
            if len(group) > 1:
                for j in group:
                    if (d := _digest(files[j], limit)) is not None:
                        refined.setdefault((key, d), []).append(j)
        groups = refined
    out += [(g[0], j) for g in groups.values() for j in g[1:]]
    return sorted(out, key=lambda p: p[1])
