"""The beam file: one beam (geometry, section, mass, boundary condition, measured points, effects).

:class:`Beam` is the currency between commands: ``model``, ``update``,
``discrepancy`` (which writes a calibrated one) and ``generate`` take
``--beam PRESET|FILE``. :func:`load_beam` accepts a preset name (``beam5``,
``beam6``, ``beam8``: Table 4.1 and the Chapter Four geometry) or a TOML file.

Beam file (TOML, UTF-8)
-----------------------
Every key is optional when ``preset`` is given (the preset supplies it);
otherwise the keys marked * are required. Unknown keys are errors::

    preset = "beam5"                 # optional: start from a preset, override below
    name = "beam5-calibrated"
    bc = "clamped-free"              # clamped-free | free-free | pinned-pinned | clamped-clamped
    n_elements = 4                   # elements of the FE model (thesis: 4)
    length_m = 0.6095                # * free (cantilever) length
    total_length_m = 1.219           # whole specimen (mass per length = mass_kg / total_length_m)
    width_m = 0.051                  # * section width b
    thickness_m = 0.007264           # * section depth h
    section = "sandwich"             # sandwich | rectangular | circular (solid) | given (EI and mass only)
    face_thickness_m = 0.0005        # each face sheet of the sandwich (t_f)
    core_modulus_pa = 1.0e8          # core Young's modulus
    EI_Nm2 = 22.674                  # * flexural rigidity ...
    # face_modulus_pa = 7.0e10       #   ... or the face modulus: EI from eq. 4.1 (faces + core)
    mass_per_length_kg_m = 0.12955   # * mass per length ...
    # mass_kg = 0.15792              #   ... or the specimen mass over total_length_m
    measured_x_m = [0.152375, 0.30475, 0.457125, 0.6095]   # measured translations (default: quarter points)
    drive_x_m = 0.152375             # the reference DOF, where the force acts (default: the first sensor)
    band_hz = [9.549, 763.9]         # band measured (default: physics.layout)
    zones_x_m = [0.2, 0.4]           # interior edges of the location zones (default: between the sensors)

    [effects.shear_deformation]      # any of physics.effects.EFFECTS, each with its parameters
    kGA_N = 2.0e4
    [effects.root_flexibility]       # the supports' effect follows bc (physics.supports.Support.effect)
    k_theta_Nm_rad = 5.0e3
    [[effects.added_mass]]           # point effects: one [[...]] table per instance (or one [...] table)
    mass_kg = 0.035
    x_m = 0.06
    [[effects.added_mass]]
    mass_kg = 0.035
    x_m = 0.12

``EI_Nm2`` and ``face_modulus_pa`` exclude each other, as do
``mass_per_length_kg_m``, ``mass_kg`` and ``density_kg_m3``. A solid section
(``section = "rectangular"`` or ``"circular"``, the circle's ``diameter_m``)
takes ``modulus_pa`` (its ``EI`` unless ``EI_Nm2`` is given), ``poisson_ratio``
(default 0.3) and ``density_kg_m3``; each section's keys are refused on another. The effects and their parameters are
listed in :mod:`physics.effects`. :func:`write_beam` writes every key
explicitly (no ``preset``), so a written file stands on its own.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType

import numpy as np

from physics import effects as fx
from physics.errors import ConfigError
from physics.fem import FEModel
from physics.io import DofMap, atomic_write_text, map_frf_dofs, map_measured_dofs
from physics.io.inputs import check_input_file
from physics.properties import PRESETS, SECTION_KINDS, SOLID_SECTIONS, layered_ei, solid_section
from physics.modal import state_matrix
from physics.supports import ENDS, THESIS_SUPPORT, Support, support

__all__ = ["Beam", "MAX_MODEL_SPREAD", "PRESET_CORE_MODULUS_PA", "PRESET_FACE_THICKNESS_M", "beam_from_dict",
           "beam_to_toml", "file_fields", "load_beam", "preset_beam", "write_beam"]


#: Face-sheet thickness and core modulus of the presets (the datagen section layout).
PRESET_FACE_THICKNESS_M = 0.0005
PRESET_CORE_MODULUS_PA = 1.0e8


@dataclass(frozen=True)
class Beam:
    """A beam with its effects.

    Attributes
    ----------
    name : str
    length_m : float
        Free (cantilever) length (m).
    total_length_m : float
        Whole specimen length (m), which the weighed mass is spread over.
    width_m, thickness_m : float
        Section width ``b`` and depth ``h`` (m).
    EI_Nm2 : float
        Flexural rigidity (N m^2).
    mass_per_length_kg_m : float
        Mass per length (kg/m).
    bc : str
        Boundary condition, a name of :data:`physics.supports.SUPPORTS` (its record: :attr:`support`).
    n_elements : int
        Elements of the default FE model.
    measured_x_m : tuple of float
        Positions (m, from node 1 at ``x = 0``) of the measured translations.
    face_thickness_m : float or None
        Thickness of each face sheet of a sandwich section (m).
    core_modulus_pa : float or None
        Young's modulus of the core (Pa).
    section : str or None
        What the section is (:data:`physics.properties.SECTION_KINDS`): ``sandwich`` (faces on a core),
        ``rectangular`` or ``circular`` (solid, one material; a circle's diameter is ``thickness_m``), or
        ``given`` (``EI`` and mass per length only: an I, a box, anything). None: ``sandwich`` when face or
        core keys are given, else ``given``.
    modulus_pa : float or None
        Young's modulus of a solid section's material (Pa).
    poisson_ratio : float or None
        Poisson's ratio of a solid section's material (default 0.3 where needed).
    effects : mapping
        ``{effect name: {parameter: value}}`` (read-only), see :mod:`physics.effects`.
    drive_x_m : float or None
        Position of the reference DOF (m); None: the first sensor.
    band_hz : tuple (lo, hi) or None
        Band measured (Hz); None: the default of :mod:`physics.layout`.
    zones_x_m : tuple of float or None
        Interior edges of the location zones (m); None: the default of :mod:`physics.layout`.
    measured_x_given : bool
        True when a beam file gave ``measured_x_m`` (then the commands place the
        measured DOFs of a file without node geometry there, not by the
        quarter-point convention).
    source : str
        The beam file read (empty for a preset or a beam built in code), for messages.
    """

    name: str
    length_m: float
    total_length_m: float
    width_m: float
    thickness_m: float
    EI_Nm2: float
    mass_per_length_kg_m: float
    bc: str = THESIS_SUPPORT
    n_elements: int = 4
    measured_x_m: tuple = ()
    face_thickness_m: float | None = None
    core_modulus_pa: float | None = None
    section: str | None = None
    modulus_pa: float | None = None
    poisson_ratio: float | None = None
    effects: MappingProxyType = field(default_factory=dict)
    drive_x_m: float | None = None
    band_hz: tuple | None = None
    zones_x_m: tuple | None = None
    measured_x_given: bool = field(default=False, compare=False, metadata={"file_key": False})
    source: str = field(default="", compare=False, metadata={"file_key": False})

    def __post_init__(self):
        if self.section is None:
            sandwich = self.face_thickness_m is not None or self.core_modulus_pa is not None
            object.__setattr__(self, "section", "sandwich" if sandwich else "given")
        if self.section not in SECTION_KINDS:
            raise ConfigError(f"beam {self.name!r}: section {self.section!r} unknown; expected one of "
                              f"{list(SECTION_KINDS)}")
        eff = fx.validate_effects(dict(self.effects), f"beam {self.name!r}")
        fx.check_supports(eff, self.bc, f"beam {self.name!r}")
        object.__setattr__(self, "effects", MappingProxyType({k: MappingProxyType(v) for k, v in eff.items()}))
        xs = self.measured_x_m or tuple(self.length_m * k / 4 for k in range(1, 5))
        object.__setattr__(self, "measured_x_m", tuple(float(x) for x in xs))

    @property
    def support(self) -> Support:
        """The record of the beam's supports (:mod:`physics.supports`)."""
        return support(self.bc)

    def fe_model(self, n_elements=None, *, EI_scale=1.0, mass_scale=1.0) -> FEModel:
        """FE model with every effect applied (:func:`physics.effects.assemble_beam`).

        Parameters
        ----------
        n_elements : int, optional
            Mesh (default :attr:`n_elements`).
        EI_scale, mass_scale : float
            Multipliers of ``EI_Nm2`` and ``mass_per_length_kg_m`` (global recalibration).
        """
        return fx.assemble_beam(self.length_m, self.EI_Nm2 * EI_scale, self.mass_per_length_kg_m * mass_scale,
                                self.n_elements if n_elements is None else n_elements, bc=self.bc,
                                thickness_m=self.thickness_m, effects=self.effects)

    def with_effects(self, effects, **changes) -> "Beam":
        """Copy with the effect mapping replaced (and other fields changed)."""
        return replace(self, effects=dict(effects), **changes)

    @property
    def where(self) -> str:
        """The beam file (its key ``measured_x_m`` named), or the beam's name, for messages."""
        return f"{self.source}: 'measured_x_m'" if self.source else f"beam {self.name!r}"

    @property
    def masters(self) -> tuple[str, ...]:
        """DOF names of the measured translations when they sit on the nodes of the default mesh."""
        node_x = np.linspace(0.0, self.length_m, self.n_elements + 1)
        out = []
        for x in self.measured_x_m:
            k = int(np.argmin(np.abs(node_x - x)))
            if abs(node_x[k] - x) > 1e-9 * self.length_m:
                raise ConfigError(f"{self.where}: measured position {x} m is not a node of the "
                                  f"{self.n_elements}-element mesh"
                                  + ("" if self.measured_x_given else " (the quarter points, the default sensors)")
                                  + ": give 'measured_x_m' on its nodes, or 'n_elements' that put nodes there")
            end = 0 if k == 0 else 1 if k == self.n_elements else None
            if end is not None and "y" in ENDS[self.support.ends[end]].held:
                raise ConfigError(f"{self.where}: measured position {x:g} m is on the {self.bc} support at "
                                  f"x = {node_x[k]:g} m, which holds the translation"
                                  + ("" if self.measured_x_given else " (the quarter points, the default sensors)")
                                  + ": give 'measured_x_m' off the supports")
            out.append(f"{k + 1}:y")
        return tuple(out)

    def map_dofs(self, dofs, *, frf=None, targets: str = "masters", where: str = "measured data"):
        """The model DOF of this beam at each measured DOF (:func:`physics.io.map_measured_dofs`).

        Positions come from ``frf``'s node geometry when it has some, else from
        this beam file's ``measured_x_m`` when it gave them, else from the
        quarter-point convention (node ``N`` at ``(N - 1) L / n_elements``).
        Rows without labels (``dofs`` empty) are the beam's measured DOFs in order.

        Parameters
        ----------
        dofs : sequence of str
            Measured DOF labels (empty: unlabelled rows, one per measured position).
        frf : MeasuredFRF, optional
            The file the DOFs come from (its geometry and name).
        targets : {"masters", "nodes"}
            Model DOFs to match: the measured translations (:attr:`masters`) or
            the translations of every node of the default mesh.
        where : str
            The file, for messages.

        Returns
        -------
        physics.io.DofMap
        """
        if targets == "masters":
            model_x, model_dofs = self.measured_x_m, self.masters
        else:
            model_x = np.linspace(0.0, self.length_m, self.n_elements + 1)
            model_dofs = tuple(f"{k}:y" for k in range(1, self.n_elements + 2))
        if not dofs:
            source = "beam file" if self.measured_x_given else "quarter-point convention"
            return DofMap(source, "rows without DOF labels: the beam's measured DOFs in order", self.masters,
                          np.array(self.measured_x_m), self.masters)
        kw = dict(length_m=self.length_m, n_elements=self.n_elements,
                  beam_x_m=self.measured_x_m if self.measured_x_given else None)
        if frf is not None:
            return map_frf_dofs(frf, dofs, model_x, model_dofs, **kw)
        return map_measured_dofs(dofs, model_x, model_dofs, where=where, **kw)

    @property
    def solid(self):
        """The :class:`physics.properties.SolidSection` of a solid section with its modulus given, else None."""
        if self.section not in SOLID_SECTIONS or self.modulus_pa is None:
            return None
        return solid_section(self.section, self.width_m, self.thickness_m, self.modulus_pa,
                             0.3 if self.poisson_ratio is None else self.poisson_ratio)

    def effects_dict(self) -> dict:
        """Plain ``{effect: {param: value}}`` copy of :attr:`effects`."""
        return {k: dict(v) for k, v in self.effects.items()}


def file_fields() -> tuple:
    """The fields of :class:`Beam` that are beam-file keys (not ``measured_x_given`` or ``source``, which say where
    the values came from)."""
    return tuple(f for f in fields(Beam) if f.metadata.get("file_key", True))


def preset_beam(name: str) -> Beam:
    """A thesis specimen (Table 4.1, Chapter Four geometry) as a :class:`Beam` without effects."""
    if name not in PRESETS:
        raise ConfigError(f"unknown beam preset {name!r}; expected one of {sorted(PRESETS)} or a .toml file")
    p = PRESETS[name]
    return Beam(name=p.name, length_m=p.length_m, total_length_m=p.total_length_m, width_m=p.width_m,
                thickness_m=p.thickness_m, EI_Nm2=p.EI_Nm2, mass_per_length_kg_m=p.mass_per_length_kg_m,
                n_elements=p.n_elements, face_thickness_m=PRESET_FACE_THICKNESS_M,
                core_modulus_pa=PRESET_CORE_MODULUS_PA, section="sandwich")


_NUMBER_KEYS = ("length_m", "total_length_m", "width_m", "thickness_m", "face_thickness_m", "core_modulus_pa",
                "EI_Nm2", "face_modulus_pa", "mass_per_length_kg_m", "mass_kg", "modulus_pa", "poisson_ratio",
                "density_kg_m3", "diameter_m")
_KEYS = ("preset", "name", "bc", "n_elements", "measured_x_m", "drive_x_m", "band_hz", "zones_x_m",
         "effects", "section") + _NUMBER_KEYS
#: The keys of each section kind beyond the geometry, EI and mass (any other section's keys are refused).
_SECTION_KEYS = {"sandwich": ("face_thickness_m", "core_modulus_pa", "face_modulus_pa"),
                 "rectangular": ("modulus_pa", "poisson_ratio", "density_kg_m3"),
                 "circular": ("modulus_pa", "poisson_ratio", "density_kg_m3", "diameter_m"),
                 "given": ()}

def beam_from_dict(obj: dict, source: str = "beam") -> Beam:
    """Validate a beam mapping (the TOML layout of the module docstring) into a :class:`Beam`."""
    if not isinstance(obj, dict):
        raise ConfigError(f"{source}: a beam file must be a TOML table of keys")
    for key in obj:
        if key not in _KEYS:
            raise ConfigError(f"{source}: unknown key {key!r}; expected some of {sorted(_KEYS)}")
    vals = _preset_values(obj, source)
    _read_scalars(obj, vals, source)
    _read_section(obj, vals, source)
    for required in ("length_m", "width_m", "thickness_m"):
        if required not in vals:
            raise ConfigError(f"{source}: missing key {required!r} (or give 'preset')")
    vals.setdefault("total_length_m", vals["length_m"])
    if "measured_x_m" in obj:
        vals["measured_x_m"] = _measured_positions(obj["measured_x_m"], vals["length_m"], source)
        vals["measured_x_given"] = True
    _read_test_keys(obj, vals, source)
    _resolve_rigidity(obj, vals, source)
    _resolve_mass(obj, vals, source)
    if "effects" in obj:
        eff = fx.validate_effects(obj["effects"], source)
        vals["effects"] = {**vals.get("effects", {}), **eff}
    fx.check_supports(vals.get("effects", {}), vals.get("bc", THESIS_SUPPORT), source)
    _check_layout(vals, source)
    beam = Beam(**vals, source=source)
    if beam.effects:
        _check_effects_keep_a_model(beam, source)
    return beam


def _preset_values(obj: dict, source: str) -> dict:
    """The fields of the ``preset`` beam (its effects as a mapping), or an empty dict without ``preset``."""
    if "preset" not in obj:
        return {}
    if not isinstance(obj["preset"], str):
        raise ConfigError(f"{source}: 'preset' must be a string such as \"beam5\"")
    b = preset_beam(obj["preset"]) if obj["preset"] in PRESETS else None
    if b is None:
        raise ConfigError(f"{source}: 'preset' = {obj['preset']!r} unknown; expected one of {sorted(PRESETS)}")
    base = {f.name: getattr(b, f.name) for f in file_fields()}
    base["effects"] = b.effects_dict()
    return base


def _read_section(obj: dict, vals: dict, source: str) -> None:
    """``section`` (default: ``sandwich`` with a preset or face/core keys, else ``given``), its keys checked; a
    circle's ``diameter_m`` becomes its ``width_m`` and ``thickness_m``."""
    if "section" in obj and obj["section"] not in SECTION_KINDS:
        raise ConfigError(f"{source}: 'section' = {obj['section']!r} unknown; expected one of {list(SECTION_KINDS)}")
    sandwich = any(vals.get(k) is not None for k in _SECTION_KEYS["sandwich"])
    kind = obj.get("section", "sandwich" if sandwich or "preset" in obj else "given")
    vals["section"] = kind
    for other, keys in _SECTION_KEYS.items():
        for k in keys:
            if k in obj and k not in _SECTION_KEYS[kind]:
                raise ConfigError(f"{source}: {k!r} describes a {other} section, not this {kind} one (section = "
                                  f"{kind!r}); its keys are {', '.join(_SECTION_KEYS[kind]) or 'EI_Nm2 and the mass'}")
    if kind != "sandwich":
        vals.pop("face_thickness_m", None)
        vals.pop("core_modulus_pa", None)
    if kind == "circular":
        d = vals.pop("diameter_m", None)
        if d is not None:
            if "width_m" in obj or "thickness_m" in obj:
                raise ConfigError(f"{source}: give 'diameter_m' or 'width_m' and 'thickness_m', not both")
            vals["width_m"] = vals["thickness_m"] = d
    if vals.get("poisson_ratio") is not None and not vals["poisson_ratio"] < 0.5:
        raise ConfigError(f"{source}: 'poisson_ratio' must lie in (0, 0.5), got {vals['poisson_ratio']!r}")


def _read_scalars(obj: dict, vals: dict, source: str) -> None:
    """Copy the checked numbers (SI), ``name`` (default: the file stem), ``bc`` and ``n_elements`` into ``vals``."""
    for key in _NUMBER_KEYS:
        if key not in obj:
            continue
        v = obj[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise ConfigError(f"{source}: {key!r} must be a positive finite number (SI units), got {v!r}")
        vals[key] = float(v)
    if "name" in obj:
        if not isinstance(obj["name"], str) or not obj["name"]:
            raise ConfigError(f"{source}: 'name' must be a non-empty string")
        vals["name"] = obj["name"]
    vals.setdefault("name", Path(source).stem)
    if "bc" in obj:
        vals["bc"] = support(obj["bc"], source).name
    if "n_elements" in obj:
        n = obj["n_elements"]
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 2000:
            raise ConfigError(f"{source}: 'n_elements' must be an integer in [1, 2000], got {n!r}")
        vals["n_elements"] = n


def _measured_positions(xs, length_m: float, source: str) -> tuple:
    """``measured_x_m`` as a tuple of floats (m), each in ``[0, length_m]``."""
    if not (isinstance(xs, list) and xs and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                and math.isfinite(x) for x in xs)):
        raise ConfigError(f"{source}: 'measured_x_m' must be a non-empty list of positions (m)")
    if any(not 0 <= x <= length_m for x in xs):
        raise ConfigError(f"{source}: 'measured_x_m' positions must lie in [0, length_m = {length_m}]")
    return tuple(float(x) for x in xs)


def _read_test_keys(obj: dict, vals: dict, source: str) -> None:
    """``drive_x_m`` (a position on the beam), ``band_hz`` ([lo, hi], 0 <= lo < hi) and ``zones_x_m`` (interior
    edges, checked with the modes by :func:`physics.layout.layout_of`) into ``vals``."""
    def number(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    L = vals["length_m"]
    if "drive_x_m" in obj:
        v = obj["drive_x_m"]
        if not (number(v) and 0 <= v <= L):
            raise ConfigError(f"{source}: 'drive_x_m' must be a position in [0, length_m = {L}] m, got {v!r}")
        vals["drive_x_m"] = float(v)
    if "band_hz" in obj:
        v = obj["band_hz"]
        if not (isinstance(v, list) and len(v) == 2 and all(map(number, v)) and 0 <= v[0] < v[1]):
            raise ConfigError(f"{source}: 'band_hz' must be [lo, hi] in Hz with 0 <= lo < hi, got {v!r}")
        vals["band_hz"] = (float(v[0]), float(v[1]))
    if "zones_x_m" in obj:
        v = obj["zones_x_m"]
        if not (isinstance(v, list) and all(map(number, v)) and all(0 < x < L for x in v)):
            raise ConfigError(f"{source}: 'zones_x_m' must be a list of positions strictly inside (0, {L}) m, "
                              f"got {v!r}")
        vals["zones_x_m"] = tuple(float(x) for x in v)


def _resolve_rigidity(obj: dict, vals: dict, source: str) -> None:
    """Set ``vals["EI_Nm2"]``, given or from the section: the sandwich's face modulus (eq. 4.1), which leaves
    ``vals``, or a solid section's modulus (which stays: it gives the shear modulus too)."""
    if "EI_Nm2" in obj and "face_modulus_pa" in obj:
        raise ConfigError(f"{source}: give 'EI_Nm2' or 'face_modulus_pa', not both")
    if vals["section"] in SOLID_SECTIONS and "EI_Nm2" not in obj and vals.get("modulus_pa") is not None:
        vals["EI_Nm2"] = solid_section(vals["section"], vals["width_m"], vals["thickness_m"],
                                       vals["modulus_pa"]).EI_Nm2
    ef = vals.pop("face_modulus_pa", None)
    if ef is not None:
        tf, ec = vals.get("face_thickness_m"), vals.get("core_modulus_pa")
        if tf is None or ec is None:
            raise ConfigError(f"{source}: 'face_modulus_pa' needs 'face_thickness_m' and 'core_modulus_pa'")
        h2 = vals["thickness_m"] / 2
        if not 0 < tf < h2:
            raise ConfigError(f"{source}: 'face_thickness_m' must be below half of 'thickness_m'")
        vals["EI_Nm2"] = float(layered_ei(vals["width_m"], [0.0, h2 - tf, h2], [ec, ef]))
    if "EI_Nm2" not in vals:
        raise ConfigError(f"{source}: missing key 'EI_Nm2' (or 'face_modulus_pa' with the layers of a sandwich, "
                          f"'modulus_pa' of a solid section, or 'preset')")


def _resolve_mass(obj: dict, vals: dict, source: str) -> None:
    """Set ``vals["mass_per_length_kg_m"]``, given or ``mass_kg / total_length_m`` (``mass_kg`` leaves ``vals``)."""
    given = [k for k in ("mass_per_length_kg_m", "mass_kg", "density_kg_m3") if k in obj]
    if len(given) > 1:
        raise ConfigError(f"{source}: give one of 'mass_per_length_kg_m', 'mass_kg' and 'density_kg_m3', not "
                          f"{' and '.join(given)}")
    mass = vals.pop("mass_kg", None)
    if mass is not None:
        vals["mass_per_length_kg_m"] = mass / vals["total_length_m"]
    density = vals.pop("density_kg_m3", None)
    if density is not None:
        vals["mass_per_length_kg_m"] = density * solid_section(vals["section"], vals["width_m"], vals["thickness_m"],
                                                               1.0).area_m2
    if "mass_per_length_kg_m" not in vals:
        raise ConfigError(f"{source}: missing key 'mass_per_length_kg_m' (or 'mass_kg', 'density_kg_m3' of a solid "
                          f"section, or 'preset')")


def _check_layout(vals: dict, source: str) -> None:
    """Faces thinner than half the section, and the added mass and local damper on the beam (``x_m <= length_m``)."""
    tf = vals.get("face_thickness_m")
    if tf is not None and not tf < vals["thickness_m"] / 2:
        raise ConfigError(f"{source}: 'face_thickness_m' must be below half of 'thickness_m'")
    for k, p in vals.get("effects", {}).items():
        x = p.get("x_m")
        if x is not None and x > vals["length_m"]:
            raise ConfigError(f"{source}: 'effects.{k}.x_m' = {x} lies beyond 'length_m' = {vals['length_m']}")


#: Largest spread of the eigenvalues of the mass matrix, and of the squared natural frequencies, of a beam
#: file's 4-element model (a plain cantilever: 3e4 and 7e4): beyond it the effects make the model singular to
#: working precision (a root spring of almost nothing, an added mass of tonnes on a light beam).
MAX_MODEL_SPREAD = 1e12


def _check_effects_keep_a_model(beam: Beam, source: str) -> None:
    """Refuse effect values that leave no positive definite, underdamped model (one line naming the file)."""
    from scipy.linalg import eigh

    model = beam.fe_model(4)
    names = ", ".join(f"effects.{k}" for k in beam.effects)
    mass = np.linalg.eigvalsh(model.M)
    w2 = eigh(model.K, model.M, eigvals_only=True) if mass.min() > 0 else np.array([-1.0])
    if not (mass.min() > 0 and mass.max() <= MAX_MODEL_SPREAD * mass.min() and w2.min() > 0
            and w2.max() <= MAX_MODEL_SPREAD * w2.min()):
        raise ConfigError(f"{source}: {names} leave no positive definite model (mass spread "
                          f"{mass.max() / mass.min() if mass.min() > 0 else float('inf'):.3g}, squared frequency "
                          f"spread {w2.max() / w2.min() if w2.min() > 0 else float('inf'):.3g}, limit "
                          f"{MAX_MODEL_SPREAD:g}): give values of the beam's own scale (mass, EI / length)")
    lam = np.linalg.eigvals(state_matrix(model.M, model.C, model.K))
    real = np.abs(lam.imag) <= 1e-9 * np.abs(lam).max()
    if real.any():
        raise ConfigError(f"{source}: {names} make {max(int(real.sum()) // 2, 1)} mode(s) of the model overdamped; "
                          "the package needs underdamped modes (a smaller 'c_Ns_m')")


def load_beam(name_or_path) -> Beam:
    """A preset name (``beam5``, ``beam6``, ``beam8``) or a TOML beam file (module docstring).

    Raises
    ------
    ConfigError
        Unknown preset, missing file, non-UTF-8 or malformed TOML, or a bad key
        (one line naming the file and key).
    """
    s = str(name_or_path)
    if s in PRESETS:
        return preset_beam(s)
    path = Path(s)
    if not path.exists():
        raise ConfigError(f"{s}: neither a beam preset ({', '.join(sorted(PRESETS))}) nor an existing beam file")
    check_input_file(path, "toml", ConfigError, "a TOML beam file")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not UTF-8 text; a beam file is TOML") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a TOML beam file") from None
    try:
        obj = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    return beam_from_dict(obj, str(path))


def _toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))


def beam_to_toml(beam: Beam, comment: str = "") -> str:
    """TOML text of a beam (every key explicit; ``comment`` lines go first, prefixed by ``#``)."""
    lines = [f"# {c}" if c else "#" for c in comment.splitlines()] if comment else []
    lines.append("# beam-damage beam file (see docs/beam-file.md); SI units")
    for f in file_fields():
        v = getattr(beam, f.name)
        if f.name == "effects" or v is None:
            continue
        lines.append(f"{f.name} = {_toml_value(v)}")
    for key, params in beam.effects.items():
        name = fx.effect_of(key)
        lines.append("")
        lines.append(f"[[effects.{name}]]" if len(fx.instances(beam.effects, name)) > 1 else f"[effects.{name}]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in params.items())
    return "\n".join(lines) + "\n"


def write_beam(path, beam: Beam, comment: str = "") -> None:
    """Write ``beam`` as a TOML beam file, atomically (temporary file, then rename)."""
    atomic_write_text(path, beam_to_toml(beam, comment))
