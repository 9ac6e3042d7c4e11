"""Damping identification and stiffness updating from complex modes (Lancaster, Pilkey).

Given the mass matrix ``M`` and a *complete* set of measured complex modes
(one eigenvalue of each conjugate pair and its eigenvector, ``n`` of each for
``n`` DOFs; see the convention in :mod:`physics.modal`):

* Lancaster's damping formula (eq. 1.11) ``C = -M (Phi L^2 Phi^T + c.c.) M``
  and stiffness formula (eq. 1.12) ``K^-1 = -(Phi L^-1 Phi^T + c.c.)`` hold when
  the eigenvectors are normalised by eq. 1.10, ``phi^T (2 lambda M + C) phi = 1``.
* That normalisation needs ``C``, so Pilkey's procedure (Chapter Five) iterates:
  normalise with ``C_k``, compute ``C_{k+1}`` by eq. 1.11, until ``C`` stops
  changing; then ``K`` follows from eq. 1.12 with the last normalised vectors.

Everything works on a leading batch axis, so datagen updates many models at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, OverdampedError, ShapeError
from physics.modal import check_square, normalize_modes


@dataclass(frozen=True)
class UpdateResult:
    """Result of :func:`pilkey`.

    Attributes
    ----------
    C : ndarray, shape (..., n, n)
        Identified damping matrix (N s/m), symmetric.
    K : ndarray, shape (..., n, n)
        Updated stiffness matrix (N/m), eq. 1.12.
    eigenvectors : ndarray, complex, shape (..., n, n)
        Measured eigenvectors normalised with the final ``C`` (eq. 1.10).
    iterations : int
        Iterations performed (``C_1`` is the result of the first).
    converged : bool or ndarray of bool, shape (...)
        Per model when batched.
    residual : float or ndarray, shape (...)
        Last relative change ``||C_k - C_{k-1}||_F / ||C_k||_F``.
    history : ndarray, shape (iterations + 1, ..., n, n) or None
        ``C_0, C_1, ...`` when requested.
    """

    C: np.ndarray
    K: np.ndarray
    eigenvectors: np.ndarray
    iterations: int
    converged: np.ndarray
    residual: np.ndarray
    history: np.ndarray | None = None


def _t(a):
    return np.swapaxes(a, -1, -2)


def check_modal_input(M, eigenvalues, eigenvectors):
    """Validate ``M`` and a complete modal set; returns the arrays.

    Raises
    ------
    ShapeError
        Size mismatch, non-square ``M``, NaN.
    OverdampedError
        Real eigenvalues, or a set that holds both members of a conjugate pair
        (so the conjugate information of another mode is missing).
    """
    M = check_square("M", M)
    n = M.shape[-1]
    lam = np.asarray(eigenvalues, dtype=complex)
    phi = np.asarray(eigenvectors, dtype=complex)
    if lam.shape != M.shape[:-1]:
        raise ShapeError(f"need one eigenvalue per DOF: M is {n}x{n} but {lam.shape[-1] if lam.ndim else 0} "
                         "eigenvalues were given (one of each conjugate pair, a complete set)")
    if phi.shape != M.shape:
        raise ShapeError(f"eigenvectors must be {n}x{n} (rows = DOFs of M, columns = modes), got {phi.shape[-2:]}")
    if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(phi))):
        raise ShapeError("eigenvalues/eigenvectors contain NaN or infinite entries")
    tiny = 1e-9 * np.max(np.abs(lam), axis=-1, keepdims=True)
    if np.any(np.abs(lam.imag) <= tiny):
        raise OverdampedError("real eigenvalue(s) found: Lancaster/Pilkey need underdamped modes, "
                              "eigenvalues in complex conjugate pairs")
    upper = (lam.imag > 0).sum(axis=-1)
    if np.any((upper != 0) & (upper != n)):
        raise OverdampedError("eigenvalues mix both halves of the conjugate pairs; give one eigenvalue of each "
                              "pair (all with Im > 0), the conjugates are implied")
    return M, lam, phi


def lancaster_damping(M, eigenvalues, eigenvectors):
    """Lancaster's damping matrix (eq. 1.11) from eq.-1.10-normalised modes.

    ``C = -M (Phi Lambda^2 Phi^T + conj(Phi Lambda^2 Phi^T)) M``

    Parameters
    ----------
    M : ndarray, shape (..., n, n)
    eigenvalues : ndarray, complex, shape (..., n)
    eigenvectors : ndarray, complex, shape (..., n, n), normalised by eq. 1.10

    Returns
    -------
    ndarray, shape (..., n, n), real symmetric
    """
    phi = np.asarray(eigenvectors)
    inner = (phi * np.asarray(eigenvalues)[..., None, :] ** 2) @ _t(phi)
    return -M @ (2 * inner.real) @ M


def lancaster_stiffness(eigenvalues, eigenvectors):
    """Lancaster's stiffness matrix (eq. 1.12) from eq.-1.10-normalised modes.

    ``K = -(Phi Lambda^-1 Phi^T + conj(Phi Lambda^-1 Phi^T))^-1``

    Returns
    -------
    ndarray, shape (..., n, n), real symmetric
    """
    phi = np.asarray(eigenvectors)
    flex = -2 * ((phi / np.asarray(eigenvalues)[..., None, :]) @ _t(phi)).real
    K = np.linalg.inv(flex)
    return 0.5 * (K + _t(K))


def pilkey(M, eigenvalues, eigenvectors, C0=None, *, tol: float = 1e-10, max_iter: int = 500,
           keep_history: bool = False, raise_on_failure: bool = True) -> UpdateResult:
    """Iterative damping identification and stiffness updating (Pilkey; thesis Chapter Five).

    Repeats: normalise the measured eigenvectors with the current damping
    matrix (eq. 5.2), compute the next damping matrix by Lancaster's formula
    (eq. 5.3), until ``||C_k - C_{k-1}||_F <= tol ||C_k||_F``; then the
    stiffness matrix by eq. 5.4.

    Parameters
    ----------
    M : ndarray, shape (..., n, n)
        Mass matrix (reduced or lumped), trusted.
    eigenvalues : ndarray, complex, shape (..., n)
        One eigenvalue of each conjugate pair, a complete set.
    eigenvectors : ndarray, complex, shape (..., n, n)
        Matching eigenvectors (columns are modes), any scaling.
    C0 : ndarray, shape (..., n, n), optional
        Starting damping matrix; identity as in the thesis.
    tol : float
        Relative Frobenius-norm change that counts as converged.
    max_iter : int
    keep_history : bool
        Store ``C_0, C_1, ...`` in ``history``.
    raise_on_failure : bool
        Raise :class:`ConvergenceError` when any model does not converge
        (default). With ``False`` the result flags it in ``converged``.

    Returns
    -------
    UpdateResult
    """
    M, lam, phi = check_modal_input(M, eigenvalues, eigenvectors)
    M = M.astype(float)
    C = np.broadcast_to(np.eye(M.shape[-1]), M.shape).copy() if C0 is None else \
        np.array(check_square("C0", C0, M.shape[-1]), dtype=float)
    history = [C] if keep_history else None
    residual = np.full(M.shape[:-2], np.inf)
    done = np.zeros(M.shape[:-2], dtype=bool)
    it = 0
    for it in range(1, max_iter + 1):
        C_new = lancaster_damping(M, lam, normalize_modes(lam, phi, M, C))
        C_new = 0.5 * (C_new + _t(C_new))
        norm = np.linalg.norm(C_new, axis=(-2, -1))
        residual = np.linalg.norm(C_new - C, axis=(-2, -1)) / np.where(norm > 0, norm, 1.0)
        # models that already converged keep their matrix (batch members are independent)
        C = np.where(done[..., None, None], C, C_new)
        if keep_history:
            history.append(C)
        done = done | (residual <= tol)
        if np.all(done) or not np.all(np.isfinite(residual[~done])):
            break
    finite = np.isfinite(residual)
    converged = done & finite
    if raise_on_failure and not np.all(converged):
        worst = float(np.max(np.where(finite, residual, np.inf)))
        raise ConvergenceError(
            f"Pilkey damping iteration did not converge after {it} iterations (relative change {worst:.3g} > "
            f"tol {tol:g}); the modal data may be inconsistent with M (check scaling, mode order and that "
            "the set is complete)", iterations=it, residual=worst)
    phi_n = normalize_modes(lam, phi, M, C)
    K = lancaster_stiffness(lam, phi_n)
    return UpdateResult(
        C=C, K=K, eigenvectors=phi_n, iterations=it,
        converged=converged if converged.ndim else bool(converged),
        residual=residual if residual.ndim else float(residual),
        history=np.stack(history) if keep_history else None,
    )
