"""Model augmentations ("effects") of the Euler-Bernoulli beam, with physical parameters.

A beam model here is a uniform beam of equal elements (:mod:`physics.fem`
conventions: nodes from 1 at ``x = 0``, DOFs ``"node:y"`` and ``"node:rz"``)
plus any of these effects, each a mapping of parameter name -> value (SI, the
unit in the name):

``shear_deformation``  ``kGA_N`` (required), ``rho_I_kg_m`` (optional)
    Timoshenko elements: shear flexibility with shear rigidity ``kGA`` (N) and
    rotary inertia ``rho I`` (kg m, default ``m h^2 / 12``, the uniform-density
    section). Element of Friedman & Kosmatka (Comput. Struct. 47, 1993,
    "interdependent interpolation"), whose stiffness is exact in statics and
    whose mass matrix reduces to eq. 3.8 when ``kGA -> inf, rho I -> 0``.
``rotary_inertia``  ``rho_I_kg_m`` (optional, default ``m h^2 / 12``)
    Rayleigh beam: Euler-Bernoulli stiffness plus rotary inertia.
``root_flexibility``  ``k_theta_Nm_rad`` (required), ``k_y_N_m`` (optional)
    The clamp becomes a rotational spring (N m/rad) and, if given, a
    translational spring (N/m); clamped-free beams only.
``clamp_flexibility``  ``k_theta_Nm_rad`` (required), ``k_y_N_m`` (optional)
    Both clamps of a clamped-clamped beam become rotational springs of the
    same stiffness (N m/rad) and, if given, translational springs (N/m). One
    value for both: the frequencies of a symmetric beam depend to first order
    on the sum of the two end compliances only, so measured modes cannot tell
    the two clamps apart.
``bearing_flexibility``  ``k_theta_Nm_rad`` (required)
    A rotational spring (N m/rad) at each pinned end of a pinned-pinned beam,
    one value for both (as ``clamp_flexibility``): 0 is the ideal pin, infinity a clamp.
``suspension``  ``k_y_N_m`` (required)
    A translational spring to ground (N/m) at each end of a free-free beam
    (the soft suspension of a free-free test): the two rigid-body modes become
    the bounce and pitch modes (bounce at ``sqrt(2 k / (m L))`` for a stiff
    beam), and the bending modes stiffen slightly.
``added_mass``  ``mass_kg`` (required), ``x_m`` (default: the tip), ``J_kg_m2`` (default 0)
    A point mass (sensor, stinger, shaker armature, bolted mass) with optional rotary
    inertia, attached through the element's cubic (Hermite) shape functions, so
    any position is allowed; at a node it adds to that node's DOFs exactly. A beam
    holds any number of them (one ``[[effects.added_mass]]`` table each).
``local_damping``  ``c_Ns_m`` (required), ``x_m`` (default: the tip)
    A viscous dashpot to ground at ``x`` (shaker attachment, clamp friction
    near the root): non-proportional damping, visible as mode complexity and a
    damping-ratio pattern that no Rayleigh damping can follow. Any number of them
    (one ``[[effects.local_damping]]`` table each).
``proportional_damping``  ``alpha_1_s`` (default 0), ``beta_s`` (default 0)
    Rayleigh damping ``C = alpha M + beta K`` of the whole beam. It is the
    damping that is always calibrated, not a candidate effect.

Each effect is one :class:`Effect` record of :data:`EFFECTS` (its parameters, how it
enters the model, the supports it fits, its discrepancy-fit bounds). The support effects follow
the boundary condition (:attr:`physics.supports.Support.effect`); an effect on supports the beam lacks is refused
in one line. :func:`candidates_for` lists the candidates of a discrepancy analysis of a beam.
:func:`assemble_beam` builds an :class:`physics.fem.FEModel` with every effect applied; :func:`interpolation_matrix`
maps its DOFs onto the translations at arbitrary positions (measured points between nodes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from physics import fem
from physics.errors import BeamDamageError, ConfigError
from physics.supports import ENDS, SUPPORTS, THESIS_SUPPORT, add_springs, support

__all__ = ["CANDIDATES", "EFFECTS", "INSTANCE_SEP", "Effect", "Parameter", "assemble_beam",
           "candidates_for", "check_supports", "dashpot_matrix", "effect_of", "hermite_row", "instance_key",
           "instances", "interpolation_matrix", "next_instance", "point_mass_matrix", "timoshenko_mass",
           "timoshenko_stiffness", "validate_effects"]


@dataclass(frozen=True)
class Parameter:
    """One physical parameter of an effect.

    Attributes
    ----------
    name : str
        Key in the beam file, unit in the name.
    required : bool
        Must be given (no physical default).
    lower : float
        Smallest admissible value (exclusive when ``positive``).
    positive : bool
        Must be strictly greater than ``lower`` (which is then 0).
    """

    name: str
    required: bool
    lower: float = 0.0
    positive: bool = True


@dataclass
class _Parts:
    """A beam under assembly, which the effects' ``apply`` steps change in place (:func:`assemble_beam`)."""

    length_m: float
    bc: str
    default_rho_i: float | None     # m h^2 / 12, or None without the section thickness
    kga: float = np.inf             # element shear rigidity (N)
    rho_i: float = 0.0              # element rotary inertia (kg m)
    M: np.ndarray | None = None
    K: np.ndarray | None = None
    C: np.ndarray | None = None
    node_x: np.ndarray | None = None
    removed: set | None = None      # constrained DOF names

    def rotary_inertia(self, p: dict) -> float:
        if "rho_I_kg_m" in p:
            return p["rho_I_kg_m"]
        if self.default_rho_i is None:
            raise BeamDamageError("the default rotary inertia m h^2/12 needs the section thickness; give "
                                  "thickness_m or the parameter rho_I_kg_m")
        return self.default_rho_i


