"""Complex modal analysis of viscously damped systems ``M x'' + C x' + K x = f``.

Conjugate-pair convention
-------------------------
An underdamped system of ``n`` DOFs has ``2n`` eigenvalues in complex
conjugate pairs. Everywhere in this package a modal set keeps the ``n``
eigenvalues with positive imaginary part, sorted by ascending imaginary part,

    ``lambda_j = -zeta_j omega_j + i omega_j sqrt(1 - zeta_j^2)``,

with ``omega_j = |lambda_j|`` (rad/s) and ``zeta_j = -Re(lambda_j)/|lambda_j|``.
The other half is ``conj(lambda_j)`` with eigenvector ``conj(psi_j)``.
Eigenvectors are the displacement part of the state-space eigenvectors,
columns are modes, scaled by Lancaster's normalisation (eq. 1.10)

    ``psi_j^T (2 lambda_j M + C) psi_j = 1``   ("unit modal A"),

which makes the receptance ``H(w) = sum_j psi_j psi_j^T / (i w - lambda_j) + c.c.``
and Lancaster's damping and stiffness formulas (eqs. 1.11, 1.12) exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import OverdampedError, ShapeError


@dataclass(frozen=True)
class ComplexModes:
    """Complex eigen-solution in the conjugate-pair convention.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (..., n)
        ``Im > 0``, ascending.
    eigenvectors : ndarray, complex, shape (..., n, n)
        Columns are modes, normalised by eq. 1.10.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return modal_parameters(self.eigenvalues)[0]

    @property
    def damping_ratios(self) -> np.ndarray:
        return modal_parameters(self.eigenvalues)[1]


def _t(a):
    return np.swapaxes(a, -1, -2)


def check_square(name, A, n=None):
    """Validate a finite square (batched) matrix; returns it as float or complex array."""
    A = np.asarray(A)
    if A.ndim < 2 or A.shape[-1] != A.shape[-2] or (n is not None and A.shape[-1] != n):
        want = f"({n}, {n})" if n is not None else "(n, n)"
        raise ShapeError(f"{name} must have shape (..., {want[1:-1]}), got {A.shape}")
    if not np.all(np.isfinite(A)):
        raise ShapeError(f"{name} has NaN or infinite entries")
    return A


def state_matrix(M, C, K):
    """First-order system matrix ``A = [[0, I], [-M^-1 K, -M^-1 C]]`` (Program A/B), shape (..., 2n, 2n)."""
    n = M.shape[-1]
    minv_k = np.linalg.solve(M, K)
    minv_c = np.linalg.solve(M, C)
    top = np.concatenate([np.zeros_like(minv_k), np.broadcast_to(np.eye(n), minv_k.shape)], axis=-1)
    return np.concatenate([top, np.concatenate([-minv_k, -minv_c], axis=-1)], axis=-2)


def normalize_modes(eigenvalues, eigenvectors, M, C):
    """Scale eigenvectors so that ``psi^T (2 lambda M + C) psi = 1`` (eq. 1.10).

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (..., m)
    eigenvectors : ndarray, complex, shape (..., n, m)
    M, C : ndarray, shape (..., n, n)

    Returns
    -------
    ndarray, complex, shape (..., n, m)
    """
    lam = np.asarray(eigenvalues)
    phi = np.asarray(eigenvectors, dtype=complex)
    h = np.sum(phi * (2 * lam[..., None, :] * (M @ phi) + C @ phi), axis=-2)  # psi_j^T (2 lam_j M + C) psi_j
    return phi / np.sqrt(h)[..., None, :]


def complex_modes(M, C, K) -> ComplexModes:
    """Complex eigenvalues and eigenvectors of ``(M, C, K)`` by the state-space form.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
        Leading axes are batch axes.

    Returns
    -------
    ComplexModes
        In the conjugate-pair convention of this module.

    Raises
    ------
    OverdampedError
        If any eigenvalue is real (overdamped or rigid-body mode), so that the
        eigenvalues do not form ``n`` conjugate pairs.
    """
    M = check_square("M", M)
    n = M.shape[-1]
    C = check_square("C", C, n)
    K = check_square("K", K, n)
    evals, evecs = np.linalg.eig(state_matrix(M, C, K))
    scale = np.max(np.abs(evals), axis=-1, keepdims=True)
    upper = evals.imag > 1e-9 * scale
    if np.any(upper.sum(axis=-1) != n):
        raise OverdampedError(
            "the system has real eigenvalues (overdamped or rigid-body modes); "
            "complex modes need n underdamped conjugate pairs")
    order = np.argsort(np.where(upper, evals.imag, np.inf), axis=-1)[..., :n]
    lam = np.take_along_axis(evals, order, axis=-1)
    vec = np.take_along_axis(evecs[..., :n, :], order[..., None, :], axis=-1)
    return ComplexModes(lam, normalize_modes(lam, vec, M, C))


def modal_parameters(eigenvalues):
    """Natural frequencies (Hz) and damping ratios of complex eigenvalues.

    ``omega_j = |lambda_j|``, ``zeta_j = -Re(lambda_j) / |lambda_j|``.

    Returns
    -------
    natural_frequencies_hz, damping_ratios : ndarray, shape like ``eigenvalues``
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    w = np.abs(lam)
    return w / (2 * np.pi), -lam.real / w


def eigenvalues_from_modal(natural_frequencies_hz, damping_ratios):
    """``lambda = -zeta w + i w sqrt(1 - zeta^2)`` with ``w = 2 pi f`` (eq. 3.30)."""
    w = 2 * np.pi * np.asarray(natural_frequencies_hz, dtype=float)
    z = np.asarray(damping_ratios, dtype=float)
    if np.any(np.abs(z) >= 1):
        raise OverdampedError("damping ratios must satisfy |zeta| < 1 for complex conjugate eigenvalues")
    return -z * w + 1j * w * np.sqrt(1 - z**2)


def undamped_modes(M, K):
    """Undamped natural frequencies (rad/s) and mass-normalised real modes.

    Parameters
    ----------
    M, K : ndarray, shape (..., n, n), symmetric, ``M`` positive definite.

    Returns
    -------
    omega_rad_s : ndarray, shape (..., n), ascending
    phi : ndarray, shape (..., n, n), ``phi^T M phi = I``
    """
    L = np.linalg.cholesky(M)
    Linv_K = np.linalg.solve(L, K)
    A = np.linalg.solve(L, _t(Linv_K))  # L^-1 K L^-T (symmetric)
    w2, v = np.linalg.eigh(0.5 * (A + _t(A)))
    phi = np.linalg.solve(_t(L), v)
    return np.sqrt(np.clip(w2, 0.0, None)), phi


def mac(phi_a, phi_b=None):
    """Modal assurance criterion between the columns of two mode-shape sets.

    ``MAC_ij = |a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j))``.

    Parameters
    ----------
    phi_a : ndarray, shape (..., n, m_a)
    phi_b : ndarray, shape (..., n, m_b), optional (defaults to ``phi_a``)

    Returns
    -------
    ndarray, shape (..., m_a, m_b), values in [0, 1]
    """
    a = np.asarray(phi_a, dtype=complex)
    b = a if phi_b is None else np.asarray(phi_b, dtype=complex)
    cross = np.abs(np.conj(_t(a)) @ b) ** 2
    na = np.sum(np.abs(a) ** 2, axis=-2)
    nb = np.sum(np.abs(b) ** 2, axis=-2)
    return cross / (na[..., :, None] * nb[..., None, :])
