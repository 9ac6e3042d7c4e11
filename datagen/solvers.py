"""Batched solvers of the dataset pipeline: undamped (subspace iteration) and light-damping complex modes.

Pure numerics (arrays in, arrays out) used by the batched pipeline
(:mod:`datagen.pipeline`) and the per-sample cross-check (:mod:`datagen.naive`).
Poles and residues of the updated models are :func:`physics.frf.poles_and_residues`,
FRFs :func:`physics.frf.pole_residue` and :func:`physics.frf.receptance_state_space`.

Conjugate pairs follow :mod:`physics.modal`: one eigenvalue per pair with
``Im > 0``, eq.-1.10 ("unit modal A") normalised shapes.
"""

from __future__ import annotations

import numpy as np

from physics.modal import undamped_modes

__all__ = ["BANDWIDTH", "light_damping_modes", "ritz_modes"]

BANDWIDTH = 3       # half-bandwidth of beam matrices with DOFs ordered node by node


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
    phi : ndarray, shape (..., n, p)   ``phi^T M phi = I``; each mode's sign makes its projection on its
                                       starting vector positive (the same on every LAPACK build)
    """
    from datagen.band_cholesky import band_cholesky, band_cholesky_solve  # numba: only where truth modes are solved

    V = np.broadcast_to(start, K.shape[:-2] + start.shape)
    n = K.shape[-1]
    Kf = np.ascontiguousarray(K).reshape(-1, n, n)
    L = band_cholesky(Kf, BANDWIDTH)  # factor once: beam stiffness is banded (2 DOFs per node)
    for _ in range(iterations):
        MV = np.broadcast_to(M @ V, K.shape[:-2] + V.shape[-2:])
        X = band_cholesky_solve(L, np.ascontiguousarray(MV).reshape(-1, n, V.shape[-1])).reshape(MV.shape)
        Kr = X.mT @ K @ X
        Mr = X.mT @ M @ X
        w, Q = undamped_modes(0.5 * (Mr + Mr.mT), 0.5 * (Kr + Kr.mT))
        V = X @ Q
    sign = np.sign(np.sum(start * V, axis=-2, keepdims=True))
    return w**2, V * np.where(sign == 0, 1.0, sign)


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
