"""What a dataset's batches share: the beam, its test and truth mesh, the supports' springs, the start basis.

:func:`build_setup` turns a validated configuration into a :class:`Setup` (built once per configuration,
:func:`get_setup` caches it): the specimen preset or beam file, the test it describes (:mod:`physics.layout`),
the truth mesh aligned with the sensors, the unit-EI and unit-mass truth matrices on the DOFs the supports keep
with their fixed springs (:mod:`physics.supports`), the measured rows, the nominal modes that start the subspace
iteration and the baseline's modal damping. The batches themselves are drawn by :mod:`datagen.batch_inputs`
and simulated by :mod:`datagen.pipeline`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import json

import numpy as np

from datagen.damage import DamageModel, damage_model
from datagen.specimen import BeamPreset, SectionLayout
from datagen.truth_beam import as_preset, load_truth_beam, point_effects, shear_parameters, unit_elements
from physics.beam import preset_beam
from physics.effects import hermite_row
from physics.errors import ConfigError
from physics.fem import assemble, dof_names, element_mass, element_stiffness
from physics.layout import Layout, layout_of
from physics.modal import undamped_modes
from physics.properties import beam_preset
from physics.supports import add_springs
from physics.updating import analyst_mass, reduced_mass

__all__ = ["MAX_TRUTH_ELEMENTS", "N_MEAS", "SOLID_LIGAMENT_FRACTION", "Setup", "aligned_elements",
           "analyst_unit_mass", "build_setup", "generated_test", "get_setup", "sensor_rows", "slit_section_keys",
           "truth_beam_of"]

N_MEAS = 4          # measured translational DOFs (thesis nodes 2..5); FRFs are driven at the first


@dataclass(frozen=True, eq=False)
class Setup:
    """Everything a batch needs that does not depend on the sample (built once per config).

    Attributes
    ----------
    cfg : dict                      validated configuration
    preset : BeamPreset             the specimen (a preset, or the fields of the beam file ``cfg["beam"]``)
    layout : SectionLayout          face/core layout matching the preset's EI (eq. 4.1)
    n_elements : int                truth mesh
    keep : ndarray (n,)             global DOF indices kept after the boundary condition
    spring : bool                   clamp rotations held by the drawn spring (DOFs ``spring_dofs`` of the model)
    K0, M0 : ndarray (n, n)         truth matrices for unit EI and unit mass per length
    meas : ndarray (S,) or (S, n)   model indices of the measured translations (sensors on nodes), or the rows
                                    interpolating them from the model's DOFs (sensors between nodes)
    phi0 : ndarray (n, p)           nominal modes (unit mass per length), subspace start
    omega_rad_s : ndarray (F,)      FRF lines
    zeta : ndarray (p,)             target modal damping ratios of modes 1..p
    root_spring_relative : tuple    ``(lo, hi)`` band of ``k_r L / EI`` drawn per specimen, or ``()``
    M_added : ndarray (n, n) or None   a beam file's point mass (kg ...), both states
    C_local : ndarray (n, n) or None   a beam file's dashpot (N s/m ...), both states
    shear_band : tuple              ``(lo, hi)`` of the specimen shear flexibility ``EI / (kGA L^2)`` (uniform);
                                    ``K0``, ``M0`` hold its centre; ``lo == hi``: every specimen has those matrices
    rho_i_over_m_m2 : float         rotary inertia per unit mass per length (m^2) of Timoshenko elements
    timoshenko : bool               Timoshenko/Rayleigh elements (else Euler-Bernoulli, eqs. 3.8, 3.9)
    K0_springs : ndarray (n, n)     fixed springs for unit EI in ``K0`` (a beam file's translational clamp springs
                                    and bearing springs, a free-free beam's suspension), zeros without
    test : Layout                   the test (:mod:`physics.layout`): supports, sensors, reference DOF, band, modes
    modes_idx : ndarray (m,)        projected modes used (indices into the ``p`` modes: rigid-body modes and modes
                                    no sensor sees left out)
    drive_row : int                 row of the reference DOF among the rows of ``meas`` (``S`` when it is no
                                    sensor: ``meas`` then holds its row last)
    spring_dofs : ndarray (k,)      model indices of the support rotations held by the drawn spring (``spring``)
    day_spring_dofs : ndarray (j,)  model indices of the fixed support springs (a free-free beam's suspension, a
                                    pinned beam's bearing springs) that change by ``root_spring_change`` between the
                                    test days
    analyst_unit_mass : ndarray (S, S) or None   the analyst's mass for unit mass per length (None: the thesis's)
    added_masses : tuple            ``(x_m, mass_kg)`` of each of the beam file's added masses
    """

    cfg: dict
    preset: BeamPreset
    layout: SectionLayout
    n_elements: int
    keep: np.ndarray
    spring: bool
    K0: np.ndarray
    M0: np.ndarray
    meas: np.ndarray
    phi0: np.ndarray
    omega_rad_s: np.ndarray
    zeta: np.ndarray
    root_spring_relative: tuple = ()
    M_added: np.ndarray | None = None
    C_local: np.ndarray | None = None
    shear_band: tuple = (0.0, 0.0)
    rho_i_over_m_m2: float = 0.0
    timoshenko: bool = False
    K0_springs: np.ndarray | float = 0.0
    test: Layout | None = None
    modes_idx: np.ndarray = field(default_factory=lambda: np.arange(N_MEAS))
    drive_row: int = 0
    spring_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    day_spring_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    analyst_unit_mass: np.ndarray | None = None
    added_masses: tuple = ()

    def analyst_mass(self, mass_per_length_kg_m):
        """The analyst's mass over the sensors (B, S, S) (kg): the thesis's model (``updating.mass_model`` of the
        4-element cantilever), else the nominal truth mesh reduced to the sensors the same way (IIRS or lumped),
        for unit mass per length, times the specimen's."""
        mpl = np.asarray(mass_per_length_kg_m, float)
        if self.analyst_unit_mass is None:
            return analyst_mass(mpl, self.length_m, self.cfg["updating"]["mass_model"])
        return mpl[..., None, None] * self.analyst_unit_mass

    @property
    def n_meas(self) -> int:
        """Measured translations (sensors)."""
        return self.meas.shape[0] - int(self.drive_off_sensors)

    @property
    def drive_off_sensors(self) -> bool:
        """The reference DOF is no sensor: ``meas`` holds its row last, and the measured FRFs are transfer FRFs."""
        return self.test is not None and self.test.drive_sensor is None

    @property
    def update_drive_row(self) -> int:
        """Row of the updated models' reference DOF among the sensors: the reference DOF's, else the nearest
        sensor's (the updated model has the sensors' DOFs only)."""
        if not self.drive_off_sensors:
            return self.drive_row
        return int(np.argmin(np.abs(np.sort(self.test.sensors_x_m) - self.test.drive_x_m)))

    @property
    def n_modes(self) -> int:
        """Modes measured (the modes of the band the sensors see)."""
        return self.modes_idx.size

    @property
    def n_update(self) -> int:
        """Modes the Lancaster/Pilkey update uses: as many as sensors (the lowest of the modes measured), or 0 when
        the band holds fewer modes than there are sensors (then no updated model)."""
        return self.n_meas if self.n_modes >= self.n_meas else 0

    def kept(self, A):
        """The kept-DOF block of full-mesh matrices ``A`` (..., 2N, 2N): a view when the supports remove the first
        DOFs only (a clamp at ``x = 0``), else a copy."""
        k = self.keep
        if k[-1] - k[0] + 1 == k.size:
            return A[..., k[0]:k[-1] + 1, k[0]:k[-1] + 1]
        return A[..., k[:, None], k]

    @property
    def length_m(self) -> float:
        return self.preset.length_m

    @property
    def damage(self) -> DamageModel:
        """The damage model of ``damage.kind`` (:data:`datagen.damage.DAMAGE_MODELS`)."""
        return damage_model(self.cfg["damage"]["kind"])

    @property
    def p(self) -> int:
        return self.phi0.shape[-1]

    @property
    def shear_varies(self) -> bool:
        """Whether the specimens' shear flexibility is drawn (then their unit matrices differ)."""
        return self.shear_band[0] != self.shear_band[1]

    def unit_matrices(self, shear_flexibility):
        """Truth stiffness for unit EI and mass for unit mass per length, and the element shear ratio.

        Parameters
        ----------
        shear_flexibility : float or ndarray, shape (B,)   ``EI / (kGA L^2)``

        Returns
        -------
        K0, M0 : ndarray, shape (n, n) or (B, n, n)   on the kept DOFs (a translational root spring included)
        shear_phi : ndarray, shape () or (B,)         ``12 EI / (kGA l^2)`` of the elements
        """
        K0, M0, phi = _unit_matrices(shear_flexibility, self.rho_i_over_m_m2, self.length_m, self.n_elements,
                                     self.timoshenko)
        K0, M0 = self.kept(K0), self.kept(M0)
        K0 += self.K0_springs
        return K0, M0, phi

    @property
    def day_to_day(self) -> bool:
        """Whether the current state differs from the baseline by more than its damage."""
        sp = self.cfg["specimen"]
        return any(v != 0.0 for k in ("temperature_stiffness_change", "root_spring_change") for v in sp[k])


def _unit_matrices(shear_flexibility, rho_i_over_m_m2, length_m, n_elements, timoshenko):
    """Full-mesh stiffness for unit EI and mass for unit mass per length, and the element shear ratio."""
    ke, me, phi = unit_elements(shear_flexibility, rho_i_over_m_m2, length_m, n_elements, timoshenko)
    K0 = assemble(np.broadcast_to(ke[..., None, :, :], ke.shape[:-2] + (n_elements, 4, 4)))
    M0 = assemble(np.broadcast_to(me[..., None, :, :], me.shape[:-2] + (n_elements, 4, 4)))
    return K0, M0, phi


def truth_beam_of(cfg: dict):
    """The beam of a configuration: the beam file of config key ``beam``, or the preset as a beam."""
    return load_truth_beam(cfg["beam"]) if cfg["beam"] else preset_beam(cfg["preset"])


#: Largest truth mesh (elements) aligned with the sensors.
MAX_TRUTH_ELEMENTS = 400


def aligned_elements(test: Layout, n_min: int) -> tuple[int, bool]:
    """Elements of the uniform truth mesh: the fewest in ``[n_min, 3 n_min]`` with a node at every sensor and at
    the reference DOF (to 1e-6 L), else ``n_min``; and whether they sit on nodes (else their translations are
    interpolated by the elements' cubic shape functions)."""
    x = np.r_[test.sensors_x_m, test.drive_x_m] / test.length_m
    n = np.arange(n_min, min(3 * n_min, MAX_TRUTH_ELEMENTS) + 1)
    off = np.abs(x[None, :] * n[:, None] - np.round(x[None, :] * n[:, None])).max(axis=1) / n
    ok = np.flatnonzero(off <= 1e-6)
    return (int(n[ok[0]]), True) if ok.size else (int(n_min), False)


def sensor_rows(x_m, node_x_m, keep) -> np.ndarray:
    """Interpolation rows (S, n) of the translations at ``x_m`` over the kept DOFs (Hermite cubics)."""
    return np.array([hermite_row(float(x), node_x_m)[0][keep] for x in x_m])


def analyst_unit_mass(test: Layout, mass_model: str, per_span: int = 4, suspension_unit: float | None = None
                      ) -> np.ndarray:
    """The analyst's mass over the sensors for unit mass and unit EI (S, S): an Euler-Bernoulli model with nodes at
    the ends and the sensors, ``per_span`` elements between neighbours, reduced to the sensors' translations
    (:func:`physics.updating.reduced_mass`), the supports as the test's nominal ones
    (:meth:`physics.supports.Support.nominal_unit_stiffness`: a free-free model on the suspension
    ``suspension_unit`` (1/m^3, for unit EI; default :func:`physics.supports.suspension_unit_stiffness`))."""
    L = test.length_m
    xs = np.sort(np.asarray(test.sensors_x_m))
    knots = np.unique(np.concatenate([[0.0, L], xs]))
    nodes = np.concatenate([np.linspace(a, b, per_span + 1)[:-1] for a, b in zip(knots[:-1], knots[1:])] + [[L]])
    le = np.diff(nodes)
    K = assemble(np.stack([element_stiffness(1.0, h) for h in le]))
    M = assemble(np.stack([element_mass(1.0, h) for h in le]))
    last = nodes.size
    sup = test.support
    names = dof_names(last)
    k_s = sup.nominal_unit_stiffness(L, suspension_unit)
    if k_s:
        K = add_springs(K, names, sup.spring_dofs(last), k_s)
    removed = sup.constrained_dofs(last)
    keep = [i for i, d in enumerate(names) if d not in removed]
    kept = [names[i] for i in keep]
    masters = [kept.index(f"{1 + int(np.argmin(np.abs(nodes - x)))}:y") for x in xs]
    return reduced_mass(M[np.ix_(keep, keep)], K[np.ix_(keep, keep)], masters, mass_model)


def generated_test(beam, source: str):
    """The :class:`physics.layout.Layout` of ``beam`` that ``generate`` simulates; ConfigError naming ``source``.
    A reference DOF off the sensors (a hammer where no accelerometer is) gives transfer FRFs only."""
    return layout_of(beam, source)


def _clamp_band(cfg: dict, test, fx: dict, preset) -> tuple:
    """The specimen band of the clamp spring ``k_r L / EI`` (empty: rigid clamps or no clamp); a calibrated root or
    clamp spring is its geometric centre, the config's width kept."""
    clamped = test.support.clamped
    band = tuple(cfg["specimen"]["root_spring_relative"]) if clamped else ()
    if clamped and fx["support_spring"] is not None:
        centre = fx["support_spring"] * preset.length_m / preset.EI_Nm2
        half = np.sqrt(band[1] / band[0]) if band else 1.0
        band = (centre / half, centre * half)
    for key in ("root_spring_change", "support_change_fraction"):
        if not band and np.any(cfg["specimen"][key]) and clamped:
            raise ConfigError(f"config key 'specimen.{key}' needs a clamp spring "
                              "('specimen.root_spring_relative' is empty: rigid clamp)")
    return band


def _supports(test, n_el: int, fx: dict, spring: bool, preset):
    """The truth mesh's DOFs and fixed springs under the test's supports (:mod:`physics.supports`).

    Returns ``keep`` (indices of the kept DOFs among all), their names, the fixed springs ``{model index: stiffness
    for unit EI}`` (a clamp effect's translational springs, the support's own springs where they are fixed: the
    suspension, a beam file's bearing springs), the model indices of the clamp rotations held by the drawn spring
    (``spring``), those of the fixed own springs (they change between the test days), and the beam file's own
    springs for unit EI (None: the nominal ones, :meth:`physics.supports.Support.nominal_unit_stiffness`).
    """
    sup, last, EI = test.support, n_el + 1, preset.EI_Nm2
    names = dof_names(last)
    own = sup.spring_dofs(last)
    clamp_y = sup.end_dofs(last, "clamped", "y") if fx["clamp_k_y_N_m"] is not None else ()
    removed = sup.constrained_dofs(last, (own if spring else ()) + clamp_y)
    keep = np.array([i for i, d in enumerate(names) if d not in removed])
    kept_names = [names[i] for i in keep]
    springs = {kept_names.index(d): fx["clamp_k_y_N_m"] / EI for d in clamp_y}
    file_unit = None if fx["support_spring"] is None or sup.clamped else fx["support_spring"] / EI
    k_own = sup.nominal_unit_stiffness(test.length_m) if file_unit is None else file_unit
    fixed = [kept_names.index(d) for d in own] if k_own else []   # a suspension, bearing springs
    springs.update({r: k_own for r in fixed})
    spring_dofs = np.array([kept_names.index(d) for d in own] if spring else [], int)
    return keep, kept_names, springs, spring_dofs, np.array(fixed, int), file_unit


def _measured_rows(test, n_el: int, on_nodes: bool, keep, kept_names):
    """The sensors' rows (indices of their translations, or interpolation rows between nodes) in ascending
    position, and the reference DOF's row among them; a reference DOF off the sensors is one more row, the last
    (then every row interpolates)."""
    order = np.argsort(test.sensors_x_m, kind="stable")
    xs = np.asarray(test.sensors_x_m)[order]
    if test.drive_sensor is None:
        return sensor_rows(np.r_[xs, test.drive_x_m], np.linspace(0.0, test.length_m, n_el + 1), keep), xs.size
    if on_nodes:
        meas = np.array([kept_names.index(f"{1 + k}:y") for k in np.rint(xs / test.length_m * n_el).astype(int)])
    else:  # the sensors between nodes: their translations interpolated
        meas = sensor_rows(xs, np.linspace(0.0, test.length_m, n_el + 1), keep)
    return meas, int(np.flatnonzero(order == test.drive_sensor)[0])


def _modal_damping(cfg: dict, fx: dict, preset, w, v, M0, K_beam, n_rigid: int, p: int) -> np.ndarray:
    """Baseline modal damping ratios of the first ``p`` modes: the beam file's Rayleigh damping in the nominal
    truth's modes, else the config's ``specimen.damping_ratios`` (the first one for rigid-body modes, the last one
    beyond)."""
    if fx["rayleigh"] is not None:
        alpha, beta = fx["rayleigh"]
        ei_m = preset.EI_Nm2 / preset.mass_per_length_kg_m
        vp = v[:, :p]
        c_diag = alpha * np.einsum("ij,ik,kj->j", vp, M0, vp) + beta * ei_m * np.einsum("ij,ik,kj->j", vp, K_beam, vp)
        zeta = c_diag / (2 * w[:p] * np.sqrt(ei_m))
        if not np.all((zeta > 0) & (zeta < 0.2)):
            raise ConfigError(f"config key 'beam': proportional_damping gives modal damping ratios {zeta.tolist()} "
                              f"of the first {p} modes; generate needs light damping, each in (0, 0.2)")
        return zeta
    zr = np.asarray(cfg["specimen"]["damping_ratios"], float)
    return np.concatenate([np.full(n_rigid, zr[0]), zr, np.full(max(p - zr.size, 0), zr[-1])])[:p]


#: Share of a solid rectangular section's depth a slit leaves at least (the deepest cut: EI loss ``1 - 0.05^3``).
SOLID_LIGAMENT_FRACTION = 0.05


def slit_section_keys(beam) -> dict:
    """The section keys (``face_thickness_m``, ``core_modulus_pa``) a beam file gives the slits' layered section.

    A sandwich's own faces and core; a solid rectangle is one material (the "core" as stiff as the "faces", whose
    modulus :class:`datagen.specimen.SectionLayout` solves from ``EI``), cut down to a ligament of
    :data:`SOLID_LIGAMENT_FRACTION` of its depth; other sections keep the config's.
    """
    if beam.section == "rectangular":
        h = beam.thickness_m
        return {"face_thickness_m": SOLID_LIGAMENT_FRACTION * h,
                "core_modulus_pa": beam.EI_Nm2 / (beam.width_m * h**3 / 12)}
    return {k: getattr(beam, k) for k in ("face_thickness_m", "core_modulus_pa") if getattr(beam, k) is not None}


def build_setup(cfg: dict) -> Setup:
    """Precompute the nominal truth matrices, measured DOFs, start basis and FRF grid."""
    beam = truth_beam_of(cfg)
    test = generated_test(beam, "config key 'beam'" if cfg["beam"] else f"preset {cfg['preset']!r}")
    preset = as_preset(beam) if cfg["beam"] else beam_preset(cfg["preset"])
    sec = dict(cfg["section"])
    if cfg["beam"]:  # the beam file's section, where it gives one
        sec.update(slit_section_keys(beam))
    section = SectionLayout.matching(preset.EI_Nm2, preset.width_m, preset.thickness_m, sec["face_thickness_m"],
                                 sec["core_modulus_pa"])
    n_rigid = test.support.rigid_body_modes
    n_el, on_nodes = aligned_elements(test, max(cfg["mesh"]["truth_elements"], 4 * (n_rigid + max(test.modes) + 1)))
    truth = beam if cfg["beam"] else None
    fx = point_effects(truth, n_el)
    damage_model(cfg["damage"]["kind"]).check_beam(cfg["damage"], preset, sec, fx["added_masses"])
    band = _clamp_band(cfg, test, fx, preset)
    spring = bool(band)
    shear_file, rho_ratio, timoshenko = shear_parameters(truth, preset.thickness_m)
    shear_band = tuple(cfg["specimen"]["shear_flexibility"])
    sandwich = truth is None or truth.section == "sandwich"
    if not (test.thesis and sandwich) and shear_file == 0:  # the band describes the thesis's soft core: another
        shear_band = (0.0, 0.0)                             # beam (a solid section, another test) states its own
    if shear_file > 0:  # the file's shear flexibility is the centre of the specimen band (its width kept)
        half = (shear_band[1] - shear_band[0]) / 2
        shear_band = (max(shear_file - half, 0.0), shear_file + half)
    timoshenko = timoshenko or shear_band[1] > 0
    keep, kept_names, springs, spring_dofs, day_dofs, k_file = _supports(test, n_el, fx, spring, preset)
    K_full, M_full, _ = _unit_matrices(0.5 * (shear_band[0] + shear_band[1]), rho_ratio, preset.length_m, n_el,
                                       timoshenko)  # the beam elements alone
    sel = np.ix_(keep, keep)
    K_beam, M0 = K_full[sel], M_full[sel]
    K_springs = np.zeros_like(K_beam)
    for r, k in springs.items():
        K_springs[r, r] = k
    K0 = K_beam + K_springs  # plus the fixed springs (Rayleigh damping acts on the beam, not on them)
    M_added = None if fx["M_added"] is None else fx["M_added"][sel]
    C_local = None if fx["C_local"] is None else fx["C_local"][sel]
    meas, drive_row = _measured_rows(test, n_el, on_nodes, keep, kept_names)
    modes_idx = n_rigid + np.asarray(test.modes) - 1
    p = max(cfg["solver"]["projection_modes"], int(modes_idx[-1]) + 1 + (4 if not test.thesis else 0))
    Kn = K0.copy()
    if spring:
        Kn[spring_dofs, spring_dofs] += np.sqrt(band[0] * band[1]) / preset.length_m
    Mn = M0 if M_added is None else M0 + M_added / preset.mass_per_length_kg_m
    w, v = undamped_modes(Mn, Kn)
    zeta = _modal_damping(cfg, fx, preset, w, v, M0, K_beam, n_rigid, p)
    lo, hi = cfg["measurement"]["band_rad_s"] if test.thesis else 2 * np.pi * np.asarray(test.band_hz)
    ma = None if test.thesis else analyst_unit_mass(test, cfg["updating"]["mass_model"], suspension_unit=k_file)
    return Setup(cfg, preset, section, n_el, keep, spring, K0, M0, meas, v[:, :p].copy(),
                 np.linspace(lo, hi, cfg["measurement"]["lines"]), zeta, band, M_added, C_local,
                 shear_band, rho_ratio, timoshenko, K_springs, test, modes_idx, drive_row, spring_dofs, day_dofs, ma,
                 fx["added_masses"])


@lru_cache(maxsize=8)
def _setup_cached(cfg_json: str) -> Setup:
    return build_setup(json.loads(cfg_json))


def get_setup(cfg: dict) -> Setup:
    """Cached :func:`build_setup` (keyed by the configuration's JSON)."""
    return _setup_cached(json.dumps(cfg, sort_keys=True))

