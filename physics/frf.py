"""Frequency response functions of ``(M, C, K)`` models, batched over models and frequencies.

Shapes: every FRF array is ``(..., n_responses, n_references, n_lines)``
(leading batch axes, then response DOF, reference (drive) DOF, frequency line),
the layout of :class:`physics.io.MeasuredFRF`. ``response`` and ``reference``
are integer DOF indices (all DOFs when omitted). Angular frequencies are in
rad/s. Three independent routes give the same receptance:

* direct inversion of the dynamic stiffness ``Z = K - w^2 M + i w C`` (eq. 3.16),
* complex modal superposition with eq.-1.10-normalised modes
  (``H = sum_j psi_j psi_j^T/(i w - lambda_j) + c.c.``, cf. eq. 3.27),
* the state-space model of the thesis's Programs A/B
  (``H = C_out (i w I - A)^-1 B``).
"""

from __future__ import annotations

import numpy as np

from physics.errors import BeamDamageError, ShapeError
from physics.modal import state_matrix

FRF_KINDS = ("receptance", "mobility", "accelerance")


def _omega(omega_rad_s):
    w = np.asarray(omega_rad_s, dtype=float)
    if w.ndim != 1 or not np.all(np.isfinite(w)):
        raise ShapeError("omega_rad_s must be a finite 1-D array of angular frequencies (rad/s)")
    return w


def _idx(sel, n):
    return np.arange(n) if sel is None else np.atleast_1d(np.asarray(sel, dtype=int))


def receptance(M, C, K, omega_rad_s, response=None, reference=None):
    """Receptance by direct inversion of the dynamic stiffness (eq. 3.16).

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    omega_rad_s : ndarray, shape (n_lines,)
    response, reference : sequence of int, optional
        Response and drive DOF indices.

    Returns
    -------
    ndarray, complex, shape (..., n_responses, n_references, n_lines)   (m/N)
    """
    w = _omega(omega_rad_s)
    M, C, K = (np.asarray(a, dtype=float) for a in (M, C, K))
    n = M.shape[-1]
    out, inp = _idx(response, n), _idx(reference, n)
    Z = (K[..., None, :, :] - (w**2)[:, None, None] * M[..., None, :, :]
         + 1j * w[:, None, None] * C[..., None, :, :])
    B = np.zeros((n, inp.size))
    B[inp, np.arange(inp.size)] = 1.0
    X = np.linalg.solve(Z, np.broadcast_to(B, Z.shape[:-1] + (inp.size,)))  # (..., F, n, n_in)
    return np.moveaxis(X[..., out, :], -3, -1)


def receptance_modal(eigenvalues, eigenvectors, omega_rad_s, response=None, reference=None):
    """Receptance by complex modal superposition (conjugate pairs, eq.-1.10 scaling).

    ``H_sr(w) = sum_j [psi_sj psi_rj / (i w - lambda_j) + conj(psi_sj psi_rj) / (i w - conj(lambda_j))]``

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (..., m)
    eigenvectors : ndarray, complex, shape (..., n, m), normalised by eq. 1.10
    omega_rad_s : ndarray, shape (n_lines,)

    Returns
    -------
    ndarray, complex, shape (..., n_responses, n_references, n_lines)
    """
    w = _omega(omega_rad_s)
    lam = np.asarray(eigenvalues, dtype=complex)
    phi = np.asarray(eigenvectors, dtype=complex)
    n = phi.shape[-2]
    out, inp = _idx(response, n), _idx(reference, n)
    po, pi = phi[..., out, :], phi[..., inp, :]
    s = 1j * w
    pole = 1.0 / (s[:, None] - lam[..., None, :])            # (..., F, m)
    pole_c = 1.0 / (s[:, None] - np.conj(lam)[..., None, :])
    return (np.einsum("...sj,...rj,...fj->...srf", po, pi, pole)
            + np.einsum("...sj,...rj,...fj->...srf", np.conj(po), np.conj(pi), pole_c))


def receptance_state_space(M, C, K, omega_rad_s, response=None, reference=None):
    """Receptance of the first-order model of the thesis's Programs A/B.

    ``A = [[0, I], [-M^-1 K, -M^-1 C]]``, ``B = [0; M^-1 B_f]``,
    ``C_out = [S_out, 0]``, ``H(w) = C_out (i w I - A)^-1 B``.

    Returns
    -------
    ndarray, complex, shape (..., n_responses, n_references, n_lines)
    """
    w = _omega(omega_rad_s)
    M, C, K = (np.asarray(a, dtype=float) for a in (M, C, K))
    n = M.shape[-1]
    out, inp = _idx(response, n), _idx(reference, n)
    A = state_matrix(M, C, K)
    Bf = np.zeros((n, inp.size))
    Bf[inp, np.arange(inp.size)] = 1.0
    B = np.concatenate([np.zeros(M.shape[:-2] + (n, inp.size)), np.linalg.solve(M, Bf)], axis=-2)
    sI_A = 1j * w[:, None, None] * np.eye(2 * n) - A[..., None, :, :]
    X = np.linalg.solve(sI_A, B[..., None, :, :])  # (..., F, 2n, n_in)
    return np.moveaxis(X[..., out, :], -3, -1)


def convert_frf(H, omega_rad_s, from_kind: str, to_kind: str):
    """Convert between receptance (m/N), mobility (m/s/N) and accelerance (m/s^2/N).

    Mobility is ``i w`` times receptance, accelerance ``-w^2`` times receptance.
    ``H`` has the frequency lines on its last axis.
    """
    for k in (from_kind, to_kind):
        if k not in FRF_KINDS:
            raise BeamDamageError(f"FRF kind {k!r} unknown; expected one of {FRF_KINDS}")
    s = 1j * _omega(omega_rad_s)
    power = FRF_KINDS.index(to_kind) - FRF_KINDS.index(from_kind)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(H) * s**power


def magnitude_db(H):
    """``20 log10 |H|`` (dB re 1 unit of H)."""
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(H))


def phase_deg(H, unwrap: bool = False):
    """Phase in degrees, optionally unwrapped along the frequency (last) axis."""
    ph = np.angle(H)
    return np.rad2deg(np.unwrap(ph, axis=-1) if unwrap else ph)
