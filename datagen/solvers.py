"""Batched solvers of the dataset pipeline: undamped and light-damping complex modes, pole-residue FRFs.

Pure numerics (arrays in, arrays out) shared by the batched pipeline
(:mod:`datagen.pipeline`), the FRF synthesis on read (:mod:`datagen.synth`)
and the per-sample cross-check (:mod:`datagen.naive`).

Conjugate pairs follow :mod:`physics.modal`: one eigenvalue per pair with
``Im > 0``, eq.-1.10 ("unit modal A") normalised shapes, so that
``H(w) = sum_j a_j/(i w - lambda_j) + conj(a_j)/(i w - conj(lambda_j))`` with
residues ``a_sj = psi_sj psi_rj`` (response ``s``, reference DOF ``r``).
"""

from __future__ import annotations

import numpy as np

from datagen.kernels import band_cholesky, band_cholesky_solve, pair_frf_kernel
from physics.modal import normalize_modes, state_matrix, undamped_modes

BANDWIDTH = 3       # half-bandwidth of beam matrices with DOFs ordered node by node

_EMPTY_SEEDS = np.zeros(0, np.uint64)
_EMPTY = np.zeros(0)


def _t(a):
    return np.swapaxes(a, -1, -2)


def gen_eigh(M, K):
    """``K v = w M v`` (batched), ``v^T M v = I``, ascending ``w`` (rad^2/s^2): :func:`physics.modal.undamped_modes`."""
    omega, v = undamped_modes(M, K)
    return omega**2, v


def ritz_modes(M, K, start, iterations):
    """Lowest undamped modes by subspace iteration with Rayleigh-Ritz (batched).

    Parameters
    ----------
    M : ndarray, shape (n, n) or (..., n, n)
    K : ndarray, shape (..., n, n)
        Banded (half-bandwidth :data:`BANDWIDTH`), symmetric positive definite.
    start : ndarray, shape (n, p)
    iterations : int

    Returns
    -------
    omega2 : ndarray, shape (..., p)   ascending (rad^2/s^2 for SI K, M)
    phi : ndarray, shape (..., n, p)   ``phi^T M phi = I``
    """
    V = np.broadcast_to(start, K.shape[:-2] + start.shape)
    n = K.shape[-1]
    Kf = np.ascontiguousarray(K).reshape(-1, n, n)
    L = band_cholesky(Kf, BANDWIDTH)  # factor once: beam stiffness is banded (2 DOFs per node)
    for _ in range(iterations):
        MV = np.broadcast_to(M @ V, K.shape[:-2] + V.shape[-2:])
        X = band_cholesky_solve(L, np.ascontiguousarray(MV).reshape(-1, n, V.shape[-1])).reshape(MV.shape)
        Kr = _t(X) @ K @ X
        Mr = _t(X) @ M @ X
        w2, Q = gen_eigh(0.5 * (Mr + _t(Mr)), 0.5 * (Kr + _t(Kr)))
        V = X @ Q
    return w2, V


def light_damping_modes(omega2, c, iterations):
    """Complex modes of ``z'' + c z' + diag(omega2) z = 0`` for light damping (batched).

    Fixed-point iteration on ``lambda_j`` and the modal-coordinate shape ``z_j``
    (``z_jj = 1``), starting from the uncoupled modes; each pass gains a factor
    of order ``zeta``.

    Parameters
    ----------
    omega2 : ndarray, shape (..., p)      squared undamped frequencies (rad^2/s^2)
    c : ndarray, shape (..., p, p)        modal damping matrix ``Phi^T C Phi`` (1/s)
    iterations : int

    Returns
    -------
    lam : ndarray, complex, shape (..., p)     Im > 0
    Z : ndarray, complex, shape (..., p, p)    columns = modes, eq.-1.10 normalised in modal coordinates
    """
    p = omega2.shape[-1]
    eye = np.eye(p, dtype=bool)
    cd = np.diagonal(c, axis1=-2, axis2=-1)
    lam = (-cd + 1j * np.sqrt(4 * omega2 - cd**2 + 0j)) / 2
    Z = np.broadcast_to(np.eye(p, dtype=complex), c.shape).copy()
    c_off = np.where(eye, 0.0, c)
    for _ in range(iterations):
        # rows k != j: (lam_j^2 + w_k^2 + lam_j c_kk) Z_kj = -lam_j sum_{l != k} c_kl Z_lj
        rhs = -(c_off @ Z) * lam[..., None, :]
        den = lam[..., None, :] ** 2 + omega2[..., :, None] + lam[..., None, :] * cd[..., :, None]
        Z = np.where(eye, 1.0 + 0j, rhs / np.where(eye, 1.0, den))
        b = cd + np.einsum("...jk,...kj->...j", c_off, Z)
        lam = (-b + 1j * np.sqrt(4 * omega2 - b**2)) / 2
    h = 2 * lam * np.einsum("...kj,...kj->...j", Z, Z) + np.einsum("...kj,...kl,...lj->...j", Z, c, Z)
    return lam, Z / np.sqrt(h)[..., None, :]


