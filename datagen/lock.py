"""The writer's lock of a dataset directory: ``DIR/.generate.lock`` holds the pid, host and start time of the
one ``generate`` allowed to write there.

The lock file is created complete (written beside, then hard-linked into
place, which fails if it exists), so a reader never sees a half-written lock.
A lock whose pid no longer runs on this host is stale (its writer was killed)
and is taken over; a lock of another host is never taken over.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from pathlib import Path

from physics.errors import BeamDamageError

__all__ = ["LOCK_NAME", "LockedError", "dataset_lock"]

LOCK_NAME = ".generate.lock"


class LockedError(BeamDamageError):
    """Another live writer holds the dataset directory."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by another user
        return True
    return True


def _holder(lock: Path):
    """The lock's record (dict with pid, host, since), or None when it cannot be read as one."""
    try:
        rec = json.loads(lock.read_text())
    except (OSError, ValueError):
        return None
    ok = isinstance(rec, dict) and isinstance(rec.get("pid"), int) and isinstance(rec.get("host"), str)
    return rec if ok else None


def _try_create(lock: Path, record: dict) -> bool:
    tmp = lock.with_name(f"{LOCK_NAME}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(record))
    try:
        os.link(tmp, lock)
        return True
    except FileExistsError:
        return False
    finally:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def dataset_lock(root):
    """Hold the writer's lock of ``root`` (created if missing) for the block.

    Raises
    ------
    LockedError
        A live process (or one on another host) holds the lock: one line naming its pid, host and start time.
    """
    root = Path(root)
    lock = root / LOCK_NAME
    record = {"pid": os.getpid(), "host": socket.gethostname(),
              "since": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    for _ in range(3):
        if _try_create(lock, record):
            break
        rec = _holder(lock)
        if rec is not None and (rec["host"] != record["host"] or _alive(rec["pid"])) and rec["pid"] != os.getpid():
            raise LockedError(f"{root}: another `generate` writes this dataset (pid {rec['pid']} on {rec['host']} "
                              f"since {rec.get('since', '?')}); wait for it to finish, or delete {lock} if it is "
                              f"gone")
        if rec is None and time.time() - _mtime(lock) < 10:  # being replaced by another taker right now
            time.sleep(0.2)
            continue
        lock.unlink(missing_ok=True)  # stale: its writer died on this host (or an unreadable leftover)
    else:
        raise LockedError(f"{root}: could not take the writer's lock {lock}; delete it if no `generate` runs")
    try:
        yield record
    finally:
        if _holder(lock) == record:
            lock.unlink(missing_ok=True)


def _mtime(p: Path) -> float:
    try:
        return p.stat().st_mtime
    except OSError:
        return 0.0
