"""The checks every output-only method makes of response records before identifying them.

:func:`check_records` reads a record (an array or a ``np.memmap``) once, chunk by chunk, and refuses in one line a
record that no output-only method can identify: not ``(n_channels, n_samples)``, a sampling rate that is not a
finite positive number, a band above the Nyquist frequency, NaN or infinite samples, a constant channel, a clipped
channel (more than :data:`CLIP_FRACTION` of its samples at its extreme values) or a record shorter than
:data:`MIN_PERIODS` periods of the lowest frequency of interest (:func:`check_periods`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError

__all__ = ["CLIP_FRACTION", "MIN_PERIODS", "CheckedRecord", "check_periods", "check_records"]

#: Fraction of a channel's samples at its extreme value beyond which the channel is called clipped.
CLIP_FRACTION = 1e-3
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
    """
    y = signals if isinstance(signals, np.ndarray) else np.asarray(signals, dtype=np.float64)
    if y.ndim != 2 or y.shape[0] < 1 or y.shape[1] < 2 or not np.issubdtype(y.dtype, np.number) \
            or np.iscomplexobj(y):
        raise ShapeError(f"{where}: signals must be a real (n_channels, n_samples) array, got {y.dtype} of shape "
                         f"{y.shape}")
    fs = float(sampling_frequency_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise ShapeError(f"{where}: sampling rate {fs:g} Hz must be finite and > 0")
    band = (0.0, 0.4 * fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if band[1] > fs / 2:
        raise ShapeError(f"{where}: band up to {band[1]:g} Hz is above the Nyquist frequency {fs / 2:g} Hz "
                         f"of a {fs:g} Hz sampling rate")
    n_ch, n = y.shape
    check_periods(n / fs, band[0], "the band's lower limit", where)
    total = np.zeros(n_ch)
    lo, hi = np.full(n_ch, np.inf), np.full(n_ch, -np.inf)
    n_lo, n_hi = np.zeros(n_ch, int), np.zeros(n_ch, int)
    step = max(1, chunk_values // n_ch)
    for a in range(0, n, step):
        c = np.asarray(y[:, a:a + step], dtype=np.float64)
        finite = np.isfinite(c)
        if not finite.all():
            k = int(np.argmax(~finite.all(axis=1)))
            raise ShapeError(f"{where}: channel {k} holds NaN or inf samples (sample "
                             f"{a + int(np.argmax(~finite[k]))})")
        total += c.sum(axis=1)
        c_lo, c_hi = c.min(axis=1), c.max(axis=1)
        at_lo, at_hi = np.sum(c == c_lo[:, None], axis=1), np.sum(c == c_hi[:, None], axis=1)
        n_lo = np.where(c_lo < lo, at_lo, np.where(c_lo == lo, n_lo + at_lo, n_lo))
        n_hi = np.where(c_hi > hi, at_hi, np.where(c_hi == hi, n_hi + at_hi, n_hi))
        lo, hi = np.minimum(lo, c_lo), np.maximum(hi, c_hi)
    flat = hi <= lo
    if np.any(flat):
        raise ShapeError(f"{where}: channel {int(np.argmax(flat))} is constant; nothing to identify from it")
    at_extreme = n_lo + n_hi
    clipped = at_extreme > CLIP_FRACTION * n + 2
    if np.any(clipped):
        k = int(np.argmax(clipped))
        raise ShapeError(f"{where}: channel {k} is clipped ({at_extreme[k]} samples at its extreme values "
                         f"{lo[k]:.4g}/{hi[k]:.4g}); identify from unclipped records")
    return CheckedRecord(y, fs, band, total / n)
