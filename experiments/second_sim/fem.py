"""Finite-element beam of the independent simulator: Euler-Bernoulli and Timoshenko elements, springs at both ends.

Uniform mesh of ``n_elements`` two-node elements, DOFs ``(v_i, theta_i)`` of node
``i = 0..n_elements`` (node 0 at the root, ``x = 0``; the other end, ``x = L``, is the tip).
Each end has a translational and a rotational spring to ground: ``0`` leaves the DOF free,
``inf`` removes it (fixed), a finite value adds it to ``K``; so clamped-free (the default),
free-free (soft suspension springs), pinned-pinned and clamped-clamped beams are one class. Element stiffness is the
exact static stiffness obtained by inverting the element flexibility of a
cantilevered element: with a compliance ``1/EI(x)`` that is piecewise constant
(slits) the integrals are closed-form, and with uniform ``EI`` it is the exact
Euler-Bernoulli (``kGA = inf``) or Timoshenko stiffness, the stiffness of the
interdependent-interpolation element (free of shear locking). The consistent
mass uses the interdependent shape functions (cubic ``v``, quadratic ``theta``,
coupled through ``phi = 12 EI / (kGA l^2)``) with 4-point Gauss quadrature, which
is exact for their degree-6 products; rotary inertia ``rho I`` is optional.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

__all__ = ["Assembled", "Beam", "Dashpot", "Modes", "N_ELEMENTS", "PointMass", "Slit", "assemble", "element_mass",
           "element_stiffness", "mesh_elements", "modes", "point_row", "shape_functions"]


#: Elements of the default mesh (a multiple of 4, so the quarter points are nodes).
N_ELEMENTS = 112


@dataclass(frozen=True)
class Slit:
    """A slit: bending rigidity ``EI`` reduced by ``ei_loss_fraction`` over ``[x - w/2, x + w/2]``."""

    x_m: float
    width_m: float
    ei_loss_fraction: float

    def stiffness_loss_Nm3(self, EI_Nm2: float) -> float:
        """Size label ``r * EI * w`` (N m^3)."""
        return self.ei_loss_fraction * EI_Nm2 * self.width_m

    def hinge_flexibility(self, length_m: float) -> float:
        """Size label ``EI / (k_theta L)``: the rotational-spring compliance ``w r / ((1 - r) EI)`` times ``EI / L``."""
        r = self.ei_loss_fraction
        return self.width_m * r / ((1.0 - r) * length_m)


@dataclass(frozen=True)
class PointMass:
    """A point mass ``mass_kg`` at ``x_m``."""

    x_m: float
    mass_kg: float


@dataclass(frozen=True)
class Dashpot:
    """A translational dashpot to ground, ``c_Ns_m`` (N s/m) at ``x_m``."""

    x_m: float
    c_Ns_m: float


@dataclass(frozen=True)
class Beam:
    """A beam from the root (``x = 0``) to the tip (``x = length_m``); by default a cantilever clamped at the root.

    ``kGA_N = inf`` gives Euler-Bernoulli elements. End supports: ``root_k_y_N_m`` (N/m),
    ``root_k_theta_Nm_rad`` (N m/rad) at ``x = 0`` and ``tip_k_y_N_m``, ``tip_k_theta_Nm_rad`` at
    ``x = length_m``; ``inf`` fixes the DOF, ``0`` leaves it free, a finite value is a spring.
    """

    length_m: float
    EI_Nm2: float
    mass_per_length_kg_m: float
    kGA_N: float = math.inf
    rho_I_kg_m: float = 0.0
    root_k_theta_Nm_rad: float = math.inf
    root_k_y_N_m: float = math.inf
    tip_k_y_N_m: float = 0.0
    tip_k_theta_Nm_rad: float = 0.0
    slits: tuple[Slit, ...] = ()
    masses: tuple[PointMass, ...] = ()
    dashpots: tuple[Dashpot, ...] = ()
    n_elements: int = N_ELEMENTS

    def __post_init__(self):
        for name in ("length_m", "EI_Nm2", "mass_per_length_kg_m", "kGA_N"):
            v = getattr(self, name)
            if not (v > 0):
                raise ValueError(f"Beam.{name} must be > 0, got {v!r}")
        for name in ("root_k_y_N_m", "root_k_theta_Nm_rad", "tip_k_y_N_m", "tip_k_theta_Nm_rad"):
            v = getattr(self, name)
            if not (v >= 0):
                raise ValueError(f"Beam.{name} must be >= 0 (0 free, inf fixed), got {v!r}")
        if self.rho_I_kg_m < 0 or self.n_elements < 1:
            raise ValueError("Beam.rho_I_kg_m must be >= 0 and Beam.n_elements >= 1")
        for s in self.slits:
            if not (0 <= s.ei_loss_fraction < 1 and s.width_m > 0
                    and 0 <= s.x_m - s.width_m / 2 and s.x_m + s.width_m / 2 <= self.length_m):
                raise ValueError(f"slit {s} must have 0 <= loss < 1, width > 0 and lie on the beam")
        for p in (*self.masses, *self.dashpots):
            if not 0 <= p.x_m <= self.length_m:
                raise ValueError(f"{p} lies outside the beam [0, {self.length_m}] m")


@dataclass(frozen=True)
class Assembled:
    """Matrices of a :class:`Beam` on its free DOFs.

    Attributes
    ----------
    M, K, C : ndarray, shape (n, n)
        Mass (kg), stiffness (N/m) and dashpot damping (N s/m) matrices.
    dashpot_rows : ndarray, shape (n_dashpots, n)
        Interpolation row ``b_j`` of each dashpot (``C = sum_j c_j b_j b_j^T``).
    dashpot_c_Ns_m : ndarray, shape (n_dashpots,)
    node_x_m : ndarray, shape (n_elements + 1,)
    dof_index : ndarray of int, shape (2 * (n_elements + 1),)
        Position of each full DOF ``(v_i, theta_i)`` among the free DOFs, -1 if constrained.
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    dashpot_rows: np.ndarray
    dashpot_c_Ns_m: np.ndarray
    node_x_m: np.ndarray
    dof_index: np.ndarray = field(repr=False)

    def translation_dofs(self, x_m) -> np.ndarray:
        """Free-DOF indices of the transverse displacement at nodes at positions ``x_m`` (m)."""
        x = np.atleast_1d(np.asarray(x_m, dtype=float))
        h = self.node_x_m[1] - self.node_x_m[0]
        node = np.rint(x / h).astype(int)
        if np.any(np.abs(node * h - x) > 1e-9 * self.node_x_m[-1]):
            raise ValueError(f"positions {x.tolist()} m are not all nodes of the mesh (spacing {h:g} m)")
        idx = self.dof_index[2 * node]
        if np.any(idx < 0):
            raise ValueError("a requested translation is constrained (a fixed end)")
        return idx


