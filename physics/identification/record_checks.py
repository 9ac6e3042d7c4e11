"""The checks every output-only method makes of response records before identifying them.

:func:`check_records` reads a record (an array or a ``np.memmap``) chunk by chunk (its range, then each channel's
runs of equal samples near its extremes) and refuses in one line a record that no output-only method can identify:
not ``(n_channels, n_samples)``, a sampling rate that is not a finite positive number, a band above the Nyquist
frequency, NaN or infinite samples, a constant channel, or a record shorter than :data:`MIN_PERIODS` periods of the
lowest frequency of interest (:func:`check_periods`).

A channel is clipped where a run of its samples is held at its highest or lowest value far longer than a smooth peak
stays at one level (:data:`CLIP_RUN_RATIO`). An impact or a pluck clips at the hit, and the decay after it is
intact: a record whose clipping lies in its leading part is identified from the samples after it
(:class:`RecordCrop`, :attr:`CheckedRecord.crop`): after each clipped channel's last sample at the limit it is
clipped at (a shorter run there is a clipped peak too) and a guard as long as its longest clipped run, when at
least :data:`CROP_MIN_FRACTION` of the record and :data:`MIN_PERIODS` periods of the band's lower limit follow. A
record clipped later, or with too little left, is refused naming its longest clipped run and what it would need.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from physics.errors import ShapeError

__all__ = ["CLIP_MIN_RUN", "CLIP_RUN_RATIO", "CROP_MIN_FRACTION", "MIN_PERIODS", "NEAR_EXTREME", "CheckedRecord",
           "RecordCrop", "check_periods", "check_records", "clipped_run_text", "modes_with_periods"]

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
#: A record with clipped runs is identified from the samples after them (and a guard) when at least this fraction
#: of its samples follows: the clipping lies in its leading part (an impact's hit).
CROP_MIN_FRACTION = 0.5


@dataclass(frozen=True)
class RecordCrop:
    """The leading part of a record left out because it holds clipped runs (:func:`check_records`).

    Attributes
    ----------
    first_sample : int
        The first sample identified (of the record as given).
    runs : tuple of (int, int, int)
        Each clipped run as ``(channel, first sample, last sample)``, in order of channel and sample.
    n_samples : int
        Samples of the record as given.
    sampling_frequency_hz : float
    last_at_limit : int
        The last sample of a clipped channel at a limit it is clipped at (the end of the last clipped run, or of a
        shorter run at that limit after it, which a clipped peak may be too).
    """

    first_sample: int
    runs: tuple
    n_samples: int
    sampling_frequency_hz: float
    last_at_limit: int

    @property
    def text(self) -> str:
        """E.g. ``"channel 0 clipped at samples 812-822; identified from sample 834 on (3.666 of 4 s)"``."""
        per = {}
        for k, a, b in self.runs:
            per.setdefault(k, []).append((a, b))
        chans = ", ".join(f"channel {k} clipped at samples " + (", ".join(f"{a}-{b}" for a, b in r) if len(r) <= 3
                                                                 else f"{r[0][0]}-{r[-1][1]} ({len(r)} runs)")
                          for k, r in per.items())
        after = max(b for _, _, b in self.runs)
        held = f" and at its limit up to sample {self.last_at_limit}" if self.last_at_limit > after else ""
        fs = self.sampling_frequency_hz
        return (f"{chans}{held}; identified from sample {self.first_sample} on "
                f"({(self.n_samples - self.first_sample) / fs:.4g} of {self.n_samples / fs:.4g} s)")

    def to_dict(self) -> dict:
        return {"first_sample": self.first_sample, "clipped_runs": [list(r) for r in self.runs],
                "last_at_limit": self.last_at_limit, "n_samples": self.n_samples, "text": self.text}


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
    crop : RecordCrop or None
        The leading part left out for its clipped runs: ``signals`` are then the samples from
        ``crop.first_sample`` on; None when ``signals`` are the whole record.
    """

    signals: np.ndarray
    sampling_frequency_hz: float
    band_hz: tuple
    mean: np.ndarray
    crop: RecordCrop | None = None

    @property
    def duration_s(self) -> float:
        return self.signals.shape[1] / self.sampling_frequency_hz


