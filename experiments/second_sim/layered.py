"""A sandwich cantilever as two layered beams: the top face and the core with the bottom face, with debonds.

The top face ``t`` (thickness ``t_f``, modulus ``E_f``) and the sub-laminate ``c`` (bottom face and core, ``E_f``
and ``E_c``) are two Euler-Bernoulli beams, each with its own axial displacement ``u`` at its own centroid and
rigidity ``EI`` about it, sharing one deflection ``w`` (they stay in contact). Energy per length:
``(EA_t u_t'^2 + EA_c u_c'^2 + (EI_t + EI_c) w''^2) / 2``. Where the face is bonded, the interface does not
slip: ``u_t - e w' = u_c`` (``e``: the distance between the two centroids; ``u`` positive towards the tip, ``w``
up); where it is debonded, ``u_t`` is free. Deflection by Hermite cubics, axial displacements by quadratics
(three nodes per element), so that the slip ``u_t - u_c + e w'`` (a quadratic) vanishes identically in a
bonded element when it vanishes at its three nodes: a fully bonded beam is then exactly the composite beam of
rigidity ``EI_t + EI_c + e^2 EA_t EA_c / (EA_t + EA_c)`` (eq. 4.1).

A debond's tips are mesh nodes. ``tied_tips=True``: the face is bonded at the tips (at the root the clamp
holds it; a debond reaching the free end leaves the face's end free there) ; a closed debond in a
continuous face: the face over the debond carries a constant axial force, which the tips tie to the rotation
there); ``tied_tips=False``: the face over the debond carries no axial force (it slides freely: a debond open
to the free end, or a face cracked at a tip), so that the section there bends with ``EI_t + EI_c``.

The axial displacements carry no inertia (the bending modes of interest lie far below the axial ones) and are
condensed statically; the mass is the consistent Hermite mass of the beam's mass per length. The root is
clamped (both layers held), the tip free. Shares no code with physics, datagen or learn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from experiments.second_sim.fem import Assembled

__all__ = ["Sandwich", "composite_ei", "debond_ei", "face_modulus_for", "layered_assembled", "layered_frequencies_hz",
           "layered_matrices", "lowest_modes"]


@dataclass(frozen=True)
class Sandwich:
    """A symmetric sandwich section: width, total thickness, each face's thickness (m), face and core moduli (Pa)."""

    width_m: float
    thickness_m: float
    face_thickness_m: float
    face_modulus_pa: float
    core_modulus_pa: float

    def layers(self):
        """``(EA_t, EI_t, EA_c, EI_c, e)`` of the top face and of the sub-laminate (N, N m^2, m)."""
        b, h, tf, ef, ec = (self.width_m, self.thickness_m, self.face_thickness_m, self.face_modulus_pa,
                            self.core_modulus_pa)
        c = h - 2 * tf
        ea_t, ei_t = ef * b * tf, ef * b * tf**3 / 12
        parts = ((ef * b * tf, tf / 2, ef * b * tf**3 / 12), (ec * b * c, tf + c / 2, ec * b * c**3 / 12))
        ea_c = sum(p[0] for p in parts)
        z_c = sum(p[0] * p[1] for p in parts) / ea_c
        ei_c = sum(p[2] + p[0] * (p[1] - z_c) ** 2 for p in parts)
        return ea_t, ei_t, ea_c, ei_c, (h - tf / 2) - z_c


def composite_ei(s: Sandwich) -> float:
    """Rigidity of the bonded section (N m^2): the two parts' own plus ``e^2 EA_t EA_c / (EA_t + EA_c)``."""
    ea_t, ei_t, ea_c, ei_c, e = s.layers()
    return ei_t + ei_c + e**2 * ea_t * ea_c / (ea_t + ea_c)


def debond_ei(s: Sandwich) -> float:
    """Rigidity of the section whose face slides freely (N m^2): the face's own plus the sub-laminate's own."""
    _, ei_t, _, ei_c, _ = s.layers()
    return ei_t + ei_c


def face_modulus_for(EI_Nm2: float, width_m: float, thickness_m: float, face_thickness_m: float,
                     core_modulus_pa: float) -> float:
    """Face modulus (Pa) whose composite rigidity is ``EI_Nm2`` (it is linear in the face modulus)."""
    def ei(ef):
        return composite_ei(Sandwich(width_m, thickness_m, face_thickness_m, ef, core_modulus_pa))

    lo, hi = 1e6, 1e13
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if ei(mid) < EI_Nm2 else (lo, mid)
    return math.sqrt(lo * hi)


