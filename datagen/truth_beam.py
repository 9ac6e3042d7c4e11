"""A beam file (``physics.beam.Beam``) as the truth of a dataset: ``generate --beam FILE``.

The truth mesh of :mod:`datagen.pipeline` is built from unit-rigidity,
unit-mass element matrices (each specimen scales them by its ``EI`` and mass
per length). Every effect a beam file can hold (:mod:`physics.effects`)
enters the generator, combined with the specimen variability as follows:

* ``shear_deformation`` (``kGA_N``, ``rho_I_kg_m``): Timoshenko elements
  (:func:`physics.effects.timoshenko_stiffness`, :func:`physics.effects.timoshenko_mass`);
  ``rotary_inertia`` (``rho_I_kg_m``): Rayleigh elements. The ratios
  ``kGA / EI`` and ``rho I / m`` of the file are kept for every specimen (a
  specimen stiffer in bending is as much stiffer in shear), so the element
  matrices still scale exactly with the specimen's ``EI`` and mass.
* ``root_flexibility`` (``k_theta_Nm_rad``, ``k_y_N_m``): the calibrated
  rotational spring is the geometric centre of the specimen root-spring band
  (``specimen.root_spring_relative`` keeps its width ``hi / lo``; an empty band
  means exactly the calibrated spring, relative to each specimen's ``EI``).
  A translational spring keeps the root translation as a DOF with the spring
  ``k_y EI / EI_file`` (it scales with the specimen like the element stiffness).
* ``clamp_flexibility`` (``k_theta_Nm_rad``, ``k_y_N_m``), clamped-clamped: as
  ``root_flexibility`` at both clamps (the specimen's drawn spring holds both
  clamp rotations; a translational spring keeps both clamp translations).
* ``bearing_flexibility`` (``k_theta_Nm_rad``), pinned-pinned: a rotational
  spring ``k_theta EI / EI_file`` on the rotation of each pinned end.
* ``suspension`` (``k_y_N_m``), free-free: translational springs
  ``k_y EI / EI_file`` at both ends replace the default suspension (bounce
  mode at 5 % of the first bending frequency, :func:`physics.supports.suspension_unit_stiffness`).
* ``added_mass`` (``mass_kg``, ``x_m``, ``J_kg_m2``; any number): each point mass (fixed
  hardware, not scaled by the specimen mass band) is added to ``M`` of both
  test days through the Hermite row of :func:`physics.effects.hermite_row`.
* ``local_damping`` (``c_Ns_m``, ``x_m``; any number): each dashpot ``c N N^T`` is added to
  ``C`` of both test days (not scaled by the damping band).
* ``proportional_damping`` (``alpha_1_s``, ``beta_s``): as in
  :func:`physics.effects.assemble_beam`, ``C_R = alpha M + beta K`` of the beam
  elements (not of the clamp springs or the point mass). The modal ratios
  ``zeta_j = phi_j^T C_R phi_j / (2 omega_j)`` in the nominal truth's modes (file
  ``EI``, mass, the band-centre root spring; ``alpha / (2 omega_j) + beta omega_j / 2``
  without springs or point mass) replace ``specimen.damping_ratios`` as the
  baseline modal damping; each specimen scales them by its damping scale (the
  small off-diagonal modal terms of ``C_R`` are dropped).

Slits (damage kind "slit") are flexibility-exact on the truth elements (:mod:`datagen.damage.slit`):
under ``shear_deformation`` they add bending compliance to the Timoshenko
element and keep its shear compliance. The Pilkey
analyst's mass model (``updating.mass_model``) knows the beam's mass per length
only, not an added mass.
"""

from __future__ import annotations

import numpy as np

from physics.beam import beam_from_dict, file_fields
from physics.effects import (
    EFFECTS,
    dashpot_matrix,
    effect_of,
    instances,
    point_mass_matrix,
    timoshenko_mass,
    timoshenko_stiffness,
)
from physics.errors import ConfigError
from physics.fem import element_mass, element_stiffness
from physics.properties import BeamPreset

__all__ = ["APPLIED_EFFECTS", "as_preset", "beam_mapping", "load_truth_beam", "point_effects", "shear_parameters",
           "unit_elements"]


#: The beam-file effects the generator applies (module docstring: how each enters); a beam file with another
#: effect is refused, and ``generate --help`` lists these.
APPLIED_EFFECTS = ("shear_deformation", "rotary_inertia", "root_flexibility", "clamp_flexibility",
                   "bearing_flexibility", "suspension", "added_mass", "local_damping", "proportional_damping")


def load_truth_beam(mapping: dict):
    """Validated :class:`physics.beam.Beam` of config key ``beam`` (the beam-file mapping)."""
    beam = beam_from_dict(dict(mapping), "config key 'beam'")
    other = [name for name in dict.fromkeys(map(effect_of, beam.effects)) if name not in APPLIED_EFFECTS]
    if other:
        raise ConfigError(f"config key 'beam': generate applies the effects {', '.join(APPLIED_EFFECTS)}; the beam "
                          f"has {', '.join(other)}")
    return beam


def beam_mapping(beam) -> dict:
    """The beam-file mapping of a Beam (every field explicit, JSON/TOML-ready): what the manifest records."""
    out = {}
    for f in file_fields():
        v = getattr(beam, f.name)
        if v is None:                                   # measured_x_m is always explicit here
            continue
        if f.name == "effects":
            v = beam.effects_dict()
        elif isinstance(v, tuple):  # measured_x_m, band_hz, zones_x_m: as JSON reads them back
            v = list(v)
        out[f.name] = v
    return out


