"""Compiled (numba) backends of physics functions: pure kernels, arrays in, arrays out.

* :func:`pole_residue_kernel`, the fast backend of :func:`physics.frf.pole_residue`:
  FRF synthesis from conjugate pole pairs, optionally with multiplicative
  measurement noise fused in, in one float64 pass writing straight into the
  (possibly complex64) output.
* :func:`box_muller`: unit-variance circular complex Gaussian from two float32 uniforms.

Results equal the numpy expressions to rounding (``tests/physics/test_frf.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def pole_residue_kernel(lam, residues, omega_rad_s, uniforms, level, out):  # pragma: no cover - compiled
    """``out[i, s, f] = sum_j a_sj/(i w_f - lam_j) + conj(a_sj)/(i w_f - conj(lam_j))``, optionally noisy.

    Each pair is ``(u + i w v) / (|lam|^2 - w^2 - 2 i w Re lam)`` with
    ``u = -2 Re(a conj(lam))`` and ``v = 2 Re a``. Sums are accumulated in
    float64 and written once, so ``out`` may be complex64 storage.

    lam (N, m) complex128; residues (N, S, m) complex128; omega_rad_s (F,)
    float64; uniforms (N*S*F, 2) float32, or (0, 2) for no noise; level
    float; out (N, S, F) complex, overwritten. With noise, each value is
    multiplied by ``1 + level z`` (see :func:`box_muller`), fused here so the
    noise-free FRF is never stored.
    """
    n_models, n_modes = lam.shape
    n_resp = residues.shape[1]
    n_lines = omega_rad_s.shape[0]
    gr = np.empty((n_modes, n_lines))
    gi = np.empty((n_modes, n_lines))
    u = np.empty(n_modes)
    v = np.empty(n_modes)
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
            for j in range(n_modes):
                ar, ai = residues[i, s, j].real, residues[i, s, j].imag
                u[j] = -2.0 * (ar * lam[i, j].real + ai * lam[i, j].imag)
                v[j] = 2.0 * ar
            for f in range(n_lines):
                w = omega_rad_s[f]
                re = 0.0
                im = 0.0
                for j in range(n_modes):
                    re += u[j] * gr[j, f] - w * v[j] * gi[j, f]
                    im += u[j] * gi[j, f] + w * v[j] * gr[j, f]
                if uniforms.shape[0]:
                    zr, zi = box_muller(uniforms[(i * n_resp + s) * n_lines + f])
                    re, im = re * (1.0 + level * zr) - im * level * zi, im * (1.0 + level * zr) + re * level * zi
                out[i, s, f] = complex(re, im)


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
def box_muller(u):  # pragma: no cover - compiled
    """Unit-variance circular complex Gaussian ``z = sqrt(-ln(1-u1)) exp(2 pi i u2)`` (``E|z|^2 = 1``).

    ``u`` is a pair of float32 uniforms in [0, 1). Returns ``(Re z, Im z)``.
    """
    t = np.float64(u[1]) * _N_TAB
    k = int(t)
    f = t - k
    c = _COS[k] + f * (_COS[k + 1] - _COS[k])
    s = _SIN[k] + f * (_SIN[k + 1] - _SIN[k])
    t = np.float64(u[0]) * _N_TAB
    k = int(t)
    if _EDGE <= k < _N_TAB - _EDGE:
        f = t - k
        r = _RAD[k] + f * (_RAD[k + 1] - _RAD[k])
    else:
        r = np.sqrt(-np.log1p(-np.float64(u[0])))
    return r * c, r * s