@dataclass(frozen=True)
class Effect:
    """One modelled effect: its beam-file parameters, how it enters the model and its fit bounds.

    Attributes
    ----------
    name : str
        Key under ``[effects]`` in the beam file.
    params : tuple of Parameter
    stage : {"element", "assembled"}
        ``element`` effects set the element's shear rigidity and rotary inertia before assembly; ``assembled``
        ones change ``M``, ``C``, ``K`` or the constrained DOFs after it, in :data:`EFFECTS` order.
    apply : callable ``(parts, params) -> None``
        Changes the beam under assembly in place.
    fit_bounds : callable ``(L, EI, m, rho_i, w1) -> {parameter: (lower, upper)}``, or None
        Bounds of the free parameters of a discrepancy fit, on the beam's own scales (``w1``: the first
        measured mode, rad/s); None for an effect that is not a discrepancy candidate.
    supports : tuple of str, or None
        Boundary conditions the effect fits (None: every one).
    repeatable : bool
        A point effect a beam may hold several of (one ``[[effects.<name>]]`` table each); its instances are
        keyed ``name``, ``name#2``, ``name#3``, ... (:func:`instance_key`).
    sections : tuple of str, or None
        Section kinds the effect fits (:data:`physics.properties.SECTION_KINDS`; None: every one).
    """

    name: str
    params: tuple
    stage: str
    apply: Callable
    fit_bounds: Callable | None = None
    supports: tuple | None = None
    repeatable: bool = False
    sections: tuple | None = None


#: Separator of an effect's name and its instance number in the keys of repeated point effects.
INSTANCE_SEP = "#"


def effect_of(key: str) -> str:
    """The effect name of an effect key (``"added_mass#3"`` -> ``"added_mass"``)."""
    return key.split(INSTANCE_SEP, 1)[0]


def instance_key(name: str, i: int) -> str:
    """Key of the ``i``-th (0-based) instance of effect ``name``: ``name`` for the first, ``name#{i+1}`` after."""
    return name if i == 0 else f"{name}{INSTANCE_SEP}{i + 1}"


def instances(effects, name: str) -> list:
    """The parameter mappings of every instance of effect ``name`` in ``effects`` (keys in order)."""
    return [v for k, v in effects.items() if effect_of(k) == name]


def next_instance(effects, name: str) -> str:
    """The key of a further instance of ``name`` in ``effects``."""
    return instance_key(name, len(instances(effects, name)))


def _shear(parts: _Parts, p: dict) -> None:
    parts.kga = p["kGA_N"]
    parts.rho_i = parts.rotary_inertia(p)


