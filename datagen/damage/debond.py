"""Face-core debonds of the sandwich beam: damage kind ``"debond"`` (:class:`Debond`).

A debond ``k`` has a centre ``x_k`` (m) and a length ``l_k`` (m): over ``[x_k - l_k/2, x_k + l_k/2]``
(clipped to the beam) the top face sheet is no longer bonded to the core. The face and the core with the
bottom face keep a common deflection (they are in contact) but no shear passes between them, so each bends
about its own neutral axis and the section's rigidity falls from the composite ``EI`` (eq. 4.1) to

    ``EI_d = E_f b t_f^3 / 12 + EI_cb``,
    ``EI_cb = (b/3) sum_k E_k ((z_k+1 - z_cb)^3 - (z_k - z_cb)^3)``, ``z_cb = sum_k E_k t_k z_k,mid / sum_k E_k t_k``

over the bottom face (``0 <= z <= t_f``, ``E_f``) and the core (``t_f <= z <= h - t_f``, ``E_c``), ``z`` from the
bottom surface (:func:`debond_section_ei`; eq. 4.1 about the sub-laminate's own modulus-weighted centroid,
:func:`physics.properties.section_ei`). The relative loss ``r = 1 - EI_d / EI`` depends on the layout alone
(:class:`datagen.specimen.SectionLayout`): 0.978 for beam 5's faces of 0.5 mm on a 0.1 GPa core.

This is the rigidity of a debonded length whose face carries no axial force: a debond open to the beam's free
end, or a face also cracked at a tip. A closed debond inside a continuous face, its tips still bonded, holds a
constant axial force in the face over the debond (the tips tie the face's stretch to the rotation there); its
mean curvature then keeps the composite rigidity and only the curvature's variation over the debond bends with
``EI_d``, which loses far less for a debond short against the mode's wavelength (the independent layered model,
:mod:`experiments.second_sim.layered`, computes both; docs/datasets.md gives the numbers). That tie couples the
rotations at the two tips, which the element corrections of :class:`datagen.damage.DamageModel` (per element,
banded) cannot hold; this kind is the upper bound of a debond's loss.

The elements are the flexibility-exact ones of the slit (:func:`datagen.damage.slit.slit_corrections`: ``1/EI``
rises by ``1/EI_d - 1/EI`` over the debond, exact on any mesh). The contact's friction adds damping proportional
to the strain energy of the debonded length itself, ``beta_k`` times it (:func:`debond_damping`): ``beta omega``
is the loss factor of the debonded length. That energy is the exact one of the element's statics, ``(1/2) int
M(s)^2 / EI_d ds`` over the debond with the moment ``M(s) = M_2 + V_2 (l - s)`` of the element's end forces
``(V_2, M_2) = R u`` (``R``: the node-2 rows of its stiffness), so ``Delta C_e = beta_k R^T D R`` with
``D = int [[(l-s)^2, l-s], [l-s, 1]] ds / EI_d``: the curvature gathers in a debond's soft length, which the
element's own (linear) curvature field does not see. Mass is unchanged.

Size
----
The hinge flexibility ``theta = l r / ((1 - r) L)`` of the rigidity loss
(:func:`datagen.damage.slit.hinge_flexibility`), as for every stiffness kind: to first order in ``l`` a debond
changes ``omega_r^2`` by ``-EI L theta kappa_r(x)^2``.
"""

from __future__ import annotations

import numpy as np

from datagen.checks import value_range
from datagen.damage.draws import check_loss_factor, draw_counts
from datagen.damage.slit import clamped_flexibility, expand_tip_stiffness, hinge_flexibility, slit_corrections, \
    slit_element_weights
from datagen.specimen import DEFAULT_SECTION, SectionLayout
from physics.errors import ConfigError
from physics.properties import beam_preset, section_ei

__all__ = ["Debond", "debond_damping", "debond_ei_loss", "debond_section_ei"]


def debond_section_ei(layout: SectionLayout) -> float:
    """Rigidity (N m^2) of the section whose top face is debonded from the core (module docstring).

    The top face's own ``E_f b t_f^3 / 12`` plus the bottom face and core about their own neutral axis.
    """
    b, h, tf = layout.width_m, layout.thickness_m, layout.face_thickness_m
    top = section_ei(b, [h - tf], [h], [layout.face_modulus_pa])
    rest = section_ei(b, [0.0, tf], [tf, h - tf], [layout.face_modulus_pa, layout.core_modulus_pa])
    return float(top + rest)


def debond_ei_loss(layout: SectionLayout) -> float:
    """Relative rigidity loss ``r = 1 - EI_d / EI`` of a debonded section (-)."""
    return 1.0 - debond_section_ei(layout) / layout.EI