def check_periods(duration_s, frequency_hz, what, where="record"):
    """Refuse a record shorter than :data:`MIN_PERIODS` periods of ``frequency_hz`` (``what`` names it)."""
    if frequency_hz > 0 and duration_s < MIN_PERIODS / frequency_hz:
        raise ShapeError(f"{where}: {duration_s:.3g} s is shorter than ten periods of {what} "
                         f"({frequency_hz:.4g} Hz): it needs at least {MIN_PERIODS / frequency_hz:.3g} s; modes below "
                         f"{MIN_PERIODS / duration_s:.3g} Hz cannot be identified from it")


def modes_with_periods(duration_s, frequencies_hz, where="record") -> np.ndarray:
    """Which modes (``frequencies_hz``, shape (m,)) a record of ``duration_s`` holds :data:`MIN_PERIODS` periods
    of; the others are named in a warning (what the record would need), and a record that holds none of them is
    refused as :func:`check_periods` refuses it."""
    f = np.asarray(frequencies_hz, float)
    keep = f * duration_s >= MIN_PERIODS
    if f.size and not keep.any():
        check_periods(duration_s, float(np.min(f)), "the lowest mode", where)
    if not keep.all():
        warnings.warn(f"{where}: {duration_s:.3g} s holds fewer than ten periods of "
                      f"{', '.join(f'{x:.4g}' for x in f[~keep])} Hz, left out (modes below "
                      f"{MIN_PERIODS / duration_s:.3g} Hz need a longer record: "
                      f"{MIN_PERIODS / f[~keep].min():.3g} s for these)", UserWarning, stacklevel=3)
    return keep


def _band(band_hz, fs):
    """The band of interest (Hz): ``band_hz``, by default 0 to 0.4 of the sampling rate ``fs``."""
    return (0.0, 0.4 * fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))


