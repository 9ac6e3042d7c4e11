"""A beam file (``physics.beam.Beam``) as the truth of a dataset: ``generate --beam FILE``.

The truth mesh of :mod:`datagen.pipeline` is built from unit-rigidity,
unit-mass element matrices (each specimen scales them by its ``EI`` and mass
per length). A beam file changes those elements and the geometry:

* ``shear_deformation`` (``kGA_N``, ``rho_I_kg_m``): Timoshenko elements
  (:func:`physics.effects.timoshenko_stiffness`, :func:`physics.effects.timoshenko_mass`);
* ``rotary_inertia`` (``rho_I_kg_m``): Rayleigh elements.

The ratios ``kGA / EI`` and ``rho I / m`` of the file are kept for every
specimen (a specimen stiffer in bending is as much stiffer in shear), so the
element matrices still scale exactly with the specimen's ``EI`` and mass.
Slits remove bending energy over the slit (:mod:`datagen.damage`): for a
Timoshenko element that of its own curvature field ``theta'`` (shear
parameter :func:`shear_parameter`), so the element keeps its shear stiffness. The root is clamped (a flexible
root is ``specimen.root_spring_relative``); other effects are refused with a
message. ``physics.beam`` is the discrepancy workflow's module: it is imported
only when a beam is given.
"""

from __future__ import annotations

import numpy as np

from physics.errors import ConfigError
from physics.fem import element_mass, element_stiffness
from physics.properties import BeamPreset

#: Effects a beam file may carry into ``generate``.
SUPPORTED_EFFECTS = ("shear_deformation", "rotary_inertia")


def load_truth_beam(mapping: dict):
    """Validated :class:`physics.beam.Beam` of config key ``beam`` (the beam-file mapping)."""
    try:
        from physics.beam import beam_from_dict
    except ImportError:
        raise ConfigError("config key 'beam' needs physics.beam (the beam-file module), which this "
                          "installation lacks") from None
    beam = beam_from_dict(dict(mapping), "config key 'beam'")
    other = sorted(set(beam.effects) - set(SUPPORTED_EFFECTS))
    if other:
        raise ConfigError(f"config key 'beam': effect(s) {other} are not supported by generate yet; supported: "
                          f"{list(SUPPORTED_EFFECTS)} (a flexible root is 'specimen.root_spring_relative')")
    if beam.bc != "clamped-free":
        raise ConfigError(f"config key 'beam': generate simulates cantilevers; bc {beam.bc!r} is not 'clamped-free'")
    quarter = beam.length_m * np.arange(1, 5) / 4
    if len(beam.measured_x_m) != 4 or not np.allclose(beam.measured_x_m, quarter, rtol=0, atol=1e-9 * beam.length_m):
        raise ConfigError(f"config key 'beam': generate measures the quarter points {quarter.tolist()} m; the beam "
                          f"has measured_x_m {list(beam.measured_x_m)}")
    return beam


def beam_mapping(beam) -> dict:
    """The beam-file mapping of a Beam (every field explicit, JSON/TOML-ready): what the manifest records."""
    from dataclasses import fields

    out = {}
    for f in fields(beam):
        v = getattr(beam, f.name)
        if v is None:
            continue
        if f.name == "effects":
            v = beam.effects_dict()
        elif f.name == "measured_x_m":
            v = list(v)
        out[f.name] = v
    return out


def as_preset(beam) -> BeamPreset:
    """The specimen fields datagen uses (geometry, ``EI``, mass) of a beam."""
    return BeamPreset(name=beam.name, mass_kg=beam.mass_per_length_kg_m * beam.total_length_m, EI_Nm2=beam.EI_Nm2,
                      total_length_m=beam.total_length_m, length_m=beam.length_m, width_m=beam.width_m,
                      thickness_m=beam.thickness_m)


def shear_parameter(beam, element_length_m: float) -> float:
    """``phi = 12 EI / (kGA l^2)`` of the truth elements (0 without shear deformation); the same for every
    specimen since ``kGA / EI`` is kept."""
    if beam is None or "shear_deformation" not in beam.effects:
        return 0.0
    return 12.0 * beam.EI_Nm2 / (beam.effects["shear_deformation"]["kGA_N"] * element_length_m**2)


def unit_elements(beam, element_length_m: float):
    """Element stiffness for ``EI = 1`` and mass for ``m = 1`` with the beam's effects, each (4, 4).

    Without a beam (``None``): the Euler-Bernoulli elements, eqs. 3.8 and 3.9.
    """
    if beam is None or not beam.effects:
        return element_stiffness(1.0, element_length_m), element_mass(1.0, element_length_m)
    from physics.effects import timoshenko_mass, timoshenko_stiffness

    eff = beam.effects_dict()
    ei, m, h = beam.EI_Nm2, beam.mass_per_length_kg_m, beam.thickness_m
    kga, rho_i = np.inf, 0.0
    if "shear_deformation" in eff:
        kga = eff["shear_deformation"]["kGA_N"]
        rho_i = eff["shear_deformation"].get("rho_I_kg_m", m * h**2 / 12)
    if "rotary_inertia" in eff:
        rho_i = eff["rotary_inertia"].get("rho_I_kg_m", m * h**2 / 12)
    return (timoshenko_stiffness(1.0, kga / ei, element_length_m),
            timoshenko_mass(1.0, rho_i / m, 1.0, kga / ei, element_length_m))
