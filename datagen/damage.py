"""Slits as local losses of flexural rigidity on the truth mesh.

A slit ``k`` has a centre ``x_k`` (m, ``0 < x < L``), an effective width
``w_k`` (m) and a depth ``d_k`` (m) into the top face sheet. Over
``[x_k - w_k/2, x_k + w_k/2]`` (clipped to the beam) the rigidity drops from
``EI`` to ``EI_d = EI * r(d_k)`` (:func:`datagen.specimen.slit_section_ei`).

Flexibility-exact elements
--------------------------
The slit need not sit on element boundaries. Every element it overlaps gets
the stiffness that follows exactly from integrating ``1/EI(x)``: clamped at
node 1 and loaded by a tip force and moment at node 2 (local ``0 <= s <= l``),
the element's flexibility is

    ``F = [[int (l-s)^2/EI ds + l/kGA, int (l-s)/EI ds], [int (l-s)/EI ds, int 1/EI ds]]``,

and equilibrium gives the 4x4 stiffness ``[[H k H^T, H k], [k H^T, k]]``
with ``k = F^-1`` and ``H = [[-1, 0], [-l, -1]]`` (DOFs ``[w1, theta1, w2,
theta2]``). For a uniform section this is eq. 3.9, and with the shear term
(``kGA = 12 EI / (phi l^2)``) the Timoshenko element of
:func:`physics.effects.timoshenko_stiffness`. Over a slit ``1/EI`` rises by
``1/EI_d - 1/EI``: moment is continuous through the reduced section, so its
curvature is ``M / EI_d`` and the static response to any load on the nodes is
exact on any mesh. The shear compliance is left unchanged (the slit removes
bending rigidity only). For a narrow shallow slit the change of the squared
natural frequency of a mass-normalised mode is ``-(EI - EI_d) w kappa(x)^2``
(curvature squared at the slit); to first order in the width it is
``-(EI - EI_d) (EI / EI_d) w kappa(x)^2`` at any depth.

The slit's extra damping is stiffness-proportional over the slit, with the
element's own curvature field ``B`` (Hermite second derivatives, or on
Timoshenko elements the curvature ``theta'`` of the interdependent
interpolation): ``Delta C_e = beta_k EI G_e``, ``G_e = int_overlap B^T B dx``.

Where slits overlap the section loses the rigidity of the deepest one (the
largest ``EI - EI_d``), not the sum.
"""

from __future__ import annotations

import numpy as np

__all__ = ["clamped_flexibility", "curvature_basis", "draw_slits", "element4_index", "expand_tip_stiffness",
           "overlap_energy", "slit_corrections", "slit_element_weights", "stiffness_from_flexibility"]


def curvature_basis(element_length, shear_phi=0.0):
    """``b0, b1`` with curvature ``B(xi) = b0 + xi b1`` over the element DOFs (1/m^2 and 1/m).

    DOF order ``[w1, theta1, w2, theta2]``, ``xi = s / l`` in ``[0, 1]``:
    curvature ``theta'`` of the Timoshenko element of
    :func:`physics.effects.timoshenko_stiffness` (its slope term is the Hermite
    one divided by ``1 + phi``); ``shear_phi = 0`` gives the second derivative of
    the Hermite shapes.

    Parameters
    ----------
    element_length : float (m)
    shear_phi : float or ndarray, shape (...)   ``12 EI / (kGA l^2)``

    Returns
    -------
    b0, b1 : ndarray, shape (..., 4)
    """
    l = float(element_length)
    phi = np.asarray(shear_phi, float)[..., None]
    b1 = np.array([12 / l**2, 6 / l, -12 / l**2, 6 / l]) / (1.0 + phi)
    return np.array([0.0, -1 / l, 0.0, 1 / l]) - b1 / 2, b1


def overlap_energy(xi1, xi2, element_length, shear_phi=0.0):
    """``G = int_{xi1}^{xi2} B^T B ds`` for local coordinates ``xi1 <= xi2`` (batched).

    Parameters
    ----------
    xi1, xi2 : ndarray, shape (...)
    element_length : float (m)
    shear_phi : float or ndarray broadcasting against ``xi1``
        ``12 EI / (kGA l^2)`` of a Timoshenko element (0: Euler-Bernoulli)

    Returns
    -------
    ndarray, shape (..., 4, 4)   (1/m^3 ... units of stiffness / EI)
    """
    b0, b1 = curvature_basis(element_length, shear_phi)
    b0c, b0r, b1c, b1r = b0[..., :, None], b0[..., None, :], b1[..., :, None], b1[..., None, :]
    a0 = b0c * b0r
    a1 = b0c * b1r + b1c * b0r
    a2 = b1c * b1r
    x1 = np.asarray(xi1, float)[..., None, None]
    x2 = np.asarray(xi2, float)[..., None, None]
    return element_length * ((x2 - x1) * a0 + (x2**2 - x1**2) / 2 * a1 + (x2**3 - x1**3) / 3 * a2)