def _hermite_stiffness(h: float) -> np.ndarray:
    return np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                     [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]]) / h**3


def _hermite_mass(h: float) -> np.ndarray:
    return h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                               [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])


def _sparse(blocks, size: int):
    """Sparse sum of element blocks ``[(dofs (E, k), matrices (E, k, k)), ...]``."""
    r = np.concatenate([np.repeat(d[:, :, None], d.shape[1], 2).ravel() for d, _ in blocks])
    c = np.concatenate([np.repeat(d[:, None, :], d.shape[1], 1).ravel() for d, _ in blocks])
    v = np.concatenate([np.asarray(m, float).ravel() for _, m in blocks])
    return scipy.sparse.csr_matrix((v, (r, c)), shape=(size, size))


def layered_matrices(length_m: float, section: Sandwich, mass_per_length_kg_m: float, debonds=(),
                     n_elements: int = 240, tied_tips: bool = True, root_k_theta_Nm_rad: float = math.inf):
    """Mass and condensed stiffness on the deflection DOFs ``(w_i, w'_i)`` of nodes 1..n (root clamped; with a
    finite ``root_k_theta_Nm_rad`` the root's rotation is a DOF too, first, on that rotational spring).

    Parameters
    ----------
    debonds : sequence of (start_m, end_m)
        Debonded lengths; their ends must be nodes of the uniform mesh of ``n_elements``.

    Returns
    -------
    M, K : ndarray, shape (2 n, 2 n) or (2 n + 1, 2 n + 1)   (kg ..., N/m ...)
    G : ndarray, shape as ``K``        bending stiffness of the debonded elements for a unit rigidity (1/m^3 ...)
    """
    ea_t, ei_t, ea_c, ei_c, e = section.layers()
    n, h = n_elements, length_m / n_elements
    node = np.arange(n + 1)
    debonded = np.zeros(n, bool)
    for a, b in debonds:
        ia, ib = a / h, b / h
        if abs(ia - round(ia)) > 1e-6 or abs(ib - round(ib)) > 1e-6 or not 0 <= round(ia) < round(ib) <= n:
            raise ValueError(f"debond ({a}, {b}) m: its ends must be nodes of the {n}-element mesh on [0, {length_m}]")
        debonded[round(ia):round(ib)] = True
    # full DOFs: w, w' per node (2 (n+1)); u_c on the 2n+1 axial points; u_t on the 2n+1 axial points
    nb, na = 2 * (n + 1), 2 * n + 1
    iw, ic, it = 0, nb, nb + na
    nd = nb + 2 * na
    kb, kq = _hermite_stiffness(h), np.array([[7, -8, 1], [-8, 16, -8], [1, -8, 7]]) / (3 * h)
    el = np.arange(n)
    wd = iw + 2 * el[:, None] + np.arange(4)                                  # (n, 4)
    ad = 2 * el[:, None] + np.arange(3)                                       # (n, 3)
    face = np.where(debonded & (not tied_tips), 0.0, ea_t)
    blocks = [(wd, (ei_t + ei_c) * np.broadcast_to(kb, (n, 4, 4))), (ic + ad, ea_c * np.broadcast_to(kq, (n, 3, 3))),
              (it + ad, face[:, None, None] * kq)]
    K = _sparse(blocks, nd)
    G = _sparse([(wd[debonded], np.broadcast_to(kb, (int(debonded.sum()), 4, 4)))], nb).toarray()
    # ties u_t = u_c - e w' at the bonded axial points (every point of a bonded element; with free sliding, also
    # the points of debonded elements, whose face then has no axial stiffness)
    tied = np.ones(na, bool)
    if tied_tips:
        inside = np.zeros(na, bool)
        inside[2 * np.flatnonzero(debonded) + 1] = True                        # mid-points of debonded elements
        both = np.r_[False, debonded[:-1] & debonded[1:], debonded[-1]]        # nodes with debonded elements each
        #                                                  side, and the free end of a debond open to it
        inside[2 * node[both]] = True
        tied = ~inside
    # T: independent DOFs (w, w', u_c, the free u_t) -> full DOFs
    free_t = np.flatnonzero(~tied)
    ni = nb + na + free_t.size
    rows = [np.arange(nb + na), it + free_t]
    cols = [np.arange(nb + na), nb + na + np.arange(free_t.size)]
    vals = [np.ones(nb + na), np.ones(free_t.size)]
    p = np.flatnonzero(tied)
    rows.append(it + p), cols.append(ic + p), vals.append(np.ones(p.size))
    pn = p[p % 2 == 0]                                                         # nodes pn/2: their w'
    rows.append(it + pn), cols.append(iw + pn + 1), vals.append(np.full(pn.size, -e))
    pm = p[p % 2 == 1]                                                         # mid-points: w' of their element
    slope_mid = np.array([-1.5 / h, -0.25, 1.5 / h, -0.25])
    rows.append(np.repeat(it + pm, 4)), cols.append((iw + (pm - 1)[:, None] + np.arange(4)).ravel())
    vals.append(np.tile(-e * slope_mid, pm.size))
    T = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nd, ni))
    Kr = (T.T @ K @ T).tocsc()
    # clamp: w, w' of node 0 and both layers' axial displacement there (u_t follows when tied)
    spring = math.isfinite(root_k_theta_Nm_rad)
    keep = np.ones(ni, bool)
    keep[[0, nb]] = False
    keep[1] = spring
    if tied_tips and not tied[0]:
        keep[nb + na + np.searchsorted(free_t, 0)] = False
    Kr = Kr[keep][:, keep]
    first = 1 if spring else 2
    nw = nb - first
    Kww, Kwu, Kuu = Kr[:nw, :nw].toarray(), Kr[:nw, nw:], Kr[nw:, nw:]
    Kc = Kww - Kwu @ scipy.sparse.linalg.splu(Kuu.tocsc()).solve(Kwu.T.toarray())
    if spring:
        Kc[0, 0] += root_k_theta_Nm_rad
    M = _sparse([(wd, np.broadcast_to(mass_per_length_kg_m * _hermite_mass(h), (n, 4, 4)))], nb).toarray()
    return M[first:, first:], 0.5 * (Kc + Kc.T), G[first:, first:]


