"""Output-only identification by frequency-domain decomposition (FDD) and enhanced FDD (EFDD).

The output cross-spectral matrix ``G(f)`` (Welch, Hann window, half overlap; frames accumulated chunk by chunk)
is decomposed line by line, ``G = U S U^H``; modes are the prominent peaks of the first singular value, their
shapes the first singular vector at the peak. EFDD takes each peak's SDOF bell (the lines around the peak whose
first singular vector has MAC >= ``mac_bell`` with the peak's), returns it to the time domain by inverse FFT and
reads the damped frequency from the zero crossings and the damping from the logarithmic decrement of the
extrema of that correlation function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.ssi import _check_channels, _unit_shapes, check_duration
from physics.modal import eigenvalues_from_modal

__all__ = ["FDDIdentification", "cross_spectra", "identify_fdd"]


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
    """

    estimate: ModalEstimate
    frequency_hz: np.ndarray
    singular_values: np.ndarray
    peaks: np.ndarray


def cross_spectra(signals, sampling_frequency_hz, n_per_segment, frames_per_chunk=64, where="record"):
    """Welch cross-spectral matrix of a multichannel record (Hann window, 50 % overlap), chunk by chunk.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    n_per_segment : int
        Samples per frame (resolution ``fs / n_per_segment``).
    frames_per_chunk : int
    where : str

    Returns
    -------
    frequency_hz : ndarray, shape (n_per_segment // 2 + 1,)
    G : ndarray, complex, shape (n_lines, n_channels, n_channels)
        One-sided spectral density (unit^2/Hz).
    """
    from scipy import fft as sfft, signal  # scipy.fft, scipy.signal: 1 s to import, only output-only identification

    y = signals if isinstance(signals, np.ndarray) else np.asarray(signals, dtype=np.float64)
    n_ch, n = y.shape
    L, hop = int(n_per_segment), int(n_per_segment) // 2
    if n < 2 * L:
        raise ShapeError(f"{where}: {n} samples are fewer than two frames of {L} (a {sampling_frequency_hz / L:.3g} Hz "
                         "resolution): too short a record for this resolution")
    mean, _, _ = _check_channels(y, where)
    win = signal.get_window("hann", L)
    scale = 2.0 / (sampling_frequency_hz * np.sum(win ** 2))
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
    return np.arange(L // 2 + 1) * sampling_frequency_hz / L, G


def _efdd(f_hz, s1, u1, peak, mac_bell, fs, n_per_segment):
    """Natural frequency and damping ratio of one peak from its SDOF bell (inverse FFT, zero crossings, log
    decrement); NaN when the bell's correlation does not decay over at least two extrema."""
    from scipy import fft as sfft, signal  # scipy.fft, scipy.signal: 1 s to import, only output-only identification

    m = np.abs(u1.conj() @ u1[peak]) ** 2
    lo, hi = peak, peak
    while lo > 0 and m[lo - 1] >= mac_bell:
        lo -= 1
    while hi < f_hz.size - 1 and m[hi + 1] >= mac_bell:
        hi += 1
    bell = np.zeros(n_per_segment // 2 + 1)
    bell[lo:hi + 1] = s1[lo:hi + 1]
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
                 prominence_db=6.0, enhanced=True, where="record") -> FDDIdentification:
    """FDD (peak frequencies, shapes) or EFDD (also damping) of a multichannel response record.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Default: 0 to 0.4 of the sampling rate.
    n_modes : int, optional
        Keep the ``n_modes`` most prominent peaks (default: every peak above ``prominence_db``).
    resolution_hz : float, optional
        Line spacing (default: the band's upper limit / 2400, coarser if the record holds fewer than 15
        half-overlapping frames of that length).
    mac_bell : float
        MAC with the peak's singular vector that delimits the SDOF bell (EFDD).
    prominence_db : float
        Least prominence of a peak of the first singular value (dB).
    enhanced : bool
        EFDD: frequency and damping from the bell; else the peak line and no damping (NaN).
    where : str

    Returns
    -------
    FDDIdentification
    """
    from scipy import signal  # scipy.signal: about 1 s to import, only for output-only identification

    fs = float(sampling_frequency_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise ShapeError(f"{where}: sampling rate {fs:g} Hz must be finite and > 0")
    band = (0.0, 0.4 * fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if band[1] > fs / 2:
        raise ShapeError(f"{where}: band up to {band[1]:g} Hz is above the Nyquist frequency {fs / 2:g} Hz "
                         f"of a {fs:g} Hz sampling rate")
    check_duration(np.shape(signals)[1] / fs, band[0], where)
    df = band[1] / 2400 if resolution_hz is None else float(resolution_hz)
    L = int(2 ** np.ceil(np.log2(fs / df)))
    if resolution_hz is None:
        L = min(L, int(2 ** np.floor(np.log2(max(np.shape(signals)[1] / 8, 16)))))
    f, G = cross_spectra(signals, fs, L, where=where)
    U, S, _ = np.linalg.svd(G)
    s1, u1 = S[:, 0], U[:, :, 0]
    inband = np.nonzero((f >= band[0]) & (f <= band[1]) & (f > 0))[0]
    db = 10 * np.log10(s1[inband] / s1[inband].max())
    pk, props = signal.find_peaks(db, prominence=prominence_db)
    if n_modes is not None:
        pk = np.sort(pk[np.argsort(props["prominences"])[::-1][:n_modes]])
    if pk.size == 0:
        raise ConvergenceError(f"{where}: no peak of the first singular value stands {prominence_db:g} dB out in "
                               f"{band[0]:g}-{band[1]:g} Hz")
    peaks = inband[pk]
    duration_s = np.shape(signals)[1] / fs
    if duration_s < 10 / f[peaks[0]]:
        raise ShapeError(f"{where}: {duration_s:.3g} s is shorter than ten periods of the lowest mode "
                         f"(near {f[peaks[0]]:.4g} Hz): mode 1 cannot be identified")
    if enhanced:
        fz = np.array([_efdd(f, s1, u1, p, mac_bell, fs, L) for p in peaks])
        fn, zeta = np.where(np.isfinite(fz[:, 0]), fz[:, 0], f[peaks]), fz[:, 1]
    else:
        fn, zeta = f[peaks], np.full(peaks.size, np.nan)
    shapes = _unit_shapes(u1[peaks].T)
    nan = np.full(fn.size, np.nan)
    lam = eigenvalues_from_modal(fn, np.nan_to_num(zeta))
    est = ModalEstimate(fn, zeta, lam, shapes, np.zeros((shapes.shape[0], 0, fn.size), complex), nan, nan,
                        modal_phase_collinearity(shapes), "efdd" if enhanced else "fdd", False)
    return FDDIdentification(est, f, S, peaks)