def check_records(signals, sampling_frequency_hz, band_hz=None, where="record", chunk_values=2**22) -> CheckedRecord:
    """Check a response record for every output-only method (see the module docstring) in one pass over chunks;
    a record clipped in its leading part, then once over the samples kept (their sums, and how many lie at their
    extremes: a channel's runs are read again only where a clipped run can lie).

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
        The whole record, or the samples after its clipped runs (``crop``).

    Raises
    ------
    ShapeError
        One line naming the record, the channel and what is wrong.

    Notes
    -----
    A :class:`CheckedRecord` of the same sampling rate and band (``band_hz`` None: the default band) is returned
    as it is: a record is read once however many steps check it. One of another band is checked again (its
    samples, its crop kept).
    """
    if isinstance(signals, CheckedRecord):
        fs_ = float(sampling_frequency_hz)
        if signals.sampling_frequency_hz == fs_ and tuple(signals.band_hz) == _band(band_hz, fs_):
            return signals
        again = check_records(signals.signals, fs_, band_hz, where, chunk_values)
        return again if signals.crop is None else replace(again, crop=signals.crop)
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
    step = max(1, chunk_values // n_ch)
    mean, runs, ends, extremes = _scan(y, step, where)
    if not runs:
        return CheckedRecord(y, fs, band, mean)
    # after each clipped channel's last sample at a limit it is clipped at, a guard as long as its longest run
    first = max(ends[k] + 1 + max(r for k_, _, r, *_ in runs if k_ == k) for k in ends)
    kept = n - first
    short = band[0] > 0 and kept / fs < MIN_PERIODS / band[0]
    if kept < CROP_MIN_FRACTION * n or short:
        k, a, r, value, near, side = max(runs, key=lambda run: run[2])
        end = max(ends.values())
        need = (f"the {kept} samples after them and the guard ({kept / fs:.3g} s from sample {first}) are shorter "
                f"than ten periods of the band's lower limit ({band[0]:.4g} Hz): that needs "
                f"{MIN_PERIODS / band[0]:.3g} s" if kept >= CROP_MIN_FRACTION * n else
                f"{max(kept, 0)} samples follow them and a guard as long as the longest run (from sample {first} "
                f"on); identified after its clipping, a record needs at least half of its {n} samples there")
        raise ShapeError(f"{where}: channel {k} is clipped: samples {a}-{a + r - 1} ({r} in a row) are held at its "
                         f"{side} value {value:.6g}, {r / near:.3g} times the longest run at any level near it "
                         f"({near}); its samples at the clipped limits end at sample {end}: {need}; identify from "
                         "unclipped records")
    crop = RecordCrop(first, tuple((k, a, a + r - 1) for k, a, r, *_ in runs), n, fs, max(ends.values()))
    return CheckedRecord(y[:, first:], fs, band, _kept_mean(y, first, step, extremes, where), crop)


def clipped_run_text(signals, names, where="record", chunk_values=2**22) -> str | None:
    """The longest clipped run of ``signals`` (shape (n_channels, n_samples), finite, no channel constant) in words,
    naming its channel by ``names``, e.g. ``"2:+Z is clipped: samples 812-822 (11 in a row) are held at its highest
    value 0.5, 5.5 times the longest run at any level near it (2)"``; None when no channel is clipped."""
    y = np.asarray(signals, dtype=np.float64)
    _, runs, _, _ = _scan(y, max(1, chunk_values // y.shape[0]), where)
    if not runs:
        return None
    k, a, r, value, near, side = max(runs, key=lambda run: run[2])
    return (f"{names[k]} is clipped: samples {a}-{a + r - 1} ({r} in a row) are held at its {side} value "
            f"{value:.6g}, {r / near:.3g} times the longest run at any level near it ({near})")


def _scan(y, step, where) -> tuple:
    """One pass over the record ``y`` in chunks of ``step`` samples: ``(each channel's mean, clipped runs, {channel:
    last sample at a limit it is clipped at}, (each chunk's lowest, each chunk's highest sample))``, the runs as
    ``(channel, first sample, length, value, longest run at any level near it, "highest" or "lowest")`` in order of
    channel and sample, the chunks' extremes of shape (n_chunks, n_channels). Refuses NaN or infinite samples and
    a constant channel (``where`` names the record)."""
    n_ch, n = y.shape
    total = np.zeros(n_ch)
    chunk_lo, chunk_hi = [], []
    for a in range(0, n, step):
        c = np.asarray(y[:, a:a + step], dtype=np.float64)
        finite = np.isfinite(c)
        if not finite.all():
            k = int(np.argmax(~finite.all(axis=1)))
            raise ShapeError(f"{where}: channel {k} holds NaN or inf samples (sample "
                             f"{a + int(np.argmax(~finite[k]))})")
        total += c.sum(axis=1)
        chunk_lo.append(c.min(axis=1))
        chunk_hi.append(c.max(axis=1))
    chunk_lo, chunk_hi = np.array(chunk_lo), np.array(chunk_hi)
    lo, hi = chunk_lo.min(axis=0), chunk_hi.max(axis=0)
    _refuse_constant(lo, hi, where)
    runs, ends = [], {}
    for k in range(n_ch):
        clipped, end = _clipped_runs(y, k, lo[k], hi[k], step)
        runs += clipped
        if clipped:
            ends[k] = end
    return total / n, runs, ends, (chunk_lo, chunk_hi)


def _kept_mean(y, first, step, extremes, where) -> np.ndarray:
    """Each channel's mean over the samples of ``y`` from ``first`` on (summed in chunks of ``step`` samples from
    ``first``, as :func:`_scan` sums a record), refusing a channel constant there or clipped there too.

    The kept part's extremes come from the chunks' extremes of :func:`_scan` (``extremes``) and the part of the
    chunk holding ``first`` after it; a clipped run at one of them is longer than :data:`CLIP_RUN_RATIO` (and at
    least :data:`CLIP_MIN_RUN`) samples, so the runs of a channel are read only when that many of its kept samples
    lie at one of its extremes."""
    n_ch, n = y.shape
    kept = n - first
    j = first // step
    head = np.asarray(y[:, first:(j + 1) * step], dtype=np.float64)
    lo = np.minimum(head.min(axis=1), extremes[0][j + 1:].min(axis=0, initial=np.inf))
    hi = np.maximum(head.max(axis=1), extremes[1][j + 1:].max(axis=0, initial=-np.inf))
    _refuse_constant(lo, hi, f"{where} (from sample {first} on, after its clipped runs)")
    rest = y[:, first:]
    total = np.zeros(n_ch)
    at_lo, at_hi = np.zeros(n_ch, int), np.zeros(n_ch, int)
    for a in range(0, kept, step):
        c = np.asarray(rest[:, a:a + step], dtype=np.float64)
        total += c.sum(axis=1)
        at_lo += np.count_nonzero(c == lo[:, None], axis=1)
        at_hi += np.count_nonzero(c == hi[:, None], axis=1)
    shortest = max(CLIP_MIN_RUN, int(np.floor(CLIP_RUN_RATIO)) + 1)     # > CLIP_RUN_RATIO x a run of 1
    for k in np.flatnonzero((at_lo >= shortest) | (at_hi >= shortest)):
        clipped, _ = _clipped_runs(rest, int(k), lo[k], hi[k], step)
        if clipped:
            k, a, r, value, *_ = clipped[0]
            raise ShapeError(f"{where}: channel {k} is clipped before sample {first} and after it, at samples "
                             f"{first + a}-{first + a + r - 1} (held at {value:.6g}); identify from unclipped records")
    return total / kept


def _refuse_constant(lo, hi, where) -> None:
    """Refuse a channel whose lowest sample ``lo`` is its highest ``hi`` (shape (n_channels,))."""
    flat = hi <= lo
    if np.any(flat):
        raise ShapeError(f"{where}: channel {int(np.argmax(flat))} is constant; nothing to identify from it")


def _clipped_runs(y, k, lo, hi, step) -> tuple:
    """``(clipped runs of channel k, last sample at a limit it is clipped at or None)``, the runs as :func:`_scan`
    gives them, of the channel's lowest sample ``lo`` and highest ``hi``."""
    starts, lengths, values, near, last = _extreme_runs(y, k, lo, hi, step)
    clipped = lengths > CLIP_RUN_RATIO * near
    runs = [(k, int(a), int(r), float(v), near, "highest" if v == hi else "lowest")
            for a, r, v in zip(starts[clipped], lengths[clipped], values[clipped])]
    return runs, (max(last[v] for v in values[clipped]) if runs else None)


def _extreme_runs(y, k, lo, hi, step):
    """Runs of at least :data:`CLIP_MIN_RUN` consecutive equal samples of channel ``k`` at ``lo`` or ``hi``:
    ``(first samples, lengths, values, longest run at any other value within NEAR_EXTREME of the range from lo or
    hi (at least 1), {lo: last sample at lo, hi: last sample at hi})``, reading the channel in chunks of ``step``
    samples."""
    margin = NEAR_EXTREME * (hi - lo)
    found, near, last = [], 1, {lo: -1, hi: -1}
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
        at = extreme & (length >= CLIP_MIN_RUN)
        found.append((first[at], length[at], value[at]))
        close = ~extreme & ((value <= lo + margin) | (value >= hi - margin))
        near = max(near, int(length[close].max(initial=1)))
        open_start, open_value = int(starts[-1]), values[-1]
        for limit in (lo, hi):
            at_limit = np.flatnonzero(v == limit)
            if at_limit.size:
                last[limit] = a + int(at_limit[-1])
    starts, lengths, values = (np.concatenate(parts) for parts in zip(*found))
    return starts.astype(int), lengths.astype(int), values, near, last
