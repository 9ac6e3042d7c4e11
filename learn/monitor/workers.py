"""The tests of a series identified over local worker processes: each file's result (its modes, or why it could
not be identified) is the one a single process gives, whichever process computed it and in whichever order the
files finish (results are kept by the file's place in the series)."""

from __future__ import annotations

from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context

from threadpoolctl import threadpool_limits

from learn.monitor.identification import IdentificationSettings, cached_identification
from physics.errors import ConfigError

__all__ = ["identify_files"]


def _one(path, settings: IdentificationSettings, cache_dir):
    """``(modes or None, error or None, pending cache entries)`` of one file, with one BLAS thread (the unit of
    parallel work is the file; one thread also makes every process's arithmetic the same)."""
    pending = []
    with threadpool_limits(1):
        modes, error, _ = cached_identification(path, settings, cache_dir, pending)
    return modes, error, pending


def identify_files(files: list, settings: IdentificationSettings, cache_dir=None, workers: int = 1,
                   progress: bool = False) -> tuple[list, list, list]:
    """``(modes, errors, pending cache entries)`` of every file, in the order of ``files``.

    ``workers`` processes identify them: ``workers - 1`` spawned ones and this one, which computes a file itself
    whenever no worker's result is waiting (a spawned worker needs seconds to import; :mod:`datagen.generation`
    runs its shards alike). Cache entries are returned, not written (the caller writes them once the series is
    accepted).
    """
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ConfigError(f"--workers {workers!r}: must be an integer >= 1")
    from tqdm import tqdm

    n = len(files)
    results: list = [None] * n
    bar = tqdm(total=n, desc="identify", unit="test", disable=not progress, leave=False)
    if workers == 1 or n <= 1:
        for i, path in enumerate(files):
            results[i] = _one(path, settings, cache_dir)
            bar.update()
    else:
        from datagen.generation import _init_worker, _stop_workers  # numba: the generator's pipeline

        todo = deque(range(n))
        with ProcessPoolExecutor(max_workers=workers - 1, mp_context=get_context("spawn"),
                                 initializer=_init_worker) as pool:
            futs = {}

            def top_up():
                while todo and len(futs) < 2 * (workers - 1):
                    i = todo.popleft()
                    futs[pool.submit(_one, files[i], settings, cache_dir)] = i

            try:
                top_up()
                while futs or todo:
                    ready = [f for f in futs if f.done()]
                    for f in ready:
                        results[futs.pop(f)] = f.result()
                        bar.update()
                    top_up()
                    if ready:
                        continue
                    if todo:
                        i = todo.pop()                   # from the end: the workers keep the front of the queue
                        results[i] = _one(files[i], settings, cache_dir)
                        bar.update()
                    else:
                        wait(futs, return_when=FIRST_COMPLETED)
            except BaseException:
                _stop_workers(pool)
                raise
    bar.close()
    modes = [r[0] for r in results]
    errors = [r[1] for r in results]
    pending = [e for r in results for e in r[2]]
    return modes, errors, pending
