"""Output-only identification by covariance-driven stochastic subspace identification (SSI-cov).

The output correlations ``R_k = E[y_{t+k} y_ref,t^T]`` are accumulated chunk by chunk (FFT cross-correlation of
each chunk with the ``n_lags`` samples before it), so a long record (an array or a ``np.memmap``) is read once
in bounded memory; a low-pass filter and decimation to the band run in the same pass (filter state carried across
chunks). One SVD of the block Toeplitz matrix of the correlations gives every model order of the stabilisation
diagram; the physical poles are selected by :func:`~physics.identification.poles.select_poles` as for LSCF. The
record is split into segments whose correlations are kept apart: the one-sigma frequency and damping of each mode
are the spread of the mode over the segments divided by ``sqrt(n_segments)`` (batch estimate of the standard
error of the full-record estimate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.poles import (MAX_DAMPING, SelectedPoles, StabilisationDiagram, select_poles,
                                         stability_status)
from physics.modal import eigenvalues_from_modal

__all__ = ["OutputCorrelations", "SSIIdentification", "identify_ssi", "output_correlations", "ssi_poles"]

#: Fraction of a channel's samples at its extreme value beyond which the channel is called clipped.
CLIP_FRACTION = 1e-3


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


def _check_channels(y, where):
    """Mean, and the error of a channel with NaN samples or no variation, in one pass over chunks."""
    n_ch, n = y.shape
    total, lo, hi = np.zeros(n_ch), np.full(n_ch, np.inf), np.full(n_ch, -np.inf)
    step = max(1, 2**22 // max(n_ch, 1))
    for a in range(0, n, step):
        c = np.asarray(y[:, a:a + step], dtype=np.float64)
        bad = ~np.all(np.isfinite(c), axis=1)
        if np.any(bad):
            raise ShapeError(f"{where}: channel {int(np.argmax(bad))} holds NaN or inf samples (sample "
                             f"{a + int(np.argmax(~np.isfinite(c[np.argmax(bad)])))})")
        total += c.sum(axis=1)
        lo, hi = np.minimum(lo, c.min(axis=1)), np.maximum(hi, c.max(axis=1))
    flat = hi <= lo
    if np.any(flat):
        raise ShapeError(f"{where}: channel {int(np.argmax(flat))} is constant; nothing to identify from it")
    return total / n, lo, hi


def output_correlations(signals, sampling_frequency_hz, n_lags, references=None, band_hz=None, n_segments=8,
                        chunk_samples=8192, where="record") -> OutputCorrelations:
    """Output correlations of a multichannel record, accumulated chunk by chunk.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
        Responses (any unit); a ``np.memmap`` is read chunk by chunk.
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
        NaN samples, a constant or clipped channel, a band above the Nyquist frequency, too short a record.
    """
    from scipy import fft as sfft, signal  # scipy.fft, scipy.signal: 1 s to import, only output-only identification

    y = signals if isinstance(signals, np.ndarray) else np.asarray(signals, dtype=np.float64)
    if y.ndim != 2 or y.shape[0] < 1:
        raise ShapeError(f"{where}: signals must be (n_channels, n_samples)")
    fs = float(sampling_frequency_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise ShapeError(f"{where}: sampling rate {fs:g} Hz must be finite and > 0")
    n_ch, n_raw = y.shape
    ref = np.arange(n_ch) if references is None else np.asarray(references, int)
    q = 1
    if band_hz is not None:
        if band_hz[1] > fs / 2:
            raise ShapeError(f"{where}: band up to {band_hz[1]:g} Hz is above the Nyquist frequency {fs / 2:g} Hz "
                             f"of a {fs:g} Hz sampling rate")
        q = max(1, int(fs // (2.5 * band_hz[1])))
    n = n_raw // q
    if n < 4 * n_lags:
        raise ShapeError(f"{where}: {n_raw} samples at {fs:g} Hz are too short for {n_lags} correlation lags "
                         f"(need {4 * n_lags * q} samples)")
    mean, lo, hi = _check_channels(y, where)
    sos = signal.butter(8, 0.8 / q, output="sos") if q > 1 else None
    zi = None if sos is None else np.zeros((sos.shape[0], n_ch, 2))
    n_segments = int(max(1, min(n_segments, n // (4 * n_lags))))
    seg_edges = np.linspace(0, n, n_segments + 1).astype(int)
    m = int(max(chunk_samples, 2 * n_lags))
    nfft = sfft.next_fast_len(m + n_lags, real=True)
    sums = np.zeros((n_segments, n_lags, n_ch, ref.size))
    tail = np.zeros((ref.size, n_lags))
    at_extreme = np.zeros(n_ch, int)
    for s in range(n_segments):
        for a in range(seg_edges[s], seg_edges[s + 1], m):
            b = min(a + m, seg_edges[s + 1])
            raw = np.asarray(y[:, a * q:b * q], dtype=np.float64)
            at_extreme += np.sum((raw >= hi[:, None]) | (raw <= lo[:, None]), axis=1)
            raw = raw - mean[:, None]
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
    clipped = at_extreme > CLIP_FRACTION * n_raw + 2
    if np.any(clipped):
        k = int(np.argmax(clipped))
        raise ShapeError(f"{where}: channel {k} is clipped ({at_extreme[k]} samples at its extreme values "
                         f"{lo[k]:.4g}/{hi[k]:.4g}); identify from unclipped records")
    counts = np.repeat(np.diff(seg_edges)[:, None], n_lags, axis=1).astype(float)
    counts[0] -= np.arange(n_lags)
    return OutputCorrelations(sums, counts, fs / q, n, q)


def check_duration(duration_s, band_low_hz, where="record"):
    """Refuse a record shorter than ten periods of the band's lower limit (the lowest mode it may hold)."""
    if band_low_hz > 0 and duration_s < 10 / band_low_hz:
        raise ShapeError(f"{where}: {duration_s:.3g} s is shorter than ten periods of the band's lower limit "
                         f"{band_low_hz:g} Hz: modes below {10 / duration_s:.3g} Hz cannot be identified")


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


