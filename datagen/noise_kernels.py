"""Compiled measurement-noise kernels of the dataset pipeline (numba).

The FRF measurement noise (a counter-based SplitMix64 stream per sample and
state, so a sample's noise never depends on what else is read with it), fused
into the pole-pair FRF synthesis of :mod:`physics.frf_kernels` (its row kernels).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from physics.frf_kernels import pair_denominators, pair_row

__all__ = ["add_noise_row", "box_muller", "hashed_normal", "noise_kernel",
           "noisy_pole_residue_kernel", "row_peak", "splitmix64"]


#: SplitMix64 constants (Steele, Lea, Flood 2014): a counter-based stream, ``z_k = mix(seed + k * GAMMA)``.
_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, nogil=True, error_model="numpy")
def splitmix64(x):  # pragma: no cover - compiled
    """The SplitMix64 finaliser of ``x`` (uint64 -> uint64), a bijective avalanche hash."""
    z = x
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


#: Tables for the Box-Muller transform: cos/sin of 2 pi u and sqrt(-ln(1-u)) on a uniform grid of u.
#: Linear interpolation is accurate to a few 1e-6 absolute (float32-level); near u = 0 and u = 1, where
#: the radius is not smooth, the exact formula is used. About 7x cheaper than log, cos and sin per value.
_N_TAB = 16384
_EDGE = 64
_GRID = np.linspace(0.0, 1.0, _N_TAB + 1)
_COS = np.cos(2 * np.pi * _GRID)
_SIN = np.sin(2 * np.pi * _GRID)
_RAD = np.sqrt(-np.log1p(-np.minimum(_GRID, 1 - 1e-12)))


@njit(cache=True, nogil=True, error_model="numpy")
def box_muller(u1, u2):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian ``z = sqrt(-ln(1-u1)) exp(2 pi i u2)`` (``E|z|^2 = 1``).

    ``u1, u2``: uniforms in [0, 1). Returns ``(Re z, Im z)``.
    """
    t = u2 * _N_TAB
    k = int(t)
    f = t - k
    c = _COS[k] + f * (_COS[k + 1] - _COS[k])
    s = _SIN[k] + f * (_SIN[k + 1] - _SIN[k])
    t = u1 * _N_TAB
    k = int(t)
    if _EDGE <= k < _N_TAB - _EDGE:
        f = t - k
        r = _RAD[k] + f * (_RAD[k + 1] - _RAD[k])
    else:
        r = np.sqrt(-np.log1p(-u1))
    return r * c, r * s


