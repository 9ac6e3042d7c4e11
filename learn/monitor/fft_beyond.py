"""The FFT peaks beyond the bands of the modes whose frequency is the record's FFT peak
(:mod:`learn.monitor.estimator_choice`): where such a mode has no peak in its band, the peak beyond it within its
reach is the mode moved (:func:`learn.monitor.beyond_band.beyond_bands` reads it as it reads a pole there)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learn.monitor.tracking import ReferenceModes, narrow_bands_hz, reach_bands_hz
from learn.monitor.workers import fft_peaks_of_files

__all__ = ["FFTBeyond", "beyond_windows_hz", "fft_peaks_beyond"]


@dataclass(frozen=True)
class FFTBeyond:
    """The FFT peaks of the FFT-peak-read modes in and beyond their bands.

    Attributes
    ----------
    chosen : ndarray bool (m,)       the modes whose frequency is the FFT peak
    in_band : ndarray bool (n, m)    the record's FFT power has a peak in the mode's band (the chosen estimator read
                                     the mode; :attr:`FrequencyChoice.fft_hz` finite)
    peaks_hz : ndarray (n, m, 2)     the FFT peak (Hz, the vertex, as in the band) in the window below and the window
                                     above the band within the reach (:func:`beyond_windows_hz`); NaN where none, for
                                     a mode not chosen and for a test that is not response records
    """

    chosen: np.ndarray
    in_band: np.ndarray
    peaks_hz: np.ndarray


def beyond_windows_hz(ref: ReferenceModes) -> np.ndarray:
    """``(m, 2, 2)``: each reference mode's window below (``[reach_lo, band_lo]``) and above (``[band_hi,
    reach_hi]``) its tracking band by frequency alone (:func:`learn.monitor.tracking.narrow_bands_hz`) within its reach
    (:func:`learn.monitor.tracking.reach_bands_hz`), Hz. The reaches of two neighbouring modes meet half-way between
    them, so no two modes' windows overlap and neither reaches a neighbour's band."""
    band, reach = narrow_bands_hz(ref, by_frequency=True), reach_bands_hz(ref, open_factor=False)
    return np.stack([np.c_[reach[:, 0], band[:, 0]], np.c_[band[:, 1], reach[:, 1]]], axis=1)


def fft_peaks_beyond(tests: list, files: list, ref: ReferenceModes, chosen, fft_hz, cache_dir=None,
                     workers=1) -> FFTBeyond | None:
    """The FFT peaks beyond the bands of the ``chosen`` modes (bool (m,)) of each response record: in each window of
    :func:`beyond_windows_hz`, the FFT peak read as in the band: the highest local maximum of the record's
    zero-padded FFT power whose vertex lies in the window (:func:`learn.monitor.identification.cached_fft_peaks`,
    cached in ``cache_dir``; over ``workers`` processes): a real maximum of the spectrum, never the value at the
    window's edge of a peak lying further out, and never one whose peak lies in the band. ``fft_hz`` (n, m): the FFT
    peaks in the bands (NaN: none). None when no mode is chosen."""
    chosen = np.asarray(chosen, bool)
    if not chosen.any():
        return None
    n, m = len(tests), chosen.size
    peaks = np.full((n, m, 2), np.nan)
    windows = beyond_windows_hz(ref)[chosen]                               # (c, 2, 2)
    rows = [i for i, t in enumerate(tests) if t is not None and t.kind == "response records"]
    if rows:
        found = fft_peaks_of_files([files[i] for i in rows], windows.reshape(-1, 2), cache_dir, workers)
        found = found.reshape(len(rows), -1, 2)
        empty = windows[:, :, 1] <= windows[:, :, 0]                       # a band wider than its reach
        peaks[np.ix_(rows, np.flatnonzero(chosen))] = np.where(empty[None], np.nan, found)
    return FFTBeyond(chosen, np.isfinite(np.asarray(fft_hz, float)) & chosen[None], peaks)
