"""Independent references for beams on any supports: exact Euler-Bernoulli roots with end springs and a plain
Hermite-element model (numpy/scipy only, nothing from physics/), the truths of ``tests/physics/test_supports.py``
and :mod:`experiments.benches.bench_supports`."""

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import brentq

__all__ = ["exact_beta_l", "plain_fe"]


def exact_beta_l(kappa_theta, kappa_y, n=4, right=None):
    """``beta L`` of the lowest ``n`` modes of a uniform beam with end springs (the same at both ends, or
    ``right = (kappa_theta, kappa_y)`` at x = L).

    ``kappa_theta = k_theta L / EI`` and ``kappa_y = k_y L^3 / EI`` (``np.inf``: held). Boundary conditions
    (x = 0, x = L): ``-+EI w'' + k_theta w' = 0`` and ``+-EI w''' + k_y w = 0``.
    """
    ends = ((kappa_theta, kappa_y), right or (kappa_theta, kappa_y))

    def rows(lam):
        ch, sh, c, s = np.cosh(lam), np.sinh(lam), np.cos(lam), np.sin(lam)
        # [A, B, C, D] rows of w, w'/beta, w''/beta^2, w'''/beta^3 at x = 0 and x = L
        w0, d0, m0, v0 = [1, 0, 1, 0], [0, 1, 0, 1], [1, 0, -1, 0], [0, 1, 0, -1]
        wl, dl, ml, vl = [ch, sh, c, s], [sh, ch, -s, c], [ch, sh, -c, -s], [sh, ch, s, -c]
        out = []
        for (moment, slope, shear, disp, sign), (kt, ky) in zip(((m0, d0, v0, w0, -1), (ml, dl, vl, wl, 1)), ends):
            out.append(slope if np.isinf(kt) else sign * np.asarray(moment) + kt / lam * np.asarray(slope))
            out.append(disp if np.isinf(ky) else -sign * np.asarray(shear) + ky / lam**3 * np.asarray(disp))
        return np.array(out, dtype=float) / np.array([1, 1, ch, ch])[:, None]

    def det(lam):
        return np.linalg.det(rows(lam))

    grid = np.arange(0.02, 16.0, 0.005)
    d = np.array([det(g) for g in grid])
    roots = [brentq(det, a, b, xtol=1e-13) for a, b, da, db in zip(grid[:-1], grid[1:], d[:-1], d[1:]) if da * db < 0]
    return np.array(roots[:n])


def plain_fe(bc, L, EI, M, n_el=64, *, k_theta=0.0, k_y=0.0, mass=None, x_sensors=(), n_modes=5):
    """Frequencies (Hz) and shapes at ``x_sensors`` (on nodes) of the lowest ``n_modes`` bending modes of a
    uniform beam (length ``L`` m, ``EI`` N m^2, ``M`` kg/m) of ``n_el`` cubic Hermite elements, with springs
    ``k_theta`` (N m/rad) and ``k_y`` (N/m) at both ends and a point ``mass = (kg, node index from 0)``; a
    free-free beam's two lowest modes are left out."""
    le = L / n_el
    k = EI / le**3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                                   [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    m = M * le / 420 * np.array([[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                 [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    n = 2 * (n_el + 1)
    K, Mm = np.zeros((n, n)), np.zeros((n, n))
    for e in range(n_el):
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += k
        Mm[2 * e:2 * e + 4, 2 * e:2 * e + 4] += m
    for i in (0, n - 2):
        K[i, i] += k_y
        K[i + 1, i + 1] += k_theta
    if mass is not None:
        Mm[2 * mass[1], 2 * mass[1]] += mass[0]
    held = {"clamped": (0, 1), "pinned": (0,), "free": ()}
    left, right = bc.split("-")
    removed = {*held[left], *(n - 2 + d for d in held[right])}
    keep = [i for i in range(n) if i not in removed]
    w2, v = eigh(K[np.ix_(keep, keep)], Mm[np.ix_(keep, keep)])
    full = np.zeros((n, len(keep)))
    full[keep] = v
    skip = 2 if bc == "free-free" else 0
    rows = [2 * int(round(x / le)) for x in x_sensors]
    return np.sqrt(w2[skip:skip + n_modes]) / (2 * np.pi), full[rows, skip:skip + n_modes]
