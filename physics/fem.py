"""Euler-Bernoulli beam finite elements: element matrices, assembly, boundary conditions.

DOF bookkeeping
---------------
Nodes are numbered from 1 at ``x = 0`` (the clamped root of a cantilever, as in
the thesis). Every node has a transverse translation ``"y"`` and a rotation
``"rz"``; a DOF is named ``"<node>:<dir>"``, e.g. ``"3:y"``. Global matrices
are ordered node by node, ``[1:y, 1:rz, 2:y, 2:rz, ...]``, and boundary
conditions remove DOFs from that list. Choose masters and slaves by name with
:meth:`FEModel.index`, never by index arithmetic.

Batching
--------
Element properties may carry leading batch axes: ``EI_Nm2`` and ``mass_per_length_kg_m``
as scalars or arrays of shape ``(..., n_elements)``. Assembly then returns
matrices of shape ``(..., n_dof, n_dof)``, so one call builds a million models.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from physics.errors import BeamDamageError, ShapeError
from physics.supports import THESIS_SUPPORT, add_springs, support

__all__ = ["FEModel", "KeptDofs", "MAX_ELEMENTS", "assemble", "beam_model", "check_n_elements",
           "constrained_dofs", "dof_names", "element_mass", "element_stiffness", "kept_dofs", "lumped_mass"]


#: Most elements of a dense model (three (2n+2)^2 float64 matrices: 2000 elements need 0.38 GB).
MAX_ELEMENTS = 2000


def check_n_elements(n_elements) -> int:
    """``n_elements`` as an int in ``1..MAX_ELEMENTS``; the error names the memory a larger mesh would need."""
    n = int(n_elements)
    if n < 1:
        raise BeamDamageError(f"n_elements must be >= 1, got {n_elements}", parameter="n_elements")
    if n > MAX_ELEMENTS:
        gib = 3 * (2 * n + 2) ** 2 * 8 / 2**30
        raise BeamDamageError(f"n_elements must be <= {MAX_ELEMENTS} (dense matrices; {n} elements would need "
                              f"{gib:.3g} GiB), got {n}", parameter="n_elements")
    return n


# Element matrices as polynomials in the element length l: A0 + A1*l + A2*l**2.
_M_COEF = np.array([
    [[156, 0, 54, 0], [0, 0, 0, 0], [54, 0, 156, 0], [0, 0, 0, 0]],
    [[0, 22, 0, -13], [22, 0, 13, 0], [0, 13, 0, -22], [-13, 0, -22, 0]],
    [[0, 0, 0, 0], [0, 4, 0, -3], [0, 0, 0, 0], [0, -3, 0, 4]],
], dtype=float)
_K_COEF = np.array([
    [[12, 0, -12, 0], [0, 0, 0, 0], [-12, 0, 12, 0], [0, 0, 0, 0]],
    [[0, 6, 0, 6], [6, 0, -6, 0], [0, -6, 0, -6], [6, 0, -6, 0]],
    [[0, 0, 0, 0], [0, 4, 0, 2], [0, 0, 0, 0], [0, 2, 0, 4]],
], dtype=float)


def _poly(coef, length_m):
    l = np.asarray(length_m, dtype=float)[..., None, None]
    return coef[0] + coef[1] * l + coef[2] * l**2


def element_mass(mass_per_length_kg_m, length_m):
    """Consistent mass matrix of a beam element (eq. 3.8).

    Parameters
    ----------
    mass_per_length_kg_m : float or ndarray, shape (...)
        Mass per unit length (kg/m).
    length_m : float or ndarray, shape (...)
        Element length (m).

    Returns
    -------
    ndarray, shape (..., 4, 4)
        DOF order ``[w1, theta1, w2, theta2]``.
    """
    m = np.asarray(mass_per_length_kg_m, dtype=float)[..., None, None]
    l = np.asarray(length_m, dtype=float)[..., None, None]
    return m * l / 420.0 * _poly(_M_COEF, length_m)


def element_stiffness(EI_Nm2, length_m):
    """Stiffness matrix of a beam element (eq. 3.9).

    Parameters
    ----------
    EI_Nm2 : float or ndarray, shape (...)
        Flexural rigidity (N m^2).
    length_m : float or ndarray, shape (...)
        Element length (m).

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    ei = np.asarray(EI_Nm2, dtype=float)[..., None, None]
    l = np.asarray(length_m, dtype=float)[..., None, None]
    return ei / l**3 * _poly(_K_COEF, length_m)


