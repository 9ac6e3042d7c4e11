"""Output-only identification by covariance-driven stochastic subspace identification (SSI-cov).

The output correlations ``R_k = E[y_{t+k} y_ref,t^T]`` are accumulated chunk by chunk (FFT cross-correlation of
each chunk with the ``n_lags`` samples before it), so a long record (an array or a ``np.memmap``) is read in
bounded memory: once by the shared checks, once for the singular-value spectrum whose clear peaks size the model,
and once per pass; a low-pass filter and decimation to the pass's band run in the same pass (filter state carried
across chunks). One SVD of the block Toeplitz matrix of the correlations gives every model order of the stabilisation
diagram, and one QR factorisation of the shifted observability matrix every order's state matrix; the physical
poles are selected by :func:`~physics.identification.poles.select_poles` as for LSCF. The record is split into
segments whose correlations are kept apart: the one-sigma frequency and damping of each mode are the spread of the
mode over the segments divided by ``sqrt(n_segments)`` (batch estimate of the standard error of the full-record
estimate).

A free response is refined on its decays (:mod:`physics.identification.ssi_free_response`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.band_refine import BandFit
from physics.identification.decays import free_response
from physics.identification.fdd import (CLEAR_PEAK_DB, ClearPeaks, clear_peaks, height_db, singular_value_spectrum,
                                       unexplained_peaks, unit_shapes)
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.peak_seeds import SeededModes
from physics.identification.peak_warning import warn_unexplained_peaks
from physics.identification.poles import (MAX_DAMPING, NO_STABLE_POLE, StabilisationDiagram, missed_clusters,
                                         missed_modes, select_known_mode, select_poles,
                                         steadiest_text)
from physics.identification.record_checks import check_periods, check_records, modes_with_periods
from physics.identification.ssi_free_response import ModeColumns, refine_free_response
from physics.identification.subspace import poles_of_order, subspace_diagram
from physics.modal import eigenvalues_from_modal

__all__ = ["OutputCorrelations", "SSIIdentification", "SSIPass", "identify_ssi", "output_correlations", "ssi_poles"]

@dataclass(frozen=True)
class OutputCorrelations:
    """Output correlations of a record, per segment.

    Attributes
    ----------
    sums : ndarray, shape (n_segments, n_lags, n_channels, n_references)
        ``sum_s y[s] y_ref[s - k]^T`` over the samples ``s`` of each segment (decimated, mean removed).
    counts : ndarray, shape (n_segments, n_lags)
        Number of products in each sum.
    sampling_frequency_hz : float
        After decimation.
    n_samples : int
        Decimated samples.
    decimation : int
    """

    sums: np.ndarray
    counts: np.ndarray
    sampling_frequency_hz: float
    n_samples: int
    decimation: int

    @property
    def correlations(self) -> np.ndarray:
        """``R_k`` of the whole record, shape (n_lags, n_channels, n_references)."""
        return self.sums.sum(axis=0) / self.counts.sum(axis=0)[:, None, None]

    def segment_correlations(self) -> np.ndarray:
        """``R_k`` of each segment, shape (n_segments, n_lags, n_channels, n_references)."""
        return self.sums / self.counts[:, :, None, None]


def output_correlations(signals, sampling_frequency_hz, n_lags, references=None, band_hz=None, n_segments=8,
                        chunk_samples=8192, where="record") -> OutputCorrelations:
    """Output correlations of a multichannel record, accumulated chunk by chunk.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples), or CheckedRecord
        Responses (any unit); a ``np.memmap`` is read chunk by chunk. Unless a :class:`CheckedRecord`,
        :func:`~physics.identification.record_checks.check_records` checks it first.
    sampling_frequency_hz : float
    n_lags : int
        Lags ``0 .. n_lags - 1`` (decimated samples).
    references : sequence of int, optional
        Reference channels (default: all).
    band_hz : (float, float), optional
        With it, the record is low-pass filtered and decimated by the largest integer ``q`` with
        ``fs / q >= 2.5 f_max``.
    n_segments : int
        Segments kept apart (for the uncertainty).
    chunk_samples : int
        Decimated samples per chunk (memory is ``O(n_channels * n_references * chunk_samples)``).
    where : str
        Name of the record in error messages.

    Returns
    -------
    OutputCorrelations

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, or too short a record for
        ``n_lags``.
    """
    from scipy import fft as sfft  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    y, fs, mean = checked.signals, checked.sampling_frequency_hz, checked.mean
    n_ch, n_raw = y.shape
    ref = np.arange(n_ch) if references is None else np.asarray(references, int)
    q = 1 if band_hz is None else max(1, int(fs // (2.5 * band_hz[1])))
    n = n_raw // q
    if n < 4 * n_lags:
        raise ShapeError(f"{where}: {n_raw} samples at {fs:g} Hz are too short for {n_lags} correlation lags "
                         f"(need {4 * n_lags * q} samples)")
    sos = signal.butter(8, 0.8 / q, output="sos") if q > 1 else None
    zi = None if sos is None else np.zeros((sos.shape[0], n_ch, 2))
    n_segments = int(max(1, min(n_segments, n // (4 * n_lags))))
    seg_edges = np.linspace(0, n, n_segments + 1).astype(int)
    m = int(max(chunk_samples, 2 * n_lags))
    nfft = sfft.next_fast_len(m + n_lags, real=True)
    sums = np.zeros((n_segments, n_lags, n_ch, ref.size))
    tail = np.zeros((ref.size, n_lags))
    for s in range(n_segments):
        for a in range(seg_edges[s], seg_edges[s + 1], m):
            b = min(a + m, seg_edges[s + 1])
            raw = np.asarray(y[:, a * q:b * q], dtype=np.float64) - mean[:, None]
            if sos is not None:
                raw, zi = signal.sosfilt(sos, raw, axis=1, zi=zi)
            c = raw[:, ::q] if q > 1 else raw
            comb = np.concatenate([tail, c[ref]], axis=1)               # (n_ref, n_lags + len)
            C = sfft.rfft(c, nfft, axis=1)
            Z = sfft.rfft(comb, nfft, axis=1)
            r = sfft.irfft(np.conj(C)[:, None, :] * Z[None, :, :], nfft, axis=2)  # (n_ch, n_ref, nfft)
            # lag k pairs c[j] with comb[j + n_lags - k]
            sums[s] += np.moveaxis(r[:, :, n_lags - np.arange(n_lags)], 2, 0)
            tail = comb[:, -n_lags:]
    counts = np.repeat(np.diff(seg_edges)[:, None], n_lags, axis=1).astype(float)
    counts[0] -= np.arange(n_lags)
    return OutputCorrelations(sums, counts, fs / q, n, q)


def _toeplitz(R, block_rows):
    """Block Toeplitz ``T[a, b] = R[block_rows + a - b]`` (a, b = 0..block_rows-1), shape (l i, r i)."""
    i = block_rows
    idx = i + np.arange(i)[:, None] - np.arange(i)[None, :]           # lags 1 .. 2i-1
    blocks = R[idx]                                                    # (i, i, l, r)
    return blocks.transpose(0, 2, 1, 3).reshape(i * R.shape[1], i * R.shape[2])


def _svd(R, block_rows):
    T = _toeplitz(R, block_rows)
    U, s, _ = np.linalg.svd(T, full_matrices=False)
    return U, s


def ssi_poles(R, sampling_frequency_hz, block_rows, orders, band_hz, max_damping=MAX_DAMPING, freq_tol=0.01,
              damping_tol=0.05, mac_tol=0.98, duration_s=float("inf")) -> StabilisationDiagram:
    """Stabilisation diagram of SSI-cov models of the given orders from one SVD.

    Parameters
    ----------
    R : ndarray, shape (n_lags, n_channels, n_references)
        Output correlations, ``n_lags >= 2 block_rows``.
    sampling_frequency_hz : float
    block_rows : int
    orders : sequence of int
        Model orders (even state dimensions, in steps of 2), each at most
        ``block_rows * min(n_channels, n_references)``.
    band_hz : (float, float)
    max_damping, freq_tol, damping_tol, mac_tol : float
        Pole filter and stability tolerances (see :func:`~physics.identification.poles.stability_status`).
    duration_s : float
        Duration of the record (s): a damping change is judged against at least the damping it resolves
        (:func:`~physics.identification.poles.damping_resolution`); infinite: against the damping alone.

    Returns
    -------
    StabilisationDiagram
        ``order`` is half the state dimension (consecutive orders are compared); ``participation`` holds the
        unit-norm mode shapes (the vector the stability test compares).
    """
    U, s = _svd(R, block_rows)
    return subspace_diagram(U, s, R.shape[1], orders, sampling_frequency_hz, band_hz, max_damping, freq_tol,
                            damping_tol, mac_tol, duration_s)


def _segment_modes(cor, block_rows, order, band_hz, fn, shapes, max_damping):
    """Each selected mode's nearest pole (frequency within 5 %, shape MAC >= 0.8) in each segment's model."""
    f_seg = np.full((cor.sums.shape[0], fn.size), np.nan)
    z_seg = np.full_like(f_seg, np.nan)
    if cor.sums.shape[0] < 2:
        return f_seg, z_seg
    for s, R in enumerate(cor.segment_correlations()):
        U, sv = _svd(R, block_rows)
        f, z, _, phi = poles_of_order(U, sv, R.shape[1], order, cor.sampling_frequency_hz, max_damping, band_hz)
        if f.size == 0:
            continue
        m = np.abs(phi.conj() @ shapes) ** 2                           # (n_poles, n_modes), unit norms
        close = np.abs(f[:, None] - fn[None, :]) <= 0.05 * fn[None, :]
        score = np.where(close & (m >= 0.8), m, -1.0)
        best = np.argmax(score, axis=0)
        ok = score[best, np.arange(fn.size)] > 0
        f_seg[s, ok], z_seg[s, ok] = f[best[ok]], z[best[ok]]
    return f_seg, z_seg


#: Periods of the lowest clear peak of a pass's band that its block rows cover (its correlation lags twice as many).
BLOCK_ROW_PERIODS = 1
#: Largest block Toeplitz dimension (block rows x channels) of a pass with automatic block rows: bounds the SVD.
MAX_TOEPLITZ_ROWS = 160
#: Least block rows, and least highest model order, of a pass sized automatically.
MIN_BLOCK_ROWS, MIN_MAX_ORDER = 30, 40
#: The automatic highest model order (state dimension) is at least this many per clear peak of the pass's band.
ORDERS_PER_PEAK = 8
#: Fewest block rows of a pass: a (decimated) record shorter than eight times this is not identified in that band.
MIN_SUPPORTED_ROWS = 4
#: Most passes (the whole band, then lower sub-bands decimated further).
MAX_PASSES = 4
#: A mode whose pass's correlation lags span fewer of its periods is identified again in a sub-band.
MIN_LAG_PERIODS = 2
#: A sub-band's upper limit is at most this many times the highest clear peak it is identified for.
SUB_BAND_PEAK_RATIO = 2.5


@dataclass(frozen=True)
class SSIPass:
    """One SSI-cov pass: the band it identified (decimated to it), its sizes and its stabilisation diagram.

    Attributes
    ----------
    band_hz : (float, float)
    block_rows : int
    orders : ndarray of int
        Model orders (state dimensions).
    diagram : StabilisationDiagram
    correlations : OutputCorrelations
    """

    band_hz: tuple
    block_rows: int
    orders: np.ndarray
    diagram: StabilisationDiagram
    correlations: OutputCorrelations


@dataclass(frozen=True)
class SSIIdentification:
    """An SSI-cov identification.

    Attributes
    ----------
    estimate : ModalEstimate
        Shapes unit-norm over the channels (largest entry real positive), unscaled (output-only);
        ``weakly_stable`` flags modes kept on fewer model orders because a clear spectral peak lies at them.
    passes : tuple of SSIPass
        The whole band first, then the lower sub-bands identified for clear peaks no mode explained.
    peaks : ClearPeaks
        The clear peaks of the record's singular-value spectrum.
    unexplained_hz : ndarray
        Clear peaks left without a mode (named in a warning).
    segment_frequencies_hz, segment_damping_ratios : ndarray, shape (n_segments, n_modes)
        Each mode in each segment of its pass (NaN where a segment did not show it).
    bands : BandFit or None
        For a free response, the band refinement of the selected poles (in their order before it); None otherwise.
    seeded : SeededModes or None
        For a free response, the modes of the clear peaks of its decays' spectrum
        (:func:`~physics.identification.decay_peaks.decay_peaks`) that no refined pole held, each started at its
        peak and refined in its band (:func:`~physics.identification.peak_seeds.seed_unheld_peaks`); the estimate
        holds them too (but those ``n_modes`` leaves out: the highest peaks are kept), flagged ``weakly_stable``,
        with no segment estimates (NaN). None otherwise.
    """

    estimate: ModalEstimate
    passes: tuple
    peaks: ClearPeaks
    unexplained_hz: np.ndarray
    segment_frequencies_hz: np.ndarray
    segment_damping_ratios: np.ndarray
    bands: BandFit | None = None
    seeded: SeededModes | None = None

    @property
    def diagram(self) -> StabilisationDiagram:
        """The stabilisation diagram of the whole band."""
        return self.passes[0].diagram

    @property
    def correlations(self) -> OutputCorrelations:
        return self.passes[0].correlations

    @property
    def block_rows(self) -> int:
        return self.passes[0].block_rows


def _pass_sizes(fs_dec, n_dec, lowest_hz, n_peaks, n_ch, n_ref, max_order, block_rows):
    """Block rows and highest model order of a pass (the given ones, or sized to its band and to the record: at
    most ``n_dec // 8`` block rows, so that the ``2 i`` correlation lags are a quarter of the decimated samples).
    With automatic block rows a given ``max_order`` is an upper bound: at most ``i * min(n_ref, n_ch)``, the rank
    of the Toeplitz matrix the record allows; the block rows it asks are at least ``max_order``, the lags the order
    spans in one channel, as far as :data:`MAX_TOEPLITZ_ROWS` allows (and at least the ``max_order / n_ref + 1`` the
    rank needs): a channel added to a record does not shorten the correlation lags a mode seen by one channel is
    fitted on."""
    if block_rows:
        i = int(block_rows)
    else:
        rank = int(np.ceil((max_order or 0) / n_ref)) + 1
        one_channel = min(max_order or 0, MAX_TOEPLITZ_ROWS // n_ch)
        least = max(MIN_BLOCK_ROWS, rank, one_channel)
        want = int(np.ceil(BLOCK_ROW_PERIODS * fs_dec / lowest_hz)) if lowest_hz else least
        i = min(max(least, min(want, MAX_TOEPLITZ_ROWS // n_ch)), n_dec // 8)
    p = max_order or min(max(MIN_MAX_ORDER, ORDERS_PER_PEAK * n_peaks), i * min(n_ref, n_ch))
    if max_order and not block_rows:
        p = min(p, i * min(n_ref, n_ch))
    return i, 2 * (p // 2)


def _ssi_pass(checked, band, peaks, tol_hz, max_order, block_rows, references, n_segments, max_damping,
              chunk_samples, where, mode_in_band=False, known_mode=False):
    """One pass over ``band``: the pass and its selected modes (:class:`_PassMode`; none when no pole is stable);
    ``known_mode``: the band of a stationary record of several channels known to hold a mode
    (:func:`~physics.identification.poles.select_known_mode`)."""
    fs = checked.sampling_frequency_hz
    n_ch = checked.signals.shape[0]
    n_ref = n_ch if references is None else len(references)
    q = max(1, int(fs // (2.5 * band[1])))
    inside = (peaks.frequency_hz >= band[0]) & (peaks.frequency_hz <= band[1])
    lowest = peaks.frequency_hz[inside][0] if inside.any() else None
    n_dec = checked.signals.shape[1] // q
    i, p = _pass_sizes(fs / q, n_dec, lowest, int(inside.sum()), n_ch, n_ref, max_order, block_rows)
    if max_order and p < 2 * (int(max_order) // 2) and p >= 2:
        warnings.warn(f"{where}: model orders up to {p}, not max_order {int(max_order)}: {i} block rows x "
                      f"{min(n_ref, n_ch)} channel(s) are what {n_dec} samples decimated for the band up to "
                      f"{band[1]:.4g} Hz allow", stacklevel=3)
    if i < MIN_SUPPORTED_ROWS or p < 2:
        raise ShapeError(f"{where}: {checked.signals.shape[1]} samples at {fs:g} Hz, decimated to {n_dec} for the "
                         f"band up to {band[1]:.4g} Hz, hold too few samples for an SSI-cov model (at least "
                         f"{8 * MIN_SUPPORTED_ROWS * q} samples, {8 * MIN_SUPPORTED_ROWS * q / fs:.3g} s)")
    if p > i * min(n_ref, n_ch):
        raise ShapeError(f"{where}: max_order {p} exceeds block_rows x channels = {i * min(n_ref, n_ch)}")
    cor = output_correlations(checked, fs, 2 * i, references, band, n_segments, chunk_samples, where)
    orders = np.arange(2, p + 1, 2)
    diagram = ssi_poles(cor.correlations, cor.sampling_frequency_hz, i, orders, band, max_damping,
                        duration_s=cor.n_samples / cor.sampling_frequency_hz if mode_in_band else float("inf"))
    this = SSIPass(band, i, orders, diagram, cor)
    try:
        rescue = inside & peaks.above_floor             # a weakly stable pole is kept at a resonance's peak only
        sel = (select_known_mode if known_mode else select_poles)(diagram, peaks_hz=peaks.frequency_hz[rescue],
                                                                  peak_tol_hz=tol_hz[rescue])
    except ConvergenceError:
        return this, []
    shapes = unit_shapes(sel.participation.T)
    f_seg, z_seg = _segment_modes(cor, i, int(orders[-1]), band, sel.natural_frequencies_hz, shapes, max_damping)
    lag_s = 2 * i / cor.sampling_frequency_hz
    return this, [_PassMode(f, sel.damping_ratios[j], weak, int(sel.count[j]), shapes[:, j], f_seg[:, j], z_seg[:, j],
                            weak or bool(lag_s * f < MIN_LAG_PERIODS))
                  for j, (f, weak) in enumerate(zip(sel.natural_frequencies_hz, sel.weakly_stable.tolist()))]


@dataclass(frozen=True, eq=False)
class _PassMode:
    """A mode one pass of :func:`identify_ssi` selected.

    Attributes
    ----------
    frequency_hz : float
    damping_ratio : float
    weakly_stable : bool
        Kept on fewer model orders than the selection asks, because a clear peak lies at it.
    count : int
        Model orders (upper half of its cluster) in which it was found stable.
    shape : ndarray, complex, shape (n_channels,)
        Unit norm.
    segment_frequencies_hz, segment_damping_ratios : ndarray, shape (n_segments,)
        The mode in each segment of its pass (NaN where a segment did not show it).
    provisional : bool
        Weakly stable, or its pass's correlation lags span fewer than :data:`MIN_LAG_PERIODS` of its periods: a
        sub-band pass identifies it again.
    """

    frequency_hz: float
    damping_ratio: float
    weakly_stable: bool
    count: int
    shape: np.ndarray
    segment_frequencies_hz: np.ndarray
    segment_damping_ratios: np.ndarray
    provisional: bool


def _merge_sub_band(modes: list, found: list, peaks: ClearPeaks, lag_before_s: float) -> list:
    """``modes`` (of the earlier passes) with the sub-band pass's ``found`` merged in (weakly stable last).

    A found mode is taken at a clear peak no settled (not provisional) earlier mode explains (a weakly stable one,
    at such a peak no found mode explains either and that it lies nearer than every earlier mode: two stable modes
    at one unresolved peak are both kept), or as a new mode when it is settled, no earlier pass's lags (longest
    ``lag_before_s``, s) spanned :data:`MIN_LAG_PERIODS` of its periods and no mode lies within 1 % of it. The
    earlier modes it is the nearest found mode of, within 1 % or at its peak, it replaces when they are all
    provisional, it is not and it is steadier (:func:`_steadier`; a weakly stable earlier mode whatever); when it is
    not steadier, they are settled as they are (no later pass looks for them again); otherwise it is dropped."""
    tol_hz = peaks.tolerance_hz
    found_hz = np.array([m.frequency_hz for m in found])
    merged = list(modes)
    for j in sorted(range(len(found)), key=lambda k: found[k].weakly_stable):
        mode, f = found[j], found[j].frequency_hz
        earlier = [m for m in merged if not any(m is x for x in found)]
        settled = [m.frequency_hz for m in (merged if mode.weakly_stable else earlier) if not m.provisional]
        at = unexplained_peaks(peaks, settled) & (np.abs(peaks.frequency_hz - f) <= tol_hz)
        if mode.weakly_stable and earlier:          # a peak an earlier mode lies nearer is that mode's resonance
            at &= np.abs(peaks.frequency_hz - f) < np.min(np.abs(peaks.frequency_hz[:, None]
                                                                - np.array([m.frequency_hz for m in earlier])), axis=1)
        new = not mode.provisional and lag_before_s * f < MIN_LAG_PERIODS \
            and all(abs(m.frequency_hz - f) > 0.01 * f for m in merged)
        if not (at.any() or new):
            continue
        same = [m for m in earlier if np.argmin(np.abs(found_hz - m.frequency_hz)) == j
                and (abs(m.frequency_hz - f) <= 0.01 * f
                     or np.any(np.abs(m.frequency_hz - peaks.frequency_hz[at]) <= tol_hz[at]))]
        if same and (mode.provisional or not all(m.provisional for m in same)):
            continue
        if same and not all(m.weakly_stable or _steadier(mode, m) for m in same):
            merged = [replace(m, provisional=False) if any(m is x for x in same) else m for m in merged]
            continue
        merged = [m for m in merged if not any(m is x for x in same)]
        merged.append(mode)
    return merged


def _steadier(mode: _PassMode, than: _PassMode) -> bool:
    """Whether ``mode``'s frequency has a smaller :func:`_standard_error` than ``than``'s (NaN: no; any beats NaN)."""
    a, b = (_standard_error(m.segment_frequencies_hz[:, None], np.isfinite(m.segment_frequencies_hz).sum(keepdims=True))
            [0] for m in (mode, than))
    return not np.isfinite(b) or (np.isfinite(a) and a < b)


def _standard_error(seg: np.ndarray, n_seen: np.ndarray) -> np.ndarray:
    """Shape (n_modes,): the spread of each mode over the ``n_seen`` segments that show it divided by
    ``sqrt(n_seen)`` (NaN below two); ``seg`` shape (n_segments, n_modes)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_seen >= 2, np.nanstd(np.where(n_seen >= 2, seg, 0), axis=0, ddof=1), np.nan) \
            / np.sqrt(np.maximum(n_seen, 1))


