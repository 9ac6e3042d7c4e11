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

__all__ = ["ComplexModes", "EigenvalueParameters", "check_square", "complex_modes", "eigenvalues_from_modal", "mac",
           "modal_parameters", "normalize_modes", "state_matrix", "undamped_frequencies_rad_s", "undamped_modes",
           "underdamped_modes", "upper_half"]


class EigenvalueParameters:
    """Natural frequencies (Hz) and damping ratios of an ``eigenvalues`` attribute (:func:`modal_parameters`)."""

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return modal_parameters(self.eigenvalues)[0]

    @property
    def damping_ratios(self) -> np.ndarray:
        return modal_parameters(self.eigenvalues)[1]


@dataclass(frozen=True)
class ComplexModes(EigenvalueParameters):
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


def upper_half(evals):
    """Mask of the eigenvalues with ``Im > 0`` (relative to the largest modulus), shape like ``evals``."""
    scale = np.max(np.abs(evals), axis=-1, keepdims=True)
    return evals.imag > 1e-9 * scale


def _lowest_upper(evals, evecs, n, m):
    """The ``m`` upper-half eigenvalues of smallest ``Im`` and their displacement parts."""
    upper = upper_half(evals)
    order = np.argsort(np.where(upper, evals.imag, np.inf), axis=-1)[..., :m]
    lam = np.take_along_axis(evals, order, axis=-1)
    vec = np.take_along_axis(evecs[..., :n, :], order[..., None, :], axis=-1)
    return upper, lam, vec


def complex_modes(M, C, K) -> ComplexModes:
    """Complex eigenvalues and eigenvectors of ``(M, C, K)`` by the state-space form.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
        Leading axes are batch axes.

    Returns
    -------
    ComplexModes
        In the conjugate-pair convention of this module, all ``n`` modes.

    Raises
    ------
    OverdampedError
        If any eigenvalue is real (overdamped or rigid-body mode), so that the
        eigenvalues do not form ``n`` conjugate pairs. See
        :func:`underdamped_modes` for a variant that tolerates overdamped high modes.
    """
    M = check_square("M", M)
    n = M.shape[-1]
    C = check_square("C", C, n)
    K = check_square("K", K, n)
    evals, evecs = np.linalg.eig(state_matrix(M, C, K))
    upper, lam, vec = _lowest_upper(evals, evecs, n, n)
    if np.any(upper.sum(axis=-1) != n):
        raise OverdampedError(
            "the system has real eigenvalues (overdamped or rigid-body modes); "
            "complex modes need n underdamped conjugate pairs")
    return ComplexModes(lam, normalize_modes(lam, vec, M, C))


def underdamped_modes(M, C, K, n_modes: int) -> ComplexModes:
    """The lowest ``n_modes`` underdamped complex modes, tolerating overdamped high modes.

    Local damping (e.g. stiffness-proportional damping of a slit on a fine mesh)
    can overdamp a mesh's highest modes; those are real eigenvalues and are
    simply not returned. Same convention as :func:`complex_modes`.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    n_modes : int
        Number of modes returned, ``1 <= n_modes <= n``.

    Returns
    -------
    ComplexModes
        ``eigenvalues`` (..., n_modes), ``eigenvectors`` (..., n, n_modes), eq.-1.10 normalised.

    Raises
    ------
    OverdampedError
        If some member has fewer than ``n_modes`` underdamped modes.
    """
    M = check_square("M", M)
    n = M.shape[-1]
    C = check_square("C", C, n)
    K = check_square("K", K, n)
    if not 1 <= int(n_modes) <= n:
        raise ShapeError(f"n_modes must be in [1, {n}], got {n_modes}")
    evals, evecs = np.linalg.eig(state_matrix(M, C, K))
    upper, lam, vec = _lowest_upper(evals, evecs, n, int(n_modes))
    if np.any(upper.sum(axis=-1) < n_modes):
        raise OverdampedError(f"fewer than n_modes={n_modes} underdamped modes (complex conjugate pairs)")
    return ComplexModes(lam, normalize_modes(lam, vec, M, C))


def modal_parameters(eigenvalues):
    """Natural frequencies (Hz) and damping ratios of complex eigenvalues (inverse of eq. 3.30).

    ``omega_j = |lambda_j|``, ``zeta_j = -Re(lambda_j) / |lambda_j|``.

    Parameters
    ----------
    eigenvalues : array_like, complex, shape (...)
        Eigenvalues in rad/s (the ``Im > 0`` member of each pair).

    Returns
    -------
    natural_frequencies_hz, damping_ratios : ndarray, shape like ``eigenvalues``
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    w = np.abs(lam)
    return w / (2 * np.pi), -lam.real / w


def eigenvalues_from_modal(natural_frequencies_hz, damping_ratios):
    """``lambda = -zeta w + i w sqrt(1 - zeta^2)`` with ``w = 2 pi f`` (eq. 3.30).

    Parameters
    ----------
    natural_frequencies_hz : array_like, shape (...)
        Natural (undamped) frequencies ``f = |lambda| / (2 pi)`` (Hz).
    damping_ratios : array_like, shape (...)
        Modal damping ratios, ``|zeta| < 1``.

    Returns
    -------
    ndarray, complex, shape (...)   (rad/s), ``Im > 0``

    Raises
    ------
    OverdampedError
        If some ``|zeta| >= 1`` (no complex conjugate pair).
    """
    w = 2 * np.pi * np.asarray(natural_frequencies_hz, dtype=float)
    z = np.asarray(damping_ratios, dtype=float)
    if np.any(np.abs(z) >= 1):
        raise OverdampedError("damping_ratios must satisfy |zeta| < 1 for complex conjugate eigenvalues")
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
    A = np.linalg.solve(L, Linv_K.mT)  # L^-1 K L^-T (symmetric)
    w2, v = np.linalg.eigh(0.5 * (A + A.mT))
    phi = np.linalg.solve(L.mT, v)
    return np.sqrt(np.clip(w2, 0.0, None)), phi


def undamped_frequencies_rad_s(M, K) -> np.ndarray:
    """Undamped natural frequencies (rad/s, ascending, shape (n,)) of one model, each to the precision of its end
    of the spectrum.

    :func:`undamped_modes` solves ``K phi = w^2 M phi``, whose eigenvalues carry an absolute error of about
    ``eps w_max^2``: the lowest lose ``eps w_max^2 / w_1^2`` of themselves, 1e-3 of ``f_1`` on a cantilever of 1000
    Hermite elements. With ``K`` positive definite (a supported beam), the inverse problem ``M phi = w^-2 K phi``
    errs by ``eps / w_1^2`` and keeps the lowest ones; each frequency is taken from the problem that holds it (the
    inverse's below the geometric mean of the spectrum's ends, the direct one's above).
    """
    w, _ = undamped_modes(M, K)
    try:
        L = np.linalg.cholesky(K)
    except np.linalg.LinAlgError:                           # rigid-body modes: the direct problem alone
        return w
    B = np.linalg.solve(L, np.linalg.solve(L, M).T)         # L^-1 M L^-T (symmetric)
    mu = np.linalg.eigvalsh(0.5 * (B + B.T))[::-1]          # 1 / w^2, descending
    low = 1.0 / np.sqrt(np.clip(mu, np.finfo(float).tiny, None))
    return np.where(w < np.sqrt(w[0] * w[-1]), low, w)


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
    cross = np.abs(np.conj(a.mT) @ b) ** 2
    na = np.sum(np.abs(a) ** 2, axis=-2)
    nb = np.sum(np.abs(b) ** 2, axis=-2)
    return cross / (na[..., :, None] * nb[..., None, :])
