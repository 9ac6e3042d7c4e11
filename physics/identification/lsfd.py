"""Least-squares frequency-domain (LSFD) residues for given poles, with residual terms, weighting and the
variable-projection covariance of the poles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError
from physics.frf import FRF_KINDS, check_frf_kind
from physics.identification.modes import checked_frf

__all__ = ["ESTIMATION_PASSES", "LSFDResult", "WEIGHTINGS", "estimate_noise_model", "lsfd", "lsfd_basis"]


#: Weightings of :func:`lsfd` (or pass an array of noise standard deviations).
WEIGHTINGS = ("relative", "uniform", "estimated")
#: Refits of ``weighting="estimated"`` after the relative-weighted start.
ESTIMATION_PASSES = 3


@dataclass(frozen=True)
class LSFDResult:
    """Residues of a pole-residue model fitted by least squares (see :func:`lsfd`).

    Attributes
    ----------
    residues : ndarray, complex, shape (n_resp, n_ref, n_modes)
        Receptance residues ``R_j`` of ``H = sum_j R_j/(i w - lambda_j) + c.c.`` (m/N/s).
    residue_std : ndarray, shape (n_resp, n_ref, n_modes)
        One-sigma standard error of ``|R|`` from the weighted least-squares
        covariance (poles taken as exact).
    lower_residual, upper_residual : ndarray, shape (n_resp, n_ref)
        Real mass-like (``-LR/w^2``) and stiffness-like (``UR``) receptance terms of
        out-of-band modes (zero when not fitted).
    synthesised : ndarray, complex, shape (n_resp, n_ref, n_lines)
        The fitted model on the input lines, in the input's ``kind``.
    eigenvalues : ndarray, complex, shape (n_modes,)
        The poles of the model (as given).
    eigenvalue_std : ndarray, shape (n_modes, 2)
        One-sigma standard errors of ``Re lambda`` and ``Im lambda`` (rad/s) from the
        variable-projection covariance of the poles given every FRF (linearised,
        residuals white within each FRF after weighting).
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        The same covariance propagated to natural frequency and damping ratio.
    kind : str
    weighting : str
    """

    residues: np.ndarray
    residue_std: np.ndarray
    lower_residual: np.ndarray
    upper_residual: np.ndarray
    synthesised: np.ndarray
    eigenvalues: np.ndarray | None = None
    eigenvalue_std: np.ndarray | None = None
    frequency_std_hz: np.ndarray | None = None
    damping_std: np.ndarray | None = None
    kind: str = "receptance"
    weighting: str = "relative"


def lsfd_basis(iw, lam, power, lower, upper):
    """Complex design matrix (n_lines, n_par) of the modal terms at ``iw`` (rad/s, times i) of the poles ``lam``
    (rad/s, (m,)): the columns of Re R of every pole, then of Im R, then the lower (``lower``) and upper (``upper``)
    residuals; in the kind of ``power`` (``(i w)^power`` times the receptance's terms)."""
    g = 1 / (iw[:, None] - lam[None, :])
    gc = 1 / (iw[:, None] - np.conj(lam)[None, :])
    cols = [g + gc, 1j * (g - gc)]  # basis of Re R and Im R
    if lower:
        cols.append((1 / iw**2)[:, None])
    if upper:
        cols.append(np.ones((iw.size, 1)))
    return np.concatenate(cols, axis=1) * (iw**power)[:, None]


def _lsfd_weights(h, weighting):
    """Weights like ``h`` (n_resp, n_ref, n_lines): 1/|H| (relative), ones (uniform) or 1/sigma (noise-based)."""
    if isinstance(weighting, str):
        if weighting not in WEIGHTINGS:
            raise ShapeError(f"weighting {weighting!r} must be one of {', '.join(WEIGHTINGS)} or an array "
                             "of noise standard deviations")
        if weighting == "uniform":
            return np.ones(h.shape)
        mag = np.abs(h)
        floor = 1e-9 * np.max(mag, axis=-1, keepdims=True)
        if np.any(floor == 0):
            raise ShapeError("relative weighting needs FRFs that are not identically zero")
        return 1 / np.maximum(mag, floor)
    try:
        sigma = np.broadcast_to(np.asarray(weighting, dtype=float), h.shape)
    except ValueError:
        raise ShapeError(f"noise standard deviations (weighting) of shape {np.shape(weighting)} do not "
                         f"broadcast to the FRF shape {h.shape}") from None
    if not (np.all(np.isfinite(sigma)) and np.all(sigma > 0)):
        raise ShapeError("noise standard deviations (weighting) must be finite and > 0")
    return 1 / sigma


def estimate_noise_model(h, residual, iterations: int = 4):
    """Noise standard deviation of each line, ``sigma = sqrt((a |h|)^2 + b^2)`` per FRF, from fit residuals.

    A measured FRF carries noise proportional to its magnitude (``a``, relative) and a floor (``b``, in the
    FRF's units) that dominates the antiresonances of a lightly damped structure. ``|residual|^2`` estimates
    ``sigma^2`` line by line; ``a^2`` and ``b^2`` (>= 0) are fitted by iteratively reweighted least squares
    (weights ``1 / sigma^4``, the variance of ``|residual|^2``).

    Parameters
    ----------
    h : ndarray, complex, shape (n_frf, n_lines)
        Model FRFs (a first fit), whose magnitude carries the relative part.
    residual : ndarray, complex, shape (n_frf, n_lines)
        Measured minus model.

    Returns
    -------
    ndarray, shape (n_frf, n_lines)  standard deviations, > 0
    """
    m2 = np.abs(h) ** 2
    r2 = np.abs(residual) ** 2
    A = np.stack([m2, np.ones_like(m2)], axis=-1)                 # (n_frf, n_lines, 2)
    w = np.ones_like(m2)
    for _ in range(iterations):
        Aw = A * w[..., None]
        G = np.einsum("fni,fnj->fij", Aw, A)
        rhs = np.einsum("fni,fn->fi", Aw, r2)
        coef = np.linalg.solve(G + 1e-300 * np.eye(2), rhs[..., None])[..., 0]
        coef = np.maximum(coef, 0.0)
        var = coef[:, None, 0] * m2 + coef[:, None, 1]
        tiny = 1e-24 * np.max(m2, axis=-1, keepdims=True) + np.finfo(float).tiny
        var = np.maximum(var, tiny)
        w = 1 / var**2
    return np.sqrt(var)


def _weighted_solve(B, h, W):
    """Batched weighted least squares of ``h_k = B x_k`` (real x) for each FRF row ``k``.

    Returns the solution (n_frf, p), residual variances (n_frf,), the standard
    errors of ``x`` (n_frf, p) and the orthonormal range basis (n_frf, 2N, p) of the
    weighted design (columns beyond its rank zeroed).
    """
    A = W[:, :, None] * B[None]
    Ar = np.concatenate([A.real, A.imag], axis=1)  # (n_frf, 2N, p)
    wh = W * h
    br = np.concatenate([wh.real, wh.imag], axis=1)  # (n_frf, 2N)
    scale = np.linalg.norm(Ar, axis=1)
    scale[scale == 0] = 1.0
    U, s, Vt = np.linalg.svd(Ar / scale[:, None, :], full_matrices=False)
    keep = s > s[:, :1] * max(Ar.shape[1:]) * np.finfo(float).eps
    sinv = np.where(keep, 1 / np.where(keep, s, 1), 0.0)
    V = np.swapaxes(Vt, 1, 2) * sinv[:, None, :]  # (n_frf, p, p): V diag(1/s)
    x = np.einsum("fpk,fnk,fn->fp", V, U, br) / scale
    resid = br - np.einsum("fnp,fp->fn", Ar, x)
    dof = np.maximum(Ar.shape[1] - keep.sum(axis=1), 1)
    s2 = np.sum(resid**2, axis=1) / dof
    x_std = np.sqrt(np.sum(V**2, axis=-1) * s2[:, None]) / scale
    return x, s2, x_std, U * keep[:, None, :]


def _pole_information(iw, lam, R, power, W, Q, s2):
    """Variable-projection (Kaufman) information matrix of the poles, shape (2m, 2m).

    ``J`` is the derivative of the weighted model with respect to ``Re lambda_j`` and
    ``Im lambda_j`` for every FRF; projected off the residue/residual columns (``Q``)
    and weighted by each FRF's residual variance, ``S = sum_k J_k^T J_k / s2_k`` is the
    inverse covariance of the poles had they been fitted with the residues.
    """
    d = 1 / (iw[:, None] - lam[None, :]) ** 2
    dc = 1 / (iw[:, None] - np.conj(lam)[None, :]) ** 2
    Rc = np.conj(R)
    d_re = R[:, None, :] * d[None] + Rc[:, None, :] * dc[None]  # (n_frf, N, m)
    d_im = 1j * (R[:, None, :] * d[None] - Rc[:, None, :] * dc[None])
    J = np.concatenate([d_re, d_im], axis=-1) * ((iw**power)[None, :, None] * W[:, :, None])
    Jr = np.concatenate([J.real, J.imag], axis=1)  # (n_frf, 2N, 2m)
    Jp = Jr - np.matmul(Q, np.matmul(np.swapaxes(Q, 1, 2), Jr))
    return np.einsum("fnp,fnq,f->pq", Jp, Jp, 1 / s2)


def lsfd(frequency_hz, frf, eigenvalues, lower_residual=True, upper_residual=True, *, kind="receptance",
         weighting="relative"):
    """Least-squares frequency-domain residues, fitted to the FRFs as measured.

    Fits, for every FRF with the poles common,
    ``H(w) = (i w)^p {sum_j [R_j/(i w - lambda_j) + conj(R_j)/(i w - conj(lambda_j))] - LR/w^2 + UR}``
    with complex residues ``R_j`` and real ``LR``, ``UR``; ``p`` = 0, 1, 2 for a
    receptance, mobility or accelerance ``frf`` (``kind``), so the data are never
    divided by ``i w`` and their noise is not reshaped. Real and imaginary parts are
    stacked so conjugate symmetry holds exactly.

    Weighting (why): measured FRFs span many decades, from the mass line of a
    free-free beam at the lowest lines to antiresonances 60 dB down. Uniform
    weights fit the largest values (the mass line, the resonance peaks) and leave
    the rest to chance. ``"relative"`` (default) divides each line by ``|H|``, so
    every line counts by its relative (about: decibel) error, the error a person
    reads off an overlay plot; ``"uniform"`` is the classical unweighted fit; an
    array of noise standard deviations (same units and shape as ``frf``, or
    broadcastable) gives the maximum-likelihood fit for known noise.

    Residual terms (why real): the rigid-body modes of a free-free test and
    elastic modes far below the band act as a real mass line ``-LR/w^2``; modes far
    above as a real stiffness ``UR``. Their damping adds imaginary parts of order
    ``zeta`` (1e-4 here), below any noise, so complex residual terms would only fit
    noise. A mode *close* to the band is not a residual: pass its pole (see
    ``margin`` of :func:`lscf`).

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,), > 0 when ``lower_residual``
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        FRFs of kind ``kind`` (SI units).
    eigenvalues : ndarray, complex, shape (n_modes,)
    lower_residual, upper_residual : bool
    kind : {"receptance", "mobility", "accelerance"}
    weighting : {"relative", "uniform", "estimated"} or ndarray
        ``"estimated"``: a relative-weighted start, then :data:`ESTIMATION_PASSES` refits weighted by the noise
        model ``sqrt((a |H|)^2 + b^2)`` of each FRF fitted to the previous residuals
        (:func:`estimate_noise_model`): relative weighting where the data have no floor, noise weighting where
        a floor dominates the antiresonances (the default of :func:`identify_lscf`).

    Returns
    -------
    LSFDResult
        Residues in the receptance convention whatever ``kind``; ``synthesised`` in ``kind``.
    """

    f, h = checked_frf(frequency_hz, frf)
    power = FRF_KINDS.index(check_frf_kind(kind))
    lam = np.asarray(eigenvalues, dtype=complex).ravel()
    if (lower_residual or power == 0) and f[0] <= 0:
        raise ShapeError("lsfd with a lower residual needs frequencies > 0 Hz (drop the 0 Hz line)")
    iw = 2j * np.pi * f
    n_s, n_r, N = h.shape
    hk = h.reshape(-1, N)
    n_m = lam.size
    B = lsfd_basis(iw, lam, power, lower_residual, upper_residual)
    W = _fit_weights(B, h, weighting)
    x, s2, x_std, Q = _weighted_solve(B, hk, W)
    R = x[:, :n_m] + 1j * x[:, n_m:2 * n_m]
    lam_std, f_std, z_std = _pole_std(lam, np.linalg.pinv(_pole_information(iw, lam, R, power, W, Q, s2)))
    R = R.reshape(n_s, n_r, n_m)
    R_std = np.hypot(x_std[:, :n_m], x_std[:, n_m:2 * n_m]).reshape(n_s, n_r, n_m)
    k = 2 * n_m
    LR = UR = np.zeros((n_s, n_r))
    if lower_residual:
        LR = x[:, k].reshape(n_s, n_r)
        k += 1
    if upper_residual:
        UR = x[:, k].reshape(n_s, n_r)
    synth = (x @ B.T).reshape(h.shape)
    return LSFDResult(R, R_std, LR, UR, synth, lam, lam_std, f_std, z_std, kind,
                      weighting if isinstance(weighting, str) else "noise")


def _fit_weights(B, h, weighting):
    """Weights (n_frf, n_lines) of the fit of ``h`` (n_resp, n_ref, n_lines) on the design ``B``.

    ``"estimated"``: relative weights, then :data:`ESTIMATION_PASSES` times the inverse of the noise model
    (:func:`estimate_noise_model`) of the residuals of a fit with the previous weights; else
    :func:`_lsfd_weights`.
    """
    hk = h.reshape(-1, h.shape[-1])
    if not (isinstance(weighting, str) and weighting == "estimated"):
        return _lsfd_weights(h, weighting).reshape(hk.shape)
    W = _lsfd_weights(hk, "relative")
    for _ in range(ESTIMATION_PASSES):
        synth0 = _weighted_solve(B, hk, W)[0] @ B.T
        W = 1 / estimate_noise_model(synth0, hk - synth0)
    return W


def _pole_std(lam, cov):
    """One-sigma errors of the poles from their covariance ``cov`` (2m, 2m) over (Re lambda, Im lambda).

    Returns the standard errors of ``(Re lambda, Im lambda)`` (m, 2) and, to first order, of
    ``f = |lambda|/2 pi`` (Hz) and ``zeta = -Re lambda/|lambda|`` (m,).
    """
    n_m = lam.size
    var_re, var_im = np.clip(np.diag(cov)[:n_m], 0, None), np.clip(np.diag(cov)[n_m:], 0, None)
    cov_ri = np.diag(cov, n_m)[:n_m]
    a = np.abs(lam)
    df = np.stack([lam.real, lam.imag]) / (2 * np.pi * a)
    dz = np.stack([-1 / a + lam.real**2 / a**3, lam.real * lam.imag / a**3])
    f_std = np.sqrt(np.clip(df[0] ** 2 * var_re + df[1] ** 2 * var_im + 2 * df[0] * df[1] * cov_ri, 0, None))
    z_std = np.sqrt(np.clip(dz[0] ** 2 * var_re + dz[1] ** 2 * var_im + 2 * dz[0] * dz[1] * cov_ri, 0, None))
    return np.column_stack([np.sqrt(var_re), np.sqrt(var_im)]), f_std, z_std


