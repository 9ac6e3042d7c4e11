"""Compiled (numba) banded Cholesky factorisation and solve of the truth stiffness matrices."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["band_cholesky", "band_cholesky_solve"]


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
