"""Compiled inner kernels of the dataset pipeline (numba).

The operations that touch every FRF value of every sample, FRF synthesis
from conjugate pole pairs and multiplicative measurement noise, dominate the
batched pipeline when written as numpy array expressions (many passes over
temporaries). Here they are one fused compiled pass, in float64, with no
Python loop, writing straight into the (complex64) dataset arrays.
Results equal the numpy expressions to rounding (``tests/datagen``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


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
def hashed_normal(seed, k):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian number ``k`` of the stream ``seed`` (counter-based).

    Two 24-bit uniforms from ``splitmix64(seed + (k + 1) GAMMA)`` go through :func:`box_muller`,
    so any entry can be drawn on its own, in any order, on any worker. Returns ``(Re z, Im z)``.
    """
    z = splitmix64(seed + np.uint64(k + 1) * _GAMMA)
    u1 = np.float64(z >> np.uint64(40)) * (1.0 / 16777216.0)
    u2 = np.float64((z >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0)
    return box_muller(u1, u2)


@njit(cache=True, nogil=True)
def pair_frf_kernel(lam, residues, omega_rad_s, seeds, level, floor, out):  # pragma: no cover - compiled
    """``out[i, s, f] = sum_j a_sj/(i w_f - lam_j) + conj(a_sj)/(i w_f - conj(lam_j))``, optionally noisy.

    Each pair is ``(u + i w v) / (|lam|^2 - w^2 - 2 i w Re lam)`` with
    ``u = -2 Re(a conj(lam))`` and ``v = 2 Re a``. Sums are accumulated in
    float64 (no fast-math: results do not depend on the CPU's vector width)
    and written once, so ``out`` may be complex64 storage.

    Noise (when ``seeds`` is not empty): ``H (1 + level_i z1) + floor_i max_f|H_is| z2`` per
    response ``s`` of model ``i``, with ``z1 = hashed_normal(seeds[i], 2 (s F + f))`` and
    ``z2`` the next number: multiplicative noise plus a floor relative to the FRF's peak.

    lam (N, m) complex128; residues (N, S, m) complex128; omega_rad_s (F,)
    float64; seeds (N,) uint64 or (0,); level, floor (N,) float64 or (0,);
    out (N, S, F) complex, overwritten.
    """
    n_models, n_modes = lam.shape
    n_resp = residues.shape[1]
    n_lines = omega_rad_s.shape[0]
    gr = np.empty((n_modes, n_lines))
    gi = np.empty((n_modes, n_lines))
    re = np.empty(n_lines)
    im = np.empty(n_lines)
    noisy = seeds.shape[0] > 0
    for i in range(n_models):
        for j in range(n_modes):
            lr, li = lam[i, j].real, lam[i, j].imag
            mod2 = lr * lr + li * li
            for f in range(n_lines):
                w = omega_rad_s[f]
                dr = mod2 - w * w
                di = -2.0 * lr * w
                inv = 1.0 / (dr * dr + di * di)
                gr[j, f] = dr * inv
                gi[j, f] = -di * inv
        for s in range(n_resp):
            re[:] = 0.0
            im[:] = 0.0
            for j in range(n_modes):
                ar, ai = residues[i, s, j].real, residues[i, s, j].imag
                u = -2.0 * (ar * lam[i, j].real + ai * lam[i, j].imag)
                v = 2.0 * ar
                for f in range(n_lines):
                    wv = omega_rad_s[f] * v
                    re[f] += u * gr[j, f] - wv * gi[j, f]
                    im[f] += u * gi[j, f] + wv * gr[j, f]
            if noisy:
                peak2 = 0.0
                for f in range(n_lines):
                    peak2 = max(peak2, re[f] * re[f] + im[f] * im[f])
                fl = floor[i] * np.sqrt(peak2)
                lv = level[i]
                for f in range(n_lines):
                    k = 2 * (s * n_lines + f)
                    z1r, z1i = hashed_normal(seeds[i], k)
                    z2r, z2i = hashed_normal(seeds[i], k + 1)
                    a, b = re[f], im[f]
                    re[f] = a * (1.0 + lv * z1r) - b * lv * z1i + fl * z2r
                    im[f] = b * (1.0 + lv * z1r) + a * lv * z1i + fl * z2i
            for f in range(n_lines):
                out[i, s, f] = complex(re[f], im[f])


#: Tables for the Box-Muller transform: cos/sin of 2 pi u and sqrt(-ln(1-u)) on a uniform grid of u.
#: Linear interpolation is accurate to a few 1e-6 absolute (float32-level); near u = 0 and u = 1, where
#: the radius is not smooth, the exact formula is used. About 7x cheaper than log, cos and sin per value.
_N_TAB = 16384
_EDGE = 64
_GRID = np.linspace(0.0, 1.0, _N_TAB + 1)
_COS = np.cos(2 * np.pi * _GRID)
_SIN = np.sin(2 * np.pi * _GRID)
_RAD = np.sqrt(-np.log1p(-np.minimum(_GRID, 1 - 1e-12)))


@njit(cache=True)
def box_muller(u1, u2):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian ``z = sqrt(-ln(1-u1)) exp(2 pi i u2)`` (``E|z|^2 = 1``).

    ``u1, u2`` uniforms in [0, 1). Returns ``(Re z, Im z)``.
    """
    t = np.float64(u2) * _N_TAB
    k = int(t)
    f = t - k
    c = _COS[k] + f * (_COS[k + 1] - _COS[k])
    s = _SIN[k] + f * (_SIN[k + 1] - _SIN[k])
    t = np.float64(u1) * _N_TAB
    k = int(t)
    if _EDGE <= k < _N_TAB - _EDGE:
        f = t - k
        r = _RAD[k] + f * (_RAD[k + 1] - _RAD[k])
    else:
        r = np.sqrt(-np.log1p(-np.float64(u1)))
    return r * c, r * s


@njit(cache=True)
def noise_kernel(H, seeds, level, floor, out):  # pragma: no cover - compiled
    """The measurement noise of :func:`pair_frf_kernel` applied to given FRFs.

    H, out (N, S, F) complex; seeds (N,) uint64; level, floor (N,) float64.
    """
    n_models, n_resp, n_lines = H.shape
    for i in range(n_models):
        for s in range(n_resp):
            peak2 = 0.0
            for f in range(n_lines):
                peak2 = max(peak2, H[i, s, f].real ** 2 + H[i, s, f].imag ** 2)
            fl = floor[i] * np.sqrt(peak2)
            for f in range(n_lines):
                k = 2 * (s * n_lines + f)
                z1r, z1i = hashed_normal(seeds[i], k)
                z2r, z2i = hashed_normal(seeds[i], k + 1)
                out[i, s, f] = H[i, s, f] * complex(1.0 + level[i] * z1r, level[i] * z1i) + fl * complex(z2r, z2i)


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
    """Solve ``L L^T X = B`` with band factors from :func:`band_cholesky`; B (N, n, p) float64."""
    N, n, w = L.shape[0], L.shape[1], L.shape[2] - 1
    p = B.shape[2]
    X = B.copy()
    for b in range(N):
        for c in range(p):
            for i in range(n):  # forward: L y = b
                acc = X[b, i, c]
                for k in range(max(0, i - w), i):
                    acc -= L[b, i, i - k] * X[b, k, c]
                X[b, i, c] = acc / L[b, i, 0]
            for i in range(n - 1, -1, -1):  # backward: L^T x = y
                acc = X[b, i, c]
                for k in range(i + 1, min(n, i + w + 1)):
                    acc -= L[b, k, k - i] * X[b, k, c]
                X[b, i, c] = acc / L[b, i, 0]
    return X