def as_preset(beam) -> BeamPreset:
    """The specimen fields datagen uses (geometry, ``EI``, mass) of a beam."""
    return BeamPreset(name=beam.name, mass_kg=beam.mass_per_length_kg_m * beam.total_length_m, EI_Nm2=beam.EI_Nm2,
                      total_length_m=beam.total_length_m, length_m=beam.length_m, width_m=beam.width_m,
                      thickness_m=beam.thickness_m)


def shear_parameters(beam, thickness_m: float) -> tuple[float, float, bool]:
    """The beam file's shear flexibility ``EI / (kGA L^2)`` (0 without shear deformation), ``rho I / m`` (m^2;
    default ``h^2 / 12``) and whether its elements are Timoshenko/Rayleigh ones (shear or rotary inertia given).

    Without a beam (``None``): ``(0, h^2 / 12, False)``, the Euler-Bernoulli elements of eqs. 3.8 and 3.9.
    """
    default = thickness_m**2 / 12
    if beam is None or not ({"shear_deformation", "rotary_inertia"} & set(beam.effects)):
        return 0.0, default, False
    eff = beam.effects_dict()
    m = beam.mass_per_length_kg_m
    shear, rho_i = 0.0, 0.0
    if "shear_deformation" in eff:
        shear = beam.EI_Nm2 / (eff["shear_deformation"]["kGA_N"] * beam.length_m**2)
        rho_i = eff["shear_deformation"].get("rho_I_kg_m", m * default)
    if "rotary_inertia" in eff:
        rho_i = eff["rotary_inertia"].get("rho_I_kg_m", m * default)
    return shear, rho_i / m, True


def unit_elements(shear_flexibility, rho_i_over_m_m2: float, length_m: float, n_elements: int,
                  timoshenko: bool = True):
    """Element stiffness for ``EI = 1`` and mass for ``m = 1``, and the element shear ratio (batched).

    Parameters
    ----------
    shear_flexibility : float or ndarray, shape (...)
        ``EI / (kGA L^2)`` of the beam (0: no shear deformation).
    rho_i_over_m_m2 : float
        Rotary inertia per unit mass per length (m^2).
    timoshenko : bool
        False: the Euler-Bernoulli elements of eqs. 3.8 and 3.9 (``shear_flexibility`` must be 0).

    Returns
    -------
    ke, me : ndarray, shape (..., 4, 4)
    shear_phi : ndarray, shape (...)   ``12 EI / (kGA l^2) = 12 n^2 EI / (kGA L^2)`` of the element
    """
    le = length_m / n_elements
    s = np.asarray(shear_flexibility, float)
    phi = 12.0 * n_elements**2 * s
    if not timoshenko:
        ke, me = element_stiffness(1.0, le), element_mass(1.0, le)
        return np.broadcast_to(ke, s.shape + (4, 4)), np.broadcast_to(me, s.shape + (4, 4)), phi
    with np.errstate(divide="ignore"):
        kga_over_ei = np.where(s > 0, 1.0 / (s * length_m**2), np.inf)
    return (timoshenko_stiffness(1.0, kga_over_ei, le), timoshenko_mass(1.0, rho_i_over_m_m2, 1.0, kga_over_ei, le),
            phi)


def point_effects(beam, n_elements: int) -> dict:
    """The beam's lumped effects on the full (unconstrained) truth mesh, in SI units.

    Returns
    -------
    dict with ``M_added`` (kg ...) and ``C_local`` (N s/m ...), each (2 N, 2 N) or
    ``None`` (the sum of every added mass, of every dashpot); ``added_masses``, the ``(x_m, mass_kg)`` of each
    added mass; ``support_spring``, the stiffness of the support's own springs its effect gives
    (:attr:`physics.supports.Support.effect`: the clamp's rotational spring (N m/rad) of ``root_flexibility`` or
    ``clamp_flexibility``, the bearing spring (N m/rad), the suspension spring (N/m)), ``clamp_k_y_N_m``, a clamp
    effect's translational spring (N/m) (each ``None`` when absent), and ``rayleigh`` (``(alpha_1_s, beta_s)`` or
    ``None``).
    """
    out = {"M_added": None, "C_local": None, "added_masses": (), "support_spring": None, "clamp_k_y_N_m": None,
           "rayleigh": None}
    if beam is None:
        return out

    eff = beam.effects_dict()
    node_x = np.linspace(0.0, beam.length_m, n_elements + 1)
    masses = instances(eff, "added_mass")
    if masses:
        out["M_added"] = sum(point_mass_matrix(node_x, p["mass_kg"], p.get("x_m", beam.length_m),
                                               p.get("J_kg_m2", 0.0)) for p in masses)
    out["added_masses"] = tuple((p.get("x_m", beam.length_m), p["mass_kg"]) for p in masses)
    dashpots = instances(eff, "local_damping")
    if dashpots:
        out["C_local"] = sum(dashpot_matrix(node_x, p["c_Ns_m"], p.get("x_m", beam.length_m)) for p in dashpots)
    own = eff.get(beam.support.effect)                        # the support's own springs
    if own is not None:
        params = EFFECTS[beam.support.effect].params
        out["support_spring"] = own[params[0].name]
        out["clamp_k_y_N_m"] = own.get(params[1].name) if len(params) > 1 else None
    if "proportional_damping" in eff:
        p = eff["proportional_damping"]
        out["rayleigh"] = (p.get("alpha_1_s", 0.0), p.get("beta_s", 0.0))
    return out