def _rotary(parts: _Parts, p: dict) -> None:
    parts.rho_i = parts.rotary_inertia(p)


def _proportional(parts: _Parts, p: dict) -> None:
    parts.C = p.get("alpha_1_s", 0.0) * parts.M + p.get("beta_s", 0.0) * parts.K


def _added_mass(parts: _Parts, p: dict) -> None:
    parts.M = parts.M + point_mass_matrix(parts.node_x, p["mass_kg"], p.get("x_m", parts.length_m),
                                          p.get("J_kg_m2", 0.0))


def _dashpot(parts: _Parts, p: dict) -> None:
    parts.C = parts.C + dashpot_matrix(parts.node_x, p["c_Ns_m"], p.get("x_m", parts.length_m))


def _springs(parts: _Parts, end: str, direction: str, k: float) -> None:
    """Springs to ground of stiffness ``k`` on ``direction`` of the ends of condition ``end`` (:data:`ENDS`), their
    DOFs kept."""
    dofs = SUPPORTS[parts.bc].end_dofs(parts.node_x.size, end, direction)
    parts.removed -= set(dofs)
    parts.K = add_springs(parts.K, fem.dof_names(parts.node_x.size), dofs, k)


def _support_springs(parts: _Parts, p: dict) -> None:
    """The support's own springs (:meth:`physics.supports.Support.spring_dofs`), ``k_theta_Nm_rad`` on rotations or
    ``k_y_N_m`` on translations, and a clamp's optional translational springs ``k_y_N_m``."""
    end = SUPPORTS[parts.bc].spring_end
    rotational = ENDS[end].spring == "rz"
    _springs(parts, end, ENDS[end].spring, p["k_theta_Nm_rad"] if rotational else p["k_y_N_m"])
    if rotational and "k_y_N_m" in p:
        _springs(parts, end, "y", p["k_y_N_m"])


def _supported_by(effect: str) -> tuple:
    """The supports whose own springs ``effect`` calibrates (:attr:`physics.supports.Support.effect`)."""
    return tuple(s.name for s in SUPPORTS.values() if s.effect == effect)


#: Every effect, one record each (see the module docstring); ``assembled`` effects apply in this order.
EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("shear_deformation", (Parameter("kGA_N", True), Parameter("rho_I_kg_m", False, positive=False)),
           "element", _shear, lambda L, EI, m, rho_i, w1: {"kGA_N": (1.0 * EI / L**2, 1e6 * EI / L**2)}),
    # between a tenth of the uniform section's and all the mass in the faces (3 m h^2 / 12); a solid section's
    # is m h^2 / 12 (rectangle) or m d^2 / 16 (circle), known, so no candidate there
    Effect("rotary_inertia", (Parameter("rho_I_kg_m", False, positive=False),), "element", _rotary,
           lambda L, EI, m, rho_i, w1: {"rho_I_kg_m": (0.1 * rho_i, 3.0 * rho_i)}, sections=("sandwich", "given")),
    Effect("proportional_damping", (Parameter("alpha_1_s", False, positive=False),
                                    Parameter("beta_s", False, positive=False)), "assembled", _proportional),
    Effect("added_mass", (Parameter("mass_kg", True, positive=False), Parameter("x_m", False, positive=False),
                          Parameter("J_kg_m2", False, positive=False)), "assembled", _added_mass,
           lambda L, EI, m, rho_i, w1: {"mass_kg": (1e-4 * m * L, 2.0 * m * L)}, repeatable=True),
    Effect("local_damping", (Parameter("c_Ns_m", True, positive=False), Parameter("x_m", False, positive=False)),
           "assembled", _dashpot, lambda L, EI, m, rho_i, w1: {"c_Ns_m": (1e-7 * m * L * w1, 0.3 * m * L * w1)},
           repeatable=True),
    Effect("root_flexibility", (Parameter("k_theta_Nm_rad", True), Parameter("k_y_N_m", False)), "assembled",
           _support_springs, lambda L, EI, m, rho_i, w1: {"k_theta_Nm_rad": (0.1 * EI / L, 1e5 * EI / L)},
           _supported_by("root_flexibility")),
    Effect("clamp_flexibility", (Parameter("k_theta_Nm_rad", True), Parameter("k_y_N_m", False)), "assembled",
           _support_springs, lambda L, EI, m, rho_i, w1: {"k_theta_Nm_rad": (0.1 * EI / L, 1e5 * EI / L)},
           _supported_by("clamp_flexibility")),
    # from an almost ideal pin (a frequency shift of ~1e-4) to almost a clamp
    Effect("bearing_flexibility", (Parameter("k_theta_Nm_rad", True),), "assembled", _support_springs,
           lambda L, EI, m, rho_i, w1: {"k_theta_Nm_rad": (1e-3 * EI / L, 1e3 * EI / L)},
           _supported_by("bearing_flexibility")),
    # bounce mode sqrt(2 k / (m L)) from 0.5 % to 40 % of the first measured (bending) mode
    Effect("suspension", (Parameter("k_y_N_m", True),), "assembled", _support_springs,
           lambda L, EI, m, rho_i, w1: {"k_y_N_m": (0.5 * m * L * (0.005 * w1) ** 2, 0.5 * m * L * (0.4 * w1) ** 2)},
           _supported_by("suspension")),
)}