def slit_element_weights(x_m, width_m, length_m, n_elements):
    """Overlap of each slit with each element as local coordinates.

    Parameters
    ----------
    x_m, width_m : ndarray, shape (..., S)
        Slit centres and widths (m); ``width_m = 0`` disables a slit.
    length_m : float
    n_elements : int

    Returns
    -------
    xi1, xi2 : ndarray, shape (..., S, n_elements)
        Local overlap interval in each element (``xi1 == xi2`` where none).
    """
    le = length_m / n_elements
    x = np.asarray(x_m, float)[..., None]
    w = np.asarray(width_m, float)[..., None]
    a = np.clip(x - w / 2, 0.0, length_m)
    b = np.clip(x + w / 2, 0.0, length_m)
    starts = np.arange(n_elements) * le
    xi1 = np.clip((a - starts) / le, 0.0, 1.0)
    xi2 = np.clip((b - starts) / le, 0.0, 1.0)
    return xi1, np.maximum(xi1, xi2)


def clamped_flexibility(ei_Nm2, element_length, shear_phi=0.0):
    """Tip flexibility ``F0`` of a uniform element clamped at node 1 (batched over ``ei_Nm2``).

    Parameters
    ----------
    ei_Nm2 : ndarray, shape (...)
    element_length : float (m)
    shear_phi : float or ndarray, shape (...)   ``12 EI / (kGA l^2)`` (0: Euler-Bernoulli)

    Returns
    -------
    ndarray, shape (..., 2, 2)   [[m/N, 1/N], [1/N, 1/(N m)]] for tip ``[force, moment]``
    """
    l = float(element_length)
    f = np.array([[l**3 / 3, l**2 / 2], [l**2 / 2, l]]) + np.array([[l**3 / 12, 0.0], [0.0, 0.0]]) * np.asarray(
        shear_phi, float)[..., None, None]
    return f / np.asarray(ei_Nm2, float)[..., None, None]


