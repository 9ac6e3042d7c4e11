"""Free parameters of each candidate effect, bounded on the beam's own scales.

Core shear modulus
------------------
For a sandwich of two faces of thickness ``t_f`` on a core of thickness
``c = h - 2 t_f``, the shear rigidity is ``kGA = G_c b d^2 / c`` with
``d = c + t_f`` the distance between face centroids (Allen, *Analysis and
Design of Structural Sandwich Panels*, 1969, ch. 2; Zenkert, *An Introduction
to Sandwich Construction*, 1995), so ``G_c = kGA c / (b d^2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from physics import effects as fx
from physics.beam import Beam
from physics.discrepancy.measurement import Measurement

__all__ = ["Param", "effect_params", "g_core_pa", "has_position", "shear_in_section_terms"]


@dataclass(frozen=True)
class Param:
    key: str            # "EI_scale", "mass_scale", "<effect>.<parameter>"
    lower: float
    upper: float
    log: bool = True

    def to_phys(self, u):
        return math.exp(u) if self.log else u

    def bounds(self):
        return (math.log(self.lower), math.log(self.upper)) if self.log else (self.lower, self.upper)


def effect_params(effect: str, beam: Beam, meas: Measurement, position_free: bool) -> list[Param]:
    """Free parameters of ``effect`` (an effect key: ``added_mass#2`` is a second point mass) with physical bounds
    scaled on the beam."""
    L, EI, m = beam.length_m, beam.EI_Nm2, beam.mass_per_length_kg_m
    rho_i = m * beam.thickness_m**2 / 12
    w1 = 2 * np.pi * meas.frequencies_hz[0]
    bounds = fx.EFFECTS[fx.effect_of(effect)].fit_bounds(L, EI, m, rho_i, w1)
    if effect == "shear_deformation" and beam.solid is not None:
        # a solid section's k G A follows from its material and shape: the fit may move it within the spread of a
        # shear modulus and shear coefficient (a factor 2), not by orders of magnitude
        bounds = {"kGA_N": (0.5 * beam.solid.kGA_N, 2.0 * beam.solid.kGA_N)}
    out = [Param(f"{effect}.{key}", lo, hi) for key, (lo, hi) in bounds.items()]
    if has_position(effect) and position_free:
        out.append(Param(f"{effect}.x_m", 0.02 * L, L, log=False))
    return out


def has_position(effect: str) -> bool:
    """Whether the effect sits at a point of the beam (an ``x_m`` parameter in :data:`physics.effects.EFFECTS`)."""
    return any(p.name == "x_m" for p in fx.EFFECTS[fx.effect_of(effect)].params)


def shear_in_section_terms(kGA_N: float, kGA_std_N: float, beam: Beam) -> dict:
    """A fitted shear rigidity in the terms of the beam's section: ``{"shear_deformation.<name>": (value, std)}``.

    A sandwich's core shear modulus ``G_core_pa`` (:func:`g_core_pa`); a solid section's implied shear modulus
    ``G_pa = kGA / (k A)`` with ``k`` of its shape (:func:`physics.properties.solid_section`); nothing more for a
    section given by its ``EI`` and mass only.
    """
    if beam.section == "sandwich":
        return {"shear_deformation.G_core_pa": (g_core_pa(kGA_N, beam), g_core_pa(kGA_std_N, beam))}
    solid = beam.solid
    if solid is not None:
        ka = solid.shear_coefficient * solid.area_m2
        return {"shear_deformation.G_pa": (kGA_N / ka, kGA_std_N / ka),
                "shear_deformation.k": (solid.shear_coefficient, 0.0)}
    return {}


def g_core_pa(kGA_N: float, beam: Beam) -> float:
    """Equivalent core shear modulus ``G_c = kGA c / (b d^2)`` (module docstring; thin-face limit ``kGA/(b h)``)."""
    tf = beam.face_thickness_m or 0.0
    c = beam.thickness_m - 2 * tf
    d = c + tf
    return kGA_N * c / (beam.width_m * d**2)
