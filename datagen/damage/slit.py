"""Slits as local losses of flexural rigidity on the truth mesh: damage kind ``"slit"`` (:class:`Slit`).

A slit ``k`` has a centre ``x_k`` (m, ``0 < x < L``), an effective width
``w_k`` (m) and a depth ``d_k`` (m) into the top face sheet. Over
``[x_k - w_k/2, x_k + w_k/2]`` (clipped to the beam) the rigidity drops from
``EI`` to ``EI_d = EI * r(d_k)`` (:func:`slit_section_ei`: the top ``d_k`` of the
layered section of :mod:`datagen.specimen` removed; the section is then no longer
symmetric, so its rigidity is computed about the shifted neutral axis, which
reduces to eq. 4.1 for ``d = 0``).

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

Size
----
The size of a slit is its hinge flexibility: a slit of width ``w`` whose
section keeps a fraction ``1 - r`` of the rigidity adds the rotational
compliance ``w r / ((1 - r) EI)`` of a rotational spring ``k_theta`` at its
centre, and the non-dimensional flexibility ``theta = EI / (k_theta L) = w r /
((1 - r) L)`` is what the natural frequencies and shapes determine (to first
order in ``w``, ``d(omega^2) = -EI L theta kappa(x)^2`` for a mass-normalised
mode of curvature ``kappa``; width and depth on their own are not).
"""

from __future__ import annotations

import numpy as np

from datagen.checks import value_range
from datagen.damage.draws import check_loss_factor, draw_counts
from datagen.specimen import DEFAULT_SECTION, SectionLayout
from physics.errors import ConfigError
from physics.properties import beam_preset, section_ei

__all__ = ["Slit", "clamped_flexibility", "curvature_basis", "depth_for_ei_loss", "draw_slits",
           "equivalent_depth", "expand_tip_stiffness", "hinge_flexibility", "overlap_energy", "slit_corrections",
           "slit_element_weights", "slit_section_ei", "stiffness_from_flexibility"]

def slit_section_ei(layout: SectionLayout, depth_m):
    """Rigidity of the section with the top ``depth_m`` removed (about its own neutral axis).

    Parameters
    ----------
    layout : SectionLayout
    depth_m : float or ndarray, shape (...)
        Slit depth(s) from the top surface (m), ``0 <= d < h/2``.

    Returns
    -------
    ndarray, shape (...)
        ``EI`` (N m^2); equals ``layout.EI`` for ``d = 0``.
    """
    d = np.asarray(depth_m, dtype=float)[..., None]
    h, tf = layout.thickness_m, layout.face_thickness_m
    top = h - d                                            # the section is cut at h - d
    z_bot = np.minimum(np.array([0.0, tf, h - tf]), top)  # layers bottom face / core / top face
    z_top = np.minimum(np.array([tf, h - tf, h]), top)
    E = np.array([layout.face_modulus_pa, layout.core_modulus_pa, layout.face_modulus_pa])
    return section_ei(layout.width_m, z_bot, z_top, E)


def depth_for_ei_loss(layout: SectionLayout, ei_loss):
    """Slit depth (m) whose section keeps ``1 - ei_loss`` of the rigidity (inverse of :func:`slit_section_ei`).

    Depths range from 0 to the top of the bottom face sheet (cut through the
    top face and the core); the loss grows monotonically with depth and is
    inverted by interpolation on a fine table (relative error in the loss
    below 1e-6; the stored loss is recomputed from the depth).
    """
    h, tf = layout.thickness_m, layout.face_thickness_m
    grid = np.linspace(0.0, h - tf, 20001)
    loss = 1.0 - slit_section_ei(layout, grid) / layout.EI
    want = np.asarray(ei_loss, float)
    if np.nanmax(want, initial=0.0) > loss[-1]:
        raise ConfigError(f"config key 'damage.ei_loss' must stay below {loss[-1]:.4f}, the loss of a cut "
                          f"through the top face and the core")
    return np.interp(want, loss, grid)


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


def draw_slits(rng: np.random.Generator, n: int, cfg: dict, length_m: float, layout) -> dict:
    """Slit parameters of ``n`` samples, padded to the maximum slit count with NaN.

    A fraction ``damage.intact_fraction`` of the samples gets no slit. The
    slit's depth is drawn from ``damage.depth_m``, or, when ``damage.ei_loss``
    is set, the relative EI loss of the slit section is drawn and the depth
    follows from the layered section (:func:`depth_for_ei_loss`).

    Returns
    -------
    dict of ndarray
        ``n_slits`` (n,), ``x_m``, ``width_m``, ``depth_m``, ``beta_s`` (n, S_max);
        absent slits are NaN.
    """
    d = cfg["damage"]
    k, u, present = draw_counts(rng, n, d, "n_slits", 4)

    def span(key, col):
        a, b = d[key]
        return a + (b - a) * u[:, :, col]

    out = {"n_slits": k}
    for key, name, col, scale in (("position_fraction", "x_m", 0, length_m), ("width_m", "width_m", 1, 1.0),
                                  ("depth_m", "depth_m", 2, 1.0), ("slit_damping_s", "beta_s", 3, 1.0)):
        out[name] = np.where(present, span(key, col) * scale, np.nan)
    if d["ei_loss"]:
        out["depth_m"] = np.where(present, depth_for_ei_loss(layout, span("ei_loss", 2)), np.nan)
    return out