def assemble(element_matrices):
    """Assemble element matrices of a straight chain of beam elements.

    Element ``e`` joins nodes ``e+1`` and ``e+2``, so its 4x4 block adds onto
    global DOFs ``2e .. 2e+3``. The loop runs over elements only; every add is
    vectorised over the batch axes.

    Parameters
    ----------
    element_matrices : ndarray, shape (..., n_elements, 4, 4)

    Returns
    -------
    ndarray, shape (..., 2*(n_elements+1), 2*(n_elements+1))
        Global matrix over all node DOFs ``[1:y, 1:rz, 2:y, ...]``.
    """
    ke = np.asarray(element_matrices, dtype=float)
    if ke.ndim < 3 or ke.shape[-2:] != (4, 4):
        raise ShapeError(f"element matrices must have shape (..., n_elements, 4, 4), got {ke.shape}")
    n_el = ke.shape[-3]
    n_dof = 2 * (n_el + 1)
    out = np.zeros(ke.shape[:-3] + (n_dof, n_dof))
    for e in range(n_el):
        out[..., 2 * e:2 * e + 4, 2 * e:2 * e + 4] += ke[..., e, :, :]
    return out


def dof_names(n_nodes: int) -> tuple[str, ...]:
    """All DOF names of a beam with ``n_nodes`` nodes, in global order."""
    return tuple(f"{n}:{d}" for n in range(1, n_nodes + 1) for d in ("y", "rz"))


def constrained_dofs(bc: str, n_nodes: int, root_spring: bool = False) -> tuple[str, ...]:
    """Names of the DOFs the supports ``bc`` (:func:`physics.supports.support`) hold at zero.

    ``root_spring=True`` keeps the rotation of every clamp, which is then held by a rotational spring instead.
    """
    sup = support(bc)
    if root_spring and not sup.clamped:
        raise BeamDamageError(f"a root rotational spring needs a clamp; a {bc} beam has none", parameter="bc")
    return sup.constrained_dofs(n_nodes, sup.end_dofs(n_nodes, "clamped", "rz") if root_spring else ())


class KeptDofs(NamedTuple):
    """DOFs left after a boundary condition (result of :func:`kept_dofs`).

    Attributes
    ----------
    indices : ndarray of int, shape (n,)
        Positions in the global node-by-node order ``[1:y, 1:rz, 2:y, ...]``.
    names : tuple of str
        Their names (``"node:dir"``).
    """

    indices: np.ndarray
    names: tuple


def kept_dofs(n_nodes: int, bc: str = THESIS_SUPPORT, root_spring: bool = False) -> KeptDofs:
    """Global indices and names of the DOFs a boundary condition keeps (the one DOF bookkeeping).

    Parameters
    ----------
    n_nodes : int
        Nodes of the beam (elements + 1).
    bc : str
        The supports (:data:`physics.supports.SUPPORTS`).
    root_spring : bool
        Keep the rotation of every clamp (held by a rotational spring).

    Returns
    -------
    KeptDofs
        ``(indices, names)``; slice global matrices with ``np.ix_(indices, indices)``.
    """
    names = dof_names(n_nodes)
    removed = set(constrained_dofs(bc, n_nodes, root_spring))
    keep = [i for i, d in enumerate(names) if d not in removed]
    return KeptDofs(np.array(keep, dtype=int), tuple(names[i] for i in keep))


