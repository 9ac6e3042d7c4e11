"""FRFs from measured time records: random excitation (Welch, overlap) and impact tests (windows, hit checks).

The spectral estimators are those of :mod:`physics.estimation` (H1, H2, Hv with
coherence); this module prepares the records the way each test needs:

* random excitation: overlapped segments with a Hann (or any scipy) window;
* impact tests: the record is cut into one block per hit, each from just before
  its hit (:func:`hit_onsets`, :data:`PRETRIGGER`) and as long as the hits'
  shortest spacing, or into ``averages`` equal blocks. The force is kept over each
  block's pulse (force window: zero after the pulse plus a short margin) and both channels get an exponential window
  ``exp(-t/tau)`` decaying to ``decay`` at the block end, so that responses that
  outlast the block do not leak. The exponential window adds ``1/tau`` (1/s) to
  every pole's decay rate: a mode's damping ratio is overestimated by
  ``1/(tau omega_n)``, which is reported so that it can be subtracted.
  By default (``decay=None``) the window is the weakest that brings every response
  to :data:`RESPONSE_END_LEVEL` of its loudest by the block end
  (:func:`window_end_value`), and none where the responses end there already: a
  window weights the samples of each decay by ``exp(-2 t/tau)`` in any fit of the
  FRF, so it leaves the later part of a record that needed none out of the estimate
  (a mode decaying at ``sigma``, least squares under white noise: the variance of
  its frequency grows by ``(a + 2b)^6 / ((a + 4b)^3 a^3)``, ``a = 2 sigma``,
  ``b = 1/tau``; 2.2 for ``sigma = 5`` 1/s and a 1 % window over 1 s) and reads
  more of its loud start, where a mode whose frequency follows its amplitude
  differs from hit to hit.
  Blocks with a second hit (a force peak above ``double_hit`` of the first after
  the pulse has ended) or an overload (a channel flat at its extreme over three
  or more samples: clipping) are flagged and left out of the average.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from physics.errors import ConfigError, FileFormatError, ShapeError
from physics.estimation import estimate_frf
from physics.identification.record_checks import clipped_run_text
from physics.io.timedata import TimeRecords
from physics.io.types import MeasuredFRF

__all__ = ["ESTIMATORS", "EXCITATIONS", "FORCE_DROP_DB", "HIT_OVER_NOISE", "IMPULSIVE_SHARE", "LEVEL_SEGMENTS",
           "PRETRIGGER", "RESPONSE_END_LEVEL", "HitCheck", "TimeEstimate", "check_hits", "count_hits",
           "estimate_as_recorded", "estimate_from_records", "exponential_window", "force_band_hz", "force_window",
           "hit_onsets", "segment_window", "window_end_value"]

ESTIMATORS = ("h1", "h2", "hv")
EXCITATIONS = ("random", "impact")
_KIND = {"displacement": "receptance", "velocity": "mobility", "acceleration": "accelerance"}
#: Level (RMS, relative to its loudest) an impact block's response is brought to by the block's end: the default
#: exponential window is the weakest that does so for every response (:func:`window_end_value`).
RESPONSE_END_LEVEL = 0.01
#: An impact test's force band: up to the first line above the force spectrum's peak where the force's power falls
#: this far (dB) below it. Beyond it the force is the hammer tip's roll-off and its noise, and H1 the response's noise
#: over it (:func:`force_band_hz`).
FORCE_DROP_DB = 20.0
#: A block's response level is its RMS (its mean removed) over each of this many equal segments: the last segment's
#: against the loudest's.
LEVEL_SEGMENTS = 20


@dataclass(frozen=True)
class HitCheck:
    """Impact blocks checked for double hits and overloads (clipping).

    Attributes
    ----------
    double_hits : tuple of int
        Blocks with a second force peak after the pulse.
    overloads : tuple of (int, str)
        ``(block, dof)`` of clipped channels.
    pulse_samples : int
        Longest force pulse found (samples above 5 % of the block's peak).
    missed : tuple of int
        Blocks without a hit: force peak below 5 % of the largest block's.
    pulse_ends : tuple of int
        Each block's sample just after its first pulse (the first below 5 % of its peak after the pulse began).
    """

    double_hits: tuple
    overloads: tuple
    pulse_samples: int
    missed: tuple = ()
    pulse_ends: tuple = ()

    @property
    def bad_blocks(self) -> set:
        return set(self.double_hits) | {b for b, _ in self.overloads} | set(self.missed)


@dataclass(frozen=True)
class TimeEstimate:
    """FRFs estimated from time records and what was done."""

    frf: MeasuredFRF
    coherence: np.ndarray
    estimator: str
    excitation: str
    n_averages: int
    hits: HitCheck | None
    added_decay_rate_1_s: float
    description: str
    window_end_value: float = 1.0     # the exponential window's value at the block end (1: none)
    force_band_hz: tuple | None = None  # impact: the lines the force excites (:func:`force_band_hz`)


def force_band_hz(frequency_hz, force_power, drop_db=FORCE_DROP_DB) -> tuple:
    """``(first line, last line)`` (Hz) of the band a hammer's force excites: from the lowest line up to the last
    line before the force's power (shape (n_lines,), averaged over the blocks) first falls ``drop_db`` below its
    largest, above that largest line. The band of interest should lie within it: a mode beyond it is driven by
    the tip's roll-off, and H1 there divides the response's noise by a force that is not there (spurious poles)."""
    f, g = np.asarray(frequency_hz, float), np.asarray(force_power, float)
    top = int(np.argmax(g))
    below = np.flatnonzero(g[top:] < g[top] * 10 ** (-drop_db / 10))
    last = top + int(below[0]) - 1 if below.size else f.size - 1
    return float(f[0]), float(f[max(last, top)])


def force_window(n, pulse_end, margin):
    """1 up to ``pulse_end + margin`` samples, then 0 (a rectangular force window): shape (n,), or (k, n) for ``k``
    pulse ends (one window per block)."""
    return (np.arange(n) < np.asarray(pulse_end)[..., None] + margin).astype(float)


def exponential_window(n, decay):
    """``exp(-t/tau)`` over ``n`` samples falling to ``decay`` at the last one; returns (window, tau in samples)."""
    if not 0 < decay <= 1:
        raise ShapeError(f"exponential window decay {decay} must be in (0, 1]")
    tau = np.inf if decay == 1 else (n - 1) / -np.log(decay)
    return np.exp(-np.arange(n) / tau), tau


def window_end_value(response_blocks, level=RESPONSE_END_LEVEL) -> float:
    """End value of the weakest exponential window that brings every response to ``level`` of its loudest by the
    block end; 1 (no window) where every response ends there already.

    Each block's response level is its RMS, the block's mean removed, over :data:`LEVEL_SEGMENTS` equal segments;
    ``r`` is the largest ratio of the last segment's to the loudest segment's over blocks and channels, and the window
    falls to ``min(1, level / r)``.

    Parameters
    ----------
    response_blocks : ndarray, shape (n_blocks, n_responses, n)
    level : float in (0, 1]

    Returns
    -------
    float in (0, 1]
    """
    x = np.asarray(response_blocks, float)
    n = x.shape[-1] // LEVEL_SEGMENTS * LEVEL_SEGMENTS
    if n == 0:
        raise ShapeError(f"blocks of {x.shape[-1]} samples cannot give {LEVEL_SEGMENTS} level segments")
    x = x - x.mean(axis=-1, keepdims=True)
    rms = np.sqrt(np.mean(x[..., :n].reshape(*x.shape[:-1], LEVEL_SEGMENTS, -1) ** 2, axis=-1))
    loud = rms.max(axis=-1)
    ratio = np.max(np.where(loud > 0, rms[..., -1] / np.where(loud > 0, loud, 1.0), 0.0))
    return 1.0 if ratio <= level else float(level / ratio)


def check_hits(force_blocks, response_blocks, dofs, double_hit=0.2, flat=3):
    """Flag double hits in ``force_blocks`` (n_blocks, n) and clipping in any channel.

    ``response_blocks`` is (n_blocks, n_channels, n) with ``dofs`` naming the
    channels (force first).
    """
    fb = np.abs(np.asarray(force_blocks, float))
    peak = fb.max(axis=1, keepdims=True)
    above = fb > 0.05 * peak
    first = np.argmax(above, axis=1)
    # end of the first pulse: first sample after the start below 5 % of the peak
    n = fb.shape[1]
    idx = np.arange(n)[None, :]
    below_after = (~above) & (idx > first[:, None])
    end = np.where(below_after.any(axis=1), np.argmax(below_after, axis=1), n)
    later = np.where(idx >= end[:, None] + 1, fb, 0.0)
    noise = 1.4826 * np.median(np.abs(fb - np.median(fb, axis=1, keepdims=True)), axis=1)
    missed_mask = ~(peak[:, 0] > 0.05 * peak.max()) | ~(peak[:, 0] > HIT_OVER_NOISE * noise)
    doubles = tuple(int(b) for b in np.nonzero((later.max(axis=1) > double_hit * peak[:, 0]) & ~missed_mask)[0])
    overloads = []
    allch = np.asarray(response_blocks, float)
    for c, dof in enumerate(dofs):
        x = allch[:, c, :]
        top = np.abs(x).max(axis=1, keepdims=True)
        at_top = np.isclose(np.abs(x), top, rtol=1e-9, atol=0) & (top > 0)
        # `flat` consecutive samples at the extreme
        run = np.ones_like(at_top[:, : n - flat + 1])
        for k in range(flat):
            run &= at_top[:, k: n - flat + 1 + k]
        overloads += [(int(b), dof) for b in np.nonzero(run.any(axis=1))[0]]
    missed = tuple(int(b) for b in np.nonzero(missed_mask)[0])
    pulse = int(np.max((end - first)[~missed_mask])) if not missed_mask.all() else int(np.max(end - first))
    return HitCheck(doubles, tuple(sorted(overloads)), pulse, missed, tuple(int(e) for e in end))


#: A block holds a hit when its force peak is at least this many robust standard deviations of its force channel
#: (the noise, which most of a block's samples hold) above the median: a block of noise alone peaks near 3.
HIT_OVER_NOISE = 10.0


def count_hits(force, double_hit=0.2) -> int:
    """How many hits a force record (shape (n,)) holds: its rises above ``double_hit`` of its largest force."""
    above = np.abs(np.asarray(force, float)) > double_hit * np.max(np.abs(force))
    return int(np.count_nonzero(above[1:] & ~above[:-1]) + above[0])


#: A force channel is a train of hits (an impact test) when at most this share of its samples exceed the hits'
#: threshold, ``double_hit`` of its largest force; a random or swept force exceeds it over a third of its samples or
#: more.
IMPULSIVE_SHARE = 0.05


def _above(force, double_hit):
    """The force's samples above ``double_hit`` of its largest deviation from its median (the force between hits):
    boolean, shape (n,); all False for a force without one."""
    f = np.abs(np.asarray(force, float) - np.median(force))
    return f > double_hit * f.max(initial=0.0) if f.max(initial=0.0) > 0 else np.zeros(f.shape, bool)


def hit_onsets(force, double_hit=0.2):
    """Onsets (sample indices, shape (n_hits,)) of the hits of a force record (shape (n,)) that is a train of hits
    (:data:`IMPULSIVE_SHARE`), its offset (the median: the force between hits) removed: each a rise above
    ``double_hit`` of the largest force at least half the hits' median spacing after the previous one (a bounce
    sooner belongs to its hit); None for any other force."""
    above = _above(force, double_hit)
    if not above.any() or np.mean(above) > IMPULSIVE_SHARE:
        return None
    rises = np.flatnonzero(above[1:] & ~above[:-1]) + 1
    rises = np.r_[0, rises] if above[0] else rises
    if not rises.size:
        return None
    spacing = np.median(np.diff(rises)) if rises.size > 1 else above.size
    onsets = [int(rises[0])]
    for r in rises[1:]:                 # one pass over the hits, a few dozen at most
        if r - onsets[-1] >= spacing / 2:
            onsets.append(int(r))
    return np.array(onsets)


#: An impact block cut at a hit begins this share of its length before the hit's onset (the pulse's rise).
PRETRIGGER = 1 / 32


#: Smallest peak force (N) of a force channel: below it the force spectra underflow (no FRF can be formed).
MIN_FORCE_N = 1e-100


def _estimate(src, *args, **kw):
    """:func:`physics.estimation.estimate_frf` with its errors naming the file."""
    try:
        return estimate_frf(*args, **kw)
    except ShapeError as exc:
        raise FileFormatError(f"{src}: {exc}") from None


def estimate_from_records(records: TimeRecords, reference=None, estimator="h1", excitation="random", averages=None,
                          overlap=0.5, window="hann", decay=None, fmax_hz=None) -> TimeEstimate:
    """FRFs (response over the reference force) of time records.

    Parameters
    ----------
    records : TimeRecords
    reference : str, optional
        DOF label of the force channel (the reference DOF); default: the only force.
    estimator : {"h1", "h2", "hv"}
    excitation : {"random", "impact"}
    averages : int, optional
        Random: number of overlapped segments (default 8). Impact: number of equal blocks, one hit each; default one
        block per hit (:func:`hit_onsets`), each from :data:`PRETRIGGER` of its length before its hit and as long as
        the shortest spacing of the hits (a single hit: to the record's end).
    overlap : float in [0, 1)
        Random excitation only.
    window : str or tuple
        Random excitation only: a :func:`scipy.signal.get_window` name, or a name and its parameters
        (``"kaiser,8.6"``; :func:`segment_window`).
    decay : float in (0, 1], optional
        Impact: value of the exponential window at the block end (1 = none); default: the weakest window that brings
        every response to :data:`RESPONSE_END_LEVEL` of its loudest by the block end (:func:`window_end_value`).
    fmax_hz : float, optional
        Keep lines up to this frequency.

    Returns
    -------
    TimeEstimate
    """
    if estimator not in ESTIMATORS:
        raise ShapeError(f"estimator {estimator!r} must be one of {', '.join(ESTIMATORS)}")
    if excitation not in EXCITATIONS:
        raise ShapeError(f"excitation {excitation!r} must be one of {', '.join(EXCITATIONS)}")
    src = records.metadata.get("source", "time records")
    bad = np.argwhere(~np.isfinite(records.signals))
    if bad.size:
        raise FileFormatError(f"{src}: channel {records.dofs[bad[0, 0]]} holds NaN or inf samples (sample "
                              f"{bad[0, 1]}); expected finite values")
    ref, resp, kind = _select_channels(records, reference, src)
    if averages is None and excitation == "random":
        averages = 8
    if averages is not None and not (isinstance(averages, (int, np.integer)) and averages >= 1):
        raise ShapeError(f"averages {averages} must be an integer >= 1")
    if excitation == "random" and (onsets := hit_onsets(records.signals[ref])) is not None:
        warnings.warn(f"{src}: force channel {records.dofs[ref]} holds {onsets.size} hit{'s' * (onsets.size != 1)} "
                      "and is near zero between them (an impact test), estimated as random excitation; excitation "
                      "'impact' cuts one block per hit", UserWarning, stacklevel=2)
    if excitation == "random":
        est, n_avg, hits, added, what = _random_spectra(records, ref, resp, src, estimator, averages, overlap, window)
        decay, band = 1.0, None
    else:
        est, n_avg, hits, added, what, decay, band = _impact_spectra(records, ref, resp, src, estimator, averages,
                                                                     decay)
    h = {"h1": est.h1, "h2": est.h2, "hv": est.hv}[estimator]
    if h is None:
        raise ShapeError("h2 needs exactly one force channel")
    h = h[:, :1]
    f = est.frequency_hz
    keep = (f > 0) & (f <= (fmax_hz if fmax_hz is not None else f[-1]))
    if keep.sum() < 2:
        raise ShapeError(f"fmax_hz {fmax_hz} keeps fewer than 2 lines")
    coh = est.coherence[:, :1, keep]
    meta = {"source": src, "format": "uff58 time records", "estimated": what}
    if band is not None:
        band = (band[0], min(band[1], float(f[keep][-1])))
        meta["force_band_hz"] = list(band)
    if added > 0:       # read by 'identify', which removes the window's decay from the modes
        meta["exponential_window"] = {"tau_s": 1.0 / added, "end_value": decay}
    try:
        frf = MeasuredFRF(f[keep], h[..., keep], tuple(records.dofs[i] for i in resp), (records.dofs[ref],),
                          kind=kind, metadata=meta)
    except ShapeError as exc:
        raise FileFormatError(f"{src}: the estimated FRFs: {exc}") from None
    return TimeEstimate(frf, coh, estimator, excitation, n_avg, hits, added, what, decay, band)


def estimate_as_recorded(records: TimeRecords) -> TimeEstimate:
    """FRFs of time records estimated as their test ran: an impact test (the only force a train of hits,
    :func:`hit_onsets`) one block per hit, any other force as random excitation; H1 and the other defaults of
    :func:`estimate_from_records`."""
    forces = records.forces
    impact = len(forces) == 1 and hit_onsets(records.signals[forces[0]]) is not None
    return estimate_from_records(records, excitation="impact" if impact else "random")


def _select_channels(records: TimeRecords, reference, src) -> tuple[int, list, str]:
    """Reference force channel, response channels and their FRF kind: ``(ref, resp, kind)``.

    Refuses records without a force, an ambiguous or absent reference, no responses, responses of
    mixed quantities or measuring one DOF twice, and a force channel that is zero.
    """
    forces, resp = records.forces, records.responses
    if not forces:
        chans = ", ".join(f"{d} {q}" for d, q in zip(records.dofs, records.quantities))
        raise FileFormatError(f"{src}: {len(records.dofs)} time records ({chans}) but no force channel "
                              "(ordinate type 13 or a force unit): FRFs cannot be estimated")
    if reference is None:
        if len(forces) > 1:
            raise ShapeError(f"{src}: {len(forces)} force channels; name the reference DOF "
                             f"({', '.join(records.dofs[i] for i in forces)})")
        ref = forces[0]
    else:
        cand = [i for i in forces if records.dofs[i] == str(reference)]
        if not cand:
            raise ShapeError(f"{src}: no force channel at reference DOF {reference!r}; force channels: "
                             f"{', '.join(records.dofs[i] for i in forces) or 'none'}")
        ref = cand[0]
    if not resp:
        raise FileFormatError(f"{src}: only force channels; no response to estimate FRFs of")
    kinds = {_KIND[records.quantities[i]] for i in resp}
    if len(kinds) > 1:
        raise FileFormatError(f"{src}: responses mix {', '.join(sorted(kinds))}; estimate one quantity per file")
    out_dofs = tuple(records.dofs[i] for i in resp)
    if len(set(out_dofs)) != len(out_dofs):
        dup = next(d for d in out_dofs if out_dofs.count(d) > 1)
        raise FileFormatError(f"{src}: two response channels measure DOF {dup}")
    peak_n = float(np.max(np.abs(records.signals[ref])))
    if not peak_n >= MIN_FORCE_N:
        raise FileFormatError(f"{src}: force channel {records.dofs[ref]} is zero (largest |F| {peak_n:.3g} N < "
                              f"{MIN_FORCE_N:g} N); expected a measured force")
    return ref, resp, kinds.pop()


def segment_window(window):
    """The :func:`scipy.signal.get_window` spec of ``window``: a name (``"hann"``), a name and its parameters
    (``"kaiser,8.6"``, ``"tukey,0.25"``) or such a tuple; :class:`ConfigError` naming the expected form otherwise."""
    from scipy.signal import get_window  # imported here: scipy.signal costs most of a second to import

    spec = window
    if isinstance(window, str) and "," in window:
        name, *params = (w.strip() for w in window.split(","))
        try:
            spec = (name, *(float(v) for v in params))
        except ValueError:
            spec = None
    try:
        w = get_window(spec, 16) if spec is not None else None
    except (ValueError, TypeError):
        w = None
    if w is None or not np.all(np.isfinite(w)):
        raise ConfigError(f"window {window!r}: expected a scipy.signal window name (hann, hamming, blackman, "
                          "flattop, boxcar, ...) or a name and its parameters separated by commas (kaiser,8.6; "
                          "tukey,0.25)")
    return spec


def _random_spectra(records: TimeRecords, ref, resp, src, estimator, averages, overlap, window):
    """Welch spectra of random excitation: ``(estimate, n_averages, None, 0.0, description)``."""
    fs, x = records.sampling_frequency_hz, records.signals
    n = x.shape[1]
    if not 0 <= overlap < 1:
        raise ShapeError(f"overlap {overlap} must be in [0, 1)")
    nperseg = int(n / (1 + (averages - 1) * (1 - overlap)))
    noverlap = int(round(overlap * nperseg))
    if nperseg < 16:
        raise ShapeError(f"{src}: {n} samples cannot give {averages} averages of at least 16 samples")
    channels = [ref, *resp]
    clipped = clipped_run_text(x[channels], [records.dofs[i] for i in channels], src)
    if clipped is not None:
        raise FileFormatError(f"{src}: {clipped}: a clipped channel's spectra hold the clipping's harmonics over the "
                              "whole band, and every average holds them; record with a larger input range")
    est = _estimate(src, x[ref], x[resp], fs, nperseg, noverlap, window=segment_window(window))
    what = f"{estimator.upper()} of random excitation, {window} window, {est.n_averages} averages, " \
           f"{overlap:.0%} overlap, {fs / nperseg:.4g} Hz lines"
    return est, int(est.n_averages), None, 0.0, what


def _hit_blocks(x, onsets, src) -> tuple:
    """``(blocks (n_blocks, n_channels, block), block samples, samples before each hit, hits beyond the record's end)``
    of the records ``x`` (n_channels, n): one block per hit of ``onsets`` (:func:`hit_onsets`), each from
    :data:`PRETRIGGER` of its length before its hit and as long as the shortest spacing of the hits (a single hit: to
    the record's end); a hit whose block would run past the record's end is left out."""
    n = x.shape[1]
    spacing = int(np.min(np.diff(onsets))) if onsets.size > 1 else n - int(onsets[0])
    pre = min(int(onsets[0]), max(4, int(spacing * PRETRIGGER)))
    block = spacing if onsets.size > 1 else n - int(onsets[0]) + pre
    starts = onsets - pre
    fits = starts + block <= n
    if block < 16:
        raise ShapeError(f"{src}: hits {spacing} samples apart cannot give impact blocks of at least 16 samples")
    idx = starts[fits, None] + np.arange(block)
    return x[:, idx].transpose(1, 0, 2), block, pre, int(np.count_nonzero(~fits))


def _impact_spectra(records: TimeRecords, ref, resp, src, estimator, averages, decay):
    """Spectra of the impact blocks (``averages`` equal blocks, or None: one per hit, :func:`_hit_blocks`), bad
    blocks left out, force and exponential windows applied (``decay`` None: :func:`window_end_value` of the good
    blocks' responses).

    Returns ``(estimate, n_good_blocks, HitCheck, added decay rate 1/s, description, window end value, force band
    (Hz))``.
    """
    fs, x = records.sampling_frequency_hz, records.signals.copy()
    x[ref] -= np.median(x[ref])                         # the force's offset (the force between hits) removed
    n = x.shape[1]
    onsets = hit_onsets(x[ref])
    if averages is None:
        if onsets is None:
            raise FileFormatError(f"{src}: force channel {records.dofs[ref]} is no train of hits: "
                                  f"{np.mean(_above(x[ref], 0.2)):.0%} of its samples lie above a fifth of its largest "
                                  f"force (an impact test's hits: at most {IMPULSIVE_SHARE:.0%}); estimate it as "
                                  "random excitation, or name --averages to cut equal blocks")
        blocks, block, pre, past = _hit_blocks(x, onsets, src)
        cut = f"one per hit from {pre} samples before it"
    else:
        block, past = n // averages, 0
        if block < 16:
            raise ShapeError(f"{src}: {n} samples cannot give {averages} impact blocks of at least 16 samples")
        blocks = x[:, : block * averages].reshape(x.shape[0], averages, block).transpose(1, 0, 2)
        cut = "equal"
    n_blocks = blocks.shape[0]
    hits = check_hits(blocks[:, ref], blocks, records.dofs)
    good = [b for b in range(n_blocks) if b not in hits.bad_blocks]
    left_out = (f"double hits in blocks {list(hits.double_hits)}, overloads "
                f"{[f'{d} in block {b}' for b, d in hits.overloads] or 'none'}, no hit in blocks {list(hits.missed)}")
    advice = "" if averages is None or onsets is None else \
        f"; the record holds {onsets.size} hit{'s' * (onsets.size != 1)}: without --averages one block is cut per hit"
    if not good:
        raise FileFormatError(f"{src}: every impact block has a double hit, an overload or no hit ({left_out})"
                              f"{advice}")
    if len(good) < n_blocks or past:
        end = f"; {past} hit{'s' * (past != 1)} too close to the record's end for a block" if past else ""
        warnings.warn(f"{src}: {n_blocks - len(good)} of {n_blocks} impact blocks left out ({left_out}){end}{advice}",
                      UserWarning, stacklevel=3)
    chosen = decay is None
    if chosen:
        decay = window_end_value(blocks[good][:, resp])
    ew, tau = exponential_window(block, decay)
    margin = max(hits.pulse_samples, 4)
    fw = force_window(block, np.asarray(hits.pulse_ends)[good], margin)
    g = blocks[good]
    f_t = (g[:, ref] * fw * ew).reshape(-1)
    r_t = (g[:, resp] * ew).transpose(1, 0, 2).reshape(len(resp), -1)
    est = _estimate(src, f_t, r_t, fs, block, 0, window="boxcar")
    force_power = np.mean(np.abs(np.fft.rfft(g[:, ref] * fw * ew, axis=-1)) ** 2, axis=0)
    band = force_band_hz(np.fft.rfftfreq(block, 1 / fs)[1:], force_power[1:])
    added = 0.0 if np.isinf(tau) else fs / tau
    why = f", the weakest bringing every response to {RESPONSE_END_LEVEL:g} of its loudest" if chosen else ""
    win = f"exponential window to {decay:g}{why}: adds {added:.4g} 1/s to every pole's decay rate" if added > 0 else \
        (f"no exponential window: every response ends below {RESPONSE_END_LEVEL:g} of its loudest" if chosen
         else "no exponential window")
    what = f"{estimator.upper()} of {len(good)} impact block{'s' * (len(good) != 1)} of {block} samples " \
           f"({cut}; force window, {win}), " \
           f"{fs / block:.4g} Hz lines"
    return est, len(good), hits, added, what, float(decay), band
