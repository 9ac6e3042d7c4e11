"""FRF estimation from force and response time histories (Welch averaging).

Spectral densities are one-sided Welch estimates from :func:`scipy.signal.csd`
with ``G_xy = E[conj(X) Y]``. For ``n_ref`` forces ``f`` and ``n_resp``
responses ``x`` at every line:

* H1 = ``G_xf G_ff^-1`` (least squares against noise on the responses),
* H2 = ``G_xx G_fx^-1`` per response for one force (noise on the force),
* Hv = total least squares: the eigenvector of the smallest eigenvalue of
  ``[[G_ff, G_fx], [G_xf, G_xx]]`` per response (between H1 and H2),

all vectorised over lines and DOFs. Frequencies are in Hz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError

__all__ = ["FRFEstimate", "estimate_frf"]


@dataclass(frozen=True)
class FRFEstimate:
    """FRF estimates and coherences.

    Attributes
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    h1, hv : ndarray, complex, shape (n_resp, n_ref, n_lines)
    h2 : ndarray, complex, shape (n_resp, 1, n_lines) or None (only for one force)
    coherence : ndarray, shape (n_resp, n_ref, n_lines)
        Ordinary coherence ``|G_fx|^2 / (G_ff G_xx)`` of each response-force pair.
    multiple_coherence : ndarray, shape (n_resp, n_lines)
        ``G_xf G_ff^-1 G_fx / G_xx`` of each response against all forces.
    n_averages : int
    """

    frequency_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray | None
    hv: np.ndarray
    coherence: np.ndarray
    multiple_coherence: np.ndarray
    n_averages: int


def estimate_frf(force, response, fs_hz, nperseg, noverlap=None, window="hann", detrend=False):
    """H1, H2, Hv and coherences from time histories.

    Parameters
    ----------
    force : ndarray, shape (n_ref, n_samples) or (n_samples,)
        Forces (N).
    response : ndarray, shape (n_resp, n_samples) or (n_samples,)
        Responses (displacement m, velocity or acceleration; the FRF kind follows).
    fs_hz : float
        Sampling frequency (Hz).
    nperseg : int
        Samples per Welch segment (line spacing ``fs_hz / nperseg``).
    noverlap : int, optional
        Overlap in samples (default ``nperseg // 2``).
    window : str or tuple
        Any :func:`scipy.signal.get_window` window ("hann", "boxcar", ...).
    detrend : str or False

    Returns
    -------
    FRFEstimate
    """
    f_t = np.atleast_2d(np.asarray(force, dtype=np.float64))
    x_t = np.atleast_2d(np.asarray(response, dtype=np.float64))
    if f_t.ndim != 2 or x_t.ndim != 2 or f_t.shape[1] != x_t.shape[1]:
        raise ShapeError("force and response must be (n_channels, n_samples) with the same n_samples")
    if not (np.all(np.isfinite(f_t)) and np.all(np.isfinite(x_t))):
        raise ShapeError("force and response must be finite")
    n = f_t.shape[1]
    if not 8 <= nperseg <= n:
        raise ShapeError(f"nperseg={nperseg} must be between 8 and the record length {n}")
    if noverlap is None:
        noverlap = nperseg // 2
    kw = dict(fs=fs_hz, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend, axis=-1)
    sig = np.concatenate([f_t, x_t])  # (n_ch, n)
    from scipy import signal  # imported here: scipy.signal costs most of a second to import

    freq, G = signal.csd(sig[:, None, :], sig[None, :, :], **kw)  # G[a, b] = E[conj(A) B]
    n_i = f_t.shape[0]
    Gff = np.moveaxis(G[:n_i, :n_i], -1, 0)  # (L, n_i, n_i), Gff[l, a, b] = E[conj(F_a) F_b]
    Gfx = np.moveaxis(G[:n_i, n_i:], -1, 0)  # (L, n_i, n_o) = E[conj(F) X]
    Gxx = np.einsum("ooL->Lo", G[n_i:, n_i:]).real  # (L, n_o)
    # H1: X = H F  ->  E[conj(F_a) X_o] = sum_b H_ob E[conj(F_a) F_b], i.e. Gfx = Gff H^T
    # a line whose force power is 300 dB below the strongest (a zero or underflowing force) has no H1
    singular = ~(np.min(np.linalg.svd(Gff, compute_uv=False), axis=-1) > 1e-30 * np.max(np.abs(Gff)))
    if singular.any():
        k = int(np.argmax(singular))
        raise ShapeError(f"the force cross-spectral matrix is singular at {int(singular.sum())} of "
                         f"{singular.size} lines (first {freq[k]:.6g} Hz): the force has no energy there or the "
                         "force channels are dependent; H1 needs force at every line")
    H1 = np.linalg.solve(Gff, Gfx).mT  # (L, n_o, n_i)
    gff = np.real(np.einsum("Laa->La", Gff))  # (L, n_i)
    coh = np.abs(Gfx) ** 2 / (gff[:, :, None] * Gxx[:, None, :])  # (L, n_i, n_o)
    mult = np.real(np.einsum("Loa,Lao->Lo", H1, Gfx.conj())) / Gxx
    H2 = None
    if n_i == 1:
        Gxf = Gfx.conj()  # E[conj(X) F]
        H2 = (Gxx / Gxf[:, 0, :])[:, :, None]  # (L, n_o, 1)
    # Hv: per response, the null direction of the (n_i+1) cross-spectral matrix of [F, X_o]
    L, n_o = Gxx.shape
    A = np.zeros((L, n_o, n_i + 1, n_i + 1), complex)
    A[:, :, :n_i, :n_i] = Gff[:, None]
    A[:, :, :n_i, n_i] = np.swapaxes(Gfx, 1, 2)
    A[:, :, n_i, :n_i] = np.swapaxes(Gfx, 1, 2).conj()
    A[:, :, n_i, n_i] = Gxx
    # A[a, b] = E[conj(Z_a) Z_b], so E|v^T Z|^2 = v^H A v: the minimising unit v is the eigenvector
    # of the smallest eigenvalue, and v_F . F + v_X X = 0 gives X = -(v_F / v_X) F
    _, vec = np.linalg.eigh(A)
    v = vec[..., 0]  # (L, n_o, n_i + 1)
    Hv = -v[..., :n_i] / v[..., n_i:]
    to3 = lambda a: np.ascontiguousarray(np.moveaxis(a, 0, -1))  # noqa: E731
    n_avg = 1 + (n - nperseg) // (nperseg - noverlap)
    return FRFEstimate(freq, to3(H1), None if H2 is None else to3(H2), to3(Hv),
                       to3(np.swapaxes(coh, 1, 2)), to3(mult), n_avg)
