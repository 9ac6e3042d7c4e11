"""The checks every output-only method makes of response records before identifying them.

:func:`check_records` reads a record (an array or a ``np.memmap``) chunk by chunk (its range, then each channel's
runs of equal samples near its extremes) and refuses in one line a record that no output-only method can identify:
not ``(n_channels, n_samples)``, a sampling rate that is not a finite positive number, a band above the Nyquist
frequency, NaN or infinite samples, a constant channel, a clipped channel (a run of samples held at its highest or
lowest value far longer than a smooth peak stays at one level: :data:`CLIP_RUN_RATIO`) or a record shorter than
:data:`MIN_PERIODS` periods of the lowest frequency of interest (:func:`check_periods`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError

__all__ = ["CLIP_MIN_RUN", "CLIP_RUN_RATIO", "MIN_PERIODS", "NEAR_EXTREME", "CheckedRecord", "check_periods",
           "check_records"]

#: A channel is clipped when a run of consecutive samples at its highest (lowest) value is longer than this many
#: times the longest run at any other value within :data:`NEAR_EXTREME` of the range from that extreme (and at
#: least :data:`CLIP_MIN_RUN` samples long). A smooth unclipped peak, quantised to levels ``q`` apart, holds at
#: most 2/(sqrt(2) - 1) = 4.8 times as many samples at its top level as on either side at the level below.
CLIP_RUN_RATIO = 5
#: Fraction of a channel's range near either extreme whose runs show how long a smooth peak stays at one level.
NEAR_EXTREME = 0.1
#: Shortest run at an extreme called clipping.
CLIP_MIN_RUN = 3
#: Least number of periods of a mode a record must hold for the mode to be identified from it.
MIN_PERIODS = 10


@dataclass(frozen=True)
class CheckedRecord:
    """A record that passed :func:`check_records`.

    Attributes
    ----------
    signals : ndarray, shape (n_channels, n_samples)
        The record as given (an array or memory map; float64 when it was neither).
    sampling_frequency_hz : float
    band_hz : (float, float)
        The band of interest (default 0 to 0.4 of the sampling rate).
    mean : ndarray, shape (n_channels,)
        Each channel's mean.
    """

    signals: np.ndarray
    sampling_frequency_hz: float
    band_hz: tuple
    mean: np.ndarray

    @property
    def duration_s(self) -> float:
        return self.signals.shape[1] / self.sampling_frequency_hz


def check_periods(duration_s, frequency_hz, what, where="record"):
    """Refuse a record shorter than :data:`MIN_PERIODS` periods of ``frequency_hz`` (``what`` names it)."""
    if frequency_hz > 0 and duration_s < MIN_PERIODS / frequency_hz:
        raise ShapeError(f"{where}: {duration_s:.3g} s is shorter than ten periods of {what} "
                         f"({frequency_hz:.4g} Hz): it needs at least {MIN_PERIODS / frequency_hz:.3g} s; modes below "
                         f"{MIN_PERIODS / duration_s:.3g} Hz cannot be identified from it")


def _band(band_hz, fs):
    """The band of interest (Hz): ``band_hz``, by default 0 to 0.4 of the sampling rate ``fs``."""
    return (0.0, 0.4 * fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))


def check_records(signals, sampling_frequency_hz, band_hz=None, where="record", chunk_values=2**22) -> CheckedRecord:
    """Check a response record for every output-only method (see the module docstring) in one pass over chunks.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Band of interest; its lower limit is the lowest frequency the record must hold ten periods of.
    where : str
        Name of the record in error messages.
    chunk_values : int
        Values read per chunk.

    Returns
    -------
    CheckedRecord

    Raises
    ------
    ShapeError
        One line naming the record, the channel and what is wrong.

    Notes
    -----
    A :class:`CheckedRecord` of the same sampling rate and band (``band_hz`` None: the default band) is returned
    as it is: a record is read once however many steps check it.
    """
    if isinstance(signals, CheckedRecord):
        fs_ = float(sampling_frequency_hz)
        if signals.sampling_frequency_hz == fs_ and tuple(signals.band_hz) == _band(band_hz, fs_):
            return signals
        signals = signals.signals
    y = signals if isinstance(signals, np.ndarray) else np.asarray(signals, dtype=np.float64)
    if y.ndim != 2 or y.shape[0] < 1 or y.shape[1] < 2 or not np.issubdtype(y.dtype, np.number) \
            or np.iscomplexobj(y):
        raise ShapeError(f"{where}: signals must be a real (n_channels, n_samples) array, got {y.dtype} of shape "
                         f"{y.shape}")
    fs = float(sampling_frequency_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise ShapeError(f"{where}: sampling rate {fs:g} Hz must be finite and > 0")
    band = _band(band_hz, fs)
    if band[1] > fs / 2:
        raise ShapeError(f"{where}: band up to {band[1]:g} Hz is above the Nyquist frequency {fs / 2:g} Hz "
                         f"of a {fs:g} Hz sampling rate")
    n_ch, n = y.shape
    check_periods(n / fs, band[0], "the band's lower limit", where)
    total = np.zeros(n_ch)
    lo, hi = np.full(n_ch, np.inf), np.full(n_ch, -np.inf)
    step = max(1, chunk_values // n_ch)
    for a in range(0, n, step):
        c = np.asarray(y[:, a:a + step], dtype=np.float64)
        finite = np.isfinite(c)
        if not finite.all():
            k = int(np.argmax(~finite.all(axis=1)))
            raise ShapeError(f"{where}: channel {k} holds NaN or inf samples (sample "
                             f"{a + int(np.argmax(~finite[k]))})")
        total += c.sum(axis=1)
        lo, hi = np.minimum(lo, c.min(axis=1)), np.maximum(hi, c.max(axis=1))
    flat = hi <= lo
    if np.any(flat):
        raise ShapeError(f"{where}: channel {int(np.argmax(flat))} is constant; nothing to identify from it")
    for k in range(n_ch):
        run, start, value, near = _extreme_runs(y, k, lo[k], hi[k], step)
        if run >= CLIP_MIN_RUN and run > CLIP_RUN_RATIO * near:
            side = "highest" if value == hi[k] else "lowest"
            raise ShapeError(f"{where}: channel {k} is clipped: samples {start}-{start + run - 1} ({run} in a row) "
                             f"are held at its {side} value {value:.6g}, {run / near:.3g} times the longest run at "
                             f"any level near it ({near}); identify from unclipped records")
    return CheckedRecord(y, fs, band, total / n)


def _extreme_runs(y, k, lo, hi, step):
    """Longest run of consecutive equal samples of channel ``k`` at ``lo`` or ``hi``: ``(length, first sample,
    value, longest run at any other value within NEAR_EXTREME of the range from lo or hi, at least 1)``, reading
    the channel in chunks of ``step`` samples."""
    margin = NEAR_EXTREME * (hi - lo)
    best, best_start, best_value, near = 0, 0, hi, 1
    open_start, open_value = 0, None
    n = y.shape[1]
    for a in range(0, n, step):
        v = np.asarray(y[k, a:a + step], dtype=np.float64)
        cut = np.flatnonzero(v[1:] != v[:-1]) + 1
        starts = a + np.concatenate([[0], cut])
        values = v[starts - a]
        if open_value is not None and values[0] == open_value:
            starts[0] = open_start
        elif open_value is not None:                     # the run open at the chunk's start ended with it
            starts, values = np.concatenate([[open_start], starts]), np.concatenate([[open_value], values])
        ends = np.concatenate([starts[1:], [a + v.size]])
        done = slice(0, None) if a + v.size >= n else slice(0, -1)
        length, first, value = ends[done] - starts[done], starts[done], values[done]
        extreme = (value == lo) | (value == hi)
        if extreme.any():
            j = int(np.argmax(np.where(extreme, length, -1)))
            if length[j] > best:
                best, best_start, best_value = int(length[j]), int(first[j]), float(value[j])
        close = ~extreme & ((value <= lo + margin) | (value >= hi - margin))
        near = max(near, int(length[close].max(initial=1)))
        open_start, open_value = int(starts[-1]), values[-1]
    return best, best_start, best_value, near