def pair_frf(lam, residues, omega_rad_s, out=None, noise=None):
    """Receptance from conjugate pairs: ``sum_j a_j/(i w - lam_j) + conj(a_j)/(i w - conj(lam_j))``.

    Evaluated in one compiled pass (:func:`datagen.kernels.pair_frf_kernel`).

    Parameters
    ----------
    lam : ndarray, complex, shape (..., m)
    residues : ndarray, complex, shape (..., S, m)     ``a_sj = psi_sj psi_rj``
    omega_rad_s : ndarray, shape (F,)
    out : ndarray, complex, shape (..., S, F), optional
        C-contiguous storage to write into (e.g. complex64 arrays).
    noise : (seeds, level, floor), optional
        Arrays of shape (...): uint64 stream seeds, relative noise level and
        noise floor relative to each FRF's peak (see the kernel).

    Returns
    -------
    ndarray, complex, shape (..., S, F)
    """
    w = np.ascontiguousarray(omega_rad_s, dtype=float)
    lam = np.asarray(lam, complex)
    batch = lam.shape[:-1]
    m, S = lam.shape[-1], residues.shape[-2]
    lam2 = np.ascontiguousarray(lam.reshape(-1, m))
    res2 = np.ascontiguousarray(np.asarray(residues, complex).reshape(-1, S, m))
    if out is None:
        out = np.empty(batch + (S, w.size), complex)
    if noise is None:
        seeds, level, floor = _EMPTY_SEEDS, _EMPTY, _EMPTY
    else:
        seeds, level, floor = (np.ascontiguousarray(np.broadcast_to(a, batch), dtype=d).reshape(-1)
                               for a, d in zip(noise, (np.uint64, float, float)))
    pair_frf_kernel(lam2, res2, w, seeds, level, floor, out.reshape(-1, S, w.size))
    return out


def pole_residues(M, C, K, response, reference):
    """Poles and residues of ``(M, C, K)`` from the eigen-decomposition of the state matrix (batched).

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    response : sequence of int
    reference : int
        Drive DOF.

    Returns
    -------
    lam : ndarray, complex, shape (..., n)
        One pole per conjugate pair (``Im > 0``, ascending); NaN for members
        that are not ``n`` conjugate pairs (real poles) or have non-finite matrices.
    residues : ndarray, complex, shape (..., n_response, n)
        ``H_s(w) = sum_j R_sj/(i w - lam_j) + c.c.`` (m/N per rad/s).
    """
    n = M.shape[-1]
    M, C, K = np.broadcast_arrays(np.asarray(M, float), np.asarray(C, float), np.asarray(K, float))
    batch = M.shape[:-2]
    M, C, K = (a.reshape(-1, n, n) for a in (M, C, K))
    good = np.isfinite(C).all(axis=(-2, -1)) & np.isfinite(K).all(axis=(-2, -1))
    Cg = np.where(good[:, None, None], C, 0.0)
    Kg = np.where(good[:, None, None], K, np.eye(n))
    lam, V = np.linalg.eig(state_matrix(M, Cg, Kg))
    Bf = np.zeros(M.shape[:-1] + (1,))
    Bf[:, reference, 0] = 1.0
    Bv = np.concatenate([np.zeros_like(Bf), np.linalg.solve(M, Bf)], axis=-2)
    W = np.linalg.solve(V, Bv.astype(complex))[..., 0]                          # (N, 2n)
    R = V[:, np.atleast_1d(response), :] * W[:, None, :]                          # (N, S, 2n)
    scale = np.max(np.abs(lam), axis=-1, keepdims=True)
    upper = lam.imag > 1e-9 * scale
    ok = (upper.sum(axis=-1) == n) & good
    order = np.argsort(np.where(upper, lam.imag, np.inf), axis=-1)[:, :n]
    lp = np.where(ok[:, None], np.take_along_axis(lam, order, axis=-1), np.nan)
    rp = np.where(ok[:, None, None], np.take_along_axis(R, order[:, None, :], axis=-1), np.nan)
    return lp.reshape(batch + (n,)), rp.reshape(batch + rp.shape[1:])


def state_space_frf(M, C, K, omega_rad_s, response, reference, out=None):
    """Receptance of any ``(M, C, K)`` through its poles and residues (batched).

    Underdamped members use the pair form (:func:`pole_residues`, :func:`pair_frf`);
    others (real poles) the state-space resolvent with all ``2n`` poles. Members
    with non-finite matrices give NaN.

    Returns
    -------
    ndarray, complex, shape (..., n_response, F)
    """
    w = np.asarray(omega_rad_s, float)
    lam, R = pole_residues(M, C, K, response, reference)
    H = pair_frf(lam, R, w, out)
    bad = np.isnan(lam).any(axis=-1)
    if bad.any():
        from physics.frf import receptance_state_space

        Mb, Cb, Kb = (np.broadcast_to(np.asarray(a, float), lam.shape[:-1] + M.shape[-2:])[bad] for a in (M, C, K))
        fin = np.isfinite(Cb).all(axis=(-2, -1)) & np.isfinite(Kb).all(axis=(-2, -1))
        Hb = np.full((Mb.shape[0], H.shape[-2], w.size), np.nan + 0j)
        if fin.any():
            Hb[fin] = receptance_state_space(Mb[fin], Cb[fin], Kb[fin], w, np.atleast_1d(response),
                                             [reference])[..., 0, :]
        H[bad] = Hb
    return H


def full_complex_modes(M, C, K, m):
    """Lowest ``m`` underdamped complex modes of one model from the full state-space eigenproblem.

    Unlike :func:`physics.modal.complex_modes` this tolerates overdamped
    high-order modes (local stiffness-proportional slit damping overdamps the
    mesh's highest modes); they are simply not returned.

    Returns
    -------
    lam : ndarray, complex, shape (m,)      Im > 0, ascending
    psi : ndarray, complex, shape (n, m)    eq.-1.10 normalised
    """
    n = M.shape[-1]
    ev, vec = np.linalg.eig(state_matrix(M, C, K))
    up = ev.imag > 1e-9 * np.max(np.abs(ev))
    order = np.flatnonzero(up)[np.argsort(ev.imag[up])][:m]
    lam = ev[order]
    return lam, normalize_modes(lam, vec[:n, order], M, C)
