"""The layered face/core section (eq. 4.1) of the beam presets and specimen variability.

Section layout
--------------
The thesis gives only the equivalent ``EI`` of each beam (Table 4.1, from a
static test) and its construction: two carbon-fibre face sheets on a
foam-filled honeycomb core, total thickness ``h = 7.264 mm``, width
``b = 51 mm``. We adopt a documented layout: faces of thickness ``t_f``
(default 0.5 mm, two plies) and a core of modulus ``E_c`` (default 0.1 GPa);
the face modulus ``E_f`` is then solved so that eq. 4.1,

    ``EI = (2 b / 3) sum_k E_k (d_{k+1}^3 - d_k^3)``,

reproduces Table 4.1 exactly (beam 5: ``E_f`` about 38.6 GPa, plausible for a
woven carbon/epoxy face). A damage kind may cut it (:mod:`datagen.damage.slit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConfigError
from physics.properties import BeamPreset, layered_ei

__all__ = ["DEFAULT_SECTION", "SectionLayout", "draw_specimens"]

#: The layered section's keys (config section ``section``) by default.
DEFAULT_SECTION = {
    "face_thickness_m": 0.0005,    # each carbon-fibre face sheet (two plies)
    "core_modulus_pa": 1.0e8,      # foam-filled honeycomb core; face modulus is solved from Table 4.1's EI
}


@dataclass(frozen=True)
class SectionLayout:
    """Symmetric face/core/face section (m, Pa)."""

    width_m: float
    thickness_m: float
    face_thickness_m: float
    face_modulus_pa: float
    core_modulus_pa: float

    @property
    def EI(self) -> float:
        """Rigidity by eq. 4.1 (N m^2)."""
        h2 = self.thickness_m / 2
        return float(layered_ei(self.width_m, [0.0, h2 - self.face_thickness_m, h2],
                                [self.core_modulus_pa, self.face_modulus_pa]))

    @classmethod
    def matching(cls, EI, width_m, thickness_m, face_thickness_m, core_modulus_pa) -> "SectionLayout":
        """Layout whose eq.-4.1 rigidity equals ``EI``, solving for the face modulus."""
        h2 = thickness_m / 2
        c = h2 - face_thickness_m
        if c <= 0:
            raise ConfigError("config key 'section.face_thickness_m' must be below half the beam thickness")
        core = 2 * width_m / 3 * core_modulus_pa * c**3
        if core >= EI:
            raise ConfigError("config key 'section.core_modulus_pa' is so stiff that the core alone exceeds EI")
        e_f = (EI - core) / (2 * width_m / 3 * (h2**3 - c**3))
        return cls(width_m, thickness_m, face_thickness_m, e_f, core_modulus_pa)


def draw_specimens(rng: np.random.Generator, n: int, cfg: dict, preset: BeamPreset,
                   root_spring_relative=None, shear_flexibility=None) -> dict:
    """Specimen parameters of ``n`` samples (one random block, fixed draw order).

    ``root_spring_relative`` (``(lo, hi)`` or empty) overrides the config's band
    of ``k_r L / EI`` (a beam file's calibrated root spring moves its centre);
    ``shear_flexibility`` (``(lo, hi)``) the config's band of ``EI / (kGA L^2)``
    (a beam file's shear deformation moves its centre). A band of one value is
    not drawn (the draws of the other parameters stay those of a config without it).

    Returns
    -------
    dict of ndarray, shape (n,)
        ``EI_Nm2``, ``mass_per_length_kg_m``, ``damping_scale`` (-),
        ``root_spring_Nm_rad`` (``inf`` for a rigid clamp) and ``shear_flexibility``
        (``EI / (kGA L^2)``, -).
    """
    sp = cfg["specimen"]
    u = rng.random((n, 4))
    ei = preset.EI_Nm2 * (1 + sp["ei_band"] * (2 * u[:, 0] - 1))
    mpl = preset.mass_per_length_kg_m * (1 + sp["mass_band"] * (2 * u[:, 1] - 1))
    dsc = 1 + sp["damping_band"] * (2 * u[:, 2] - 1)
    band = sp["root_spring_relative"] if root_spring_relative is None else root_spring_relative
    if band:
        lo, hi = np.log(band)
        kr = np.exp(lo + (hi - lo) * u[:, 3]) * ei / preset.length_m
    else:
        kr = np.full(n, np.inf)
    lo, hi = sp["shear_flexibility"] if shear_flexibility is None else shear_flexibility
    shear = np.full(n, float(lo)) if lo == hi else lo + (hi - lo) * rng.random(n)
    return {"EI_Nm2": ei, "mass_per_length_kg_m": mpl, "damping_scale": dsc, "root_spring_Nm_rad": kr,
            "shear_flexibility": shear}
