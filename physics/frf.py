"""Frequency response functions of ``(M, C, K)`` and modal models, batched over models and frequencies.

Shapes: every FRF array is ``(..., n_responses, n_references, n_lines)``
(leading batch axes, then response DOF, reference (drive) DOF, frequency line),
the layout of :class:`physics.io.MeasuredFRF`. ``response`` and ``reference``
are integer DOF indices (all DOFs when omitted). Angular frequencies are in
rad/s. Three independent routes give the same receptance:

* direct inversion of the dynamic stiffness ``Z = K - w^2 M + i w C`` (eq. 3.16),
  :func:`receptance`;
* complex modal superposition with eq.-1.10-normalised modes
  (``H = sum_j psi_j psi_j^T/(i w - lambda_j) + c.c.``, cf. eq. 3.27),
  :func:`receptance_modal`, on top of the one pole-residue FRF :func:`pole_residue`
  (with a compiled backend for datasets);
* the state-space model of the thesis's Programs A/B
  (``H = C_out (i w I - A)^-1 B``), :func:`receptance_state_space`, which also
  handles overdamped members and NaN members of a batch; its poles and residues
  come from :func:`poles_and_residues`.

FRF kinds (:data:`FRF_KINDS`, units :data:`FRF_UNITS`) convert with :func:`convert_frf`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import BeamDamageError, ShapeError
from physics.modal import upper_half, state_matrix

__all__ = ["FRF_KINDS", "FRF_UNITS", "PoleResidues", "check_frf_kind", "convert_frf", "magnitude_db", "phase_deg",
           "pole_residue", "poles_and_residues", "receptance", "receptance_modal", "receptance_state_space"]


#: Displacement, velocity and acceleration over force, in the order of the power of ``i w``.
FRF_KINDS = ("receptance", "mobility", "accelerance")
#: SI units of each kind.
FRF_UNITS = {"receptance": "m/N", "mobility": "m/s/N", "accelerance": "m/s^2/N"}


def _omega(omega_rad_s):
    w = np.asarray(omega_rad_s, dtype=float)
    if w.ndim != 1 or not np.all(np.isfinite(w)):
        raise ShapeError("omega_rad_s must be a finite 1-D array of angular frequencies (rad/s)")
    return w


def _idx(sel, n):
    return np.arange(n) if sel is None else np.atleast_1d(np.asarray(sel, dtype=int))


def receptance(M, C, K, omega_rad_s, response=None, reference=None):
    """Receptance by direct inversion of the dynamic stiffness (eq. 3.16), one solve per line.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    omega_rad_s : ndarray, shape (n_lines,)
    response, reference : sequence of int, optional
        Response and reference (drive) DOF indices.

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


