"""Compiled inner kernels of the dataset pipeline (numba).

The FRF measurement noise (a counter-based SplitMix64 stream per sample and
state, so a sample's noise never depends on what else is read with it), fused
into the pole-pair FRF synthesis of :mod:`physics.kernels` (its row kernels),
and the banded Cholesky factorisation of the truth stiffness.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from physics.kernels import box_muller, pair_denominators, pair_row


#: SplitMix64 constants (Steele, Lea, Flood 2014): a counter-based stream, ``z_k = mix(seed + k * GAMMA)``.
_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True)
def splitmix64(x):  # pragma: no cover - compiled
    """The SplitMix64 finaliser of ``x`` (uint64 -> uint64), a bijective avalanche hash."""
    z = x
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def hashed_normal(seed, k, u):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian number ``k`` of the stream ``seed`` (counter-based).

    Two 24-bit uniforms from ``splitmix64(seed + (k + 1) GAMMA)`` go through
    :func:`physics.kernels.box_muller` (``u``: a float64 buffer of 2), so any
    entry can be drawn on its own, in any order, on any worker. Returns ``(Re z, Im z)``.
    """
    z = splitmix64(seed + np.uint64(k + 1) * _GAMMA)
    u[0] = np.float64(z >> np.uint64(40)) * (1.0 / 16777216.0)
    u[1] = np.float64((z >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0)
    return box_muller(u)


@njit(cache=True, nogil=True)
def add_noise_row(re, im, seed, s, level, floor, u, out):  # pragma: no cover - compiled
    """Noisy FRF of response ``s`` of one model from its noise-free ``re + i im`` (F,) into ``out`` (F,).

    ``out = H (1 + level z1) + floor max_f|H| z2`` with ``z1 = hashed_normal(seed, 2 (s F + f))``
    and ``z2`` the next number of the stream (drawn only when the floor is not 0); ``u``: float64 buffer of 2.
    """
    n_lines = re.shape[0]
    peak2 = 0.0
    for f in range(n_lines):
        peak2 = max(peak2, re[f] ** 2 + im[f] ** 2)
    fl = floor * np.sqrt(peak2)
    for f in range(n_lines):
        k = 2 * (s * n_lines + f)
        z1r, z1i = hashed_normal(seed, k, u)
        h = complex(re[f], im[f]) * complex(1.0 + level * z1r, level * z1i)
        if fl != 0.0:
            z2r, z2i = hashed_normal(seed, k + 1, u)
            h += fl * complex(z2r, z2i)
        out[f] = h


@njit(cache=True, nogil=True)
def noisy_pole_residue_kernel(lam, residues, omega_rad_s, seeds, level, floor, out):  # pragma: no cover - compiled
    """Measured FRFs: :func:`physics.kernels.pole_residue_kernel` with :func:`add_noise_row` fused in.

    lam (N, m) complex128; residues (N, S, m) complex128; omega_rad_s (F,);
    seeds (N,) uint64; level, floor (N,) float64; out (N, S, F) complex (complex64 ok).
    The noise-free FRF is never stored; values equal the two-pass route bit for bit.
    """
    n_models, n_modes = lam.shape
    n_lines = omega_rad_s.shape[0]
    gr = np.empty((n_modes, n_lines))
    gi = np.empty((n_modes, n_lines))
    re = np.empty(n_lines)
    im = np.empty(n_lines)
    u = np.empty(2)
    for i in range(n_models):
        pair_denominators(lam[i], omega_rad_s, gr, gi)
        for s in range(residues.shape[1]):
            pair_row(lam[i], residues[i, s], omega_rad_s, gr, gi, re, im)
            add_noise_row(re, im, seeds[i], s, level[i], floor[i], u, out[i, s])


@njit(cache=True, nogil=True)
def noise_kernel(H, seeds, level, floor, out):  # pragma: no cover - compiled
    """The measurement noise of :func:`add_noise_row` applied to given FRFs (the per-sample cross-check).

    H (N, S, F) complex128; out (N, S, F) complex; seeds (N,) uint64; level, floor (N,) float64.
    """
    re = np.empty(H.shape[2])
    im = np.empty(H.shape[2])
    u = np.empty(2)
    for i in range(H.shape[0]):
        for s in range(H.shape[1]):
            re[:] = H[i, s].real
            im[:] = H[i, s].imag
            add_noise_row(re, im, seeds[i], s, level[i], floor[i], u, out[i, s])


@njit(cache=True)
def band_cholesky(K, bw):  # pragma: no cover - compiled
    """Cholesky factors of symmetric positive definite banded matrices, ``K = L L^T``.

    K (N, n, n) float64, dense storage, half-bandwidth ``bw`` (entries with
    ``|i - j| > bw`` are ignored). Returns L in band storage (N, n, bw + 1),
    ``L[i, i - d] = out[:, i, d]``. Raises ``ValueError`` if a pivot is not positive.
    """
    N, n = K.shape[0], K.shape[1]
    L = np.zeros((N, n, bw + 1))
    for b in range(N):
        for i in range(n):
            for d in range(min(i, bw), -1, -1):  # j = i - d, left to right
                j = i - d
                acc = K[b, i, j]
                for k in range(max(0, i - bw), j):
                    acc -= L[b, i, i - k] * L[b, j, j - k]
                if d == 0:
                    if acc <= 0.0:
                        raise ValueError("band_cholesky: matrix is not positive definite")
                    L[b, i, 0] = np.sqrt(acc)
                else:
                    L[b, i, d] = acc / L[b, j, 0]
    return L


@njit(cache=True)
def band_cholesky_solve(L, B):  # pragma: no cover - compiled
    """Solve ``L L^T X = B`` with band factors from :func:`band_cholesky`; B (N, n, p) float64.

    The right-hand sides are the innermost loop (contiguous, vectorised); each
    value sees the same operations in the same order as a column-by-column solve.
    """
    N, n, w = L.shape[0], L.shape[1], L.shape[2] - 1
    p = B.shape[2]
    X = B.copy()
    for b in range(N):
        for i in range(n):  # forward: L y = b
            for k in range(max(0, i - w), i):
                lik = L[b, i, i - k]
                for c in range(p):
                    X[b, i, c] -= lik * X[b, k, c]
            d = L[b, i, 0]
            for c in range(p):
                X[b, i, c] = X[b, i, c] / d
        for i in range(n - 1, -1, -1):  # backward: L^T x = y
            for k in range(i + 1, min(n, i + w + 1)):
                lki = L[b, k, k - i]
                for c in range(p):
                    X[b, i, c] -= lki * X[b, k, c]
            d = L[b, i, 0]
            for c in range(p):
                X[b, i, c] = X[b, i, c] / d
    return X