def _poles_of_order(U, s, n_out, order, fs, max_damping, band_hz):
    """Continuous-time eigenvalues (Im > 0) and unit-norm shapes of the SSI model of one order."""
    O = U[:, :order] * np.sqrt(s[:order])
    A = np.linalg.lstsq(O[:-n_out], O[n_out:], rcond=None)[0]
    mu, V = np.linalg.eig(A)
    lam = np.log(mu.astype(complex)) * fs
    phi = O[:n_out] @ V
    wn = np.abs(lam)
    zeta = -lam.real / np.where(wn > 0, wn, 1)
    fn = wn / (2 * np.pi)
    keep = (lam.imag > 0) & (zeta > 0) & (zeta < max_damping) & (fn >= band_hz[0]) & (fn <= band_hz[1])
    phi = phi[:, keep]
    phi = phi / np.linalg.norm(phi, axis=0)
    return fn[keep], zeta[keep], lam[keep], phi.T


def ssi_poles(R, sampling_frequency_hz, block_rows, orders, band_hz, max_damping=MAX_DAMPING, freq_tol=0.01,
              damping_tol=0.05, mac_tol=0.98) -> StabilisationDiagram:
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

    Returns
    -------
    StabilisationDiagram
        ``order`` is half the state dimension (consecutive orders are compared); ``participation`` holds the
        unit-norm mode shapes (the vector the stability test compares).
    """
    U, s = _svd(R, block_rows)
    rows = [_poles_of_order(U, s, R.shape[1], p, sampling_frequency_hz, max_damping, band_hz) for p in orders]
    order = np.concatenate([np.full(r[0].size, p // 2) for p, r in zip(orders, rows)])
    fn, zeta, lam = (np.concatenate([r[k] for r in rows]) for k in range(3))
    phi = np.concatenate([r[3] for r in rows], axis=0) if rows else np.zeros((0, R.shape[1]), complex)
    status = stability_status(order, fn, zeta, phi, freq_tol, damping_tol, mac_tol)
    return StabilisationDiagram(order, lam, fn, zeta, phi, status, tuple(float(b) for b in band_hz))


@dataclass(frozen=True)
class SSIIdentification:
    """An SSI-cov identification.

    Attributes
    ----------
    estimate : ModalEstimate
        Shapes unit-norm over the channels (largest entry real positive), unscaled (output-only).
    diagram : StabilisationDiagram
    poles : SelectedPoles
    segment_frequencies_hz, segment_damping_ratios : ndarray, shape (n_segments, n_modes)
        Each mode in each segment (NaN where a segment did not show it).
    correlations : OutputCorrelations
    block_rows : int
    """

    estimate: ModalEstimate
    diagram: StabilisationDiagram
    poles: SelectedPoles
    segment_frequencies_hz: np.ndarray
    segment_damping_ratios: np.ndarray
    correlations: OutputCorrelations
    block_rows: int


def _unit_shapes(phi):
    """Columns of unit norm with the largest entry real and positive."""
    k = np.argmax(np.abs(phi), axis=0)
    ph = phi[k, np.arange(phi.shape[1])]
    return phi * (np.abs(ph) / ph) / np.linalg.norm(phi, axis=0)


def _segment_modes(cor, block_rows, order, band_hz, fn, shapes, max_damping):
    """Each selected mode's nearest pole (frequency within 5 %, shape MAC >= 0.8) in each segment's model."""
    f_seg = np.full((cor.sums.shape[0], fn.size), np.nan)
    z_seg = np.full_like(f_seg, np.nan)
    if cor.sums.shape[0] < 2:
        return f_seg, z_seg
    for s, R in enumerate(cor.segment_correlations()):
        U, sv = _svd(R, block_rows)
        f, z, _, phi = _poles_of_order(U, sv, R.shape[1], order, cor.sampling_frequency_hz, max_damping, band_hz)
        if f.size == 0:
            continue
        m = np.abs(phi.conj() @ shapes) ** 2                           # (n_poles, n_modes), unit norms
        close = np.abs(f[:, None] - fn[None, :]) <= 0.05 * fn[None, :]
        score = np.where(close & (m >= 0.8), m, -1.0)
        best = np.argmax(score, axis=0)
        ok = score[best, np.arange(fn.size)] > 0
        f_seg[s, ok], z_seg[s, ok] = f[best[ok]], z[best[ok]]
    return f_seg, z_seg


def steadiest_text(diagram: StabilisationDiagram, n: int = 3) -> str:
    """What a failed selection saw: the ``n`` frequencies whose poles kept their frequency and shape (status >= 3)
    over the most model orders, and what to try; empty without such poles."""
    d = diagram
    ok = d.status >= 3
    if not ok.any():
        return ""
    key = np.round(np.log(d.natural_frequencies_hz[ok]) / np.log1p(0.01)).astype(int)    # 1 % bins
    bins, inverse = np.unique(key, return_inverse=True)
    orders = np.array([np.unique(d.order[ok][inverse == b]).size for b in range(bins.size)])
    top = np.argsort(-orders, kind="stable")[:n]
    total = np.unique(d.order).size
    seen = ", ".join(f"{np.median(d.natural_frequencies_hz[ok][inverse == b]):.4g} Hz ({orders[b]} of {total} "
                     "orders)" for b in top)
    return (f"; the steadiest poles (frequency and shape): {seen}; try --band around one of them, or --method fdd "
            "(peaks of the spectra)")


def identify_ssi(signals, sampling_frequency_hz, band_hz=None, n_modes=None, max_order=40, block_rows=None,
                 references=None, n_segments=8, max_damping=MAX_DAMPING, chunk_samples=8192,
                 where="record") -> SSIIdentification:
    """SSI-cov identification of a multichannel response record (output-only).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
        Responses, one unit per channel (a ``np.memmap`` is read in chunks).
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Modes kept (Hz); the record is decimated to it. Default: 0 to 0.4 of the sampling rate.
    n_modes : int, optional
        Modes to keep (default: every stable cluster).
    max_order : int
        Highest model order (state dimension; even orders from 2).
    block_rows : int, optional
        Block rows ``i`` of the Toeplitz matrix (default ``max(max_order / n_references + 1, 30)``).
    references : sequence of int, optional
        Reference channels (default: all).
    n_segments : int
        Segments for the uncertainty.
    max_damping : float
    chunk_samples : int
    where : str
        Name of the record in error messages.

    Returns
    -------
    SSIIdentification

    Raises
    ------
    ShapeError
        Bad record (see :func:`output_correlations`) or a record shorter than ten periods of the lowest mode.
    ConvergenceError
        No stable pole.
    """
    fs = float(sampling_frequency_hz)
    y = signals if isinstance(signals, np.ndarray) else np.asarray(signals, dtype=np.float64)
    band = (0.0, 0.4 * fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    n_ref = y.shape[0] if references is None else len(references)
    i = int(block_rows) if block_rows else max(int(np.ceil(max_order / n_ref)) + 1, 30)
    if max_order > i * min(n_ref, y.shape[0]):
        raise ShapeError(f"{where}: max_order {max_order} exceeds block_rows x channels = "
                         f"{i * min(n_ref, y.shape[0])}")
    check_duration(y.shape[1] / fs, band[0], where)
    cor = output_correlations(y, fs, 2 * i, references, band_hz, n_segments, chunk_samples, where)
    orders = np.arange(2, max_order + 1, 2)
    diagram = ssi_poles(cor.correlations, cor.sampling_frequency_hz, i, orders, band, max_damping)
    duration_s = y.shape[1] / fs
    try:
        sel = select_poles(diagram, n_modes)
        lowest_hz = sel.natural_frequencies_hz[0]
    except ConvergenceError as exc:
        lowest_hz = np.min(diagram.natural_frequencies_hz, initial=np.inf)
        if duration_s >= 10 / lowest_hz:
            raise ConvergenceError(f"{where}: {exc}{steadiest_text(diagram)}") from None
    if duration_s < 10 / lowest_hz:
        raise ShapeError(f"{where}: {duration_s:.3g} s is shorter than ten periods of the lowest mode "
                         f"(near {lowest_hz:.4g} Hz): mode 1 cannot be identified")
    shapes = _unit_shapes(sel.participation.T)
    f_seg, z_seg = _segment_modes(cor, i, int(orders[-1]), band, sel.natural_frequencies_hz, shapes, max_damping)
    n_seen = np.sum(np.isfinite(f_seg), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        f_std = np.where(n_seen >= 2, np.nanstd(np.where(n_seen >= 2, f_seg, 0), axis=0, ddof=1), np.nan) \
            / np.sqrt(np.maximum(n_seen, 1))
        z_std = np.where(n_seen >= 2, np.nanstd(np.where(n_seen >= 2, z_seg, 0), axis=0, ddof=1), np.nan) \
            / np.sqrt(np.maximum(n_seen, 1))
    fn, zeta = sel.natural_frequencies_hz, sel.damping_ratios
    est = ModalEstimate(fn, zeta, eigenvalues_from_modal(fn, zeta), shapes,
                        np.zeros((shapes.shape[0], 0, fn.size), complex), f_std, z_std,
                        modal_phase_collinearity(shapes), "ssi", False)
    return SSIIdentification(est, diagram, sel, f_seg, z_seg, cor, i)