def shape_functions(xi, length_m, phi):
    """Interdependent (Timoshenko) shape functions on an element; ``phi = 0`` gives the Hermite cubics.

    Parameters
    ----------
    xi : ndarray, shape (q,)
        Local coordinate ``x / l`` in [0, 1].
    length_m : float
    phi : float
        ``12 EI / (kGA l^2)``.

    Returns
    -------
    Nv, Nt : ndarray, shape (q, 4)
        Displacement (-) and rotation (1/m) shape functions for DOFs ``(v1, theta1, v2, theta2)``.
    """
    x = np.asarray(xi, dtype=float)[:, None]
    l, g = length_m, 1.0 / (1.0 + phi)
    x2, x3 = x * x, x * x * x
    Nv = g * np.hstack([2 * x3 - 3 * x2 - phi * x + 1 + phi,
                        l * (x3 - (2 + phi / 2) * x2 + (1 + phi / 2) * x),
                        -2 * x3 + 3 * x2 + phi * x,
                        l * (x3 - (1 - phi / 2) * x2 - phi / 2 * x)])
    Nt = g * np.hstack([6 / l * (x2 - x),
                        3 * x2 - (4 + phi) * x + 1 + phi,
                        -6 / l * (x2 - x),
                        3 * x2 - (2 - phi) * x])
    return Nv, Nt