def layered_assembled(length_m: float, section: Sandwich, mass_per_length_kg_m: float, debonds=(),
                      n_elements: int = 120, tied_tips: bool = True, root_k_theta_Nm_rad: float = math.inf):
    """:func:`layered_matrices` as the simulator's :class:`experiments.second_sim.fem.Assembled` (no dashpots),
    and the debonded elements' unit bending stiffness ``G``."""
    M, K, G = layered_matrices(length_m, section, mass_per_length_kg_m, debonds, n_elements, tied_tips,
                               root_k_theta_Nm_rad)
    first = 2 * (n_elements + 1) - K.shape[0]
    dof_index = np.r_[np.full(first, -1), np.arange(K.shape[0])]
    return Assembled(M=M, K=K, C=np.zeros_like(K), dashpot_rows=np.zeros((0, K.shape[0])),
                     dashpot_c_Ns_m=np.zeros(0), node_x_m=np.linspace(0.0, length_m, n_elements + 1),
                     dof_index=dof_index), G


def layered_frequencies_hz(length_m: float, section: Sandwich, mass_per_length_kg_m: float, debonds=(),
                           n_elements: int = 240, tied_tips: bool = True, n_modes: int = 4) -> np.ndarray:
    """The first ``n_modes`` natural frequencies (Hz) of :func:`layered_matrices`."""
    M, K, _ = layered_matrices(length_m, section, mass_per_length_kg_m, debonds, n_elements, tied_tips)
    return np.sqrt(lowest_modes(M, K, n_modes)[0]) / (2 * math.pi)


def lowest_modes(M, K, n_modes: int):
    """The ``n_modes`` lowest ``omega^2`` (rad^2/s^2) and mass-normalised modes of ``(M, K)``, by shift-invert Lanczos
    refined by two steps of inverse iteration and a Rayleigh-Ritz solve."""
    m = min(2 * n_modes + 4, K.shape[0] - 1)
    _, X = scipy.sparse.linalg.eigsh(K, k=m, M=M, sigma=0.0, v0=np.ones(K.shape[0]))
    chol = scipy.linalg.cho_factor(K)
    for _ in range(2):
        X = scipy.linalg.cho_solve(chol, M @ X)
        w2, Y = scipy.linalg.eigh(X.T @ K @ X, X.T @ M @ X)
        X = X @ Y
    return w2[:n_modes], X[:, :n_modes]
