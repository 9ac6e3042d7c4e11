"""Compiled (numba) backends of physics functions: pure kernels, arrays in, arrays out.

:func:`pole_residue_kernel` is the fast backend of :func:`physics.frf.pole_residue`:
FRF synthesis from conjugate pole pairs in one float64 pass, written once into
the (possibly complex64) output. It is built from two row-level kernels that
other compiled code (e.g. datagen's fused measurement noise) calls, so the
arithmetic exists once:

* :func:`pair_denominators` - the pole terms of one model on every line,
* :func:`pair_row` - one response's noise-free FRF from its residues.

Each pair ``a/(i w - lam) + conj(a)/(i w - conj(lam))`` is the real-coefficient
term ``(u + i w v) / (|lam|^2 - w^2 - 2 i w Re lam)`` with
``u = -2 Re(a conj(lam))`` and ``v = 2 Re a``. Sums run over modes in order
(no fast-math), so results do not depend on the CPU's vector width.
Results equal the numpy expressions to rounding (``tests/physics/test_frf.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["pair_denominators", "pair_row", "pole_residue_kernel"]


@njit(cache=True, nogil=True, error_model="numpy")
def pair_denominators(lam, omega_rad_s, gr, gi):  # pragma: no cover - compiled
    """``gr + i gi = 1 / (|lam_j|^2 - w^2 - 2 i w Re lam_j)`` of one model.

    lam (m,) complex128; omega_rad_s (F,) float64; gr, gi (m, F) float64, overwritten.
    """
    for j in range(lam.shape[0]):
        lr, li = lam[j].real, lam[j].imag
        mod2 = lr * lr + li * li
        for f in range(omega_rad_s.shape[0]):
            w = omega_rad_s[f]
            dr = mod2 - w * w
            di = -2.0 * lr * w
            inv = 1.0 / (dr * dr + di * di)
            gr[j, f] = dr * inv
            gi[j, f] = -di * inv


@njit(cache=True, nogil=True, error_model="numpy")
def pair_row(lam, residues, omega_rad_s, gr, gi, re, im):  # pragma: no cover - compiled
    """One response's FRF ``re + i im`` from residues (m,) and :func:`pair_denominators` of its model.

    re, im (F,) float64, overwritten.
    """
    re[:] = 0.0
    im[:] = 0.0
    for j in range(lam.shape[0]):
        ar, ai = residues[j].real, residues[j].imag
        u = -2.0 * (ar * lam[j].real + ai * lam[j].imag)
        v = 2.0 * ar
        for f in range(omega_rad_s.shape[0]):
            wv = omega_rad_s[f] * v
            re[f] += u * gr[j, f] - wv * gi[j, f]
            im[f] += u * gi[j, f] + wv * gr[j, f]


@njit(cache=True, nogil=True, error_model="numpy")
def pole_residue_kernel(lam, residues, omega_rad_s, out):  # pragma: no cover - compiled
    """``out[i, s, f] = sum_j a_isj/(i w_f - lam_ij) + conj(a_isj)/(i w_f - conj(lam_ij))``.

    lam (N, m) complex128; residues (N, S, m) complex128; omega_rad_s (F,)
    float64; out (N, S, F) complex (complex64 allowed), overwritten.
    """
    n_models, n_modes = lam.shape
    n_lines = omega_rad_s.shape[0]
    gr = np.empty((n_modes, n_lines))
    gi = np.empty((n_modes, n_lines))
    re = np.empty(n_lines)
    im = np.empty(n_lines)
    for i in range(n_models):
        pair_denominators(lam[i], omega_rad_s, gr, gi)
        for s in range(residues.shape[1]):
            pair_row(lam[i], residues[i, s], omega_rad_s, gr, gi, re, im)
            for f in range(n_lines):
                out[i, s, f] = complex(re[f], im[f])