def pole_residue(eigenvalues, residues, omega_rad_s, *, lower_residual=None, upper_residual=None, out=None,
                 backend: str = "numba"):
    """FRF of a pole-residue (modal) model, conjugate pairs implied (cf. eqs. 3.27, 3.30).

    ``H_s(w) = sum_j [R_sj/(i w - lambda_j) + conj(R_sj)/(i w - conj(lambda_j))] - LR_s/w^2 + UR_s``

    The one pole-residue FRF of the package: :func:`receptance_modal`,
    :func:`receptance_state_space`, identification and datagen all use it.

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (..., m)
        One pole of each conjugate pair (rad/s), ``Im > 0``.
    residues : ndarray, complex, shape (..., S, m)
        Residue of each response channel ``s`` and mode (``R_sj = psi_sj psi_rj``
        for eq.-1.10 modes and reference DOF ``r``). ``eigenvalues[..., None, :]``
        must broadcast against ``residues``: e.g. eigenvalues (B, m) with
        residues (B, S, m), or eigenvalues (m,) with residues (n_resp, n_ref, m).
    omega_rad_s : ndarray, shape (F,)
        Angular frequency lines (rad/s).
    lower_residual, upper_residual : ndarray, shape (..., S), optional
        Residual terms ``-LR/w^2`` (mass line) and ``UR`` (flexibility) of the
        modes outside the band (the lower one is infinite at 0 rad/s).
    out : ndarray, complex, shape (..., S, F), optional
        C-contiguous storage written in place (e.g. complex64 dataset arrays);
        ``backend="numba"`` only. Values are accumulated in float64 and written once.
    backend : {"numba", "numpy"}
        ``"numba"``: one compiled pass (:func:`physics.frf_kernels.pole_residue_kernel`),
        the fast path for datasets; ``"numpy"``: array expressions. Equal to rounding.

    Returns
    -------
    ndarray, complex, shape (..., S, F)   (``out`` when given)
    """
    w = _omega(omega_rad_s)
    lam = np.asarray(eigenvalues, dtype=complex)
    R = np.asarray(residues, dtype=complex)
    if lam.ndim < 1 or R.ndim < 2:
        raise ShapeError(f"eigenvalues must be (..., m) and residues (..., S, m), got {lam.shape} and {R.shape}")
    try:
        full = np.broadcast_shapes(lam.shape[:-1] + (1,) + lam.shape[-1:], R.shape)
    except ValueError:
        raise ShapeError(f"eigenvalues {lam.shape} and residues {R.shape} do not broadcast as (..., m) and "
                         "(..., S, m)") from None
    batch, (S, m) = full[:-2], full[-2:]
    if backend == "numpy":
        if out is not None:
            raise BeamDamageError("out needs backend='numba'", parameter="out")
        s = 1j * w
        g = 1.0 / (s - lam[..., :, None])                      # (..., m, F)
        gc = 1.0 / (s - np.conj(lam)[..., :, None])
        H = R @ g + np.conj(R) @ gc
    elif backend == "numba":
        from physics.frf_kernels import pole_residue_kernel  # numba: compiled on first use of this backend

        n = int(np.prod(batch, dtype=int))
        lam2 = np.ascontiguousarray(np.broadcast_to(lam, batch + (m,)).reshape(n, m))
        R2 = np.ascontiguousarray(np.broadcast_to(R, full).reshape(n, S, m))
        if out is None:
            H = np.empty(batch + (S, w.size), complex)
        elif out.shape != batch + (S, w.size) or not out.flags.c_contiguous or not np.iscomplexobj(out):
            raise ShapeError(f"out must be a C-contiguous complex array of shape {batch + (S, w.size)}, "
                             f"got {out.shape}", parameter="out")
        else:
            H = out
        pole_residue_kernel(lam2, R2, np.ascontiguousarray(w), H.reshape(n, S, w.size))
    else:
        raise BeamDamageError(f"backend {backend!r} unknown; expected 'numba' or 'numpy'", parameter="backend")
    if lower_residual is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            H += np.asarray(lower_residual)[..., None] / (1j * w) ** 2
    if upper_residual is not None:
        H += np.asarray(upper_residual)[..., None]
    return H


