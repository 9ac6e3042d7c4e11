"""Model reduction to master DOFs: Guyan, IRS and iterated IRS (eqs. 3.35-3.44).

All functions take ``M`` and ``K`` of shape ``(..., n, n)`` (leading batch
axes allowed) and the integer indices of the master DOFs (see
:meth:`physics.fem.FEModel.index` to get them by name). The remaining DOFs are
slaves. Reduced matrices are over the masters, in the order given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import BeamDamageError, ConvergenceError, ShapeError

__all__ = ["REDUCTIONS", "Reduction", "guyan", "iirs", "irs", "reduce_model"]


@dataclass(frozen=True)
class Reduction:
    """A reduced model.

    Attributes
    ----------
    M, K : ndarray, shape (..., m, m)
        Reduced mass and stiffness matrices (eq. 3.37, 3.40 or 3.44).
    T : ndarray, shape (..., n, m)
        Transformation ``x = T x_m`` in the original DOF order.
    iterations : int
        IIRS iterations performed (0 for Guyan, 1 for IRS).
    converged : bool
    method : str
    """

    M: np.ndarray
    K: np.ndarray
    T: np.ndarray
    iterations: int
    converged: bool
    method: str


def _partition(M, K, masters):
    M = np.asarray(M, dtype=float)
    K = np.asarray(K, dtype=float)
    if M.shape != K.shape or M.ndim < 2 or M.shape[-1] != M.shape[-2]:
        raise ShapeError(f"M and K must be square and of equal shape, got {M.shape} and {K.shape}")
    n = M.shape[-1]
    m = np.asarray(masters, dtype=int).ravel()
    if m.size == 0 or m.size >= n or len(set(m.tolist())) != m.size or m.min() < 0 or m.max() >= n:
        raise BeamDamageError(f"masters must be 1..{n - 1} distinct DOF indices in [0, {n}), got {m.tolist()}")
    s = np.setdiff1d(np.arange(n), m)
    order = np.concatenate([m, s])
    return M[..., order, :][..., :, order], K[..., order, :][..., :, order], m.size, order


def _unpermute(T, order):
    out = np.empty_like(T)
    out[..., order, :] = T
    return out


def _static_t(Kp, nm):
    """``t_s = -K_ss^{-1} K_sm`` (eq. 3.36, 3.43)."""
    return -np.linalg.solve(Kp[..., nm:, nm:], Kp[..., nm:, :nm])


def _reduce(Mp, Kp, t, nm):
    eye = np.broadcast_to(np.eye(nm), t.shape[:-2] + (nm, nm))
    T = np.concatenate([eye, t], axis=-2)  # eq. 3.41
    return T, T.mT @ Mp @ T, T.mT @ Kp @ T  # eq. 3.44


def guyan(M, K, masters) -> Reduction:
    """Guyan (static) reduction (eqs. 3.36-3.37)."""
    Mp, Kp, nm, order = _partition(M, K, masters)
    T, Mr, Kr = _reduce(Mp, Kp, _static_t(Kp, nm), nm)
    return Reduction(Mr, Kr, _unpermute(T, order), 0, True, "guyan")


def _irs_step(Mp, Kp, ts, T, Mr, Kr, nm):
    """``t_{i+1} = t_s + K_ss^{-1} [M_sm M_ss] T_i M_Ri^{-1} K_Ri`` (eq. 3.42)."""
    rhs = Mp[..., nm:, :] @ T @ np.linalg.solve(Mr, Kr)
    return ts + np.linalg.solve(Kp[..., nm:, nm:], rhs)


def irs(M, K, masters) -> Reduction:
    """Improved reduced system, one IRS step from Guyan (eqs. 3.38-3.40)."""
    Mp, Kp, nm, order = _partition(M, K, masters)
    ts = _static_t(Kp, nm)
    T, Mr, Kr = _reduce(Mp, Kp, ts, nm)
    T, Mr, Kr = _reduce(Mp, Kp, _irs_step(Mp, Kp, ts, T, Mr, Kr, nm), nm)
    return Reduction(Mr, Kr, _unpermute(T, order), 1, True, "irs")


def iirs(M, K, masters, *, tol: float = 1e-12, max_iter: int = 1000, raise_on_failure: bool = True) -> Reduction:
    """Iterated improved reduced system (eqs. 3.41-3.44; Friswell et al. 1998).

    Iterates eq. 3.42 from the static transformation (eq. 3.43) until the
    largest relative change of the slave transformation ``t`` falls below
    ``tol`` (the thesis's MATLAB code iterates to exact equality).

    Parameters
    ----------
    M, K : ndarray, shape (..., n, n)
    masters : sequence of int
    tol : float
        Convergence tolerance on ``max|t_{i+1} - t_i| / max|t_{i+1}|``.
    max_iter : int
    raise_on_failure : bool
        Raise :class:`ConvergenceError` when ``tol`` is not reached (default);
        otherwise return the last iterate with ``converged=False``.

    Returns
    -------
    Reduction
    """
    Mp, Kp, nm, order = _partition(M, K, masters)
    ts = _static_t(Kp, nm)
    t = ts
    T, Mr, Kr = _reduce(Mp, Kp, t, nm)
    change = np.inf
    for it in range(1, max_iter + 1):
        t_new = _irs_step(Mp, Kp, ts, T, Mr, Kr, nm)
        scale = np.max(np.abs(t_new), axis=(-2, -1))
        change = float(np.max(np.max(np.abs(t_new - t), axis=(-2, -1)) / scale))
        t = t_new
        T, Mr, Kr = _reduce(Mp, Kp, t, nm)
        if not np.isfinite(change):
            break
        if change < tol:
            return Reduction(Mr, Kr, _unpermute(T, order), it, True, "iirs")
    if raise_on_failure:
        raise ConvergenceError(
            f"IIRS did not converge in {max_iter} iterations (relative change {change:.3g} > tol {tol:g}); "
            "choose masters that capture the lowest modes or raise max_iter",
            iterations=max_iter, residual=change)
    return Reduction(Mr, Kr, _unpermute(T, order), max_iter, False, "iirs")


#: Reduction methods by name.
REDUCTIONS = {"guyan": guyan, "irs": irs, "iirs": iirs}


def reduce_model(M, K, masters, method: str = "iirs") -> Reduction:
    """Reduce ``(M, K)`` to ``masters`` with the method named ``method`` (one of :data:`REDUCTIONS`)."""
    if method not in REDUCTIONS:
        raise BeamDamageError(f"method {method!r} unknown; expected one of {', '.join(REDUCTIONS)}",
                              parameter="method")
    return REDUCTIONS[method](M, K, masters)
