"""The one atomic writer of the package: temporary file in the target folder, then rename.

A reader never sees a half-written file: data go to a temporary file beside
the target (same file system), are flushed to disk, get normal permissions and
replace the target with :func:`os.replace`. On any error the temporary file is
removed and the target is left as it was; a full disk (ENOSPC, EDQUOT) becomes a one-line
:class:`physics.errors.DiskFullError` saying so.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from pathlib import Path

from physics.errors import DISK_FULL_ERRNOS, DiskFullError

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "figure_png", "pyplot"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file does not exist when the block starts (writers such as
    pyuff create it themselves). If the block raises, or leaves no file, the
    temporary file is removed and ``path`` is untouched.

    Examples
    --------
    >>> with atomic_path("out/frf.uff") as tmp:      # doctest: +SKIP
    ...     pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    os.unlink(tmp)
    tmp = Path(tmp)
    try:
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(f"{path}: the writer produced no file")
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file normal permissions
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno in DISK_FULL_ERRNOS:
            raise DiskFullError(f"{path}: no space left on device; not written, "
                                f"{'its previous version is intact' if path.exists() else 'nothing left behind'}") \
                from None
        raise
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file, fsync and an atomic rename."""
    with atomic_path(path) as tmp:
        with open(tmp, "xb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def atomic_write_text(path, text: str) -> None:
    """Text version of :func:`atomic_write_bytes` (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def pyplot():
    """``matplotlib.pyplot`` on the non-interactive Agg backend (a figure is written, never shown)."""
    import matplotlib  # heavy: loaded only when a figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_png(fig, **savefig) -> bytes:
    """The PNG (110 dpi; ``savefig`` passed on, e.g. ``bbox_inches="tight"``) of a matplotlib figure, then closed."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, **savefig)
    plt.close(fig)
    return buf.getvalue()