def debond_damping(x_m, length_m, ei_debonded_Nm2, beta_s, element_stiffness, beam_length_m):
    """Damping matrices of the debonds' contact, ``beta`` times the strain energy of each debonded length.

    Parameters
    ----------
    x_m, length_m : ndarray, shape (B, S)
        Centres and lengths (m) on the beam; a length of 0 adds nothing.
    ei_debonded_Nm2, beta_s : ndarray, shape (B, S)
        ``EI_d`` of each debonded section (N m^2) and its contact's damping coefficient (s).
    element_stiffness : ndarray, shape (B, E, 4, 4)
        The elements' stiffness with the debonds (their statics give the moment over each).
    beam_length_m : float

    Returns
    -------
    ndarray, shape (B, E, 4, 4)   (N s/m ...); debonds that overlap count each
    """
    n = element_stiffness.shape[-3]
    le = beam_length_m / n
    a, b = slit_element_weights(x_m, length_m, beam_length_m, n)          # (B, S, E)
    ua, ub = 1.0 - a, 1.0 - b
    w = (np.asarray(beta_s, float) / np.asarray(ei_debonded_Nm2, float))[..., None]
    d00 = np.sum(w * le**3 * (ua**3 - ub**3) / 3, axis=1)                 # int (l-s)^2 ds / EI_d, (B, E)
    d01 = np.sum(w * le**2 * (ua**2 - ub**2) / 2, axis=1)
    d11 = np.sum(w * le * (b - a), axis=1)
    D = np.stack([np.stack([d00, d01], -1), np.stack([d01, d11], -1)], -2)    # (B, E, 2, 2)
    R = element_stiffness[..., 2:4, :]                                    # (V_2, M_2) = R u
    return R.mT @ D @ R


def _layout_of(beam) -> SectionLayout:
    """The face/core layout of a preset name or a truth beam's mapping (its own face and core keys, else the
    defaults, :data:`datagen.specimen.DEFAULT_SECTION`)."""
    if isinstance(beam, str):
        p = beam_preset(beam)
        EI, width, thickness, tf, ec = p.EI_Nm2, p.width_m, p.thickness_m, None, None
    else:
        EI, width, thickness = beam["EI_Nm2"], beam["width_m"], beam["thickness_m"]
        tf, ec = beam.get("face_thickness_m"), beam.get("core_modulus_pa")
    return SectionLayout.matching(EI, width, thickness, tf or DEFAULT_SECTION["face_thickness_m"],
                                  ec or DEFAULT_SECTION["core_modulus_pa"])


def _mapping(beam) -> dict:
    """The geometry and ``EI`` of a preset name as a truth beam's mapping (a mapping: a copy)."""
    if not isinstance(beam, str):
        return dict(beam)
    p = beam_preset(beam)
    return {"EI_Nm2": p.EI_Nm2, "width_m": p.width_m, "thickness_m": p.thickness_m, "length_m": p.length_m}


def _beam_length_m(beam) -> float:
    return beam_preset(beam).length_m if isinstance(beam, str) else float(beam["length_m"])