def element_stiffness(beam: Beam, x0_m: np.ndarray, h_m: float) -> np.ndarray:
    """Exact static stiffness of elements ``[x0, x0 + h]`` with the beam's slits, shape (n_el, 4, 4) (N/m, N, N m)."""
    c0 = 1.0 / beam.EI_Nm2
    # flexibility of the element clamped at its left node, loads (shear, moment) at the right node
    f11 = np.full(x0_m.shape, c0 * h_m ** 3 / 3 + h_m / beam.kGA_N)
    f12 = np.full(x0_m.shape, c0 * h_m ** 2 / 2)
    f22 = np.full(x0_m.shape, c0 * h_m)
    for s in beam.slits:
        dc = s.ei_loss_fraction / (beam.EI_Nm2 * (1.0 - s.ei_loss_fraction))  # added compliance 1/(N m^2)
        a = np.clip(s.x_m - s.width_m / 2 - x0_m, 0.0, h_m)  # covered part [a, b] in local x
        b = np.clip(s.x_m + s.width_m / 2 - x0_m, 0.0, h_m)
        f11 += dc * ((h_m - a) ** 3 - (h_m - b) ** 3) / 3
        f12 += dc * ((h_m - a) ** 2 - (h_m - b) ** 2) / 2
        f22 += dc * (b - a)
    det = f11 * f22 - f12 ** 2
    k22 = np.stack([np.stack([f22, -f12], -1), np.stack([-f12, f11], -1)], -2) / det[:, None, None]
    T = np.array([[-1.0, -h_m, 1.0, 0.0], [0.0, -1.0, 0.0, 1.0]])
    return np.einsum("ia,eij,jb->eab", T, k22, T)


def element_mass(beam: Beam, h_m: float) -> np.ndarray:
    """Consistent mass of one element (uniform), shape (4, 4) (kg, kg m, kg m^2)."""
    phi = 0.0 if math.isinf(beam.kGA_N) else 12 * beam.EI_Nm2 / (beam.kGA_N * h_m ** 2)
    g, w = np.polynomial.legendre.leggauss(4)
    xi, w = (g + 1) / 2, w / 2
    Nv, Nt = shape_functions(xi, h_m, phi)
    return h_m * (beam.mass_per_length_kg_m * np.einsum("q,qa,qb->ab", w, Nv, Nv)
                  + beam.rho_I_kg_m * np.einsum("q,qa,qb->ab", w, Nt, Nt))


