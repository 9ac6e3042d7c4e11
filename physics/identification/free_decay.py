"""Output-only identification of free responses: the decays after impacts (or plucks) recorded without the force.

:func:`find_decays` segments a record into decays: a hit is a run of samples a free response cannot predict (large
one-step prediction errors of a linear predictor of each channel), sought at the record's rate and, for an
oversampled record, at the rate of its modes; each decay runs from just after its hit to the next hit (or the
record's end). :func:`free_response` tells a free response from a
stationary one: its decays' energy falls from their start to their end.

:func:`identify_era` identifies the decays jointly (common poles, amplitudes of each decay its own): the
Eigensystem Realisation Algorithm (Kung's shift invariance) on the block Hankel matrix of the decay samples of all
channels gives a model of every order from one eigen-decomposition, the stabilisation diagram's physical poles
are selected by :func:`~physics.identification.poles.select_poles` (as for SSI-cov and LSCF), then refined by the
nonlinear least-squares fit of damped sinusoids to the samples
(:func:`~physics.identification.damped_sinusoids.fit_damped_sinusoids`; it splits decays where a missed hit
shows and decides which poles carry energy). Each kept pole is then refined in its own narrow band of the decays'
Fourier transforms at the record's rate, from each hit's onset, across the cuts of missed hits that add no energy
(:func:`~physics.identification.band_refine.refine_in_bands`: the closed-form transform of truncated damped
exponentials and a smooth background, close modes together), so that the other modes, the unmodelled ones and the
hit itself do not enter a mode's fit; its covariance gives the one-sigma frequency and damping. A clear peak of the
record's spectrum (:func:`~physics.identification.decay_peaks.decay_peaks`, the peaks ``fftpeak`` reports) that no
kept pole holds (a weak mode beyond the model's order, or a diagram with no pole stable enough) is started at its
peak and refined in its band, the kept poles held fixed (:mod:`~physics.identification.peak_seeds`). Shapes: the
dominant direction of each mode's complex amplitudes over the decays, unit-norm and unscaled (no force measured).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.band_refine import BandFit, refine_in_bands
from physics.identification.damped_sinusoids import DampedSinusoidFit, fit_damped_sinusoids, mode_snr
from physics.identification.decay_peaks import decay_peaks
from physics.identification.fdd import SingularValueSpectrum, _running_floor, clear_peaks, unit_shapes
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.peak_seeds import SeededModes, refine_seeds, unheld_peaks
from physics.identification.poles import MAX_DAMPING, StabilisationDiagram, select_poles
from physics.identification.record_checks import CheckedRecord, check_periods, check_records
from physics.identification.ssi import MIN_MAX_ORDER, ORDERS_PER_PEAK
from physics.identification.subspace import subspace_diagram

__all__ = ["Decays", "ERAIdentification", "FreeResponse", "decay_spectrum", "find_decays", "free_response",
           "identify_era"]

#: Order of the linear predictor (per channel) whose innovations mark the hits.
PREDICTOR_ORDER = 24
#: A hit: a sample whose innovation, over the channels, exceeds this many robust standard deviations.
HIT_SIGMA = 8.0
#: A hit seen as a rise: the first differences' energy over the next window at least this many times that over the
#: window before ...
HIT_RISE = 4.0
#: ... and at least this fraction of the loudest window's.
HIT_LEVEL = 0.05
#: A hit adds energy: the record's energy after it at least this many times that before it (:func:`_adds_energy`).
HIT_GAIN = 2.0
#: A record of more values (channels x samples) is not searched for hits (read whole): a stationary response.
MAX_FREE_VALUES = 2 ** 24
#: A free response: its decays' energy falls by at least this much from their first to their last quarter (dB) ...
FREE_DROP_DB = 6.0
#: ... or the first decay after a hit is this much louder than the record before the hit (dB) ...
FREE_LEAD_DB = 10.0
#: ... or, for a record without a hit (a decay under way when the record starts), by this much, or by
#: :data:`FREE_DROP_DB` with every quarter's energy below the one before (an exponential envelope falls steadily; a
#: stationary response's quarters rise and fall at random, all three in order by chance one time in six).
FREE_DROP_NO_HIT_DB = 10.0
#: An oversampled record is searched for hits at its content's rate too: this many times its highest clear peak ...
CONTENT_RATE = 2.5
#: ... keeping at least this many predictor orders of samples.
MIN_DECIMATED_ORDERS = 40
#: Largest block Hankel dimension (block rows x channels) of the ERA.
MAX_HANKEL_ROWS = 160
#: A refined pole is kept when its energy over the decays is at least this many noise variances
#: (:func:`~physics.identification.damped_sinusoids.mode_snr`; a pole fitted to white noise alone reaches about
#: 2 ln(n_samples)).
MIN_MODE_SNR = 50.0
#: A decay is cut where the fit's residual energy rises this many times over a window (a hit the segmentation
#: missed; a cut in a free decay costs only its amplitudes), and fitted again; at most this many rounds.
SPLIT_RISE, MAX_SPLIT_ROUNDS = 4.0, 2
#: A decay holds at least this many times the Hankel's block rows (shorter decays are left out).
MIN_DECAY_ROWS = 3
#: Least stability code (:data:`~physics.identification.poles.STABILITY_CODES`) of a pole the selection clusters:
#: stable in frequency and shape; the damping, which a real decay's noise moves from order to order more than the
#: frequency, is the least-squares refinement's.
MIN_STATUS = 4


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
        without a hit, or with fewer samples before it than the least decay).
    onsets : ndarray of int, shape (n_decays,)
        First sample of each decay's free response: the first sample of its hit (0 for the decay under way when
        the record starts). The samples from it to ``starts`` hold the hit, and the first milliseconds of the
        decay that the record's predictor fits worst.
    energy_window : int
        Samples over which a hit must add energy to be one (:func:`_adds_energy`): four predictor orders, at least
        a period of the lowest mode when it is known.
    """

    hits: np.ndarray
    starts: np.ndarray
    stops: np.ndarray
    drop_db: float
    lead_db: float = np.nan
    onsets: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    energy_window: int = 0


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
        lead = f", {d.lead_db:.0f} dB louder than the record before the first hit" if np.isfinite(d.lead_db) else ""
        return (f"{what}: {hits}, {d.starts.size} decay{'s' if d.starts.size != 1 else ''} whose energy falls "
                f"{d.drop_db:.0f} dB from their first to their last quarter{lead}")


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


