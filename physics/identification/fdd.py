"""Output-only identification by frequency-domain decomposition (FDD) and enhanced FDD (EFDD), and the clear
peaks of a record's spectrum that every output-only method answers for.

The output cross-spectral matrix ``G(f)`` (Welch, Hann window, half overlap; frames accumulated chunk by chunk)
is decomposed line by line, ``G = U S U^H`` (:func:`singular_value_spectrum`). A *clear peak*
(:func:`clear_peaks`) is a local maximum of the first singular value that stands :data:`CLEAR_PEAK_DB` above the
smoothed floor (the running median of the spectrum in dB over +-15 % in frequency, at least +-5 lines) and
:data:`PEAK_PROMINENCE_DB` above the valleys on either side (a ripple of the estimate on a resonance's flank is
not a peak). Where modes crowd (three within +-15 %) the running median rides on their flanks and a mode clear to
the eye stands less than 10 dB above it; on a Welch average a peak is then clear too when its prominence (its
height over the higher of the lowest points either side before a higher peak, scipy's ``find_peaks``
prominence) passes the ripple the average's noise reaches (:func:`ripple_db`). FDD's modes are the clear peaks,
their shapes the first singular vector at the peak. EFDD takes each peak's SDOF bell (the lines around the peak
whose first singular vector has MAC >= ``mac_bell`` with the peak's, above the floor and not past the valley to a
neighbouring peak), returns it to the time domain by inverse FFT and reads the damped frequency from the zero
crossings and the damping from the logarithmic decrement of the extrema of that correlation function; a peak whose
frequency falls in a more prominent peak's bell is the same mode and is left out (one peak per mode, also on one
channel, where every line's vector is the same).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.record_checks import CheckedRecord, check_periods, check_records
from physics.modal import eigenvalues_from_modal

__all__ = ["CLEAR_PEAK_DB", "FALSE_RIPPLES", "HANN_HALF_OVERLAP", "PEAK_PROMINENCE_DB", "ClearPeaks",
           "FDDIdentification", "SingularValueSpectrum", "clear_peaks", "cross_spectra", "height_db", "identify_fdd",
           "ripple_db", "running_floor", "singular_value_spectrum", "unexplained_peaks", "unit_shapes"]

#: Least height (dB) of a clear spectral peak above the smoothed floor of the first singular value.
CLEAR_PEAK_DB = 10.0
#: Least prominence (dB) of a clear peak above the valleys on either side.
PEAK_PROMINENCE_DB = 6.0
#: Half-width of the floor's running median: relative frequency, and least number of lines.
FLOOR_HALF_WIDTH, FLOOR_MIN_LINES = 0.15, 5
#: Expected number of noise ripples over a band's lines whose prominence passes :func:`ripple_db`.
FALSE_RIPPLES = 0.01
#: Variance factor of a Welch average of Hann frames overlapping by half, ``1 + 2 c^2`` with the frames' correlation
#: ``c = 0.167``: ``n_frames / HANN_HALF_OVERLAP`` independent averages.
HANN_HALF_OVERLAP = 1 + 2 * 0.167 ** 2
#: Values (complex) a chunk of Welch frames may hold.
CHUNK_VALUES = 2**21


def unit_shapes(phi):
    """Columns of unit norm with the largest entry real and positive."""
    k = np.argmax(np.abs(phi), axis=0)
    ph = phi[k, np.arange(phi.shape[1])]
    return phi * (np.abs(ph) / ph) / np.linalg.norm(phi, axis=0)


def cross_spectra(signals, sampling_frequency_hz, n_per_segment, frames_per_chunk=None, mean=None,
                  where="record"):
    """Welch cross-spectral matrix of a multichannel record (Hann window, 50 % overlap), chunk by chunk.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    n_per_segment : int
        Samples per frame (resolution ``fs / n_per_segment``).
    frames_per_chunk : int, optional
        Default: as many as :data:`CHUNK_VALUES` allows.
    mean : ndarray, shape (n_channels,), optional
        Each channel's mean (default: :func:`check_records` checks the record and gives it).
    where : str

    Returns
    -------
    frequency_hz : ndarray, shape (n_per_segment // 2 + 1,)
    G : ndarray, complex, shape (n_lines, n_channels, n_channels)
        One-sided spectral density (unit^2/Hz).
    """
    from scipy import fft as sfft  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    fs = float(sampling_frequency_hz)
    if mean is None:
        checked = check_records(signals, fs, where=where)
        y, mean = checked.signals, checked.mean
    else:
        y = signals
    n_ch, n = y.shape
    L, hop = int(n_per_segment), int(n_per_segment) // 2
    if n < 2 * L:
        raise ShapeError(f"{where}: {n} samples are fewer than two frames of {L} (a {fs / L:.3g} Hz "
                         "resolution): too short a record for this resolution")
    if frames_per_chunk is None:
        frames_per_chunk = max(1, CHUNK_VALUES // (n_ch * L))
    win = signal.get_window("hann", L)
    scale = 2.0 / (fs * np.sum(win ** 2))
    n_frames = (n - L) // hop + 1
    G = np.zeros((L // 2 + 1, n_ch, n_ch), complex)
    for a in range(0, n_frames, frames_per_chunk):
        b = min(a + frames_per_chunk, n_frames)
        block = np.asarray(y[:, a * hop:(b - 1) * hop + L], dtype=np.float64) - mean[:, None]
        frames = np.lib.stride_tricks.sliding_window_view(block, L, axis=1)[:, ::hop]   # (n_ch, n_f, L)
        X = sfft.rfft(frames * win, axis=2)
        G += np.einsum("ifk,jfk->kij", X, X.conj())
    G *= scale / n_frames
    G[0] *= 0.5
    if L % 2 == 0:
        G[-1] *= 0.5
    return np.arange(L // 2 + 1) * fs / L, G


@dataclass(frozen=True)
class SingularValueSpectrum:
    """Singular values of a record's cross-spectral matrix, line by line, and the floor of the first.

    Attributes
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    singular_values : ndarray, shape (n_lines, n_channels)
        Largest first (unit^2/Hz).
    vectors : ndarray, complex, shape (n_lines, n_channels)
        First singular vector at each line.
    floor : ndarray, shape (n_lines,)
        Running median of the first singular value (see the module docstring); NaN outside the band.
    band_hz : (float, float)
    lowest_hz : float
        Lowest frequency a peak may have: ten periods in the record, and three lines above 0 Hz.
    averages : float
        Independent averages of each line (a Welch average: frames / :data:`HANN_HALF_OVERLAP`); 0 for a spectrum
        that is not such an average (no prominence rule, :func:`clear_peaks`).
    """

    frequency_hz: np.ndarray
    singular_values: np.ndarray
    vectors: np.ndarray
    floor: np.ndarray
    band_hz: tuple
    lowest_hz: float
    averages: float = 0.0

    @property
    def resolution_hz(self) -> float:
        return float(self.frequency_hz[1])


def running_floor(f, s1, df):
    """Running median of ``10 log10 s1`` over +-max(FLOOR_HALF_WIDTH f, FLOOR_MIN_LINES df), as s1's unit."""
    from scipy import ndimage  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    fc = FLOOR_MIN_LINES * df / FLOOR_HALF_WIDTH                   # below fc the window is FLOOR_MIN_LINES lines

    def u(x):                                                       # the window is +-1 in u everywhere
        x = np.asarray(x, float)
        return np.where(x < fc, x / (FLOOR_MIN_LINES * df),
                        fc / (FLOOR_MIN_LINES * df) + np.log(np.maximum(x, fc) / fc) / FLOOR_HALF_WIDTH)

    uf = u(f)
    if uf.size == 0:                                                # a band narrower than the line spacing
        return np.zeros(0)
    grid = np.arange(uf[0], uf[-1] + 1 / 16, 1 / 16)
    db = np.interp(grid, uf, 10 * np.log10(np.maximum(s1, np.finfo(float).tiny)))
    return 10 ** (np.interp(uf, grid, ndimage.median_filter(db, size=33, mode="nearest")) / 10)


def singular_value_spectrum(checked: CheckedRecord, resolution_hz=None, where="record") -> SingularValueSpectrum:
    """The singular-value spectrum of a checked record (see :class:`SingularValueSpectrum`).

    Parameters
    ----------
    checked : CheckedRecord
    resolution_hz : float, optional
        Line spacing (default: the band's upper limit / 2400, coarser if the record holds fewer than 15
        half-overlapping frames of that length).
        A band narrower than the spacing holds no line: no floor and no clear peak there (a method sized by the
        peaks then runs unguided).
    where : str
    """
    fs, band = checked.sampling_frequency_hz, checked.band_hz
    n = checked.signals.shape[1]
    df = band[1] / 2400 if resolution_hz is None else float(resolution_hz)
    L = int(2 ** np.ceil(np.log2(fs / df)))
    if resolution_hz is None:
        L = min(L, int(2 ** np.floor(np.log2(max(n / 8, 16)))))
    f, G = cross_spectra(checked.signals, fs, L, mean=checked.mean, where=where)
    U, S, _ = np.linalg.svd(G)
    inband = (f >= band[0]) & (f <= band[1]) & (f > 0)
    floor = np.full(f.size, np.nan)
    floor[inband] = running_floor(f[inband], S[inband, 0], f[1])
    lowest = max(3 * f[1], 10 / checked.duration_s, band[0])
    n_frames = (n - L) // (L // 2) + 1
    return SingularValueSpectrum(f, S, U[:, :, 0], floor, band, lowest, n_frames / HANN_HALF_OVERLAP)


def ripple_db(averages, n_lines, false_ripples=FALSE_RIPPLES) -> float:
    """Prominence (dB) that a ripple of a spectrum averaged over ``averages`` independent estimates passes with
    probability ``false_ripples`` over ``n_lines`` lines: the ratio of the upper and lower quantiles
    (``false_ripples / n_lines``) of a line's power, ``Gamma(averages) / averages`` times the density. The noise
    is a factor of the density, so the bound holds on a resonance's flank as on the floor (the first singular value
    of several channels varies less than one channel's power: the bound errs high)."""
    from scipy import special  # scipy: only output-only identification

    k = max(float(averages), 1.0)
    p = min(0.5, false_ripples / max(int(n_lines), 1))
    return float(10 * np.log10(special.gammainccinv(k, p) / special.gammaincinv(k, p)))


@dataclass(frozen=True)
class ClearPeaks:
    """Clear peaks of a singular-value spectrum (see :func:`clear_peaks`), by frequency.

    Attributes
    ----------
    lines : ndarray of int, shape (n_peaks,)
    frequency_hz : ndarray, shape (n_peaks,)
    height_db : ndarray, shape (n_peaks,)
        Height above the smoothed floor.
    valleys : ndarray of int, shape (n_peaks, 2)
        Lowest line between each peak and its neighbour (or the band's edge) on either side.
    tolerance_hz : ndarray, shape (n_peaks,)
        How far a mode may lie from the peak and still explain it: the larger of 1 % of its frequency, 1.5 lines
        and the peak's half-power (-3 dB) half-width, bounded by half the gap to the nearest neighbouring clear
        peak (a mode at one peak explains no other clear peak, and a search within the tolerance stops at the
        midpoint to the neighbour).
    above_floor : ndarray of bool, shape (n_peaks,)
        Clear by its height over the floor (:data:`CLEAR_PEAK_DB`), not by its prominence over the noise's ripple
        alone: a resonance, where a ripple-prominent peak may also be a harmonic or a small feature of a long
        average. Only such a peak keeps a pole stable over fewer orders than the selection asks (SSI-cov).
    """

    lines: np.ndarray
    frequency_hz: np.ndarray
    height_db: np.ndarray
    valleys: np.ndarray
    tolerance_hz: np.ndarray
    above_floor: np.ndarray


def clear_peaks(sv: SingularValueSpectrum, band_hz=None, prominent_above_db=np.inf) -> ClearPeaks:
    """The clear peaks of the first singular value within ``band_hz`` (default the spectrum's band): local maxima
    :data:`CLEAR_PEAK_DB` above the floor (or, with ``prominent_above_db``, :data:`CLEAR_PEAK_DB` above the valleys
    either side and ``prominent_above_db`` above the floor) and :data:`PEAK_PROMINENCE_DB` above the valleys either
    side, at or above :attr:`SingularValueSpectrum.lowest_hz` (its valleys read on the lines below that too: a mode
    a few lines above it, in a short record, rises from a valley there); on a Welch average (``sv.averages > 0``)
    also a local maximum whose prominence passes :data:`PEAK_PROMINENCE_DB` and :func:`ripple_db` of the band's
    lines, at any height over the floor (modes crowding within the floor's window raise it)."""
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    band = sv.band_hz if band_hz is None else band_hz
    f = sv.frequency_hz
    low = max(band[0], sv.lowest_hz)
    idx = np.nonzero(np.isfinite(sv.floor) & (f >= band[0]) & (f > 0) & (f <= band[1]))[0]
    if np.count_nonzero(f[idx] >= low) < 3:
        return ClearPeaks(np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros((0, 2), int), np.zeros(0),
                          np.zeros(0, bool))
    db = 10 * np.log10(np.maximum(sv.singular_values[idx, 0], np.finfo(float).tiny))
    over = db - 10 * np.log10(sv.floor[idx])
    pk, props = signal.find_peaks(db, prominence=PEAK_PROMINENCE_DB)   # valleys below the lowest line too
    inside = f[idx[pk]] >= low
    pk, prom = pk[inside], props["prominences"][inside]
    ripple = max(PEAK_PROMINENCE_DB, ripple_db(sv.averages, np.count_nonzero(f[idx] >= low))) if sv.averages > 0 \
        else np.inf
    floor_clear = (over[pk] >= CLEAR_PEAK_DB) | ((prom >= CLEAR_PEAK_DB) & (over[pk] >= prominent_above_db))
    keep = floor_clear | (prom >= ripple)
    pk, floor_clear = pk[keep], floor_clear[keep]
    edges = np.concatenate([[0], pk, [idx.size - 1]])
    valleys = np.array([[a + np.argmin(db[a:p + 1]), p + np.argmin(db[p:b + 1])]
                        for a, p, b in zip(edges[:-2], pk, edges[2:])], int).reshape(-1, 2)
    half = np.zeros(pk.size)
    if pk.size:                                        # half-power half-width, within the valleys
        bases = (np.full(pk.size, 3.0), np.ascontiguousarray(valleys[:, 0]), np.ascontiguousarray(valleys[:, 1]))
        half = signal.peak_widths(db, pk, rel_height=1.0, prominence_data=bases)[0] / 2
    tol = np.maximum.reduce([0.01 * f[idx[pk]], np.full(pk.size, 1.5 * sv.resolution_hz), half * sv.resolution_hz])
    gap = np.diff(f[idx[pk]])
    tol = np.minimum(tol, 0.5 * np.minimum(np.r_[np.inf, gap], np.r_[gap, np.inf]))    # half the gap to a neighbour
    return ClearPeaks(idx[pk], f[idx[pk]], over[pk], idx[valleys] if pk.size else valleys, tol, floor_clear)


def unexplained_peaks(peaks: ClearPeaks, frequencies_hz) -> np.ndarray:
    """Boolean mask of the peaks with no frequency within their :attr:`ClearPeaks.tolerance_hz`."""
    fn = np.asarray(frequencies_hz, float)
    if fn.size == 0:
        return np.ones(peaks.lines.size, bool)
    return np.abs(peaks.frequency_hz[:, None] - fn[None, :]).min(axis=1) > peaks.tolerance_hz


def height_db(sv: SingularValueSpectrum, frequencies_hz, tol=0.01) -> np.ndarray:
    """Height (dB) of the first singular value over its floor: the largest within ``tol`` (relative, at least one
    line) of each frequency; NaN outside the spectrum's band."""
    f = sv.frequency_hz
    over = 10 * np.log10(np.maximum(sv.singular_values[:, 0], np.finfo(float).tiny) / sv.floor)
    fq = np.asarray(frequencies_hz, float)
    near = np.abs(f[None, :] - fq[:, None]) <= np.maximum(tol * fq, sv.resolution_hz)[:, None]
    near &= np.isfinite(over)[None, :]
    return np.where(near.any(axis=1), np.max(np.where(near, over[None, :], -np.inf), axis=1), np.nan)


def peak_text(peaks: ClearPeaks, mask) -> str:
    """``"21.7 Hz (18 dB), ..."`` of the masked peaks."""
    return ", ".join(f"{f:.4g} Hz ({h:.0f} dB)" for f, h in zip(peaks.frequency_hz[mask], peaks.height_db[mask]))


@dataclass(frozen=True)
class FDDIdentification:
    """An FDD/EFDD identification.

    Attributes
    ----------
    estimate : ModalEstimate
        Unit-norm, unscaled shapes (output-only).
    frequency_hz : ndarray, shape (n_lines,)
    singular_values : ndarray, shape (n_lines, n_channels)
        Singular values of the cross-spectral matrix at each line, largest first.
    peaks : ndarray of int, shape (n_modes,)
        Line of each mode's peak.
    spectrum : SingularValueSpectrum
    """

    estimate: ModalEstimate
    frequency_hz: np.ndarray
    singular_values: np.ndarray
    peaks: np.ndarray
    spectrum: SingularValueSpectrum


def _bell(sv: SingularValueSpectrum, peak, valleys, mac_bell):
    """First and last line of a peak's SDOF bell: MAC >= ``mac_bell`` with the peak's vector, above the floor,
    within the valleys either side."""
    u1, s1 = sv.vectors, sv.singular_values[:, 0]
    ok = (np.abs(u1[valleys[0]:valleys[1] + 1].conj() @ u1[peak]) ** 2 >= mac_bell) \
        & (s1[valleys[0]:valleys[1] + 1] >= sv.floor[valleys[0]:valleys[1] + 1])
    k = peak - valleys[0]
    below = np.nonzero(~ok[:k])[0]
    above = np.nonzero(~ok[k:])[0]
    lo = valleys[0] + (below[-1] + 1 if below.size else 0)
    hi = valleys[0] + (k + above[0] - 1 if above.size else ok.size - 1)
    return lo, hi


def _efdd(sv: SingularValueSpectrum, lo, hi, fs, n_per_segment):
    """Natural frequency and damping ratio of one SDOF bell (inverse FFT, zero crossings, log decrement); NaN when
    the bell's correlation does not decay over at least two extrema."""
    from scipy import fft as sfft  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    bell = np.zeros(n_per_segment // 2 + 1)
    bell[lo:hi + 1] = sv.singular_values[lo:hi + 1, 0]
    r = sfft.irfft(bell, n_per_segment)[:n_per_segment // 2]
    r = r / r[0]
    t = np.arange(r.size) / fs
    ext = signal.argrelextrema(np.abs(r), np.greater)[0]
    ext = ext[(np.abs(r[ext]) <= 0.9) & (np.abs(r[ext]) >= 0.1)]
    cross = np.nonzero(np.diff(np.signbit(r)))[0]
    if ext.size < 2 or cross.size < 2:
        return np.nan, np.nan
    tc = t[cross] - r[cross] / (r[cross + 1] - r[cross]) * (t[1] - t[0])    # linear interpolation
    tc = tc[tc <= t[ext[-1]]] if np.sum(tc <= t[ext[-1]]) >= 2 else tc[:2]
    fd = 1.0 / (2.0 * np.polyfit(np.arange(tc.size), tc, 1)[0])
    slope = np.polyfit(t[ext], np.log(np.abs(r[ext])), 1)[0]            # -zeta wn
    delta = -slope / fd                                                   # log decrement per cycle
    zeta = delta / np.sqrt(4 * np.pi ** 2 + delta ** 2)
    return fd / np.sqrt(1 - zeta ** 2), zeta


def identify_fdd(signals, sampling_frequency_hz, band_hz=None, n_modes=None, resolution_hz=None, mac_bell=0.8,
                 enhanced=True, where="record") -> FDDIdentification:
    """FDD (peak frequencies, shapes) or EFDD (also damping) of a multichannel response record.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Default: 0 to 0.4 of the sampling rate.
    n_modes : int, optional
        Keep the ``n_modes`` highest clear peaks (default: every clear peak).
    resolution_hz : float, optional
        Line spacing (see :func:`singular_value_spectrum`).
    mac_bell : float
        MAC with the peak's singular vector that delimits the SDOF bell (EFDD).
    enhanced : bool
        EFDD: frequency and damping from the bell; else the peak line and no damping (NaN).
    where : str

    Returns
    -------
    FDDIdentification

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, or shorter than ten periods
        of its lowest peak.
    ConvergenceError
        No clear peak.
    """
    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    sv = singular_value_spectrum(checked, resolution_hz, where)
    fs, band, f = checked.sampling_frequency_hz, checked.band_hz, sv.frequency_hz
    peaks = clear_peaks(sv)
    if peaks.lines.size == 0:
        raise ConvergenceError(f"{where}: no peak of the first singular value stands {CLEAR_PEAK_DB:g} dB above "
                               f"its floor in {band[0]:g}-{band[1]:g} Hz")
    check_periods(checked.duration_s, peaks.frequency_hz[0], "the lowest peak", where)
    L = 2 * (f.size - 1)
    bells = np.array([_bell(sv, p, v, mac_bell) for p, v in zip(peaks.lines, peaks.valleys)], int)
    if enhanced:
        fz = np.array([_efdd(sv, lo, hi, fs, L) for lo, hi in bells])
        fn, zeta = np.where(np.isfinite(fz[:, 0]), fz[:, 0], f[peaks.lines]), fz[:, 1]
    else:
        fn, zeta = f[peaks.lines], np.full(peaks.lines.size, np.nan)
    keep = []                                          # one peak per mode: highest first, none in a kept bell
    for j in np.argsort(-peaks.height_db, kind="stable"):
        if not any(f[bells[k, 0]] <= fn[j] <= f[bells[k, 1]] or abs(fn[j] - fn[k]) <= 0.01 * fn[k] for k in keep):
            keep.append(j)
    keep = np.sort(np.array(keep[:n_modes] if n_modes is not None else keep, int))
    lines = peaks.lines[keep]
    fn, zeta = fn[keep], zeta[keep]
    shapes = unit_shapes(sv.vectors[lines].T)
    nan = np.full(fn.size, np.nan)
    lam = eigenvalues_from_modal(fn, np.nan_to_num(zeta))
    est = ModalEstimate(fn, zeta, lam, shapes, np.zeros((shapes.shape[0], 0, fn.size), complex), nan, nan,
                        modal_phase_collinearity(shapes), "efdd" if enhanced else "fdd", False)
    return FDDIdentification(est, f, sv.singular_values, lines, sv)