def receptance_modal(eigenvalues, eigenvectors, omega_rad_s, response=None, reference=None):
    """Receptance by complex modal superposition (conjugate pairs, eq.-1.10 scaling).

    ``H_sr(w) = sum_j [psi_sj psi_rj / (i w - lambda_j) + conj(psi_sj psi_rj) / (i w - conj(lambda_j))]``,
    i.e. :func:`pole_residue` with residues ``psi_sj psi_rj``.

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (..., m)
    eigenvectors : ndarray, complex, shape (..., n, m), normalised by eq. 1.10
    omega_rad_s : ndarray, shape (n_lines,)
    response, reference : sequence of int, optional
        Response and reference (drive) DOF indices (all when omitted).

    Returns
    -------
    ndarray, complex, shape (..., n_responses, n_references, n_lines)
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    phi = np.asarray(eigenvectors, dtype=complex)
    n = phi.shape[-2]
    out, inp = _idx(response, n), _idx(reference, n)
    residues = phi[..., out, None, :] * phi[..., None, inp, :]      # (..., n_out, n_in, m)
    return pole_residue(lam[..., None, :], residues, omega_rad_s)


@dataclass(frozen=True)
class PoleResidues:
    """Poles and residues of ``(M, C, K)`` models (result of :func:`poles_and_residues`).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (..., n)
        One pole of each conjugate pair (rad/s), ``Im > 0``, ascending.
    residues : ndarray, complex, shape (..., n_responses, n_references, n)
        ``H_sr(w) = sum_j R_srj/(i w - lambda_j) + c.c.`` (m/N times rad/s); feed
        both to :func:`pole_residue` as ``(eigenvalues[..., None, :], residues)``.
    underdamped : ndarray of bool, shape (...)
        Members with ``n`` conjugate pairs and finite matrices; the others hold NaN.
    """

    eigenvalues: np.ndarray
    residues: np.ndarray
    underdamped: np.ndarray


def _state_space_eig(M, C, K, response, reference):
    """Eigen-decomposition of the state matrix of flattened models and the residues of every pole.

    Returns ``batch, n, (o, r), mu (N, 2n), res (N, n_out * n_in, 2n), good (N,)``; members
    with non-finite ``C`` or ``K`` (``good`` False) are replaced by a harmless model.
    """
    M, C, K = np.broadcast_arrays(np.asarray(M, float), np.asarray(C, float), np.asarray(K, float))
    n = M.shape[-1]
    if M.ndim < 2 or M.shape[-2] != n:
        raise ShapeError(f"M, C and K must have shape (..., n, n), got {M.shape}")
    o, r = _idx(response, n), _idx(reference, n)
    batch = M.shape[:-2]
    M, C, K = (a.reshape(-1, n, n) for a in (M, C, K))
    good = np.isfinite(C).all(axis=(-2, -1)) & np.isfinite(K).all(axis=(-2, -1))
    C = np.where(good[:, None, None], C, 0.0)
    K = np.where(good[:, None, None], K, np.eye(n))
    mu, V = np.linalg.eig(state_matrix(M, C, K))
    Bf = np.zeros((n, r.size))
    Bf[r, np.arange(r.size)] = 1.0
    B = np.concatenate([np.zeros((M.shape[0], n, r.size)), np.linalg.solve(M, Bf)], axis=-2)
    W = np.linalg.solve(V, B.astype(complex))                                   # (N, 2n, n_in)
    res = V[:, o, None, :] * W.mT[:, None, :, :]              # (N, n_out, n_in, 2n)
    return batch, n, (o, r), mu, res.reshape(M.shape[0], o.size * r.size, 2 * n), good


def _pairs(mu, res, n):
    """Upper-half poles (N, n), their residues (N, S, n) and which members are ``n`` conjugate pairs."""
    upper = upper_half(mu)
    order = np.argsort(np.where(upper, mu.imag, np.inf), axis=-1)[:, :n]
    return (np.take_along_axis(mu, order, axis=-1), np.take_along_axis(res, order[:, None, :], axis=-1),
            upper.sum(axis=-1) == n)


def poles_and_residues(M, C, K, response=None, reference=None) -> PoleResidues:
    """Poles and residues of ``(M, C, K)`` from the eigen-decomposition of the state matrix (batched).

    ``A = [[0, I], [-M^-1 K, -M^-1 C]] = V diag(mu) V^-1`` (Programs A/B);
    the residue of pole ``mu_k`` is ``R_srk = V_sk (V^-1 B)_kr`` with
    ``B = [0; M^-1 B_f]``. This is what a dataset stores to synthesise FRFs
    with :func:`pole_residue` later; :func:`receptance_state_space` evaluates it.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    response, reference : sequence of int, optional
        Response and reference (drive) DOF indices (all when omitted).

    Returns
    -------
    PoleResidues
        NaN for members that are not ``n`` underdamped pairs or have non-finite ``C``, ``K``.
    """
    batch, n, (o, r), mu, res, good = _state_space_eig(M, C, K, response, reference)
    lam, R, pairs = _pairs(mu, res, n)
    ok = pairs & good
    lam = np.where(ok[:, None], lam, np.nan)
    R = np.where(ok[:, None, None], R, np.nan)
    return PoleResidues(lam.reshape(batch + (n,)), R.reshape(batch + (o.size, r.size, n)), ok.reshape(batch))


def receptance_state_space(M, C, K, omega_rad_s, response=None, reference=None, *, out=None):
    """Receptance of the first-order model of the thesis's Programs A/B, batched.

    ``H(w) = C_out (i w I - A)^-1 B = C_out V diag(1/(i w - mu)) V^-1 B``
    (see :func:`poles_and_residues`): one eigenproblem per model, then
    :func:`pole_residue` over the lines. Any damping works: members whose
    eigenvalues are ``n`` conjugate pairs use the pair form, others
    (overdamped or rigid-body modes) sum over all ``2n`` poles. Members with
    non-finite ``C`` or ``K`` (e.g. failed updates in a batch) give NaN
    instead of raising.

    Parameters
    ----------
    M, C, K : ndarray, shape (..., n, n)
    omega_rad_s : ndarray, shape (n_lines,)
    response, reference : sequence of int, optional
    out : ndarray, complex, shape (..., n_responses, n_references, n_lines), optional
        C-contiguous storage written in place (e.g. complex64).

    Returns
    -------
    ndarray, complex, shape (..., n_responses, n_references, n_lines)
    """
    w = _omega(omega_rad_s)
    batch, n, (o, r), mu, res, good = _state_space_eig(M, C, K, response, reference)
    shape = batch + (o.size, r.size, w.size)
    if out is not None and (out.shape != shape or not out.flags.c_contiguous or not np.iscomplexobj(out)):
        raise ShapeError(f"out must be a C-contiguous complex array of shape {shape}, got {out.shape}",
                         parameter="out")
    lam, R, pairs = _pairs(mu, res, n)
    if pairs.all() and good.all():  # the usual case: straight into the output
        H = pole_residue(lam, R, w, out=None if out is None else out.reshape(-1, o.size * r.size, w.size))
        return out if out is not None else H.reshape(shape)
    H = np.empty((mu.shape[0], o.size * r.size, w.size), complex)
    if pairs.any():
        H[pairs] = pole_residue(lam[pairs], R[pairs], w)
    if (~pairs).any():
        H[~pairs] = res[~pairs] @ (1.0 / (1j * w - mu[~pairs][:, :, None]))
    H[~good] = np.nan
    if out is None:
        return H.reshape(shape)
    out[...] = H.reshape(shape)
    return out


def check_frf_kind(kind: str, name: str = "kind") -> str:
    """Return ``kind`` if it is one of :data:`FRF_KINDS`, else raise naming the parameter ``name``."""
    if kind not in FRF_KINDS:
        raise BeamDamageError(f"FRF kind {kind!r} ({name}) unknown; expected one of {', '.join(FRF_KINDS)}")
    return kind


def convert_frf(H, omega_rad_s, from_kind: str, to_kind: str):
    """Convert between receptance (m/N), mobility (m/s/N) and accelerance (m/s^2/N).

    Mobility is ``i w`` times receptance, accelerance ``-w^2`` times receptance.
    ``H`` has the frequency lines on its last axis. Converting towards
    receptance divides by ``i w``, so a 0 rad/s line is then rejected.

    Raises
    ------
    BeamDamageError
        Unknown kind (the message names ``from_kind`` or ``to_kind``).
    ShapeError
        Division by ``i w`` at a 0 rad/s line.
    """
    power = (FRF_KINDS.index(check_frf_kind(to_kind, "to_kind"))
             - FRF_KINDS.index(check_frf_kind(from_kind, "from_kind")))
    w = _omega(omega_rad_s)
    if power == 0:
        return np.asarray(H)
    if power < 0 and np.any(w == 0):
        raise ShapeError(f"cannot convert a {from_kind} to a {to_kind} at 0 rad/s: drop the 0 line first")
    return np.asarray(H) * (1j * w) ** power

def magnitude_db(H):
    """``20 log10 |H|`` (dB re 1 unit of H); a zero magnitude is read as ``1e-300`` (-6000 dB), so differences of
    magnitudes stay finite."""
    return 20.0 * np.log10(np.maximum(np.abs(H), 1e-300))


def phase_deg(H, unwrap: bool = False):
    """Phase in degrees, optionally unwrapped along the frequency (last) axis."""
    ph = np.angle(H)
    return np.rad2deg(np.unwrap(ph, axis=-1) if unwrap else ph)