#: Effects a discrepancy analysis may name on some beam (``proportional_damping`` is always calibrated); the
#: candidates of one beam are :func:`candidates_for` its boundary condition.
CANDIDATES = ("shear_deformation", "rotary_inertia", "root_flexibility", "clamp_flexibility", "bearing_flexibility",
              "suspension", "added_mass", "local_damping")


def candidates_for(bc: str, section: str | None = None) -> tuple[str, ...]:
    """The candidate effects of a beam with boundary condition ``bc`` and section kind ``section``: the
    :data:`CANDIDATES` that fit its supports and its section (None: any section).

    Shear deformation, added mass and local damping fit every beam, rotary inertia every section but a solid
    one (whose ``rho I`` is known); of the support effects the one of its support
    (:attr:`physics.supports.Support.effect`). An unknown ``bc`` is refused (:func:`physics.supports.support`).
    """
    support(bc)
    return tuple(c for c in CANDIDATES if (EFFECTS[c].supports is None or bc in EFFECTS[c].supports)
                 and (section is None or EFFECTS[c].sections is None or section in EFFECTS[c].sections))


def check_supports(names, bc: str, source: str = "effects") -> None:
    """Refuse effects that do not fit the supports of a ``bc`` beam.

    Raises
    ------
    ConfigError
        One line naming ``source``, the effect, the boundary condition and the support effect that fits it, or
        the unknown boundary condition and the accepted ones.
    """
    own = support(bc, source).effect
    for name in dict.fromkeys(effect_of(n) for n in names):
        sup = EFFECTS[name].supports
        if sup is not None and bc not in sup:
            raise ConfigError(f"{source}: effect '{name}' is defined for a {' or '.join(sup)} beam, not {bc}; "
                              f"the supports of a {bc} beam take '{own}'")


def validate_effects(effects, source: str = "effects") -> dict:
    """Check effect names, parameter names and values; returns a clean ``{key: {param: float}}``.

    A repeatable point effect (:attr:`Effect.repeatable`) may be a list of tables (TOML ``[[effects.added_mass]]``,
    one per instance), which become the keys ``added_mass``, ``added_mass#2``, ... (:func:`instance_key`); those
    keys are read back as they are.

    Raises
    ------
    ConfigError
        One line naming ``source``, the effect (with the table's index among its instances, from 1:
        ``effects.added_mass[2].mass_kg``) and the parameter.
    """
    if effects is None:
        return {}
    if not hasattr(effects, "items"):
        raise ConfigError(f"{source}: 'effects' must be a table of effect name -> parameters")
    out = {}
    for key, params in effects.items():
        name = effect_of(key)
        if name not in EFFECTS:
            raise ConfigError(f"{source}: unknown effect 'effects.{key}'; expected one of {sorted(EFFECTS)}")
        if isinstance(params, (list, tuple)):
            if not EFFECTS[name].repeatable or key != name:
                rep = sorted(n for n, e in EFFECTS.items() if e.repeatable)
                raise ConfigError(f"{source}: 'effects.{key}' must be one table (only {', '.join(rep)} take one "
                                  f"[[effects.<name>]] table per instance)")
            if not params:
                raise ConfigError(f"{source}: 'effects.{key}' is an empty list of tables")
            tables = [(f"effects.{key}[{i + 1}]", instance_key(name, i), p) for i, p in enumerate(params)]
        else:
            if key != name and not EFFECTS[name].repeatable:
                raise ConfigError(f"{source}: unknown effect 'effects.{key}'; expected one of {sorted(EFFECTS)}")
            tables = [(f"effects.{key}", key, params)]
        for where, ikey, table in tables:
            if ikey in out:
                raise ConfigError(f"{source}: '{where}' repeats the effect key '{ikey}'")
            out[ikey] = _validate_table(name, table, where, source)
    return out