def hinge_flexibility(ei_loss, width_m, length_m):
    """Non-dimensional flexibility ``EI / (k_theta L) = w r / ((1 - r) L)`` of slits (batched).

    Parameters
    ----------
    ei_loss : array_like
        ``r``, the fraction of the flexural rigidity the slit section loses (0 <= r < 1).
    width_m : array_like
        Slit width ``w`` (m), broadcast against ``ei_loss``.
    length_m : float
        Beam length ``L`` (m).
    """
    r = np.asarray(ei_loss, float)
    return np.asarray(width_m, float) * r / ((1.0 - r) * length_m)


def _beam_fields(preset):
    """``EI, width, thickness, length`` of a preset name or of a truth beam's mapping (SI)."""
    if isinstance(preset, str):
        p = beam_preset(preset)
        return p.EI_Nm2, p.width_m, p.thickness_m, p.length_m
    return preset["EI_Nm2"], preset["width_m"], preset["thickness_m"], preset["length_m"]


def _section_keys(beam, section: dict | None) -> dict:
    """``face_thickness_m`` and ``core_modulus_pa``: of ``section``, else of the truth beam's mapping, else the
    configuration's defaults."""
    if section is not None:
        return section
    if isinstance(beam, dict) and "face_thickness_m" in beam and "core_modulus_pa" in beam:
        return beam
    return DEFAULT_SECTION


def _layout(preset, section: dict) -> tuple[SectionLayout, float]:
    """The layered section matching a preset's or a truth beam's EI, and its length (m)."""
    EI, width, thickness, length = _beam_fields(preset)
    return SectionLayout.matching(EI, width, thickness, section["face_thickness_m"], section["core_modulus_pa"]), length


def equivalent_depth(flexibility: float, preset, width_m: float, section: dict) -> float | None:
    """Depth (m) of a slit ``width_m`` wide whose hinge flexibility ``w r / ((1 - r) L)`` is the given one.

    ``r`` is the rigidity loss of the layered section cut to that depth (face/core layout of
    :mod:`datagen.specimen`, eq. 4.1, with the config's ``section`` keys ``face_thickness_m`` and
    ``core_modulus_pa``). ``preset``: a preset name or a truth beam's mapping. None when even a cut to
    mid-thickness would not be that flexible.
    """
    lay, length = _layout(preset, section)
    depths = np.linspace(0.0, 0.999 * lay.thickness_m / 2, 4000)
    curve = hinge_flexibility(1.0 - slit_section_ei(lay, depths) / lay.EI, width_m, length)
    if not np.isfinite(flexibility) or flexibility > curve[-1]:
        return None
    return float(np.interp(flexibility, curve, depths))