def point_row(beam: Beam, x_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Full-DOF indices (4,) and displacement interpolation row (4,) at ``x_m``."""
    n, h = beam.n_elements, beam.length_m / beam.n_elements
    e = min(int(x_m // h), n - 1)
    phi = 0.0 if math.isinf(beam.kGA_N) else 12 * beam.EI_Nm2 / (beam.kGA_N * h ** 2)
    Nv, _ = shape_functions(np.array([(x_m - e * h) / h]), h, phi)
    return np.arange(2 * e, 2 * e + 4), Nv[0]


def assemble(beam: Beam) -> Assembled:
    """Assemble ``(M, K, C)`` of a beam on its free DOFs (end constraints or springs applied)."""
    n, h = beam.n_elements, beam.length_m / beam.n_elements
    nd = 2 * (n + 1)
    node_x = np.linspace(0.0, beam.length_m, n + 1)
    Ke = element_stiffness(beam, node_x[:-1], h)
    Me = element_mass(beam, h)
    idx = 2 * np.arange(n)[:, None] + np.arange(4)[None, :]
    M, K, C = np.zeros((nd, nd)), np.zeros((nd, nd)), np.zeros((nd, nd))
    rows, cols = idx[:, :, None], idx[:, None, :]
    np.add.at(K, (np.broadcast_to(rows, Ke.shape), np.broadcast_to(cols, Ke.shape)), Ke)
    np.add.at(M, (np.broadcast_to(rows, Ke.shape), np.broadcast_to(cols, Ke.shape)),
              np.broadcast_to(Me, Ke.shape))
    for p in beam.masses:
        d, N = point_row(beam, p.x_m)
        M[np.ix_(d, d)] += p.mass_kg * np.outer(N, N)
    B = np.zeros((len(beam.dashpots), nd))
    for j, p in enumerate(beam.dashpots):
        d, N = point_row(beam, p.x_m)
        C[np.ix_(d, d)] += p.c_Ns_m * np.outer(N, N)
        B[j, d] = N
    keep = np.ones(nd, bool)
    for dof, k in ((0, beam.root_k_y_N_m), (1, beam.root_k_theta_Nm_rad),
                   (nd - 2, beam.tip_k_y_N_m), (nd - 1, beam.tip_k_theta_Nm_rad)):
        if math.isinf(k):
            keep[dof] = False
        elif k > 0:
            K[dof, dof] += k
    dof_index = np.full(nd, -1)
    dof_index[keep] = np.arange(keep.sum())
    sel = np.ix_(keep, keep)
    return Assembled(M=M[sel], K=K[sel], C=C[sel], dashpot_rows=B[:, keep],
                     dashpot_c_Ns_m=np.array([p.c_Ns_m for p in beam.dashpots], dtype=float),
                     node_x_m=node_x, dof_index=dof_index)


def mesh_elements(length_m: float, points_x_m, min_elements: int = N_ELEMENTS, max_elements: int = 2000) -> int:
    """The fewest elements ``>= min_elements`` of a uniform mesh with a node at every point ``points_x_m`` (m).

    Raises ``ValueError`` when no mesh up to ``max_elements`` has them all as nodes."""
    r = np.asarray(points_x_m, dtype=float) / length_m
    for n in range(max(1, min_elements), max_elements + 1):
        if np.all(np.abs(r * n - np.rint(r * n)) <= 1e-9 * n):
            return n
    raise ValueError(f"no uniform mesh of {min_elements}-{max_elements} elements has nodes at {list(points_x_m)} m "
                     f"on a {length_m} m beam")


@dataclass(frozen=True)
class Modes:
    """Undamped modes: ``omega_rad_s`` (n,) ascending, mass-normalised ``phi`` (n_dof, n)."""

    omega_rad_s: np.ndarray
    phi: np.ndarray

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.omega_rad_s / (2 * math.pi)


def modes(asm: Assembled, n_refine: int = 12) -> Modes:
    """All undamped modes of ``(M, K)``; the lowest ``n_refine`` refined to full relative accuracy.

    The dense generalised eigensolver is accurate to ``eps * omega_max^2``, which for a fine mesh
    is ~1e-7 of the fundamental's ``omega^2``; two steps of subspace (inverse) iteration with
    ``K^-1 M`` and a Rayleigh-Ritz solve restore the low modes to ~``eps``. A beam free at both ends
    without springs (singular ``K``) iterates with ``(K + s M)^-1 M``, ``s`` a small shift; the
    Rayleigh-Ritz solve on ``(K, M)`` gives its rigid-body modes at ``omega = 0``.
    """
    w2, phi = scipy.linalg.eigh(asm.K, asm.M)
    n = min(n_refine, w2.size)
    if n:
        try:
            chol = scipy.linalg.cho_factor(asm.K)
        except np.linalg.LinAlgError:
            shift = 1e-6 * float(abs(w2[n - 1]))
            chol = scipy.linalg.cho_factor(asm.K + shift * asm.M)
        X = phi[:, :n]
        for _ in range(2):
            X = scipy.linalg.cho_solve(chol, asm.M @ X)
            r2, Y = scipy.linalg.eigh(X.T @ asm.K @ X, X.T @ asm.M @ X)
            X = X @ Y
        w2[:n], phi[:, :n] = r2, X
        phi[:, n:] -= X @ (X.T @ (asm.M @ phi[:, n:]))  # keep the higher modes M-orthogonal to them
    return Modes(np.sqrt(np.clip(w2, 0.0, None)), phi)
