"""Independent tasks over ``workers - 1`` spawned processes and the calling one.

The calling process is warm (imports, compiled kernels) while a spawned worker needs seconds to start, so it runs a
task itself whenever no worker's result is waiting: no core idles during start-up, and handling the results (writing
shards, updating a bar) overlaps the workers' computation. A task's result does not depend on which process ran it.
"""

from __future__ import annotations

import os
import signal
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context

__all__ = ["run_warm_pool"]


def _init_worker():
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    # Ctrl-C reaches the whole process group: the parent alone reports it and stops the workers
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stop_workers(pool) -> None:
    """Cancel queued tasks and end the workers at once (an interrupted run resumes from what it recorded)."""
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()


def run_warm_pool(fn, tasks, workers: int, record) -> None:
    """``record(key, fn(*args))`` in this process for each ``(key, args)`` of ``tasks``, ``fn`` run in ``workers - 1``
    spawned processes and in this one (all in this one when ``workers == 1`` or there is one task at most).

    ``fn`` is a module-level function (it is pickled by reference). The workers take the tasks from the front,
    this process from the end. An exception (Ctrl-C too) stops the workers at once and propagates.
    """
    pending = deque(tasks)
    if workers == 1 or len(pending) <= 1:
        for key, args in pending:
            record(key, fn(*args))
        return
    with ProcessPoolExecutor(max_workers=workers - 1, mp_context=get_context("spawn"),
                             initializer=_init_worker) as pool:
        futs = {}

        def top_up():
            while pending and len(futs) < 2 * (workers - 1):
                key, args = pending.popleft()
                futs[pool.submit(fn, *args)] = key

        try:
            top_up()
            while futs or pending:
                ready = [fut for fut in futs if fut.done()]
                for fut in ready:
                    record(futs.pop(fut), fut.result())
                top_up()
                if ready:
                    continue
                if pending:
                    key, args = pending.pop()
                    record(key, fn(*args))
                else:
                    wait(futs, return_when=FIRST_COMPLETED)
        except BaseException:
            _stop_workers(pool)
            raise