def _validate_table(name: str, params, where: str, source: str) -> dict:
    """One table of effect ``name``'s parameters (``where``: its place in the file, for messages)."""
    if not hasattr(params, "items"):
        raise ConfigError(f"{source}: '{where}' must be a table of parameters "
                          f"({', '.join(p.name for p in EFFECTS[name].params)})")
    spec = {p.name: p for p in EFFECTS[name].params}
    clean = {}
    for key, value in params.items():
        if key not in spec:
            raise ConfigError(f"{source}: unknown parameter '{where}.{key}'; expected one of {sorted(spec)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{source}: '{where}.{key}' must be a finite number, got {value!r}")
        p = spec[key]
        if value < p.lower or (p.positive and value <= p.lower):
            raise ConfigError(f"{source}: '{where}.{key}' must be {'>' if p.positive else '>='} "
                              f"{p.lower:g}, got {value!r}")
        clean[key] = float(value)
    for p in EFFECTS[name].params:
        if p.required and p.name not in clean:
            raise ConfigError(f"{source}: '{where}' needs parameter '{p.name}'")
    return clean


# ---------------------------------------------------------------------------
# Elements
# ---------------------------------------------------------------------------

def _matrix4(rows):
    """(..., 4, 4) array from a 4x4 nested list of scalars and broadcastable arrays."""
    flat = np.broadcast_arrays(*(v for row in rows for v in row))
    return np.stack(flat, axis=-1).reshape(flat[0].shape + (4, 4))


def timoshenko_stiffness(EI, kGA, length):
    """Timoshenko element stiffness (Friedman & Kosmatka 1993), DOFs ``[w1, theta1, w2, theta2]``.

    ``K = EI / (l^3 (1 + phi)) [[12, 6l, -12, 6l], [6l, (4+phi) l^2, -6l, (2-phi) l^2], ...]``
    with ``phi = 12 EI / (kGA l^2)``; ``kGA = inf`` gives eq. 3.9.

    Parameters
    ----------
    EI : float or ndarray, shape (...)   (N m^2)
    kGA : float or ndarray, shape (...)  (N), ``np.inf`` for no shear flexibility
    length : float  element length (m)

    Returns
    -------
    ndarray, shape (..., 4, 4)   (broadcast over ``EI`` and ``kGA``)
    """
    l = float(length)
    EI, kGA = np.broadcast_arrays(np.asarray(EI), np.asarray(kGA))
    phi = 12.0 * EI / (kGA * l**2)
    a = (4 + phi) * l**2
    b = (2 - phi) * l**2
    k = _matrix4([[12, 6 * l, -12, 6 * l], [6 * l, a, -6 * l, b],
                  [-12, -6 * l, 12, -6 * l], [6 * l, b, -6 * l, a]])
    return (EI / (l**3 * (1 + phi)))[..., None, None] * k