@dataclass(frozen=True)
class FEModel:
    """Assembled beam model after boundary conditions.

    Attributes
    ----------
    M, K : ndarray, shape (..., n, n)
        Mass (kg, kg m^2) and stiffness (N/m, N m/rad) matrices over ``dofs``.
    C : ndarray, shape (..., n, n)
        Viscous damping matrix (N s/m); zeros unless element damping was given.
    dofs : tuple of str
        Names of the remaining DOFs (``"node:dir"``).
    node_x : ndarray, shape (n_nodes,)
        Node positions along the beam (m), node 1 at ``x = 0`` (also as ``node_x_m``).
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    dofs: tuple
    node_x: np.ndarray

    @property
    def node_x_m(self) -> np.ndarray:
        """Node positions along the beam (m); the unit-suffixed name of ``node_x``."""
        return self.node_x

    def index(self, names) -> np.ndarray:
        """Indices of DOFs given by name (``"3:y"``); raises on unknown names."""
        lookup = {d: i for i, d in enumerate(self.dofs)}
        missing = [n for n in names if n not in lookup]
        if missing:
            raise BeamDamageError(f"unknown or constrained DOF(s) {missing}; model DOFs are {list(self.dofs)}")
        return np.array([lookup[n] for n in names], dtype=int)

    def translations(self) -> tuple[str, ...]:
        """Names of the free translational DOFs (the measurable ones)."""
        return tuple(d for d in self.dofs if d.endswith(":y"))


def beam_model(
    n_elements: int,
    length_m: float,
    EI_Nm2,
    mass_per_length_kg_m,
    *,
    ei_factors=None,
    mass_factors=None,
    damping_factors=None,
    bc: str = THESIS_SUPPORT,
    root_spring=None,
) -> FEModel:
    """Uniform beam of equal elements with optional per-element factors.

    Parameters
    ----------
    n_elements : int
        Number of equal elements.
    length_m : float
        Beam (cantilever) length (m).
    EI_Nm2 : float or ndarray, shape (...)
        Nominal flexural rigidity (N m^2); leading axes are batch axes.
    mass_per_length_kg_m : float or ndarray, shape (...)
        Nominal mass per length (kg/m).
    ei_factors, mass_factors : ndarray, shape (..., n_elements), optional
        Multipliers of each element's ``EI`` and mass (damage, variability).
    damping_factors : ndarray, shape (..., n_elements), optional
        Stiffness-proportional damping coefficient of each element (s):
        ``C = sum_e beta_e K_e``. Zeros give ``C = 0``.
    bc : str
        The supports (:data:`physics.supports.SUPPORTS`).
    root_spring : float or ndarray, shape (...), optional
        Rotational stiffness (N m/rad) replacing each clamp's hold on its rotation (supports with a clamp).

    Returns
    -------
    FEModel
    """
    check_n_elements(n_elements)
    if not np.isfinite(length_m) or length_m <= 0:
        raise BeamDamageError(f"length_m must be a positive number of metres, got {length_m}", parameter="length_m")
    n_el = int(n_elements)
    ei, mpl = _element_properties(n_el, EI_Nm2, mass_per_length_kg_m, ei_factors, mass_factors)
    le = length_m / n_el
    ke = element_stiffness(ei, le)
    me = element_mass(mpl, le)
    K = assemble(ke)
    M = assemble(me)
    C = _damping_matrix(damping_factors, ke, n_el) if damping_factors is not None else np.zeros_like(K)
    n_nodes = n_el + 1
    keep, names = kept_dofs(n_nodes, bc, root_spring is not None)
    if root_spring is not None:
        K = _with_root_spring(K, root_spring, support(bc).end_dofs(n_nodes, "clamped", "rz"), n_nodes)
    sel = np.ix_(keep, keep)
    return FEModel(
        M=M[(...,) + sel],
        K=K[(...,) + sel],
        C=C[(...,) + sel],
        dofs=names,
        node_x=np.linspace(0.0, length_m, n_nodes),
    )


def _element_properties(n_el: int, EI_Nm2, mass_per_length_kg_m, ei_factors, mass_factors):
    """Checked ``EI`` (N m^2) and mass per length (kg/m) of each element, both of shape (batch..., n_el)."""
    ei = np.asarray(EI_Nm2, dtype=float)[..., None] * (1.0 if ei_factors is None else np.asarray(ei_factors, float))
    mpl = np.asarray(mass_per_length_kg_m, dtype=float)[..., None] * (
        1.0 if mass_factors is None else np.asarray(mass_factors, float))
    for name, arr in (("EI_Nm2", ei), ("mass_per_length_kg_m", mpl)):
        if arr.shape[-1] not in (1, n_el):
            raise ShapeError(f"{name} factors must have n_elements={n_el} entries on the last axis")
    # one batch shape for both matrices
    batch = np.broadcast_shapes(ei.shape[:-1], mpl.shape[:-1])
    ei = np.broadcast_to(ei, batch + (n_el,))
    mpl = np.broadcast_to(mpl, batch + (n_el,))
    for name, arr in (("EI_Nm2", ei), ("mass_per_length_kg_m", mpl)):
        if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise BeamDamageError(f"{name} (times its factors) must be finite and positive", parameter=name)
    return ei, mpl


def _damping_matrix(damping_factors, ke, n_el: int):
    """Assembled ``C = sum_e beta_e K_e`` (N s/m) from checked coefficients ``beta_e >= 0`` (s), one per element."""
    beta = np.asarray(damping_factors, dtype=float)
    if beta.shape[-1] != n_el or np.any(beta < 0) or not np.all(np.isfinite(beta)):
        raise BeamDamageError("damping_factors must be finite, >= 0, one per element", parameter="damping_factors")
    return assemble(beta[..., None, None] * ke)


def _with_root_spring(K, root_spring, clamp_rotations, n_nodes: int):
    """``K`` (over all DOFs) with the checked rotational stiffness ``root_spring`` (N m/rad) added on each of
    ``clamp_rotations``."""
    kr = np.asarray(root_spring, dtype=float)
    if np.any(kr <= 0) or not np.all(np.isfinite(kr)):
        raise BeamDamageError("root_spring must be a positive rotational stiffness (N m/rad)",
                              parameter="root_spring")
    return add_springs(K, dof_names(n_nodes), clamp_rotations, kr)


def lumped_mass(mass_per_length_kg_m, element_length_m, n_masters: int = 4):
    """The thesis's lumped-mass model over the translations (eq. 4.6).

    It is the translation-translation partition of the consistent mass matrix of
    a cantilever: ``m l / 420`` times 312 on the diagonal (156 at the free tip)
    and 54 between neighbouring nodes.

    Parameters
    ----------
    mass_per_length_kg_m : float or ndarray, shape (...)
        Mass per length (kg/m).
    element_length_m : float
        Element length (m).
    n_masters : int
        Number of translational DOFs (free nodes).

    Returns
    -------
    ndarray, shape (..., n_masters, n_masters)
    """
    pattern = 312.0 * np.eye(n_masters) + 54.0 * (np.eye(n_masters, k=1) + np.eye(n_masters, k=-1))
    pattern[-1, -1] = 156.0
    m = np.asarray(mass_per_length_kg_m, dtype=float)[..., None, None]
    return m * element_length_m / 420.0 * pattern
