"""The stabilisation diagram of shift-invariant (subspace) models of every order from one column space: the state
matrix of each order from one QR factorisation of the largest order's shifted observability matrix, its
continuous-time eigenvalues and shapes, the physical poles kept. Shared by SSI-cov
(:mod:`~physics.identification.ssi`, the block Toeplitz matrix of output correlations) and ERA
(:mod:`~physics.identification.free_decay`, the block Hankel matrix of free decays).
"""

from __future__ import annotations

import numpy as np

from physics.identification.poles import MAX_DAMPING, StabilisationDiagram, damping_resolution, stability_status

__all__ = ["MAX_QR_CONDITION", "poles_of_order", "state_matrices", "subspace_diagram"]


#: Largest condition number of the shifted observability matrix whose orders are solved from its one QR
#: factorisation; an order beyond it is solved by its own least squares (as ``np.linalg.lstsq``, which drops
#: singular values below ``eps max(m, n)`` of the largest).
MAX_QR_CONDITION = 1e8


def _observability(U, s, order):
    """Observability matrix ``U_p sqrt(S_p)`` of the first ``order`` singular vectors, shape (l i, p)."""
    return U[:, :order] * np.sqrt(s[:order])


def state_matrices(O, n_out, orders):
    """State matrix of each order: the least-squares ``A_p`` of ``O_p[:-n_out] A_p = O_p[n_out:]`` with ``O_p`` the
    first ``p`` columns of ``O``.

    One QR factorisation ``O[:-n_out] = Q R`` serves every order (Döhler and Mevel 2012, fast multi-order SSI):
    the first ``p`` columns are ``Q_p R_p`` with ``R_p`` the leading block of the triangular ``R``, so
    ``A_p = R_p^-1 (Q^T O[n_out:])_p``. The condition number of ``R_p`` grows with ``p`` (singular values of a
    column truncation interlace), so the orders up to the last one with a condition number below
    :data:`MAX_QR_CONDITION` take this path and the others their own ``np.linalg.lstsq``.

    Parameters
    ----------
    O : ndarray, shape (n_out * block_rows, k)
    n_out : int
    orders : sequence of int
        Each at most ``k``.

    Returns
    -------
    list of ndarray, shapes (p, p)
    """
    lo, hi = O[:-n_out], O[n_out:]
    fast = [p for p in orders if p <= lo.shape[0]]
    if fast:
        Q, R = np.linalg.qr(lo[:, :max(fast)])
        S = Q.T @ hi[:, :max(fast)]

        def conditioned(p):
            sv = np.linalg.svd(R[:p, :p], compute_uv=False)
            return sv[-1] * MAX_QR_CONDITION > sv[0]

        ok = np.array(fast)
        if not conditioned(int(ok.max())):          # condition numbers rise with the order: bisect the last good one
            a, b = 0, ok.size                       # ok[:a] good, ok[b:] bad
            while a < b:
                c = (a + b) // 2
                a, b = (c + 1, b) if conditioned(int(ok[c])) else (a, c)
            ok = ok[:a]
        good = set(ok.tolist())
    else:
        good = set()
    return [np.linalg.solve(R[:p, :p], S[:p, :p]) if p in good
            else np.linalg.lstsq(lo[:, :p], hi[:, :p], rcond=None)[0] for p in orders]


def _modal(O, n_out, A, fs):
    """Continuous-time eigenvalues and (unnormalised) shapes ``C V`` of the state matrix ``A`` of ``O``'s first
    ``len(A)`` columns; with one output the shapes are ones (a unit-norm shape of one entry, largest entry real
    positive, is 1 whatever the eigenvector), and the eigenvectors are not computed."""
    if n_out == 1:
        return np.log(np.linalg.eigvals(A).astype(complex)) * fs, np.ones((1, A.shape[0]))
    mu, V = np.linalg.eig(A)
    return np.log(mu.astype(complex)) * fs, O[:n_out, :A.shape[0]] @ V


def _physical(lam, phi, max_damping, band_hz, duration_s=float("inf")):
    """Frequencies (Hz), damping ratios, eigenvalues and shapes (rows; unit norm, largest entry real positive) of
    the poles with ``Im > 0``, damping in ``(-r, max_damping)`` and frequency in ``band_hz``, and the mask of those
    poles. ``r``: the damping a record of ``duration_s`` resolves at the pole's frequency
    (:func:`~physics.identification.poles.damping_resolution`; 0 for an infinite duration): a mode damped less
    than the record resolves is estimated at zero within ``+-r`` from one model order to the next, and a pole of it
    that comes out slightly negative is the same mode, not a growing one."""
    wn = np.abs(lam)
    zeta = -lam.real / np.where(wn > 0, wn, 1)
    fn = wn / (2 * np.pi)
    keep = ((lam.imag > 0) & (zeta > -damping_resolution(fn, duration_s)) & (zeta < max_damping)
            & (fn >= band_hz[0]) & (fn <= band_hz[1]))
    phi = phi[:, keep].astype(complex)
    big = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    phi = phi * (np.conj(big) / np.where(big != 0, np.abs(big), 1)) / np.linalg.norm(phi, axis=0)
    return fn[keep], zeta[keep], lam[keep], phi.T, keep


def poles_of_order(U, s, n_out, order, fs, max_damping, band_hz):
    """Continuous-time eigenvalues (Im > 0) and unit-norm shapes of the SSI model of one order."""
    O = _observability(U, s, order)
    A = np.linalg.lstsq(O[:-n_out], O[n_out:], rcond=None)[0]
    return _physical(*_modal(O, n_out, A, fs), max_damping, band_hz)[:4]


def subspace_diagram(U, s, n_out, orders, sampling_frequency_hz, band_hz, max_damping=MAX_DAMPING, freq_tol=0.01,
                     damping_tol=0.05, mac_tol=0.98, duration_s=float("inf")) -> StabilisationDiagram:
    """Stabilisation diagram of the shift-invariant models of the given orders of one column space.

    Parameters
    ----------
    U : ndarray, shape (n_out * block_rows, k)
        Left singular vectors of a block Hankel/Toeplitz matrix whose block rows are successive samples (``n_out``
        rows each), most significant first.
    s : ndarray, shape (k,)
        Their singular values.
    n_out : int
        Outputs (rows of a block).
    orders, sampling_frequency_hz, band_hz, max_damping, freq_tol, damping_tol, mac_tol, duration_s
        As :func:`~physics.identification.ssi.ssi_poles`.

    Returns
    -------
    StabilisationDiagram
        As :func:`~physics.identification.ssi.ssi_poles`.
    """
    sizes = [min(int(p), U.shape[1]) for p in orders]
    if not sizes:
        fn = zeta = np.zeros(0)
        order, lam, phi = np.zeros(0, int), np.zeros(0, complex), np.zeros((0, n_out), complex)
    else:
        O = _observability(U, s, max(sizes))
        modal = [_modal(O, n_out, A, sampling_frequency_hz) for A in state_matrices(O, n_out, sizes)]
        order = np.concatenate([np.full(m[0].size, p // 2) for p, m in zip(orders, modal)])
        fn, zeta, lam, phi, keep = _physical(np.concatenate([m[0] for m in modal]),
                                             np.concatenate([m[1] for m in modal], axis=1), max_damping, band_hz,
                                             duration_s)
        order = order[keep]
    status = stability_status(order, fn, zeta, phi, freq_tol, damping_tol, mac_tol, duration_s)
    return StabilisationDiagram(order, lam, fn, zeta, phi, status, tuple(float(b) for b in band_hz), float(duration_s))
