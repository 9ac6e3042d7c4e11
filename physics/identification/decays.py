"""The free decays of a record: where an impact (or a pluck) starts one, and whether the record is a free response.

:func:`find_decays` segments a record into decays: a hit is a run of samples a free response cannot predict (large
one-step prediction errors of a linear predictor of each channel), sought at the record's rate and, for an
oversampled record, at the rate of its modes; each decay runs from just after its hit to the next hit (or the
record's end). :func:`free_response` tells a free response from a stationary one: its decays' energy falls from
their start to their end; :func:`decay_spectrum` is the spectrum whose clear peaks its modes are.
:mod:`~physics.identification.free_decay` identifies the decays.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

from physics.identification.fdd import SingularValueSpectrum, running_floor, clear_peaks
from physics.identification.record_checks import CheckedRecord

__all__ = ["CHANCE_FALL_CAP_DB", "CHANCE_STDS", "Decays", "FreeResponse", "adds_energy", "chance_fall_db",
           "decay_spectrum", "find_decays", "free_response", "least_fall_db", "slowest_mode"]

#: Order of the linear predictor (per channel) whose innovations mark the hits.
PREDICTOR_ORDER = 24
#: A hit: a sample whose innovation, over the channels, exceeds this many robust standard deviations.
HIT_SIGMA = 8.0
#: A hit seen as a rise: the first differences' energy over the next window at least this many times that over the
#: window before ...
HIT_RISE = 4.0
#: ... and at least this fraction of the loudest window's.
HIT_LEVEL = 0.05
#: A hit adds energy: the record's energy after it at least this many times that before it (:func:`adds_energy`).
HIT_GAIN = 2.0
#: A record of more values (channels x samples) is not searched for hits (read whole): a stationary response.
MAX_FREE_VALUES = 2 ** 24
#: A free response: its decays' energy falls by at least this much from their first to their last quarter (dB) ...
FREE_DROP_DB = 6.0
#: ... or the first decay after a hit is this much louder than the record before the hit (dB) ...
FREE_LEAD_DB = 10.0
#: ... or this much louder than ``m`` samples before the hit that are white noise (:func:`_white`: a quiet
#: pre-trigger, which a stationary response is not), plus three standard deviations of their variance's estimate
#: (``10 log10(e) sqrt(2 / m)`` dB each: 9.1 dB from 36 samples, 8 dB from 84, 6.6 dB from 1000) ...
FREE_QUIET_LEAD_DB = 6.0
#: ... or, for a record without a hit (a decay under way when the record starts), by this much, or by
#: :data:`FREE_DROP_DB` with every quarter's energy below the one before (an exponential envelope falls steadily; a
#: stationary response's quarters rise and fall at random, all three in order by chance one time in six).
FREE_DROP_NO_HIT_DB = 10.0
#: ... its loudest sample within this fraction of the part before the first hit from its start (a decay under way
#: when the record starts is loudest near its start; a stationary response's loudest sample lies anywhere, and the
#: part after it falls as the response returns to its level).
NO_HIT_LOUDEST = 0.25
#: A pre-trigger shorter than the least decay is measured against the decay after it (:attr:`Decays.lead_db`) when
#: it is white noise: its lag-one correlation within this of zero (white noise's, from 24 samples: 0 +- 0.2) ...
WHITE_LAG1 = 0.5
#: ... and its correlations over lags 1 to ``min(WHITE_LAGS, m // 4)`` jointly white noise's (Ljung-Box statistic
#: below its chi-square quantile ``1 - WHITE_P``): a stationary response dominated by a mode near a quarter of the
#: sampling rate has a lag-one correlation near zero but swings at the mode's period (a 1234-Hz mode at 4341 Hz:
#: lag-one -0.2, Ljung-Box 77 over 20 lags of 86 samples against a quantile of 45).
WHITE_LAGS, WHITE_P = 20, 1e-3
#: An oversampled record is searched for hits at its content's rate too: this many times its highest clear peak ...
CONTENT_RATE = 2.5
#: ... keeping at least this many predictor orders of samples.
MIN_DECIMATED_ORDERS = 40


@dataclass(frozen=True)
class Decays:
    """The free decays of a record.

    Attributes
    ----------
    hits : ndarray of int, shape (n_hits,)
        Last sample of each hit (a run of samples the free response cannot predict).
    starts, stops : ndarray of int, shape (n_decays,)
        First sample and one past the last of each decay.
    drop_db : float
        Energy of the decays' first quarters over that of their last quarters (dB, a length-weighted mean; NaN
        without a decay).
    lead_db : float
        Mean energy of the first decay after a hit over that of the samples before the first hit (dB; NaN
        without a hit; with samples before it that are not white noise (:func:`_white`: the noise of a
        pre-trigger, which a stationary response's samples are not), NaN when they are fewer than the least decay
        or the decay is not loudest within its first :data:`NO_HIT_LOUDEST` (a stationary response started from
        rest, quiet for its first tenths of a second, is loudest anywhere); white, at least the predictor's order
        of them).
    onsets : ndarray of int, shape (n_decays,)
        First sample of each decay's free response: the first sample of its hit (0 for the decay under way when
        the record starts). The samples from it to ``starts`` hold the hit, and the first milliseconds of the
        decay that the record's predictor fits worst.
    energy_window : int
        Samples over which a hit must add energy to be one (:func:`adds_energy`): four predictor orders, at least
        a period of the lowest mode when it is known.
    quiet_samples : int
        Samples before the first hit when they are white noise (:func:`_white`), at least the predictor's order of
        them (a pre-trigger); else 0.
    """

    hits: np.ndarray
    starts: np.ndarray
    stops: np.ndarray
    drop_db: float
    lead_db: float = np.nan
    onsets: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    energy_window: int = 0
    quiet_samples: int = 0


@dataclass(frozen=True)
class FreeResponse:
    """Whether a record is a free response, and why (see :func:`free_response`).

    Attributes
    ----------
    free : bool
    decays : Decays
    note : str
        Why the record was not searched for hits (empty when it was).
    """

    free: bool
    decays: Decays
    note: str = ""

    @property
    def text(self) -> str:
        if self.note:
            return f"not a free response: {self.note}"
        d = self.decays
        n = d.hits.size
        hits = f"{n} hit{'s' if n != 1 else ''}" if n else "no hit"
        if not d.starts.size:
            return f"not a free response: {hits}, no decay"
        what = "a free response" if self.free else "not a free response"
        lead = (f", {round(d.lead_db)} dB louder than the record before the first hit" if d.lead_db >= 0.5
                else ", no louder than the record before the first hit" if np.isfinite(d.lead_db) else "")
        falls = f"falls {round(d.drop_db)} dB" if d.drop_db >= 0.5 else f"does not fall ({round(d.drop_db):+d} dB)"
        return (f"{what}: {hits}, {d.starts.size} decay{'s' if d.starts.size != 1 else ''} whose energy {falls} "
                f"from their first to their last quarter{lead}")


def _innovations(x):
    """Squared one-step prediction errors of each channel's own linear predictor (Yule-Walker, order
    :data:`PREDICTOR_ORDER`), in robust standard deviations, summed over the channels: shape (n_samples,)."""
    from scipy import fft as sfft  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification
    from scipy import linalg, signal  # scipy: only output-only identification

    n_ch, n = x.shape
    p = int(min(PREDICTOR_ORDER, max(2, n // 20)))
    nfft = sfft.next_fast_len(2 * n, real=True)
    r = sfft.irfft(np.abs(sfft.rfft(x, nfft, axis=1)) ** 2, nfft, axis=1)[:, :p + 1]
    total = np.zeros(n)
    for c in range(n_ch):
        if r[c, 0] <= 0:
            continue
        a = linalg.solve_toeplitz(r[c, :p] + 1e-9 * r[c, 0] * (np.arange(p) == 0), r[c, 1:p + 1])
        e = signal.lfilter(np.concatenate([[1.0], -a]), [1.0], x[c])
        e[:p] = 0.0                                    # no prediction before p samples
        scale = 1.4826 * np.median(np.abs(e[p:] - np.median(e[p:])))
        total += (e / max(scale, 1e-12 * np.sqrt(r[c, 0] / n))) ** 2
    return total


def _quarter_drop_db(x, a, b):
    """Energy (about the samples' own mean) of the first quarter of samples ``a:b`` over that of the last (dB)."""
    k = max(1, (b - a) // 4)
    seg = x[:, a:b] - x[:, a:b].mean(axis=1, keepdims=True)
    first, last = np.sum(seg[:, :k] ** 2), np.sum(seg[:, -k:] ** 2)
    return float(10 * np.log10(max(first, np.finfo(float).tiny) / max(last, np.finfo(float).tiny)))


def _decays_without_hit(x, a, b):
    """Whether samples ``a:b`` (no hit among them) are a decay: their energy (about their mean) falls
    :data:`FREE_DROP_NO_HIT_DB` from the first quarter to the last, or :data:`FREE_DROP_DB` with each quarter below
    the one before."""
    k = max(1, (b - a) // 4)
    seg = x[:, a:a + 4 * k] - x[:, a:b].mean(axis=1, keepdims=True)
    quarters = np.sum(seg.reshape(seg.shape[0], 4, k) ** 2, axis=(0, 2))
    drop = _quarter_drop_db(x, a, b)
    return bool(drop >= FREE_DROP_NO_HIT_DB or (drop >= FREE_DROP_DB and np.all(np.diff(quarters) < 0)))


def _loudest_early(x, a, b):
    """Whether samples ``a:b`` are loudest (summed square over the channels) within their first
    :data:`NO_HIT_LOUDEST`, as a decay after a hit is; a stationary response is loudest anywhere."""
    return bool(np.argmax(np.sum(x[:, a:b] ** 2, axis=0)) <= NO_HIT_LOUDEST * (b - a))


def _white(seg):
    """Whether samples ``seg`` (shape (n_channels, n_samples)) are white noise, as a pre-trigger is: the lag-one
    correlation of their deviations from their mean, over the channels, within :data:`WHITE_LAG1` of zero (a
    sampled response's is near one; a segment without variation, under one quantisation step, is white), and their
    Ljung-Box statistic over :data:`WHITE_LAGS` lags below its chi-square quantile (Wilson-Hilferty) at
    ``1 - WHITE_P``."""
    d = seg - seg.mean(axis=1, keepdims=True)
    energy = np.sum(d ** 2)
    if energy <= 0:
        return True
    m = d.shape[1]
    lags = np.arange(1, max(min(WHITE_LAGS, m // 4), 1) + 1)
    r = np.array([np.sum(d[:, k:] * d[:, :-k]) for k in lags]) / energy
    q = m * (m + 2) * np.sum(r ** 2 / (m - lags))
    z, n = NormalDist().inv_cdf(1 - WHITE_P), lags.size
    quantile = n * (1 - 2 / (9 * n) + z * np.sqrt(2 / (9 * n))) ** 3
    return bool(abs(r[0]) < WHITE_LAG1 and q < quantile)


def _rises(x, innovation, p):
    """Hits seen as a sharp rise of the energy of the first differences (the channels each scaled to unit
    variance): the energy over the next window at least :data:`HIT_RISE` times that over the window before and
    :data:`HIT_LEVEL` of the loudest window's, the window about one period of the loudest channel's oscillation.
    Each hit is placed at the largest innovation within the window of its rise: ``(first, last)`` sample arrays."""
    n = x.shape[1]
    loud = int(np.argmax(np.sum(x ** 2, axis=1)))
    crossings = np.count_nonzero(np.diff(np.signbit(x[loud])))
    w = int(np.clip(round(2 * n / max(crossings, 1)), 4, max(4, n // 50)))
    d = np.diff(x, axis=1)
    e = np.concatenate([[0.0], np.sum(d ** 2 / np.maximum(d.var(axis=1, keepdims=True), np.finfo(float).tiny),
                                      axis=0)])
    c = np.concatenate([[0.0], np.cumsum(e)])
    k = np.arange(w, n - w)
    before, after = c[k] - c[k - w], c[k + w] - c[k]
    rise = (after >= HIT_RISE * before) & (after >= HIT_LEVEL * after.max(initial=0.0))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], rise.astype(int), [0]])))
    onsets = k[edges[0::2]] if edges.size else np.zeros(0, int)
    at = np.array([o + int(np.argmax(innovation[o:o + w + 1])) for o in onsets], int)
    return at, np.minimum(at + p // 4, n - 1)


def _loudest(x, firsts, lasts):
    """The loudest sample (summed square over the channels) of each run ``firsts[i]..lasts[i]``: where the response
    to a hit stops growing. A run of large innovations lasts as long as the decay stands far above the noise (the
    record's one linear predictor fits a loud decay only to a fraction of its level), which is no part of the hit."""
    e = np.sum(x ** 2, axis=0)
    return np.array([a + int(np.argmax(e[a:b + 1])) for a, b in zip(firsts, lasts)], int)


def adds_energy(x, firsts, lasts, w):
    """Whether each hit (its first and last samples) adds energy: the record's energy over the ``w`` samples after
    it at least :data:`HIT_GAIN` times that over the ``w`` samples before it (per sample, where fewer precede it).
    A prediction error within a decay (its first milliseconds, which the record's one linear predictor fits worst,
    or its tail in the noise) is no new hit; ``w`` spans at least a period of the lowest mode, so that the phase of
    an oscillation within its windows does not pass for a hit."""
    e = np.concatenate([[0.0], np.cumsum(np.sum(x ** 2, axis=0))])
    n = x.shape[1]
    before = e[firsts] - e[np.maximum(firsts - w, 0)]
    after = e[np.minimum(lasts + 1 + w, n)] - e[np.minimum(lasts + 1, n)]
    return after * np.clip(np.minimum(w, firsts), 1, None) >= HIT_GAIN * before * w


def _hit_runs(x, p, rises=True):
    """The runs of samples of ``x`` (mean removed, shape (n_channels, n_samples)) that hold a hit: the samples
    whose innovation exceeds :data:`HIT_SIGMA` robust standard deviations and (with ``rises``) the rises
    (:func:`_rises`), runs closer than ``p`` samples one, a rise within a run starting a new one: ``(first, last)``
    sample arrays."""
    innovation = _innovations(x)
    over = np.flatnonzero(innovation > HIT_SIGMA ** 2 * x.shape[0])
    r_first, r_last = _rises(x, innovation, p) if rises else (np.zeros(0, int), np.zeros(0, int))
    over = np.unique(np.concatenate([over, r_first, r_last]))
    if not over.size:
        return np.zeros(0, int), np.zeros(0, int)
    gaps = np.flatnonzero((np.diff(over) > p) | np.isin(over[1:], r_first))
    return over[np.concatenate([[0], gaps + 1])], over[np.concatenate([gaps, [over.size - 1]])]


def _content_decimation(checked):
    """The decimation that brings a record to :data:`CONTENT_RATE` times its highest clear peak
    (:func:`decay_spectrum`; 1 without a clear peak), keeping :data:`MIN_DECIMATED_ORDERS` predictor orders of
    samples: the rate at which a hit stands out of the noise of an oversampled record."""
    peaks = clear_peaks(decay_spectrum(checked)).frequency_hz
    if not peaks.size:
        return 1
    q = int(checked.sampling_frequency_hz // (CONTENT_RATE * peaks.max()))
    return max(1, min(q, checked.signals.shape[1] // (MIN_DECIMATED_ORDERS * PREDICTOR_ORDER)))


def _block_means(x, q):
    """The means of ``x`` (shape (n_channels, n_samples)) over consecutive blocks of ``q`` samples (the last
    partial block dropped): a decimation whose sample ``k`` holds samples ``kq`` to ``(k + 1)q - 1`` alone, so
    that a hit it shows lies at or before ``(k + 1)q - 1``; its white noise falls by ``q`` as through an ideal
    low-pass filter."""
    m = x.shape[1] // q
    return x[:, :m * q].reshape(x.shape[0], m, q).mean(axis=2)


def find_decays(checked: CheckedRecord, min_samples=None, lowest_hz=None) -> Decays:
    """The hits and free decays of a checked record (see the module docstring).

    A hit is a run of samples whose innovation (the one-step prediction error of a linear predictor of each
    channel, which a free response does not have) exceeds :data:`HIT_SIGMA` robust standard deviations, or a
    sharp rise of the record's energy (:data:`HIT_RISE`; an impulse on a displacement or strain record, or a
    release, shows only a small innovation) placed at the largest innovation near it; hits closer than the
    predictor's order are one, and a hit that adds no energy (:func:`adds_energy`) is none. A hit ends where its
    response stops growing (its loudest sample); a hit whose end lies within the predictor's order of the next
    one's start (a tip's force lasting many samples, its response growing through a rise) is one with it. An
    oversampled record is searched again for innovations at :data:`CONTENT_RATE` times its highest clear peak (block
    means, :func:`_content_decimation`): its noise is white over the whole rate while the response to a hit, spread over
    many samples, stands out only in the band of the modes (a scope's capture, hundreds of samples per period of
    its first mode). A hit found there alone starts after the block that shows it (never before the hit, at most
    two blocks after it). Not for rises: at that rate a stationary response's own energy rises fourfold within a
    period at random. Each decay runs from
    the sample after a hit to the sample before the next one (or
    the record's end); the part before the first hit (or the whole record, without a hit) from its loudest sample
    on is a decay when that sample lies in its first :data:`NO_HIT_LOUDEST` and its energy falls steadily
    (:func:`_decays_without_hit`). Decays
    shorter than ``min_samples`` (default four times the predictor's order) are left out.
    """
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    n_ch, n = x.shape
    p = int(min(PREDICTOR_ORDER, max(2, n // 20)))
    least = 4 * p if min_samples is None else int(min_samples)
    w = 4 * p if lowest_hz is None else max(4 * p, int(np.ceil(checked.sampling_frequency_hz / lowest_hz)))
    firsts, lasts = _hit_runs(x, p)
    q = _content_decimation(checked)
    if q > 1:                                           # the hits only the record at its content's rate shows
        f_dec, l_dec = _hit_runs(_block_means(x, q), int(min(PREDICTOR_ORDER, max(2, (n // q) // 20))), rises=False)
        l_dec = np.minimum(l_dec * q + q - 1, n - 1)
        f_dec = np.minimum((f_dec + 1) * q, l_dec)      # the block before may hold the hit's first samples
        near = np.any((f_dec[:, None] <= lasts[None, :] + p) & (l_dec[:, None] >= firsts[None, :] - p), axis=1)
        order = np.argsort(np.concatenate([firsts, f_dec[~near]]), kind="stable")
        firsts = np.concatenate([firsts, f_dec[~near]])[order]
        lasts = np.concatenate([lasts, l_dec[~near]])[order]
    if firsts.size:
        lasts = np.minimum(lasts, _loudest(x, firsts, lasts) + p // 4)
        keep = adds_energy(x, firsts, lasts, w)
        firsts, lasts = firsts[keep], lasts[keep]
        one = np.flatnonzero(firsts[1:] - lasts[:-1] <= p)  # a response still growing at the next rise: one hit
        firsts, lasts = np.delete(firsts, one + 1), np.delete(lasts, one)
    spans = [(int(last) + 1, int(nxt), int(first)) for first, last, nxt in zip(firsts, lasts, [*firsts[1:], n])]
    spans = [(a, b, o) for a, b, o in spans if b - a >= least]
    drop = [_quarter_drop_db(x, a, b) for a, b, _ in spans]
    head = int(firsts[0]) if firsts.size else n
    if head >= least:
        s0 = int(np.argmax(np.sum(x[:, :head] ** 2, axis=0)))
        if head - s0 >= least and s0 <= NO_HIT_LOUDEST * head and _decays_without_hit(x, s0, head):
            spans, drop = [(s0, head, 0), *spans], [_quarter_drop_db(x, s0, head), *drop]
    drop_db = float(np.average(drop, weights=[b - a for a, b, _ in spans])) if spans else np.nan
    lead_db = np.nan
    after = [(a, b) for a, b, _ in spans if a > head]
    quiet = bool(after) and head >= p and _white(x[:, :head])
    if after and (quiet or (head >= least and _loudest_early(x, *after[0]))):
        seg = x[:, after[0][0]:after[0][1]]
        lead_db = float(10 * np.log10(max(np.mean(seg.var(axis=1)), np.finfo(float).tiny)
                                      / max(np.mean(x[:, :head].var(axis=1)), np.finfo(float).tiny)))
    return Decays(lasts.astype(int), np.array([a for a, _, _ in spans], int), np.array([b for _, b, _ in spans], int),
                  drop_db, lead_db, np.array([o for _, _, o in spans], int), w, head if quiet else 0)


def free_response(checked: CheckedRecord) -> FreeResponse:
    """Whether a checked record is a free response (a record of more than :data:`MAX_FREE_VALUES` values is
    not, unread): it holds a decay, and its decays' energy falls by
    :data:`FREE_DROP_DB` from their first to their last quarter (a length-weighted mean in dB), or the first decay
    after a hit is :data:`FREE_LEAD_DB` louder than the record before the hit (a pre-trigger: lightly damped decays
    fall little within a record), or :data:`FREE_QUIET_LEAD_DB` and three standard deviations of the estimate of
    its variance louder than a record before the hit that is white noise (:attr:`Decays.quiet_samples`)."""
    if checked.signals.size > MAX_FREE_VALUES:
        none = np.zeros(0, int)
        return FreeResponse(False, Decays(none, none, none, np.nan), f"{checked.signals.shape[1]} samples: longer "
                            "than a free response's capture, not searched for hits")
    decays = find_decays(checked)
    m = decays.quiet_samples
    lead = min(FREE_LEAD_DB, FREE_QUIET_LEAD_DB + 30 / np.log(10) * np.sqrt(2 / m)) if m else FREE_LEAD_DB
    free = decays.starts.size > 0 and (decays.drop_db >= FREE_DROP_DB or decays.lead_db >= lead)
    return FreeResponse(bool(free), decays)


def _slowest_rate(decays: Decays, frequencies_hz, damping_ratios) -> tuple:
    """``(the decays' lengths (samples, float), the slowest mode's decay rate zeta 2 pi f_n (1/s))``; the rate None
    without a mode or a decay (:func:`slowest_mode`)."""
    k = slowest_mode(frequencies_hz, damping_ratios)
    lengths = (decays.stops - decays.starts).astype(float)
    if k is None or not lengths.size:
        return lengths, None
    return lengths, float(np.asarray(damping_ratios, float)[k] * 2 * np.pi * np.asarray(frequencies_hz, float)[k])


def least_fall_db(decays: Decays, frequencies_hz, damping_ratios, sampling_frequency_hz: float) -> float:
    """The least fall (dB) of the decays' energy from their first to their last quarter, weighted by their lengths
    as :attr:`Decays.drop_db`, were they free decays of these modes: the slowest-decaying mode's, ``20 log10(e)
    sigma dt`` with ``sigma = zeta 2 pi f_n`` (1/s) and ``dt`` three quarters of a decay's length (s), the time
    between its quarters. A sum of decaying modes falls at least as fast as its slowest one; a noise floor reached
    within a decay makes it fall less, but then the decay leads its noise by :data:`FREE_LEAD_DB` only when it
    falls more than :data:`FREE_DROP_DB` (its first quarter holds the decay's energy, its last the noise). A
    stationary response started quiet (a shaker switched on with the capture, or a simulation from rest) has a "hit"
    where it starts to build up, louder than the samples before it, and a "decay" that never falls, where the modes
    found in it, damped as they are, would have fallen tens of dB. NaN without a mode or a decay."""
    lengths, sigma = _slowest_rate(decays, frequencies_hz, damping_ratios)
    if sigma is None:
        return np.nan
    dt = 0.75 * lengths / sampling_frequency_hz
    return float(np.average(20 * np.log10(np.e) * sigma * dt, weights=lengths))


#: A fall of a response's energy from its first to its last quarter within this many standard deviations of a
#: stationary response's chance fall (:func:`chance_fall_db`) is no evidence of a free decay ...
CHANCE_STDS = 3.0
#: ... where that chance fall is at most this: quarters of at least two time constants ``1 / sigma`` of the slowest
#: mode. Over shorter quarters a stationary response's fall scatters so widely that no fall tells it from a free
#: decay's (the DROPBEAR beam's dwells of 0.6-1 s after each roller step, quarters of 0.3-1 time constant of its
#: 25-34 Hz modes), and the fall's verdict stands.
CHANCE_FALL_CAP_DB = CHANCE_STDS * 10 * np.log10(np.e) * np.sqrt(2.0 / 2.0)


def chance_fall_db(decays: Decays, frequencies_hz, damping_ratios, sampling_frequency_hz: float) -> float:
    """The fall (dB) of the decays' energy from their first to their last quarter that a stationary response of these
    modes reaches by chance: :data:`CHANCE_STDS` standard deviations of its length-weighted mean, as
    :attr:`Decays.drop_db`. A quarter's energy, the mean of ``x^2`` over ``D`` seconds of a mode decaying at
    ``sigma`` (1/s; the slowest mode's, whose correlations last longest), scatters by ``1 / sqrt(sigma D)`` relative
    (a Gaussian response, ``D >> 1 / sigma``), so the fall between two quarters by ``10 log10(e) sqrt(2 / (sigma
    D))`` dB. NaN without a mode or a decay."""
    lengths, sigma = _slowest_rate(decays, frequencies_hz, damping_ratios)
    if sigma is None:
        return np.nan
    if not sigma > 0:
        return np.inf
    std = 10 * np.log10(np.e) * np.sqrt(2 / (sigma * 0.25 * lengths / sampling_frequency_hz))
    return float(CHANCE_STDS * np.sqrt(np.sum((lengths * std) ** 2)) / lengths.sum())


def slowest_mode(frequencies_hz, damping_ratios) -> int | None:
    """Index of the mode whose free decay is slowest, the least ``zeta f_n`` among those with a finite positive
    frequency and a finite damping ratio of at least 0; None without one."""
    f = np.asarray(frequencies_hz, float)
    z = np.asarray(damping_ratios, float)
    ok = np.isfinite(f) & np.isfinite(z) & (f > 0) & (z >= 0)
    return int(np.argmin(np.where(ok, z * f, np.inf))) if ok.any() else None


def decay_spectrum(checked: CheckedRecord) -> SingularValueSpectrum:
    """The spectrum whose clear peaks a free response's modes are: the summed power of the whole record's FFT (no
    window, no padding, mean removed) averaged over three adjacent lines, with the running floor FDD uses.

    Welch frames would miss a fast-decaying mode: it lives at the start of the first frame, where a Hann window is
    nearly zero. Three lines take a noise line's power from an exponential law to a Gamma(3) one, so a noise
    line stands 10 dB above the floor with probability ~1e-9 instead of 1e-3.
    """
    from scipy import fft as sfft  # scipy.fft/ndimage: about 1 s to import, only output-only identification
    from scipy import ndimage  # scipy.fft/ndimage: about 1 s to import, only output-only identification

    y = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    fs, band, n = checked.sampling_frequency_hz, checked.band_hz, y.shape[1]
    X = sfft.rfft(y, axis=1)
    f = np.arange(X.shape[1]) * fs / n
    power = ndimage.uniform_filter1d(np.sum(np.abs(X) ** 2, axis=0), 3, mode="nearest") / (fs * n)
    s = np.zeros((f.size, y.shape[0]))
    s[:, 0] = power
    vectors = (X / np.maximum(np.linalg.norm(X, axis=0), np.finfo(float).tiny)).T
    inband = (f >= band[0]) & (f <= band[1]) & (f > 0)
    floor = np.full(f.size, np.nan)
    floor[inband] = running_floor(f[inband], power[inband], f[1])
    return SingularValueSpectrum(f, s, vectors, floor, band, max(3 * f[1], 10 / checked.duration_s, band[0]))