def _adds_energy(x, firsts, lasts, w):
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
    predictor's order are one, and a hit that adds no energy (:func:`_adds_energy`) is none. An oversampled record
    is searched again for innovations at :data:`CONTENT_RATE` times its highest clear peak (block means,
    :func:`_content_decimation`): its noise is white over the whole rate while the response to a hit, spread over
    many samples, stands out only in the band of the modes (a scope's capture, hundreds of samples per period of
    its first mode). A hit found there alone starts after the block that shows it (never before the hit, at most
    two blocks after it). Not for rises: at that rate a stationary response's own energy rises fourfold within a
    period at random. Each decay runs from
    the sample after a hit to the sample before the next one (or
    the record's end); the part before the first hit (or the whole record, without a hit) from its loudest sample
    on is a decay when its energy falls steadily (:func:`_decays_without_hit`). Decays
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
        keep = _adds_energy(x, firsts, lasts, w)
        firsts, lasts = firsts[keep], lasts[keep]
    spans = [(int(last) + 1, int(nxt), int(first)) for first, last, nxt in zip(firsts, lasts, [*firsts[1:], n])]
    spans = [(a, b, o) for a, b, o in spans if b - a >= least]
    drop = [_quarter_drop_db(x, a, b) for a, b, _ in spans]
    head = int(firsts[0]) if firsts.size else n
    if head >= least:
        s0 = int(np.argmax(np.sum(x[:, :head] ** 2, axis=0)))
        if head - s0 >= least and _decays_without_hit(x, s0, head):
            spans, drop = [(s0, head, 0), *spans], [_quarter_drop_db(x, s0, head), *drop]
    drop_db = float(np.average(drop, weights=[b - a for a, b, _ in spans])) if spans else np.nan
    lead_db = np.nan
    after = [(a, b) for a, b, _ in spans if a > head]
    if head >= least and after:
        seg = x[:, after[0][0]:after[0][1]]
        lead_db = float(10 * np.log10(max(np.mean(seg.var(axis=1)), np.finfo(float).tiny)
                                      / max(np.mean(x[:, :head].var(axis=1)), np.finfo(float).tiny)))
    return Decays(lasts.astype(int), np.array([a for a, _, _ in spans], int), np.array([b for _, b, _ in spans], int),
                  drop_db, lead_db, np.array([o for _, _, o in spans], int), w)


def free_response(checked: CheckedRecord) -> FreeResponse:
    """Whether a checked record is a free response (a record of more than :data:`MAX_FREE_VALUES` values is
    not, unread): it holds a decay, and its decays' energy falls by
    :data:`FREE_DROP_DB` from their first to their last quarter (a length-weighted mean in dB), or the first decay
    after a hit is :data:`FREE_LEAD_DB` louder than the record before the hit (a pre-trigger: lightly damped decays
    fall little within a record)."""
    if checked.signals.size > MAX_FREE_VALUES:
        none = np.zeros(0, int)
        return FreeResponse(False, Decays(none, none, none, np.nan), f"{checked.signals.shape[1]} samples: longer "
                            "than a free response's capture, not searched for hits")
    decays = find_decays(checked)
    free = decays.starts.size > 0 and (decays.drop_db >= FREE_DROP_DB or decays.lead_db >= FREE_LEAD_DB)
    return FreeResponse(bool(free), decays)


@dataclass(frozen=True)
class ERAIdentification:
    """A free-decay identification (see the module docstring).

    Attributes
    ----------
    estimate : ModalEstimate
        Unit-norm, unscaled shapes; ``frequency_std_hz``/``damping_std`` from the least-squares fit.
    diagram : StabilisationDiagram
    fit : DampedSinusoidFit or None
        The refinement of every selected pole (the estimate keeps those in the band); None when no pole of the
        stabilisation diagram was stable enough (the estimate then holds the seeded modes alone).
    decays : Decays
        In samples of the record as given.
    decimation : int
    block_rows : int
    n_fitted : int
        Decays fitted: those of ``decays`` long enough, split where the fit's residual showed a hit they missed.
    bands : BandFit or None
        The narrow-band refinement of the poles kept (before ``n_modes``), on the fitted decays at the record's
        rate from their hits' onsets, joined across the cuts that add no energy (:func:`_band_spans`); the estimate
        holds its poles where it converged, the time-domain fit's elsewhere.
    seeded : SeededModes or None
        The modes of the record's clear peaks that no kept pole held, each started at its peak and refined in its
        band (:func:`~physics.identification.peak_seeds.refine_seeds`); the estimate holds them too, flagged
        ``weakly_stable``.
    """

    estimate: ModalEstimate
    diagram: StabilisationDiagram
    fit: DampedSinusoidFit | None
    decays: Decays
    decimation: int
    block_rows: int
    n_fitted: int = 0
    bands: BandFit | None = None
    seeded: SeededModes | None = None


def _decimated(checked, q, decays):
    """Each decay low-pass filtered (zero phase) and decimated by ``q``: a list of (n_channels, n_d) arrays, and
    each one's ``(onset, first, stop)`` in samples of the record (its free response's first sample, the sample of
    its own first one, one past its last)."""
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    spans = list(zip(decays.onsets.tolist(), decays.starts.tolist(), decays.stops.tolist()))
    if q == 1:
        return [x[:, a:b] for _, a, b in spans], spans
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    x = signal.sosfiltfilt(signal.butter(8, 0.8 / q, output="sos"), x, axis=1)
    margin = 4 * q                                   # the filter's response to the hit, decimated samples
    spans = [(o, a + margin, b) for o, a, b in spans if b - a > margin]
    return [x[:, a:b:q] for _, a, b in spans], spans


def _model_peaks(parts, fs_dec, band, record_peaks):
    """The modes the model must hold: frequencies (Hz) and tolerances (Hz) of the clear peaks in ``band`` of the
    longest decimated decay's spectrum (:func:`decay_spectrum`, peaks by
    :func:`~physics.identification.decay_peaks.decay_peaks`: close modes resolved as finely as the decays allow)
    and of the record's (``record_peaks``, the whole record at its rate: a mode above the decimated decay's floor
    there), each once."""
    y = max(parts, key=lambda p: p.shape[1])
    fine = decay_peaks(decay_spectrum(CheckedRecord(y, fs_dec, tuple(band), y.mean(axis=1))))
    f, tol = record_peaks.frequency_hz, record_peaks.tolerance_hz
    new = (f >= band[0]) & (f <= band[1]) & np.all(np.abs(f[:, None] - fine.frequency_hz[None, :])
                                                    > np.maximum(tol[:, None], fine.tolerance_hz[None, :]), axis=1)
    f, tol = np.concatenate([fine.frequency_hz, f[new]]), np.concatenate([fine.tolerance_hz, tol[new]])
    order = np.argsort(f)
    return f[order], tol[order]


def _hankel_basis(parts, rows):
    """Left singular vectors and values of the block Hankel matrix of the decays (``rows`` samples per column)."""
    n_ch = parts[0].shape[0]
    G = np.zeros((rows * n_ch, rows * n_ch))
    for y in parts:
        H = np.lib.stride_tricks.sliding_window_view(y, rows, axis=1)       # (n_ch, n_cols, rows)
        H = H.transpose(1, 2, 0).reshape(H.shape[1], rows * n_ch)
        G += H.T @ H
    ev, U = np.linalg.eigh(G)
    order = np.argsort(ev)[::-1]
    return U[:, order], np.sqrt(np.maximum(ev[order], 0))


def _split_missed_hits(parts, spans, q, residuals, window):
    """The decays cut where the fit's residual rises sharply (a hit the segmentation missed): the residual's
    energy (channels scaled by their median) over the next ``window`` samples :data:`SPLIT_RISE` times that over
    the window before and than the quietest tenth of the windows; the cut at the first sample past that level.
    The parts and their spans (as :func:`_decimated` gives them; ``q`` the decimation)."""
    out, out_spans = [], []
    for y, (o, a, b), r in zip(parts, spans, residuals):
        e = np.sum(r ** 2 / np.maximum(np.median(r ** 2, axis=1, keepdims=True), np.finfo(float).tiny), axis=0)
        c = np.concatenate([[0.0], np.cumsum(e)]) / window
        k = np.arange(window, e.size - window)
        before, after = c[k] - c[k - window], c[k + window] - c[k]
        floor = np.percentile(c[window:] - c[:-window], 10) if e.size > window else 0.0
        rise = np.flatnonzero((after >= SPLIT_RISE * before) & (after >= SPLIT_RISE * floor))
        if not rise.size:
            out.append(y)
            out_spans.append((o, a, b))
            continue
        t = k[rise[0]]
        loud = np.flatnonzero(e[t:t + window] >= SPLIT_RISE * floor)
        cut = t + (int(loud[0]) if loud.size else window // 2)
        out += [y[:, :cut], y[:, cut + 2:]]
        out_spans += [(o, a, a + cut * q), (a + cut * q, a + (cut + 2) * q, b)]
    return out, out_spans


def _band_spans(x, decays, fitted_spans, window):
    """The decays the band refinement reads, a list of ``(first, stop)`` samples of the record ``x`` (mean removed):
    each decay from its hit's onset, its fitted pieces (``fitted_spans``, as :func:`_split_missed_hits` gives them)
    joined across every cut that adds no energy (:func:`_adds_energy` over ``window`` samples: a missed hit adds
    energy like any hit; a cut without is the fit's misfit, and the decay runs on across it)."""
    out = []
    for onset, stop in zip(decays.onsets.tolist(), decays.stops.tolist()):
        firsts = sorted(o for o, _, _ in fitted_spans if onset <= o < stop)
        if not firsts:
            continue
        cuts = np.array([o for o in firsts if o > onset], int)
        hits = cuts[_adds_energy(x, cuts, cuts, window)] if cuts.size else cuts
        edges = [onset, *hits.tolist(), stop]
        out += [(a, b) for a, b in zip(edges[:-1], edges[1:]) if any(a <= o < b for o in firsts)]
    return out


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
    floor[inband] = _running_floor(f[inband], power[inband], f[1])
    return SingularValueSpectrum(f, s, vectors, floor, band, max(3 * f[1], 10 / checked.duration_s, band[0]))


def identify_era(signals, sampling_frequency_hz, band_hz=None, n_modes=None, max_order=None, max_damping=MAX_DAMPING,
                 where="record") -> ERAIdentification:
    """Free-decay identification of a record of impact (or pluck) responses (see the module docstring).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples), or CheckedRecord
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Modes kept (Hz); the decays are decimated to it. Default: 0 to 0.4 of the sampling rate, the decays
        decimated so that the Hankel's :data:`MAX_HANKEL_ROWS` rows span about one period of the lowest clear
        peak of the spectrum, but no further than keeps the highest clear peak below 0.4 of the decimated rate
        (where the band then ends).
    n_modes : int, optional
        Modes to keep (default: every stable cluster; with it, the steadiest).
    max_order : int, optional
        Highest model order (state dimension; default :data:`ORDERS_PER_PEAK` per clear peak, at least
        :data:`MIN_MAX_ORDER`, at most the Hankel's rows less one block).
    max_damping : float
    where : str

    Returns
    -------
    ERAIdentification

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, no decay, or decays too short
        for a model; shorter than ten periods of the lowest mode.
    ConvergenceError
        No stable pole, or a singular fit.
    """
    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    fs, band = checked.sampling_frequency_hz, checked.band_hz
    n_ch = checked.signals.shape[0]
    peaks = clear_peaks(decay_spectrum(checked))
    lowest = band[0] if band[0] > 0 else (peaks.frequency_hz[0] if peaks.frequency_hz.size else None)
    decays = find_decays(checked, lowest_hz=lowest)
    if decays.starts.size == 0:
        raise ShapeError(f"{where}: no free decay found (no hit followed by enough samples, nor a decaying "
                         "record); identify a stationary response with --method ssi")
    rows_wanted = MAX_HANKEL_ROWS // n_ch
    q = max(1, int(fs // (2.5 * band[1])))
    if band_hz is None and peaks.frequency_hz.size:     # oversampled: rows span one period of the lowest peak,
        q = max(1, min(int(fs // (peaks.frequency_hz[0] * rows_wanted)),      # every clear peak kept in the band
                       int(fs // (2.5 * peaks.frequency_hz[peaks.frequency_hz <= band[1]].max(initial=0.0)))
                       if np.any(peaks.frequency_hz <= band[1]) else fs))
    hi = min(band[1], fs / (2.5 * q))
    fs_dec = fs / q
    parts, spans = _decimated(checked, q, decays)
    longest = max((p.shape[1] for p in parts), default=0)
    rows = min(rows_wanted, longest // MIN_DECAY_ROWS)
    if rows < 2:
        need = 2 * MIN_DECAY_ROWS * q + (4 * q if q > 1 else 0)
        raise ShapeError(f"{where}: its longest decay holds {int(np.max(decays.stops - decays.starts))} samples at "
                         f"{fs:g} Hz; a decay needs at least {need} samples ({need / fs:.3g} s) for a free-decay model")
    long_enough = [j for j, p in enumerate(parts) if p.shape[1] >= MIN_DECAY_ROWS * rows]
    parts, spans = [parts[j] for j in long_enough], [spans[j] for j in long_enough]   # shorter decays left out
    # the modes the model must hold: in a band given, every mode the decays show; without one, the record's clear
    # peaks up to ``hi`` (a default band at the full rate can hold hundreds of the decays' peaks, each a costly mode
    # of the refinement)
    if band_hz is not None:
        peaks_hz, peak_tol_hz = _model_peaks(parts, fs_dec, (band[0], hi), peaks)
    else:
        inside = peaks.frequency_hz <= hi
        peaks_hz, peak_tol_hz = peaks.frequency_hz[inside], peaks.tolerance_hz[inside]
    p_max = max_order or max(MIN_MAX_ORDER, ORDERS_PER_PEAK * peaks_hz.size)
    p_max = 2 * (min(p_max, (rows - 1) * n_ch) // 2)
    if p_max < 2:
        raise ShapeError(f"{where}: the decays are too short for a model of order 2 ({rows} block rows of "
                         f"{n_ch} channel(s))")
    record_peaks = decay_peaks(decay_spectrum(checked))         # the peaks fftpeak reports a mode at
    sel = fit = None
    for _ in range(1 + MAX_SPLIT_ROUNDS):
        U, s = _hankel_basis(parts, rows)
        diagram = subspace_diagram(U, s, n_ch, np.arange(2, p_max + 1, 2), fs_dec, (0.0, hi), max_damping)
        try:
            sel = select_poles(diagram, min_status=MIN_STATUS, peaks_hz=peaks_hz, peak_tol_hz=peak_tol_hz)
        except ConvergenceError:
            if peaks_hz.size:
                check_periods(checked.duration_s, peaks_hz[0], "the lowest peak", where)
            if fit is not None:                         # a split decay's model lost its poles: the last fit stands
                break
            if record_peaks.frequency_hz.size:          # the clear peaks alone start the band refinement
                fitted_spans = spans
                break
            raise ConvergenceError(f"{where}: no pole of the free decays is stable over enough model orders: raise "
                                   "max_order, widen the band, or try --method ssi") from None
        try:
            fit, fitted, fitted_spans = fit_damped_sinusoids(parts, fs_dec, sel.eigenvalues), parts, spans
        except np.linalg.LinAlgError:
            at = ", ".join(f"{v:.4g}" for v in sel.natural_frequencies_hz)
            raise ConvergenceError(f"{where}: the damped-sinusoid fit of the free decays diverged from the "
                                   f"stabilisation diagram's poles at {at} Hz; narrow the band or try --method ssi") \
                from None
        split, split_spans = _split_missed_hits(parts, spans, q, fit.residuals, rows)
        kept = [j for j, p in enumerate(split) if p.shape[1] >= MIN_DECAY_ROWS * rows]
        if len(split) == len(parts) or not kept:       # no missed hit, or only pieces too short for the model
            break
        parts, spans = [split[j] for j in kept], [split_spans[j] for j in kept]
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    full = [x[:, a:b] for a, b in _band_spans(x, decays, fitted_spans, decays.energy_window)]
    idx, bands = np.zeros(0, int), None
    lam = f_std = z_std = np.zeros(0)
    amps = []                                           # each mode's amplitudes, (n_decays, n_channels)
    merged = np.zeros(0, bool)
    if fit is not None:
        keep = (fit.natural_frequencies_hz >= band[0]) & (fit.natural_frequencies_hz <= hi) \
            & (fit.damping_ratios > 0) & (fit.damping_ratios < max_damping) \
            & (mode_snr(fit, [p.shape[1] for p in fitted], fs_dec) >= MIN_MODE_SNR)
        idx = np.flatnonzero(keep)
    if idx.size:
        bands = refine_in_bands(full, fs, fit.eigenvalues[idx])
        ok = bands.converged
        lam = np.where(ok, bands.eigenvalues, fit.eigenvalues[idx])
        f_std = np.where(ok, bands.frequency_std_hz, fit.frequency_std_hz[idx])
        z_std = np.where(ok, bands.damping_std, fit.damping_std[idx])
        amps = [bands.amplitudes[:, :, j] if ok[j] else fit.amplitudes[:, :, i] for j, i in enumerate(idx)]
        merged = np.asarray(bands.merged, bool)        # a pole merged into a stronger one of its peak is none
    # the clear peaks no mode holds: each started at its peak and refined in its band, the modes held fixed
    held_hz = np.abs(lam[~merged]) / (2 * np.pi)
    held_amps = np.where(ok, bands.amplitudes, np.nan)[:, :, ~merged] if idx.size else None   # NaN: a failed fit
    seeded = refine_seeds(full, fs, lam[~merged], record_peaks, unheld_peaks(record_peaks, held_hz, band),
                          max_damping, held_amplitudes=held_amps)
    if idx.size - merged.sum() + seeded.eigenvalues.size == 0:
        raise ConvergenceError(f"{where}: no refined pole of the free decays lies in {band[0]:g}-{hi:.4g} Hz, nor "
                               "a mode at a clear peak of their spectrum")
    lam = np.concatenate([lam, seeded.eigenvalues])
    f_std = np.concatenate([f_std, seeded.frequency_std_hz])
    z_std = np.concatenate([z_std, seeded.damping_std])
    amps += list(np.moveaxis(seeded.amplitudes, 2, 0))
    weak = np.concatenate([np.asarray(sel.weakly_stable, bool)[idx] if idx.size else np.zeros(0, bool),
                           np.ones(seeded.eigenvalues.size, bool)])
    sub = np.flatnonzero(np.concatenate([~merged, np.ones(seeded.eigenvalues.size, bool)]))
    if n_modes is not None:                             # ERA's steadiest clusters first, the seeded modes last
        rank = sorted(sub, key=lambda j: (j >= idx.size, bool(weak[j]),
                                          -int(sel.count[idx[j]]) if j < idx.size else 0))
        sub = np.sort(np.array(rank[:n_modes], int))
    sub = sub[np.argsort(np.abs(lam[sub]), kind="stable")]     # the refinements may reorder poles
    wn = np.abs(lam[sub])
    check_periods(checked.duration_s, wn[0] / (2 * np.pi), "the lowest mode", where)
    # shapes: the dominant direction of each mode's amplitudes over the decays
    shapes = np.empty((n_ch, sub.size), complex)
    for c, j in enumerate(sub):
        u, _, _ = np.linalg.svd(amps[j].T, full_matrices=False)
        shapes[:, c] = u[:, 0]
    shapes = unit_shapes(shapes)
    est = ModalEstimate(wn / (2 * np.pi), -lam[sub].real / wn, lam[sub], shapes,
                        np.zeros((n_ch, 0, sub.size), complex), f_std[sub], z_std[sub],
                        modal_phase_collinearity(shapes), "era", False, weakly_stable=weak[sub])
    return ERAIdentification(est, diagram, fit, decays, q, rows, len(fitted_spans), bands, seeded)