class Debond:
    """Damage kind ``"debond"``: the top face debonded from the core over a length (see the module docstring).

    Config keys besides the generic ones: ``n_debonds`` (range of the count per damaged sample), ``length_m``
    (range of the debonded length, uniform) and ``debond_damping_s`` (range of the contact's damping ``beta``,
    proportional to the debonded length's strain energy, s). Parameters per damage: ``length_m`` (on the beam),
    ``ei_loss`` (``r``) and ``beta_s``. Size: the hinge flexibility ``l r / ((1 - r) L)``.
    """

    kind = "debond"
    defaults = {
        "n_debonds": [1, 1],
        "length_m": [0.006, 0.06],          # debonded length (1-10 % of beam 5's span)
        "debond_damping_s": [0.0, 1.0e-4],  # the contact's damping, proportional to the debonded stiffness (s)
    }
    units = {"length_m": "m", "ei_loss": "- (relative)", "damping_s": "s"}
    sample_units: dict = {}
    size_meaning = "hinge flexibility EI / (k_theta L) = l r / ((1 - r) L) of the debonded length l"
    size_label = "hinge flexibility"
    label = "a face-core debond"
    #: The size head learns ``log(size)``: a debond's hinge flexibility is positive.
    size_transform = "log"
    perturbs = "stiffness"
    #: A face debonds from a core: sandwich sections only (the config refuses another, :mod:`datagen.config`).
    sections = ("sandwich",)
    separates = {
        "slit": "the damping of the modes (a debond's contact rubs: its damping ratios rise with the modes that bend "
                "it), a higher mode (a long debond spreads its loss, so a higher mode whose curvature changes sign "
                "over it drops less than a slit's point sensitivity predicts) or mode shapes across the debond",
        "mass_change": "a higher mode (a debond follows the curvature squared, a mass the displacement squared: a "
                       "debond near the free end changes almost nothing, a mass there the most) or the sign of the "
                       "change (a debond only lowers the frequencies)",
        "support_change": "mode shapes near the support or a higher mode; a debond also damps the modes",
        "intact": "a second baseline day (the day-to-day scatter of these frequencies), the damping ratios or a "
                  "higher mode",
        "global_stiffness": "the temperature of both test days, or a higher mode (a debond's change follows its "
                            "place)",
    }

    def validate(self, d: dict, cfg: dict) -> None:
        d["n_debonds"] = value_range("damage.n_debonds", d["n_debonds"], lo=0, hi=8, integer=True)
        d["length_m"] = value_range("damage.length_m", d["length_m"], lo=1e-4)
        d["debond_damping_s"] = value_range("damage.debond_damping_s", d["debond_damping_s"], lo=0.0, hi=1.0)
        check_loss_factor("debond_damping_s", d["debond_damping_s"], cfg)

    def check_beam(self, d: dict, preset, section: dict, added_masses=()) -> None:
        if d["length_m"][1] >= preset.length_m:
            raise ConfigError(f"config key 'damage.length_m' must stay below the beam's length "
                              f"({preset.length_m:g} m), got {d['length_m']!r}")

    def draw(self, rng: np.random.Generator, n: int, cfg: dict, setup) -> dict:
        """Counts, centres, lengths (clipped to the beam), the layout's loss and the damping of ``n`` samples."""
        d = cfg["damage"]
        k, u, present = draw_counts(rng, n, d, "n_debonds", 3)
        (a, b), (la, lb), (ba, bb) = d["position_fraction"], d["length_m"], d["debond_damping_s"]
        L = setup.length_m
        x = (a + (b - a) * u[..., 0]) * L
        length = la + (lb - la) * u[..., 1]
        on_beam = np.clip(x + length / 2, 0, L) - np.clip(x - length / 2, 0, L)
        nan = np.nan
        return {"n_damages": k, "x_m": np.where(present, x, nan), "length_m": np.where(present, on_beam, nan),
                "ei_loss": np.where(present, debond_ei_loss(setup.layout), nan),
                "beta_s": np.where(present, ba + (bb - ba) * u[..., 2], nan)}

    def corrections(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements, shear_phi=0.0):
        ok = np.isfinite(x_m)
        # a debond is clipped to the beam when drawn: its centre on the beam is the middle of what lies there
        lo = np.clip(np.where(ok, x_m - params["length_m"] / 2, 0.0), 0.0, length_m)
        span = np.where(ok, params["length_m"], 0.0)
        loss = np.where(ok, params["ei_loss"], 0.0)
        dK, _ = slit_corrections(lo + span / 2, span, loss * ei_Nm2[:, None], np.zeros_like(span), ei_Nm2, length_m,
                                 n_elements, shear_phi)
        le = length_m / n_elements
        phi = np.asarray(shear_phi, float)
        k0 = expand_tip_stiffness(np.linalg.inv(clamped_flexibility(ei_Nm2, le, phi)), le)[:, None]   # (B, 1, 4, 4)
        dC = debond_damping(lo + span / 2, span, (1 - loss) * ei_Nm2[:, None], np.where(ok, params["beta_s"], 0.0),
                            k0 + dK, length_m)
        return None, dK, dC

    def size(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return hinge_flexibility(params["ei_loss"], params["length_m"], length_m)

    def damage_at(self, d, beam, x_m, size, extent, mass_per_length_kg_m, length_m):
        """A debond of hinge flexibility ``size`` at ``x_m``: the section's loss ``r`` over the length
        ``size L (1 - r) / r`` (within the beam; ``extent`` does not enter), no damping."""
        r = debond_ei_loss(_layout_of(beam))
        s = np.clip(np.asarray(size, float), 0.0, None)
        on_beam = np.clip(s * length_m * (1 - r) / r, 1e-9, length_m) * np.ones_like(np.asarray(x_m, float))
        return {"length_m": on_beam, "ei_loss": np.full_like(on_beam, r), "beta_s": np.zeros_like(on_beam)}

    def columns(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return {}, {"length_m": params["length_m"], "ei_loss": params["ei_loss"], "damping_s": params["beta_s"]}

    def size_range(self, d: dict, beam) -> tuple[float, float]:
        """``(0, theta)`` of the longest debond of ``d`` on ``beam`` (a preset name or a truth beam's mapping)."""
        L = _beam_length_m(beam)
        return 0.0, float(hinge_flexibility(debond_ei_loss(_layout_of(beam)), min(d["length_m"][1], L), L))

    def spread_m(self, d: dict, length_m: float) -> float:
        """The middle of the debonded lengths (m)."""
        return 0.5 * (d["length_m"][0] + d["length_m"][1])

    def describe(self, x_m: float, size: float, preset, section: dict | None = None) -> str:
        """``"a face-core debond at x = 0.300 m about 40 mm long (hinge flexibility 0.012)"``.

        The length follows from the size and the section's loss ``r`` (``l = theta L (1 - r) / r``): the
        config's ``section`` keys where given, else the beam's own (a preset's: 0.5 mm faces, 0.1 GPa core);
        without a beam (``preset`` None) it is left out. No place for ``x_m`` None.
        """
        at = "" if x_m is None else f" at x = {x_m:.3f} m"
        if preset is None:
            return f"a face-core debond{at} (hinge flexibility {size:.3g})"
        beam = preset
        if section is not None:
            beam = _mapping(preset)
            beam.update({k: section[k] for k in ("face_thickness_m", "core_modulus_pa") if k in section})
        r = debond_ei_loss(_layout_of(beam))
        length_mm = 1000 * size * _beam_length_m(beam) * (1 - r) / r
        return f"a face-core debond{at} about {length_mm:.0f} mm long (hinge flexibility {size:.3g})"