def identify_ssi(signals, sampling_frequency_hz, band_hz=None, n_modes=None, max_order=None, block_rows=None,
                 references=None, n_segments=8, max_damping=MAX_DAMPING, chunk_samples=8192,
                 where="record", mode_in_band=False, refine_decays=None, free=None) -> SSIIdentification:
    """SSI-cov identification of a multichannel response record (output-only), sized to the record's spectrum.

    The clear peaks of the record's singular-value spectrum (:func:`~physics.identification.fdd.clear_peaks`) size
    each pass: block rows covering :data:`BLOCK_ROW_PERIODS` periods of the lowest peak of the pass's band (at most
    :data:`MAX_TOEPLITZ_ROWS` / channels), model orders up to :data:`ORDERS_PER_PEAK` per peak (at least
    :data:`MIN_MAX_ORDER`). The first pass identifies the whole band; while a clear peak has no stable mode, a lower
    sub-band (upper limit half the last, or :data:`SUB_BAND_PEAK_RATIO` times the highest such peak) is decimated to
    and identified again, keeping the modes at those peaks (:data:`MAX_PASSES` passes at most); a mode whose
    correlation lags span fewer than :data:`MIN_LAG_PERIODS` of its periods is identified again so, and replaced by
    the sub-band's estimate nearest it when that one is stable and steadier over its segments, else settled as it is
    (two modes of a sub-band at one unresolved peak are both kept). A sub-band's stable mode that no earlier pass's
    lags spanned :data:`MIN_LAG_PERIODS` periods of and no mode lies within 1 % of is kept too, peak or none (a mode
    the whole band's model could not resolve). A cluster of poles stable over fewer orders than the selection asks
    but at a clear peak is kept, flagged ``weakly_stable``. A clear peak left without a mode is named in a warning,
    and so is a cluster of stable poles no pass kept (:func:`~physics.identification.poles.missed_clusters`), with
    its height above the spectrum's floor. The modes of a free response are then refined in their bands of its
    decays, as ``era``'s are (module docstring).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
        Responses, one unit per channel (a ``np.memmap`` is read in chunks).
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Modes kept (Hz); the record is decimated to it. Default: 0 to 0.4 of the sampling rate.
    n_modes : int, optional
        Modes to keep (default: every stable cluster; with it, the steadiest).
    max_order : int, optional
        Highest model order (state dimension; even orders from 2) of every pass (default: sized per pass); with
        automatic block rows, at most block rows x channels (a warning says so).
    block_rows : int, optional
        Block rows ``i`` of the Toeplitz matrix of every pass (default: sized per pass).
    references : sequence of int, optional
        Reference channels (default: all).
    n_segments : int
        Segments for the uncertainty.
    max_damping : float
    chunk_samples : int
    where : str
        Name of the record in error messages.
    mode_in_band : bool
        A mode is known to lie in the band (a series' reference mode identified again in its band): a damping change
        is judged against at least the damping the record resolves (:func:`~.poles.damping_resolution`; else a
        harmonic, zero damping within the noise, is unstable: a peak without a mode); in a record of several
        channels that is no free response, where no pole is stable enough, those steady in frequency and shape
        (:func:`~physics.identification.poles.select_known_mode`; one channel has no shape to be steady).
    refine_decays : bool, optional
        Refine the modes in their bands of the record's decays (module docstring). None: when the record is a free
        response (:func:`~physics.identification.decays.free_response`); True: the caller has judged it one; False:
        SSI-cov's poles kept (``identify_records``' fallback where ``era`` found no mode).
    free : bool, optional
        The caller's :func:`~physics.identification.decays.free_response` verdict on the record (None: judged here
        where ``refine_decays`` or ``mode_in_band`` needs it).

    Returns
    -------
    SSIIdentification

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, or shorter than ten periods
        of the lowest mode.
    ConvergenceError
        No stable pole.
    """
    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    band = checked.band_hz
    sv = singular_value_spectrum(checked, where=where)
    peaks = clear_peaks(sv)
    tol_hz = peaks.tolerance_hz
    passes, modes, missed = [], [], []
    hi, lag_before_s = band[1], 0.0
    several = checked.signals.shape[0] > 1
    if free is None and (refine_decays is None or (mode_in_band and several)):
        free = free_response(checked).free
    for k in range(MAX_PASSES):
        try:
            this, found = _ssi_pass(checked, (band[0], hi), peaks, tol_hz, max_order, block_rows, references,
                                    n_segments, max_damping, chunk_samples, where, mode_in_band,
                                    mode_in_band and several and not free)
        except ShapeError:
            if not k:
                raise
            break                              # a sub-band the (decimated) record is too short for: not identified
        passes.append(this)
        at = (peaks.frequency_hz >= this.band_hz[0]) & (peaks.frequency_hz <= this.band_hz[1])
        at &= peaks.above_floor
        missed.append(missed_clusters(this.diagram, peaks.frequency_hz[at], tol_hz[at]))   # as select_poles saw it
        modes = _merge_sub_band(modes, found, peaks, lag_before_s) if k else found
        lag_before_s = max(lag_before_s, 2 * this.block_rows / this.correlations.sampling_frequency_hz)
        wanted = unexplained_peaks(peaks, [m.frequency_hz for m in modes if not m.provisional])
        wanted &= peaks.frequency_hz <= hi
        if not wanted.any():
            break
        hi = min(hi / 2, SUB_BAND_PEAK_RATIO * peaks.frequency_hz[wanted].max())
        if hi <= band[0]:
            break
    duration_s = checked.duration_s
    if not modes:
        d = passes[0].diagram
        lowest_hz = np.min(d.natural_frequencies_hz, initial=np.inf)
        check_periods(duration_s, lowest_hz, "the lowest pole", where)
        raise ConvergenceError(f"{where}: {NO_STABLE_POLE}{steadiest_text(d)}")
    if n_modes is not None:
        modes = sorted(modes, key=lambda m: (m.weakly_stable, -m.count))[:n_modes]
    modes.sort(key=lambda m: m.frequency_hz)
    keep = modes_with_periods(duration_s, [m.frequency_hz for m in modes], where)
    modes = [m for m, k in zip(modes, keep) if k]
    fn, zeta = np.array([m.frequency_hz for m in modes]), np.array([m.damping_ratio for m in modes])
    weak = np.array([m.weakly_stable for m in modes])
    shapes = np.array([m.shape for m in modes]).T
    n_seg = max(m.segment_frequencies_hz.size for m in modes)
    f_seg, z_seg = (np.array([np.pad(s, (0, n_seg - s.size), constant_values=np.nan) for s in segs]).T
                    for segs in ([m.segment_frequencies_hz for m in modes], [m.segment_damping_ratios for m in modes]))
    n_seen = np.sum(np.isfinite(f_seg), axis=0)
    f_std, z_std = _standard_error(f_seg, n_seen), _standard_error(z_seg, n_seen)
    cols = ModeColumns(eigenvalues_from_modal(fn, zeta), f_std, z_std, weak, shapes, f_seg, z_seg)
    bands, seeded = None, None
    if refine_decays if refine_decays is not None else free:
        bands, seeded, cols = refine_free_response(checked, cols, sv, band, n_modes, max_damping)
    lam, f_std, z_std, weak, shapes, f_seg, z_seg = cols
    if bands is not None:                               # refined: the poles' own frequencies and damping
        fn, zeta = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    if weak.any():
        warnings.warn(f"{where}: mode(s) at {', '.join(f'{f:.4g} Hz' for f in fn[weak])} weakly stable (stable "
                      "over fewer model orders than the selection asks), kept because a clear spectral peak lies "
                      "there", UserWarning, stacklevel=2)
    unexplained = warn_unexplained_peaks(peaks, fn, where, "a harmonic, or a mode to look for with --band around "
                                         "it or --method efdd")
    missed = missed_modes(missed, fn)
    if missed.frequency_hz.size:
        warnings.warn(f"{where}: stable poles the selection left out: {missed.text(height_db(sv, missed.frequency_hz))}"
                      f"; stable over fewer model orders than the selection asks, and no clear peak of the spectrum "
                      f"there ({CLEAR_PEAK_DB:g} dB above its floor or prominent over its noise): a mode to look for "
                      "with --band around it, or noise", UserWarning, stacklevel=2)
    est = ModalEstimate(fn, zeta, lam, shapes, np.zeros((shapes.shape[0], 0, fn.size), complex), f_std, z_std,
                        modal_phase_collinearity(shapes), "ssi", False, weakly_stable=weak)
    return SSIIdentification(est, tuple(passes), peaks, peaks.frequency_hz[unexplained], f_seg, z_seg, bands,
                             seeded)
