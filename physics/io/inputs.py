"""What a user's input file may be before a reader opens it: a regular file of bounded size.

Every reader of a user file calls :func:`check_input_file` first. It only
``stat`` s the path (never opens it), so a FIFO with no writer cannot hang a
command and a device such as ``/dev/zero`` cannot be read until memory runs out.
The caps (:data:`MAX_BYTES`) bound what a reader holds in memory: a universal
file or CSV text is read whole and parsed into arrays a few times its size.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from physics.errors import FileFormatError

__all__ = ["MAX_BYTES", "check_input_file"]

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
