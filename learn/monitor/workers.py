"""The tests of a series identified, and their records' FFT peaks read, over local worker processes: each file's
result (its modes, or why it could not be identified; its FFT peaks) is the one a single process gives, whichever
process computed it and in whichever order the files finish (results are kept by the file's place in the series)."""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.warm_pool import run_warm_pool
from learn.monitor.identification import IdentificationSettings, cached_fft_peaks, cached_identification
from physics.errors import ConfigError

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


def _over_files(fn, args: list, workers: int, progress: bool, desc: str) -> list:
    """``[fn(*a) for a in args]`` over ``workers`` processes (:func:`~datagen.warm_pool.run_warm_pool`:
    ``workers - 1`` spawned ones and this one, which computes a file itself whenever no worker's result is
    waiting)."""
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ConfigError(f"--workers {workers!r}: must be an integer >= 1")
    from tqdm import tqdm

    results: list = [None] * len(args)
    bar = tqdm(total=len(args), desc=desc, unit="test", disable=not progress, leave=False)

    def record(i, result):
        results[i] = result
        bar.update()

    run_warm_pool(fn, list(enumerate(args)), workers, record)
    bar.close()
    return results


def identify_files(files: list, settings: IdentificationSettings, cache_dir=None, workers: int = 1,
                   progress: bool = False) -> tuple[list, list, list]:
    """``(modes, errors, pending cache entries)`` of every file, in the order of ``files``, over ``workers``
    processes. Cache entries are returned, not written (the caller writes them once the series is accepted).
    """
    results = _over_files(_one, [(path, settings, cache_dir) for path in files], workers, progress, "identify")
    return [r[0] for r in results], [r[1] for r in results], [e for r in results for e in r[2]]


def fft_peaks_of_files(files: list, bands_hz, cache_dir=None, workers: int = 1) -> np.ndarray:
    """Shape (n, m): each response record's FFT peak (Hz) in each of
    ``bands_hz`` ((m, 2), Hz), NaN where none (:func:`~learn.monitor.identification.cached_fft_peaks`, cached in
    ``cache_dir``), over ``workers`` processes."""
    bands = np.asarray(bands_hz, float).reshape(-1, 2)
    out = _over_files(_fft_one, [(path, bands, cache_dir) for path in files], workers, False, "FFT peaks")
    return np.array(out, float).reshape(len(files), bands.shape[0])
