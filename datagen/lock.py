"""One writer per dataset directory: the lock file ``.lock`` that ``generate`` holds on its ``--out``.

The lock file holds the writer's pid, host and start time (JSON). It is created
with ``O_CREAT | O_EXCL``, so of two writers starting together exactly one gets
it; the other is refused in one line naming the holder. A lock left by a writer
that no longer runs on this host (killed with SIGKILL, machine crash) is stale:
the next writer takes it over with a warning. A lock of another host is never
taken over (its process cannot be checked from here): remove the file by hand
when that writer is known to be gone.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import socket
import time
import warnings
from pathlib import Path

from physics.errors import BeamDamageError

__all__ = ["LOCK_NAME", "DatasetLockedError", "dataset_lock"]

LOCK_NAME = ".lock"


class DatasetLockedError(BeamDamageError):
    """Another writer holds the dataset directory."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # a process of another user holds that pid
        return True
    return True


def _holder(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _try_create(path: Path, record: dict) -> bool:
    try:
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        return False
    except OSError as exc:  # a read-only directory: no writer can change it, so none needs the lock
        if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
            return True
        raise
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(record, f)
    return True


@contextlib.contextmanager
def dataset_lock(root):
    """Hold ``root/.lock`` while the block runs (``root`` is created if missing).

    Raises
    ------
    DatasetLockedError
        When a running writer (on this host, or any writer on another host) holds the lock.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    path = root / LOCK_NAME
    host = socket.gethostname()
    record = {"pid": os.getpid(), "host": host, "since": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    for _ in range(3):  # a stale lock removed by a third writer in between: try again
        if _try_create(path, record):
            break
        held = _holder(path)
        pid, their_host = held.get("pid"), held.get("host")
        if their_host == host and isinstance(pid, int) and pid != os.getpid() and not _alive(pid):
            warnings.warn(f"{root}: took over the stale lock of pid {pid} (started {held.get('since', '?')}), "
                          "which no longer runs", stacklevel=3)
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
            continue
        who = (f"pid {pid} on {their_host}, since {held.get('since', '?')}" if pid is not None
               else f"an unreadable lock file {path}")
        raise DatasetLockedError(f"{root}: another generate writes this dataset ({who}); wait for it to end, or "
                                 f"remove {path} if that process is gone")
    else:
        raise DatasetLockedError(f"{root}: could not take the lock {path}")
    try:
        yield
    finally:
        if _holder(path).get("pid") == os.getpid():
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
