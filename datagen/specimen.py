"""Beam presets, the layered face/core section (eq. 4.1) and specimen variability.

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
woven carbon/epoxy face). A slit of depth ``d`` across the top face removes
the top ``d`` of the section over the slit; the section is then no longer
symmetric, so its rigidity is computed about the shifted neutral axis
(:func:`slit_section_ei`), which reduces to eq. 4.1 for ``d = 0``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

import numpy as np

from physics.errors import ConfigError


@dataclass(frozen=True)
class BeamPreset:
    """Nominal properties of one thesis beam (Table 4.1 and geometry).

    Attributes
    ----------
    name : str
    mass_kg : float          whole beam (1.219 m) mass
    EI : float               N m^2
    total_length_m, length_m : float   whole beam and cantilever (free) length
    width_m, thickness_m : float
    m_per_length : float     kg/m, ``mass_kg / total_length_m``
    """

    name: str
    mass_kg: float
    EI: float
    total_length_m: float
    length_m: float
    width_m: float
    thickness_m: float
    m_per_length: float


def beam_preset(name: str = "beam5") -> BeamPreset:
    """Preset ``"beam5"``, ``"beam6"`` or ``"beam8"`` from the packaged thesis fixture.

    Uses ``physics.properties.beam_preset`` when the physics core provides it.
    """
    try:  # the lead's module, when present
        from physics.properties import beam_preset as _bp  # type: ignore
        p = _bp(name)
        return BeamPreset(name, float(p.mass_kg), float(p.EI), float(p.total_length_m), float(p.length_m),
                          float(p.width_m), float(p.thickness_m), float(p.m_per_length))
    except Exception:  # noqa: BLE001 - fall back to the fixture below
        pass
    data = json.loads(resources.files("experiments").joinpath("data/thesis/beams.json").read_text())
    key = str(name).lower().removeprefix("beam")
    if key not in data["beams"]:
        raise ConfigError(f"config key 'preset': unknown beam {name!r}; expected one of "
                          f"{['beam' + k for k in data['beams']]}")
    g, b = data["geometry"], data["beams"][key]
    return BeamPreset(f"beam{key}", b["mass_kg"], b["EI_Nm2"], g["total_length_m"], g["cantilever_length_m"],
                      g["width_m"], g["thickness_m"], b["mass_kg"] / g["total_length_m"])


def layered_ei(moduli, interfaces, width):
    """Eq. 4.1 for a section symmetric about its neutral axis.

    Parameters
    ----------
    moduli : sequence of float, length K
        ``E_k`` (Pa) of the layers from the neutral axis outwards (one half).
    interfaces : sequence of float, length K + 1
        ``d_k`` (m): distances from the neutral axis, ``d_0 = 0`` ... ``d_K = h/2``.
    width : float
        ``b`` (m).

    Returns
    -------
    float
        ``EI`` (N m^2).
    """
    d = np.asarray(interfaces, dtype=float)
    return 2.0 * width / 3.0 * float(np.sum(np.asarray(moduli, float) * (d[1:] ** 3 - d[:-1] ** 3)))


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
        return layered_ei([self.core_modulus_pa, self.face_modulus_pa], [0.0, h2 - self.face_thickness_m, h2],
                          self.width_m)

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
    d = np.asarray(depth_m, dtype=float)
    h, tf, b = layout.thickness_m, layout.face_thickness_m, layout.width_m
    # layers bottom -> top: (y0, y1, E); the top is cut at h - d
    top = h - d
    bounds = [(0.0, tf, layout.face_modulus_pa), (tf, h - tf, layout.core_modulus_pa),
              (h - tf, h, layout.face_modulus_pa)]
    EA = np.zeros_like(d)
    ES = np.zeros_like(d)
    parts = []
    for y0, y1, E in bounds:
        y1c = np.minimum(y1, top)
        t = np.clip(y1c - y0, 0.0, None)
        yc = y0 + t / 2
        parts.append((t, yc, E))
        EA = EA + E * b * t
        ES = ES + E * b * t * yc
    yna = ES / EA
    EI = np.zeros_like(d)
    for t, yc, E in parts:
        EI = EI + E * b * (t**3 / 12 + t * (yc - yna) ** 2)
    return EI


def draw_specimens(rng: np.random.Generator, n: int, cfg: dict, preset: BeamPreset) -> dict:
    """Specimen parameters of ``n`` samples (one random block, fixed draw order).

    Returns
    -------
    dict of ndarray, shape (n,)
        ``EI`` (N m^2), ``m_per_length`` (kg/m), ``damping_scale`` (-) and
        ``root_spring`` (N m/rad, ``inf`` for a rigid clamp).
    """
    sp = cfg["specimen"]
    u = rng.random((n, 4))
    ei = preset.EI * (1 + sp["ei_band"] * (2 * u[:, 0] - 1))
    mpl = preset.m_per_length * (1 + sp["mass_band"] * (2 * u[:, 1] - 1))
    dsc = 1 + sp["damping_band"] * (2 * u[:, 2] - 1)
    if sp["root_spring_relative"]:
        lo, hi = np.log(sp["root_spring_relative"])
        kr = np.exp(lo + (hi - lo) * u[:, 3]) * ei / preset.length_m
    else:
        kr = np.full(n, np.inf)
    return {"EI": ei, "m_per_length": mpl, "damping_scale": dsc, "root_spring": kr}