def expand_tip_stiffness(k, element_length):
    """4x4 element stiffness ``[[H k H^T, H k], [k H^T, k]]`` from the node-2 block ``k`` (..., 2, 2).

    ``H = [[-1, 0], [-l, -1]]`` carries the tip force and moment to node 1 by
    equilibrium; DOFs ``[w1, theta1, w2, theta2]`` (N/m ...).
    """
    l = float(element_length)
    hk = np.stack([-k[..., 0, :], -l * k[..., 0, :] - k[..., 1, :]], axis=-2)       # H k
    hkh = np.stack([-hk[..., :, 0], -l * hk[..., :, 0] - hk[..., :, 1]], axis=-1)    # H k H^T
    top = np.concatenate([hkh, hk], axis=-1)
    bottom = np.concatenate([hk.mT, k], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


def stiffness_from_flexibility(F, element_length):
    """Element stiffness (..., 4, 4) of the tip flexibility ``F`` (..., 2, 2) of :func:`clamped_flexibility`."""
    return expand_tip_stiffness(np.linalg.inv(F), element_length)


def slit_corrections(x_m, width_m, ei_loss_Nm2, beta_s, ei_Nm2, length_m, n_elements, shear_phi=0.0):
    """Element stiffness and damping corrections of all slits (overlaps lose the deepest slit's rigidity).

    ``dK = K(F0 + dF) - K(F0)`` per element (flexibility-exact, see the module
    docstring), evaluated as ``expand(-k dF k0)`` with ``k = (F0 + dF)^-1``;
    exactly 0 where no slit covers an element.

    Parameters
    ----------
    x_m, width_m : ndarray, shape (B, S)
    ei_loss_Nm2 : ndarray, shape (B, S)
        ``EI - EI_d`` of each slit (N m^2, below ``EI``); 0 for absent slits.
    beta_s : ndarray, shape (B, S)
        Extra stiffness-proportional damping coefficient of each slit (s).
    ei_Nm2 : ndarray, shape (B,)
        Specimen rigidity (N m^2).
    shear_phi : float or ndarray, shape (B,)
        ``12 EI / (kGA l^2)`` of the truth elements (0: Euler-Bernoulli), per sample or for all.

    Returns
    -------
    dK, dC : ndarray, shape (B, n_elements, 4, 4)
        To add to the element stiffness and damping matrices (``dK`` negative semi-definite).
    """
    le = length_m / n_elements
    ei = np.asarray(ei_Nm2, float)
    xi1, xi2 = slit_element_weights(x_m, width_m, length_m, n_elements)
    phi = np.asarray(shear_phi, float)
    G = overlap_energy(xi1, xi2, le, phi[..., None, None] if phi.ndim else phi)  # (B, S, E, 4, 4)
    dC = np.einsum("bs,bseij->beij", np.asarray(beta_s, float) * ei[:, None], G)
    # pieces between consecutive slit edges, each losing its deepest covering slit's rigidity
    edges = np.sort(np.concatenate([xi1, xi2], axis=1), axis=1)           # (B, 2S, E)
    a, b = edges[:, :-1], edges[:, 1:]
    mid = 0.5 * (a + b)
    cover = (xi1[:, :, None] <= mid[:, None]) & (mid[:, None] < xi2[:, :, None])      # (B, S, 2S-1, E)
    loss = np.max(np.where(cover, np.asarray(ei_loss_Nm2, float)[:, :, None, None], 0.0), axis=1)
    e = ei[:, None, None]
    c = loss / (e * (e - loss))                                           # 1/EI_d - 1/EI (m^-2 N^-1), (B, 2S-1, E)
    ua, ub = 1.0 - a, 1.0 - b                                             # (l - s) / l at the piece ends
    d00 = le**3 * np.sum(c * (ua**3 - ub**3), axis=1) / 3                 # int (l-s)^2 ds, (B, E)
    d01 = le**2 * np.sum(c * (ua**2 - ub**2), axis=1) / 2                 # int (l-s) ds
    d11 = le * np.sum(c * (b - a), axis=1)                                # int ds
    dF = np.stack([np.stack([d00, d01], -1), np.stack([d01, d11], -1)], -2)   # (B, E, 2, 2)
    F0 = clamped_flexibility(ei, le, phi)[:, None]                        # (B, 1, 2, 2)
    k0 = np.linalg.inv(F0)
    k = np.linalg.inv(F0 + dF)
    dK = expand_tip_stiffness(-(k @ dF @ k0), le)
    return dK, dC


def element4_index(x_m, length_m):
    """1-based element of the thesis's 4-element grid holding ``x`` (0 where ``x`` is NaN)."""
    x = np.asarray(x_m, float)
    idx = np.clip(np.floor(np.nan_to_num(x, nan=-1.0) / (length_m / 4)).astype(int) + 1, 1, 4)
    return np.where(np.isfinite(x), idx, 0)


def draw_slits(rng: np.random.Generator, n: int, cfg: dict, length_m: float, layout) -> dict:
    """Slit parameters of ``n`` samples, padded to the maximum slit count with NaN.

    A fraction ``damage.intact_fraction`` of the samples gets no slit. The
    slit's depth is drawn from ``damage.depth_m``, or, when ``damage.ei_loss``
    is set, the relative EI loss of the slit section is drawn and the depth
    follows from the layered section (:func:`datagen.specimen.depth_for_ei_loss`).

    Returns
    -------
    dict of ndarray
        ``n_slits`` (n,), ``x_m``, ``width_m``, ``depth_m``, ``beta_s`` (n, S_max);
        absent slits are NaN.
    """
    from datagen.specimen import depth_for_ei_loss

    d = cfg["damage"]
    lo, hi = d["n_slits"]
    smax = max(hi, 1)
    k = rng.integers(lo, hi + 1, size=n)
    u = rng.random((n, smax, 4))
    k = np.where(rng.random(n) < d["intact_fraction"], 0, k)

    def span(key, col):
        a, b = d[key]
        return a + (b - a) * u[:, :, col]

    present = np.arange(smax)[None, :] < k[:, None]
    out = {"n_slits": k}
    for key, name, col, scale in (("position_fraction", "x_m", 0, length_m), ("width_m", "width_m", 1, 1.0),
                                  ("depth_m", "depth_m", 2, 1.0), ("slit_damping_s", "beta_s", 3, 1.0)):
        out[name] = np.where(present, span(key, col) * scale, np.nan)
    if d["ei_loss"]:
        out["depth_m"] = np.where(present, depth_for_ei_loss(layout, span("ei_loss", 2)), np.nan)
    return out
