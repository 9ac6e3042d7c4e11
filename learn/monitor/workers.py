"""The tests of a series identified, and their records' FFT peaks read, over local worker processes or a Dask
cluster: each file's result (its modes, or why it could not be identified; its FFT peaks) is the one a single
process gives, whichever process or machine computed it and in whichever order the files finish (results are kept
by the file's place in the series; every file is computed with one BLAS thread).

``workers`` is the number of local processes, or a Dask client (:func:`datagen.cluster.connect`, ``monitor
--scheduler``) whose workers read the files, and the identification cache, at the paths this process gives: a file
system they share. A worker that cannot read a file stops the run with one line naming it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.warm_pool import run_warm_pool
from learn.monitor.identification import IdentificationSettings, cached_fft_peaks, cached_identification
from physics.errors import BeamDamageError, ConfigError

__all__ = ["fft_peaks_of_files", "identify_files"]


def _one(path, settings: IdentificationSettings, cache_dir):
    """``(modes or None, error or None, pending cache entries)`` of one file, with one BLAS thread (the unit of
    parallel work is the file; one thread also makes every process's arithmetic the same)."""
    pending = []
    with threadpool_limits(1):
        modes, error, _ = cached_identification(path, settings, cache_dir, pending)
    return modes, error, pending


def _fft_one(path, bands_hz, cache_dir):
    """:func:`~learn.monitor.identification.cached_fft_peaks` of one file, with one BLAS thread."""
    with threadpool_limits(1):
        return cached_fft_peaks(path, bands_hz, cache_dir)


class _Unreadable(OSError):
    """A file a Dask worker cannot read."""


def _on_worker(fn, path, *args):
    """``fn(path, *args)`` on a Dask worker, which must read ``path`` as this process does (a missing file there is
    not a test that cannot be identified, it is a cluster without the series' files)."""
    if not Path(path).is_file():
        raise _Unreadable(str(path))
    return fn(path, *args)


def _over_client(fn, args: list, client, bar, record) -> None:
    """``record(i, fn(*args[i]))`` for every ``i``, each computed on a worker of the Dask ``client``."""
    from distributed import as_completed

    futs = {client.submit(_on_worker, fn, *a, pure=False): i for i, a in enumerate(args)}
    try:
        for fut in as_completed(futs):
            try:
                record(futs[fut], fut.result())
            except _Unreadable as exc:
                raise BeamDamageError(f"--scheduler: a worker cannot read {exc}; the tests must lie on a file "
                                      "system the workers share, at the paths given here", parameter="scheduler") \
                    from None
    finally:
        client.cancel(list(futs))


def _over_files(fn, args: list, workers, progress: bool, desc: str) -> list:
    """``[fn(*a) for a in args]`` over ``workers``: that many local processes
    (:func:`~datagen.warm_pool.run_warm_pool`: ``workers - 1`` spawned ones and this one, which computes a file
    itself whenever no worker's result is waiting), or the workers of a Dask client."""
    client = workers if callable(getattr(workers, "submit", None)) else None
    if client is None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise ConfigError(f"--workers {workers!r}: must be an integer >= 1")
    from tqdm import tqdm

    results: list = [None] * len(args)
    bar = tqdm(total=len(args), desc=desc, unit="test", disable=None if progress else True,
               leave=False)                                     # None: only on a terminal

    def record(i, result):
        results[i] = result
        bar.update()

    if client is not None:
        _over_client(fn, args, client, bar, record)
    else:
        run_warm_pool(fn, list(enumerate(args)), workers, record)
    bar.close()
    return results


def identify_files(files: list, settings: IdentificationSettings, cache_dir=None, workers=1,
                   progress: bool = False) -> tuple[list, list, list]:
    """``(modes, errors, pending cache entries)`` of every file, in the order of ``files``, over ``workers`` (local
    processes, or a Dask client). Cache entries are returned, not written (the caller writes them once the series
    is accepted)."""
    results = _over_files(_one, [(path, settings, cache_dir) for path in files], workers, progress, "identify")
    return [r[0] for r in results], [r[1] for r in results], [e for r in results for e in r[2]]


def fft_peaks_of_files(files: list, bands_hz, cache_dir=None, workers=1) -> np.ndarray:
    """Shape (n, m): each response record's FFT peak (Hz) in each of
    ``bands_hz`` ((m, 2), Hz), NaN where none (:func:`~learn.monitor.identification.cached_fft_peaks`, cached in
    ``cache_dir``), over ``workers`` (local processes, or a Dask client)."""
    bands = np.asarray(bands_hz, float).reshape(-1, 2)
    out = _over_files(_fft_one, [(path, bands, cache_dir) for path in files], workers, False, "FFT peaks")
    return np.array(out, float).reshape(len(files), bands.shape[0])