def timoshenko_mass(m_per_length, rho_I, EI, kGA, length):
    """Consistent Timoshenko element mass: translational plus rotary inertia.

    Interdependent-interpolation mass of Friedman & Kosmatka (1993)
    (Przemieniecki's coefficients) with ``phi = 12 EI / (kGA l^2)``. For
    ``phi = 0`` the translational part is eq. 3.8 and the rotary part is the
    Rayleigh-beam matrix ``rho I / (30 l) [[36, 3l, -36, 3l], ...]``.

    Parameters
    ----------
    m_per_length : float or ndarray, shape (...)  (kg/m)
    rho_I : float or ndarray, shape (...)  rotary inertia per length (kg m)
    EI, kGA : float or ndarray, shape (...)  (N m^2, N); ``kGA = inf`` for no shear flexibility
    length : float  (m)

    Returns
    -------
    ndarray, shape (..., 4, 4)   (broadcast over the array arguments)
    """
    l = float(length)
    m, rho_I, EI, kGA = np.broadcast_arrays(*(np.asarray(v) for v in (m_per_length, rho_I, EI, kGA)))
    p = 12.0 * EI / (kGA * l**2)
    t11 = 13 / 35 + 7 * p / 10 + p**2 / 3
    t12 = (11 / 210 + 11 * p / 120 + p**2 / 24) * l
    t13 = 9 / 70 + 3 * p / 10 + p**2 / 6
    t14 = (13 / 420 + 3 * p / 40 + p**2 / 24) * l
    t22 = (1 / 105 + p / 60 + p**2 / 120) * l**2
    t24 = (1 / 140 + p / 60 + p**2 / 120) * l**2
    mt = _matrix4([[t11, t12, t13, -t14], [t12, t22, t14, -t24],
                   [t13, t14, t11, -t12], [-t14, -t24, -t12, t22]]) * (m * l / (1 + p) ** 2)[..., None, None]
    r11 = 6 / 5
    r12 = (1 / 10 - p / 2) * l
    r22 = (2 / 15 + p / 6 + p**2 / 3) * l**2
    r24 = (-1 / 30 - p / 6 + p**2 / 6) * l**2
    mr = _matrix4([[r11, r12, -r11, r12], [r12, r22, -r12, r24],
                   [-r11, -r12, r11, -r12], [r12, r24, -r12, r22]]) * (rho_I / (l * (1 + p) ** 2))[..., None, None]
    return mt + mr


def hermite_row(x_m, node_x):
    """Cubic (Hermite) interpolation of the translation at ``x_m`` from all node DOFs.

    Returns the row ``N`` (over ``[1:y, 1:rz, 2:y, ...]``) with ``w(x) = N u`` and
    the row ``N'`` with ``w'(x) = N' u``.

    Parameters
    ----------
    x_m : float  position along the beam (m), within ``[node_x[0], node_x[-1]]``
    node_x : ndarray, shape (n_nodes,)  equally or unequally spaced node positions (m)

    Returns
    -------
    N, dN : ndarray, shape (2 n_nodes,)
    """
    node_x = np.asarray(node_x, dtype=float)
    if not node_x[0] - 1e-12 <= x_m <= node_x[-1] + 1e-12:
        raise BeamDamageError(f"position {x_m} m lies outside the beam [{node_x[0]}, {node_x[-1]}] m")
    e = int(np.clip(np.searchsorted(node_x, x_m, side="right") - 1, 0, node_x.size - 2))
    le = node_x[e + 1] - node_x[e]
    s = (x_m - node_x[e]) / le
    n = np.array([1 - 3 * s**2 + 2 * s**3, le * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, le * (-s**2 + s**3)])
    dn = np.array([-6 * s + 6 * s**2, le * (1 - 4 * s + 3 * s**2), 6 * s - 6 * s**2, le * (-2 * s + 3 * s**2)]) / le
    N = np.zeros(2 * node_x.size)
    dN = np.zeros(2 * node_x.size)
    N[2 * e:2 * e + 4] = n
    dN[2 * e:2 * e + 4] = dn
    return N, dN


def point_mass_matrix(node_x, mass_kg, x_m, J_kg_m2=0.0) -> np.ndarray:
    """Mass matrix of a point mass with rotary inertia at ``x_m``, over all node DOFs (``added_mass``).

    ``mass_kg N N^T + J_kg_m2 N' N'^T`` with the Hermite rows of :func:`hermite_row`.

    Returns
    -------
    ndarray, shape (2 n_nodes, 2 n_nodes)   (kg, kg m, kg m^2)
    """
    N, dN = hermite_row(x_m, node_x)
    return mass_kg * np.outer(N, N) + J_kg_m2 * np.outer(dN, dN)


