"""The tests of a series identified over local worker processes: each file's result (its modes, or why it could
not be identified) is the one a single process gives, whichever process computed it and in whichever order the
files finish (results are kept by the file's place in the series)."""

from __future__ import annotations

from threadpoolctl import threadpool_limits

from datagen.warm_pool import run_warm_pool
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

    ``workers`` processes identify them (:func:`~datagen.warm_pool.run_warm_pool`: ``workers - 1`` spawned ones and
    this one, which computes a file itself whenever no worker's result is waiting). Cache entries are returned, not
    written (the caller writes them once the series is accepted).
    """
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ConfigError(f"--workers {workers!r}: must be an integer >= 1")
    from tqdm import tqdm

    results: list = [None] * len(files)
    bar = tqdm(total=len(files), desc="identify", unit="test", disable=not progress, leave=False)

    def record(i, result):
        results[i] = result
        bar.update()

    run_warm_pool(_one, [(i, (path, settings, cache_dir)) for i, path in enumerate(files)], workers, record)
    bar.close()
    modes = [r[0] for r in results]
    errors = [r[1] for r in results]
    pending = [e for r in results for e in r[2]]
    return modes, errors, pending