@njit(cache=True, nogil=True, error_model="numpy")
def hashed_normal(seed, k):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian number ``k`` of the stream ``seed`` (counter-based).

    Two 24-bit uniforms from ``splitmix64(seed + (k + 1) GAMMA)`` go through
    :func:`box_muller`, so any entry can be drawn on its own, in any order, on
    any worker. Returns ``(Re z, Im z)``.
    """
    z = splitmix64(seed + np.uint64(k + 1) * _GAMMA)
    return box_muller(np.float64(z >> np.uint64(40)) * (1.0 / 16777216.0),
                      np.float64((z >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0))


@njit(cache=True, nogil=True, error_model="numpy")
def row_peak(re, im):  # pragma: no cover - compiled
    """``max_f |re + i im|`` of one FRF row (the scale of its noise floor)."""
    peak2 = 0.0
    for f in range(re.shape[0]):
        peak2 = max(peak2, re[f] ** 2 + im[f] ** 2)
    return np.sqrt(peak2)


@njit(cache=True, nogil=True, error_model="numpy")
def add_noise_row(re, im, lines, n_lines, seed, s, level, floor, peak, z, work, out):  # pragma: no cover - compiled
    """Noisy FRF of response ``s`` of one model from its noise-free ``re + i im`` (L,) into ``out`` (L,).

    ``out = H (1 + level z1) + floor max_f|H| z2`` with ``z1 = hashed_normal(seed, 2 (s F + f))``
    and ``z2`` the next number of the stream (drawn only when the floor is not 0).
    ``lines`` (L,) int64 are the indices ``f`` of the given values among the ``n_lines = F`` lines of
    the dataset, so a subset of lines gets exactly the noise of the full FRF on those lines.
    ``peak``: ``max_f |H|`` over all F lines (:func:`row_peak`), or NaN to take it from the given
    lines (then they must be all F when the floor is not 0).
    ``z`` (L,) uint64 and ``work`` (3, L) float64: work space. :func:`hashed_normal` is computed in
    stages, each a loop of its own without branches (they vectorise), with the same arithmetic.
    """
    fl = floor * (row_peak(re, im) if np.isnan(peak) else peak) if floor != 0.0 else 0.0
    base = seed + np.uint64(2 * s * n_lines + 1) * _GAMMA
    n = re.shape[0]
    for f in range(n):
        z[f] = splitmix64(base + np.uint64(2 * lines[f]) * _GAMMA)   # = the hash of hashed_normal(seed, k)
    rad, cos, sin = work[0], work[1], work[2]
    for f in range(n):  # box_muller's table interpolation, everywhere
        t = np.float64((z[f] >> np.uint64(16)) & np.uint64(0xFFFFFF)) * (1.0 / 16777216.0) * _N_TAB
        k = int(t)
        g = t - k
        cos[f] = _COS[k] + g * (_COS[k + 1] - _COS[k])
        sin[f] = _SIN[k] + g * (_SIN[k + 1] - _SIN[k])
        t = np.float64(z[f] >> np.uint64(40)) * (1.0 / 16777216.0) * _N_TAB
        k = int(t)
        g = t - k
        rad[f] = _RAD[k] + g * (_RAD[k + 1] - _RAD[k])
    for f in range(n):  # ... and its exact radius near u1 = 0 and 1 (about 1 % of draws)
        k = int(z[f] >> np.uint64(50))
        if k < _EDGE or k >= _N_TAB - _EDGE:
            rad[f] = np.sqrt(-np.log1p(-np.float64(z[f] >> np.uint64(40)) * (1.0 / 16777216.0)))
    for f in range(n):
        h = complex(re[f], im[f]) * complex(1.0 + level * (rad[f] * cos[f]), level * (rad[f] * sin[f]))
        if fl != 0.0:
            z2r, z2i = hashed_normal(seed, 2 * (s * n_lines + lines[f]) + 1)
            h += fl * complex(z2r, z2i)
        out[f] = h


@njit(cache=True, nogil=True, error_model="numpy")
def noisy_pole_residue_kernel(lam, residues, omega_rad_s, lines, n_lines, seeds, level, floor, peak,
                              out):  # pragma: no cover - compiled
    """Measured FRFs: :func:`physics.frf_kernels.pole_residue_kernel` with :func:`add_noise_row` fused in.

    lam (N, m) complex128; residues (N, S, m) complex128; omega_rad_s (L,) the lines synthesised,
    ``lines`` (L,) int64 their indices among the dataset's ``n_lines``; seeds (N,) uint64;
    level, floor (N,) float64; peak (N, S) float64 (see :func:`add_noise_row`);
    out (N, S, L) complex (complex64 ok).
    The noise-free FRF is never stored; values equal the two-pass route bit for bit.
    """
    n_models, n_modes = lam.shape
    n_w = omega_rad_s.shape[0]
    gr = np.empty((n_modes, n_w))
    gi = np.empty((n_modes, n_w))
    re = np.empty(n_w)
    im = np.empty(n_w)
    z = np.empty(n_w, np.uint64)
    work = np.empty((3, n_w))
    for i in range(n_models):
        pair_denominators(lam[i], omega_rad_s, gr, gi)
        for s in range(residues.shape[1]):
            pair_row(lam[i], residues[i, s], omega_rad_s, gr, gi, re, im)
            add_noise_row(re, im, lines, n_lines, seeds[i], s, level[i], floor[i], peak[i, s], z, work, out[i, s])


@njit(cache=True, nogil=True, error_model="numpy")
def noise_kernel(H, seeds, level, floor, out):  # pragma: no cover - compiled
    """The measurement noise of :func:`add_noise_row` applied to given FRFs (the per-sample cross-check).

    H (N, S, F) complex128; out (N, S, F) complex; seeds (N,) uint64; level, floor (N,) float64.
    """
    n_lines = H.shape[2]
    re = np.empty(n_lines)
    im = np.empty(n_lines)
    lines = np.arange(n_lines)
    z = np.empty(n_lines, np.uint64)
    work = np.empty((3, n_lines))
    for i in range(H.shape[0]):
        for s in range(H.shape[1]):
            re[:] = H[i, s].real
            im[:] = H[i, s].imag
            add_noise_row(re, im, lines, n_lines, seeds[i], s, level[i], floor[i], np.nan, z, work, out[i, s])