def dashpot_matrix(node_x, c_Ns_m, x_m) -> np.ndarray:
    """Damping matrix ``c N N^T`` of a dashpot to ground at ``x_m``, over all node DOFs (``local_damping``).

    Returns
    -------
    ndarray, shape (2 n_nodes, 2 n_nodes)   (N s/m ...)
    """
    N, _ = hermite_row(x_m, node_x)
    return c_Ns_m * np.outer(N, N)


def interpolation_matrix(model: fem.FEModel, x_m) -> np.ndarray:
    """Matrix ``T`` (n_points, n_model_dofs) with ``w(x_m) = T u`` over the model's free DOFs."""
    all_names = fem.dof_names(model.node_x.size)
    keep = [all_names.index(d) for d in model.dofs]
    return np.array([hermite_row(float(x), model.node_x)[0][keep] for x in np.atleast_1d(x_m)])


# ---------------------------------------------------------------------------
# Assembly with effects
# ---------------------------------------------------------------------------

def _in_order(eff: dict, stage: str) -> list:
    """The keys of ``eff`` whose effect enters at ``stage``, in :data:`EFFECTS` order (instances in key order)."""
    return [k for name in EFFECTS if EFFECTS[name].stage == stage for k in eff if effect_of(k) == name]


def assemble_beam(length_m, EI_Nm2, mass_per_length_kg_m, n_elements, *, bc=THESIS_SUPPORT,
                  thickness_m=None, effects=None) -> fem.FEModel:
    """A uniform beam of ``n_elements`` equal elements with every effect applied.

    Parameters
    ----------
    length_m : float  free (cantilever) length (m)
    EI_Nm2 : float  flexural rigidity (N m^2)
    mass_per_length_kg_m : float  (kg/m)
    n_elements : int
    bc : str  one of :data:`physics.supports.SUPPORTS`
    thickness_m : float, optional
        Section depth ``h`` (m) for the default rotary inertia ``m h^2 / 12``.
    effects : mapping, optional
        ``{effect key: {parameter: value}}`` (module docstring; several instances of a point effect keyed by
        :func:`instance_key`).

    Returns
    -------
    FEModel
        ``C`` holds proportional plus local damping (zeros without them).
    """
    eff = validate_effects(effects)
    check_supports(eff, bc)
    n_el = fem.check_n_elements(n_elements)
    for name, v in (("length_m", length_m), ("EI_Nm2", EI_Nm2), ("mass_per_length_kg_m", mass_per_length_kg_m)):
        if not (np.isfinite(v) and v > 0):
            raise BeamDamageError(f"{name} must be a positive finite number, got {v}")
    le = length_m / n_el
    m = float(mass_per_length_kg_m)
    parts = _Parts(length_m, bc, None if thickness_m is None else m * thickness_m**2 / 12.0)
    for key in _in_order(eff, "element"):
        EFFECTS[effect_of(key)].apply(parts, eff[key])
    ke = timoshenko_stiffness(EI_Nm2, parts.kga, le)
    me = timoshenko_mass(m, parts.rho_i, EI_Nm2, parts.kga, le)
    parts.K = fem.assemble(np.broadcast_to(ke, (n_el, 4, 4)))
    parts.M = fem.assemble(np.broadcast_to(me, (n_el, 4, 4)))
    parts.C = np.zeros_like(parts.K)
    parts.node_x = np.linspace(0.0, length_m, n_el + 1)
    names = fem.dof_names(n_el + 1)
    parts.removed = set(fem.constrained_dofs(bc, n_el + 1))
    for key in _in_order(eff, "assembled"):
        EFFECTS[effect_of(key)].apply(parts, eff[key])
    M, K, C, node_x, removed = parts.M, parts.K, parts.C, parts.node_x, parts.removed
    keep = np.array([i for i, d in enumerate(names) if d not in removed], int)
    if keep.size == 0:
        raise BeamDamageError(f"n_elements {n_el} on a {bc} beam: its supports hold every DOF; at least 2 elements "
                              "are needed", parameter="n_elements")
    sel = np.ix_(keep, keep)
    return fem.FEModel(M=M[sel], K=K[sel], C=C[sel], dofs=tuple(names[i] for i in keep), node_x=node_x)