class Slit:
    """Damage kind ``"slit"``: a cut into the top face sheet (see the module docstring).

    Parameters per damage: ``width_m``, ``depth_m``, ``ei_loss`` (relative rigidity loss of
    the section), ``beta_s`` (extra stiffness-proportional damping, s). Size: the hinge
    flexibility ``w r / ((1 - r) L)``.
    """

    kind = "slit"
    defaults = {
        "n_slits": [1, 1],
        "width_m": [0.002, 0.01],            # effective length of the reduced section
        "depth_m": [0.0002, 0.0003],         # thesis: 0.2-0.3 mm into the top face sheet
        "ei_loss": [],                       # if set: relative EI loss of the slit section (depth follows)
        "slit_damping_s": [0.0, 2.0e-5],     # extra stiffness-proportional damping of the slit region (s)
    }
    units = {"width_m": "m", "depth_m": "m", "ei_loss": "- (relative)", "stiffness_loss_Nm3": "N m^3",
             "damping_s": "s"}
    sample_units = {"stiffness_loss_Nm3": "N m^3 (sum over slits of dEI * width)"}
    size_meaning = "hinge flexibility EI / (k_theta L) = w r / ((1 - r) L)"
    size_label = "hinge flexibility"
    label = "a slit"
    #: The size head learns ``log(size)``: a slit's hinge flexibility is positive.
    size_transform = "log"
    perturbs = "stiffness"
    sections = None                 # every section
    separates = {
        "support_change": "mode shapes near the support (a support change bends the beam differently there, a "
                          "slit changes the curvature at the slit) or a higher mode",
        "mass_change": "a higher mode (a slit follows the curvature squared, a mass the displacement squared) or "
                       "mode shapes around the place",
    }

    def size_range(self, d: dict, beam) -> tuple[float, float]:
        """``(0, theta_max)``: the hinge flexibility of the deepest slit (its ``ei_loss`` or ``depth_m`` range's
        top, the section of ``beam``'s mapping or the defaults) over the widest width."""
        lay, length = _layout(beam, _section_keys(beam, None))
        if d.get("ei_loss"):
            loss = max(d["ei_loss"])
        else:
            loss = 1.0 - float(slit_section_ei(lay, max(d["depth_m"]))) / lay.EI
        return 0.0, float(hinge_flexibility(loss, max(d["width_m"]), length))

    def spread_m(self, d: dict, length_m: float) -> float:
        """The middle of the widths (m)."""
        return 0.5 * (d["width_m"][0] + d["width_m"][1])

    def validate(self, d: dict, cfg: dict) -> None:
        d["n_slits"] = value_range("damage.n_slits", d["n_slits"], lo=0, hi=8, integer=True)
        d["width_m"] = value_range("damage.width_m", d["width_m"], lo=1e-6, hi=0.1)
        d["depth_m"] = value_range("damage.depth_m", d["depth_m"], lo=0.0)
        d["ei_loss"] = value_range("damage.ei_loss", d["ei_loss"], lo=0.0, hi=0.9999, allow_empty=True)
        slits = d["n_slits"][1] > 0 and d["intact_fraction"] < 1
        key, size = ("ei_loss", d["ei_loss"]) if d["ei_loss"] else ("depth_m", d["depth_m"])
        if slits and size[1] == 0:
            raise ConfigError(f"config key 'damage.{key}' = {size}: slits of zero size change nothing, yet their "
                              f"samples would be labelled damaged; give an upper bound > 0 (or n_slits = [0, 0] "
                              f"for intact samples only)")
        d["slit_damping_s"] = value_range("damage.slit_damping_s", d["slit_damping_s"], lo=0.0, hi=1.0)
        check_loss_factor("slit_damping_s", d["slit_damping_s"], cfg)

    def check_beam(self, d: dict, preset, section: dict, added_masses=()) -> None:
        if d["depth_m"][1] >= preset.thickness_m - section["face_thickness_m"]:
            raise ConfigError(f"config key 'damage.depth_m' must stay below the thickness minus the bottom face "
                              f"({preset.thickness_m - section['face_thickness_m']:g} m)")

    def draw(self, rng: np.random.Generator, n: int, cfg: dict, setup) -> dict:
        sl = draw_slits(rng, n, cfg, setup.length_m, setup.layout)
        ei0 = setup.layout.EI
        sl["ei_loss"] = np.where(np.isfinite(sl["depth_m"]),
                                 1.0 - slit_section_ei(setup.layout, np.nan_to_num(sl["depth_m"])) / ei0, np.nan)
        sl["n_damages"] = sl.pop("n_slits")
        return sl

    def corrections(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements, shear_phi=0.0):
        ok = np.isfinite(x_m)
        dK, dC = slit_corrections(np.where(ok, x_m, 0.0), np.where(ok, params["width_m"], 0.0),
                                  np.where(ok, params["ei_loss"] * ei_Nm2[:, None], 0.0),
                                  np.where(ok, params["beta_s"], 0.0), ei_Nm2, length_m, n_elements, shear_phi)
        return None, dK, dC

    def size(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return hinge_flexibility(params["ei_loss"], params["width_m"], length_m)

    def damage_at(self, d, beam, x_m, size, extent, mass_per_length_kg_m, length_m):
        """A slit of hinge flexibility ``size`` at ``x_m``, its width ``width_m`` at ``extent`` (0: the lower bound,
        1: the upper), its EI loss ``r`` from ``size = w r / ((1 - r) L)``, no damping."""
        lo, hi = d["width_m"]
        s = np.clip(np.asarray(size, float), 0.0, None)
        w = (lo + (hi - lo) * np.clip(np.asarray(extent, float), 0.0, 1.0)) * np.ones_like(s)
        return {"width_m": w, "ei_loss": s * length_m / (w + s * length_m), "beta_s": np.zeros_like(s)}

    def columns(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        loss = params["ei_loss"] * ei_Nm2[:, None] * params["width_m"]
        return ({"stiffness_loss_Nm3": np.nansum(loss, axis=1)},
                {"width_m": params["width_m"], "depth_m": params["depth_m"], "ei_loss": params["ei_loss"],
                 "stiffness_loss_Nm3": loss, "damping_s": params["beta_s"]})

    #: Width (m) of the depth example of :meth:`describe`: the middle of the training widths.
    reference_width_m = 0.0055

    def describe(self, x_m: float, size: float, preset, section: dict | None = None) -> str:
        """``"a slit at x = 0.152 m of hinge flexibility EI/(k L) = 0.0123 (e.g. 0.25 mm deep over 5.5 mm)"``.

        The depth example (:func:`equivalent_depth`, :attr:`reference_width_m` wide) needs the config's
        ``section``; without it, or when no cut is that flexible, it is left out. No place for ``x_m`` None.
        """
        width_m = self.reference_width_m
        depth = None if section is None else equivalent_depth(size, preset, width_m, section)
        eg = "" if depth is None else f" (e.g. {depth * 1000:.2f} mm deep over {width_m * 1000:.1f} mm)"
        at = "" if x_m is None else f" at x = {x_m:.3f} m"
        return f"a slit{at} of hinge flexibility EI/(k L) = {size:.3g}{eg}"
