"""Batched simulation of one shard: truth model -> measured modal data -> Pilkey updating.

Every sample is one specimen tested on two days: state 0 = baseline
(undamaged), state 1 = current (damage, plus what changes between test days:
a global stiffness change from temperature and a re-clamped root spring), so
features can be current-minus-baseline as in the thesis's before/after tests.
All randomness of a batch is drawn up front by :func:`draw_batch` (fixed
order), so the batched path :func:`simulate_batch` and the per-sample path
:func:`datagen.naive.simulate_naive` consume the same numbers.

What is stored is what defines a sample (see :mod:`datagen.store`): the truth
poles and shapes at the measured DOFs, the noisy measured modal data, the
updated ``M, C, K`` with their poles and residues, and a per-sample noise
seed. FRFs are synthesised from those when read (:mod:`datagen.synth`).

Truth model
-----------
Clamped-free Euler-Bernoulli beam of ``mesh.truth_elements`` equal elements
(optionally with a root rotational spring), specimen ``EI`` and mass, the
damage of ``damage.kind`` as element corrections ``(dM, dK, dC)`` of the current
state (:mod:`datagen.damage`); a beam file
(``generate --beam FILE``) adds its effects as described in
:mod:`datagen.truth_beam`. Damping:
``C = C_0 + Delta C_damage`` with the specimen's modal damping
``C_0 = M Phi_p diag(2 zeta_j omega_j) Phi_p^T M`` over the first ``p``
undamped modes of the baseline specimen (``zeta_j`` from
``specimen.damping_ratios`` times the specimen's damping scale, the last ratio
for ``j`` beyond the list; a beam file's Rayleigh damping gives the ratios instead), so the
baseline has exactly the prescribed damping ratios (plus a beam file's dashpot, in both states).

Cheap complex modes (the "projection" shortcut)
-----------------------------------------------
Undamped modes by subspace iteration started from the nominal beam's modes
(batched ``solve`` + Rayleigh-Ritz on ``p x p``), then the damped problem is
projected on those ``p`` modes and solved by a fixed-point iteration that
converges at a rate of order ``zeta`` (light damping). Accuracy against the
full state-space solution is checked in ``tests/datagen/test_pipeline.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import json

import numpy as np

from datagen.config import OUTPUT_ONLY_VARIABLES, REPEATABILITY, calibrated_modal_std, output_only_variables
from datagen.damage import DamageModel, damage_model
from datagen.solvers import light_damping_modes, ritz_modes
from datagen.specimen import BeamPreset, SectionLayout, draw_specimens
from datagen.synth import measured_peak
from physics.beam import preset_beam
from physics.effects import hermite_row
from physics.errors import ConfigError
from physics.properties import beam_preset
from datagen.truth_beam import as_preset, load_truth_beam, point_effects, shear_parameters, unit_elements
from physics.fem import assemble, constrained_dofs, dof_names, element_mass, element_stiffness
from physics.frf import poles_and_residues
from physics.layout import RIGID_BODY_MODES, Layout, layout_of
from physics.modal import eigenvalues_from_modal, modal_parameters, undamped_modes
from physics.updating import analyst_mass, pilkey, reduced_mass

__all__ = ["BatchInputs", "CHUNK", "LABEL_FIELDS", "N_MEAS", "Setup", "build_setup", "draw_batch", "generated_test",
           "get_setup", "measure_modes", "projected_modes", "simulate_batch", "simulate_chunk", "simulate_shard",
           "damage_frequency_drop", "truth_matrices", "unit_mass", "update_models"]

N_MEAS = 4          # measured translational DOFs (thesis nodes 2..5); FRFs are driven at the first


# --------------------------------------------------------------------------- setup
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
    (:func:`physics.updating.reduced_mass`), the supports as the test's (a free-free model on the suspension
    ``suspension_unit`` (1/m^3, for unit EI; default that of :func:`suspension_unit_stiffness`))."""
    L = test.length_m
    xs = np.sort(np.asarray(test.sensors_x_m))
    knots = np.unique(np.concatenate([[0.0, L], xs]))
    nodes = np.concatenate([np.linspace(a, b, per_span + 1)[:-1] for a, b in zip(knots[:-1], knots[1:])] + [[L]])
    le = np.diff(nodes)
    K = assemble(np.stack([element_stiffness(1.0, h) for h in le]))
    M = assemble(np.stack([element_mass(1.0, h) for h in le]))
    last = nodes.size
    removed = constrained_dofs(test.bc, last)
    names = dof_names(last)
    if test.bc == "free-free":
        k_s = suspension_unit_stiffness(L) if suspension_unit is None else suspension_unit
        for d in ("1:y", f"{last}:y"):
            K[names.index(d), names.index(d)] += k_s
    keep = [i for i, d in enumerate(names) if d not in removed]
    kept = [names[i] for i in keep]
    masters = [kept.index(f"{1 + int(np.argmin(np.abs(nodes - x)))}:y") for x in xs]
    return reduced_mass(M[np.ix_(keep, keep)], K[np.ix_(keep, keep)], masters, mass_model)


def suspension_unit_stiffness(length_m: float, bounce_fraction: float = 0.05) -> float:
    """Default suspension of a free-free beam for unit EI (1/m^3), one spring at each end: the bounce mode at
    ``bounce_fraction`` of the first bending frequency (``omega_1 = 22.373 sqrt(EI / (m L^4))``; the bounce
    frequency ``sqrt(2 k / (m L))``, so the mass per length drops out)."""
    return 0.5 * length_m * (bounce_fraction * 22.3733 / length_m**2) ** 2


def generated_test(beam, source: str):
    """The :class:`physics.layout.Layout` of ``beam`` that ``generate`` simulates; ConfigError naming ``source``.
    A reference DOF off the sensors (a hammer where no accelerometer is) gives transfer FRFs only."""
    return layout_of(beam, source)


def _clamp_band(cfg: dict, test, fx: dict, preset) -> tuple:
    """The specimen band of the clamp spring ``k_r L / EI`` (empty: rigid clamps or no clamp); a calibrated root or
    clamp spring is its geometric centre, the config's width kept."""
    band = tuple(cfg["specimen"]["root_spring_relative"]) if test.bc in ("clamped-free", "clamped-clamped") else ()
    if fx["k_theta_Nm_rad"] is not None:
        centre = fx["k_theta_Nm_rad"] * preset.length_m / preset.EI_Nm2
        half = np.sqrt(band[1] / band[0]) if band else 1.0
        band = (centre / half, centre * half)
    for key in ("root_spring_change", "support_change_fraction"):
        if not band and np.any(cfg["specimen"][key]) and test.bc in ("clamped-free", "clamped-clamped"):
            raise ConfigError(f"config key 'specimen.{key}' needs a clamp spring "
                              "('specimen.root_spring_relative' is empty: rigid clamp)")
    return band


def _supports(test, n_el: int, fx: dict, spring: bool, preset):
    """The truth mesh's DOFs and fixed springs under the test's supports.

    Returns ``keep`` (indices of the kept DOFs among all), their names, the fixed springs ``{model index: stiffness
    for unit EI}`` (translational clamp springs, bearing springs, the suspension), the model indices of the clamp
    rotations held by the drawn spring, those of the fixed support springs that change between the test days
    (the suspension, bearing springs), and the suspension for unit EI (None: the default of
    :func:`suspension_unit_stiffness`).
    """
    names = dof_names(n_el + 1)
    last = n_el + 1
    removed = list(constrained_dofs(test.bc, last))
    clamp_rotations = [d for d in ("1:rz", f"{last}:rz") if d in removed]
    if spring:
        removed = [d for d in removed if d not in clamp_rotations]
    clamp_translations = [d.replace(":rz", ":y") for d in clamp_rotations]
    if fx["k_y_N_m"] is not None:  # translational clamp springs: the clamps' translations stay DOFs
        removed = [d for d in removed if d not in clamp_translations]
    keep = np.array([i for i, d in enumerate(names) if d not in removed])
    kept_names = [names[i] for i in keep]
    springs = {}
    if fx["k_y_N_m"] is not None:
        for d in clamp_translations:
            springs[kept_names.index(d)] = fx["k_y_N_m"] / preset.EI_Nm2
    if fx["bearing_k_theta_Nm_rad"] is not None:        # bearing springs on the pinned ends' rotations
        for d in ("1:rz", f"{last}:rz"):
            springs[kept_names.index(d)] = fx["bearing_k_theta_Nm_rad"] / preset.EI_Nm2
    k_suspension = None if fx["suspension_k_y_N_m"] is None else fx["suspension_k_y_N_m"] / preset.EI_Nm2
    if test.bc == "free-free":                          # the suspension (rigid-body modes left out)
        k = suspension_unit_stiffness(test.length_m) if k_suspension is None else k_suspension
        for d in ("1:y", f"{last}:y"):
            springs[kept_names.index(d)] = k
    spring_dofs = np.array([kept_names.index(d) for d in clamp_rotations] if spring else [], int)
    day = [kept_names.index(d) for d in ("1:y", f"{last}:y")] if test.bc == "free-free" else \
        [kept_names.index(d) for d in ("1:rz", f"{last}:rz")] if fx["bearing_k_theta_Nm_rad"] is not None else []
    return keep, kept_names, springs, spring_dofs, np.array(day, int), k_suspension


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
    n_rigid = RIGID_BODY_MODES[test.bc]
    n_el, on_nodes = aligned_elements(test, max(cfg["mesh"]["truth_elements"], 4 * (n_rigid + max(test.modes) + 1)))
    truth = beam if cfg["beam"] else None
    fx = point_effects(truth, n_el)
    damage_model(cfg["damage"]["kind"]).check_beam(cfg["damage"], preset, sec, fx["added_masses"])
    band = _clamp_band(cfg, test, fx, preset)
    spring = bool(band)
    shear_file, rho_ratio, timoshenko = shear_parameters(truth, preset.thickness_m)
    shear_band = tuple(cfg["specimen"]["shear_flexibility"])
    if not test.thesis and shear_file == 0:  # the band describes sandwich cores: a beam file states its own shear
        shear_band = (0.0, 0.0)
    if shear_file > 0:  # the file's shear flexibility is the centre of the specimen band (its width kept)
        half = (shear_band[1] - shear_band[0]) / 2
        shear_band = (max(shear_file - half, 0.0), shear_file + half)
    timoshenko = timoshenko or shear_band[1] > 0
    keep, kept_names, springs, spring_dofs, day_dofs, k_suspension = _supports(test, n_el, fx, spring, preset)
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
    ma = None if test.thesis else analyst_unit_mass(test, cfg["updating"]["mass_model"],
                                                     suspension_unit=k_suspension)
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


# --------------------------------------------------------------------------- randomness
@dataclass(frozen=True)
class BatchInputs:
    """All random draws of a batch of ``B`` samples (see :func:`draw_batch`).

    Specimen: ``EI_Nm2``, ``mass_per_length_kg_m``, ``damping_scale`` (-),
    ``root_spring_Nm_rad`` (``inf`` for a rigid clamp) each (B,). Damage: ``n_damages`` (B,), centres
    ``x_m`` (B, S) NaN-padded and ``damage``, the parameters of the damage model (name -> (B, S),
    its ``draw`` returns). Between the test days (B,):
    ``temperature_stiffness_change`` (relative EI change of the current state)
    and ``root_spring_change`` (relative change of the root spring). Modal
    measurement noise (standard normal, per state): ``n_freq``, ``n_zeta``
    (B, 2, 4), ``n_shape`` (B, 2, 4, 4, 2). FRF noise: ``noise_level`` (relative
    to |H|), ``noise_floor`` (relative to each FRF's peak) and the uint64
    ``noise_seed`` of the counter-based stream the FRF noise is drawn from (B,), and the factor
    ``modal_noise_scale`` on the modal noise's standard deviations (B,); the specimen's
    ``shear_flexibility`` ``EI / (kGA L^2)`` (B,). Repeatability of the tests (B,) each
    (``measurement.*_scatter``): ``frequency_scatter``, ``damping_scatter`` and ``shape_scatter``, stds of
    independent per-mode changes of each test added in quadrature to the modal noise, and ``gain_scatter``, the
    std of each sensor channel's relative gain error per test, with its standard normal draws ``n_gain``
    (B, 2, S) (zeros when ``gain_scatter`` is 0). ``support_changed`` (B,) bool: an intact specimen whose
    supports change between the days beyond re-clamping (``specimen.support_change_fraction``); its
    ``root_spring_change`` is then ``factor - 1`` with the factor drawn from ``specimen.support_change_factor``
    (softer or stiffer alike). Supports without a spring (pinned ends without bearing springs) change none.
    With ``measurement.modal_noise = "output-only"``: ``sensor_noise`` (relative to the response RMS) and
    ``record_length_s`` (s) of each sample's tests (B,), drawn after everything else (None otherwise).
    """

    EI_Nm2: np.ndarray
    mass_per_length_kg_m: np.ndarray
    damping_scale: np.ndarray
    root_spring_Nm_rad: np.ndarray
    n_damages: np.ndarray
    x_m: np.ndarray
    damage: dict
    temperature_stiffness_change: np.ndarray
    root_spring_change: np.ndarray
    n_freq: np.ndarray
    n_zeta: np.ndarray
    n_shape: np.ndarray
    noise_level: np.ndarray
    noise_floor: np.ndarray
    noise_seed: np.ndarray
    modal_noise_scale: np.ndarray
    shear_flexibility: np.ndarray
    frequency_scatter: np.ndarray
    damping_scatter: np.ndarray
    shape_scatter: np.ndarray
    gain_scatter: np.ndarray
    n_gain: np.ndarray
    support_changed: np.ndarray
    sensor_noise: np.ndarray | None = None
    record_length_s: np.ndarray | None = None

    def __len__(self):
        return self.EI_Nm2.shape[0]

    def take(self, i) -> "BatchInputs":
        """Sub-batch by index (slice or array)."""
        def part(k):
            v = getattr(self, k)
            return {p: a[i] for p, a in v.items()} if k == "damage" else None if v is None else v[i]
        return BatchInputs(**{k: part(k) for k in self.__dataclass_fields__})


def _uniform(u, lo_hi, log=False):
    """Uniform (log-uniform when ``log`` and ``lo > 0``) draws in a range ``[lo, hi]``, or a fixed number."""
    lo, hi = (lo_hi, lo_hi) if np.isscalar(lo_hi) else lo_hi
    if lo == hi:
        return np.full(u.shape, float(lo))
    if log and lo > 0:
        return np.exp(np.log(lo) + (np.log(hi) - np.log(lo)) * u)
    return lo + (hi - lo) * u


def draw_batch(rng: np.random.Generator, n: int, setup: Setup) -> BatchInputs:
    """Draw specimens, damage, day-to-day changes and all measurement noise of ``n`` samples, in a fixed order."""
    cfg = setup.cfg
    sp = draw_specimens(rng, n, cfg, setup.preset, setup.root_spring_relative, setup.shear_band)
    dmg = setup.damage.draw(rng, n, cfg, setup)
    S, m = setup.n_meas, setup.n_modes
    nf = rng.standard_normal((n, 2, m))
    nz = rng.standard_normal((n, 2, m))
    ns = rng.standard_normal((n, 2, S, m, 2))
    u = rng.random((n, 4))
    seeds = rng.integers(0, np.iinfo(np.uint64).max, size=n, dtype=np.uint64, endpoint=True)
    u_scale = rng.random(n)
    spc, meas = cfg["specimen"], cfg["measurement"]
    scatter = {k: _uniform(np.zeros(n) if meas[k][0] == meas[k][1] else rng.random(n), meas[k], log=True)
               for k in REPEATABILITY}                                     # one value: not drawn
    n_gain = rng.standard_normal((n, 2, S)) if meas["gain_scatter"][1] > 0 else np.zeros((n, 2, S))
    change = _uniform(u[:, 1], spc["root_spring_change"])
    support = np.zeros(n, bool)
    if spc["support_change_fraction"] > 0 and (setup.spring or setup.day_spring_dofs.size):   # a spring to change
        v = rng.random((n, 3))
        support = (dmg["n_damages"] == 0) & (v[:, 0] < spc["support_change_fraction"])
        factor = _uniform(v[:, 1], spc["support_change_factor"], log=True) ** np.where(v[:, 2] < 0.5, -1, 1)
        change = np.where(support, factor - 1, change)
    if not np.all(np.isfinite(sp["root_spring_Nm_rad"])) and setup.spring:
        raise ConfigError("config key 'specimen.root_spring_relative' gave an infinite spring")
    oma = {}
    if meas["modal_noise"] == "output-only":       # drawn last: the other draws stay those of the other modes
        u_oma = rng.random((n, 2))
        oma = {"sensor_noise": _uniform(u_oma[:, 0], meas["sensor_noise"], log=True),
               "record_length_s": _uniform(u_oma[:, 1], meas["record_length_s"], log=True)}
    return BatchInputs(sp["EI_Nm2"], sp["mass_per_length_kg_m"], sp["damping_scale"], sp["root_spring_Nm_rad"],
                       dmg.pop("n_damages"), dmg.pop("x_m"), dmg,
                       _uniform(u[:, 0], spc["temperature_stiffness_change"]),
                       change, nf, nz, ns,
                       _uniform(u[:, 2], meas["frf_noise"], log=True),
                       _uniform(u[:, 3], meas["frf_noise_floor"], log=True), seeds,
                       _uniform(u_scale, meas["modal_noise_scale"], log=True), sp["shear_flexibility"],
                       *(scatter[k] for k in REPEATABILITY), n_gain, support, **oma)



# --------------------------------------------------------------------------- truth model
def truth_matrices(setup: Setup, inp: BatchInputs):
    """Mass, the stiffness of both test days and the damage's damping of the current state (explicit matrices).

    The current state's stiffness is ``(1 + t) (EI K_0 + dK)`` plus the root
    spring ``k_r (1 + c)`` and its mass ``M + dM``, with ``(dM, dK, dC)`` the
    element corrections of the damage model (:mod:`datagen.damage`), ``t`` the
    temperature stiffness change and ``c`` the re-clamping change. ``M = m M_0``
    plus a beam file's point mass.

    Returns
    -------
    M : ndarray, shape (B, n, n)      baseline mass (kg ...)
    Mu : ndarray                      the same for unit mass per length (:func:`unit_mass`); with a mass
                                      change (B, 2, n, n), state 1 holding ``(M + dM) / m``
    K : ndarray, shape (B, 2, n, n)   N/m ... (state 0 baseline, 1 current)
    dC : ndarray, shape (B, n, n)     damage damping (N s/m ...)
    dK : ndarray, shape (B, n, n)     damage stiffness change (N/m ...)
    """
    ei, mpl = inp.EI_Nm2, inp.mass_per_length_kg_m
    if setup.shear_varies:
        K0, M0, shear_phi = setup.unit_matrices(inp.shear_flexibility)
    else:
        K0, M0, shear_phi = setup.K0, setup.M0, 12.0 * setup.n_elements**2 * setup.shear_band[0]
    dMe, dKe, dCe = setup.damage.corrections(inp.damage, inp.x_m, ei, mpl, setup.length_m, setup.n_elements,
                                             shear_phi)
    shape = (len(inp),) + setup.K0.shape
    dK = np.zeros(shape) if dKe is None else setup.kept(assemble(dKe))
    dC = np.zeros(shape) if dCe is None else setup.kept(assemble(dCe))
    K = np.empty((len(inp), 2) + setup.K0.shape)
    np.multiply(ei[:, None, None], K0, out=K[:, 0])
    np.add(K[:, 0], dK, out=K[:, 1])
    K[:, 1] *= (1.0 + inp.temperature_stiffness_change)[:, None, None]
    if setup.spring:
        r = setup.spring_dofs
        K[:, 1, r, r] += (inp.root_spring_Nm_rad * (1.0 + inp.root_spring_change))[:, None]
        K[:, 0, r, r] += inp.root_spring_Nm_rad[:, None]
    if setup.day_spring_dofs.size:   # the suspension or bearing springs change between the test days
        r = setup.day_spring_dofs
        K[:, 1, r, r] += (ei * inp.root_spring_change)[:, None] * setup.K0_springs[r, r]
    M = mpl[:, None, None] * M0
    if setup.M_added is not None:
        M += setup.M_added
    Mu = unit_mass(setup, inp, M0)
    if dMe is not None:
        base = np.broadcast_to(Mu, (len(inp), 1) + setup.M0.shape)
        Mu = np.concatenate([base, base + (setup.kept(assemble(dMe)) / mpl[:, None, None])[:, None]], axis=1)
    return M, Mu, K, dC, dK


def unit_mass(setup: Setup, inp: BatchInputs, M0):
    """Mass for unit mass per length from the element mass ``M0`` of :func:`truth_matrices` ((n, n) or, with a
    shear flexibility drawn per specimen, (B, n, n)): ``M0`` (n, n), or (B, 1, n, n) with a beam file's point
    mass or per-specimen elements."""
    if setup.M_added is None:
        return M0 if M0.ndim == 2 else M0[:, None]
    return (M0 + setup.M_added / inp.mass_per_length_kg_m[:, None, None])[:, None]


def projected_modes(setup: Setup, inp: BatchInputs, M, Mu, K, dC):
    """Complex modes of both states by the light-damping shortcut (batched).

    Undamped modes by :func:`datagen.solvers.ritz_modes` on the unit-EI,
    unit-mass problem, the baseline specimen's modal damping projected on both
    states' modes plus a beam file's dashpot and the damage damping ``dC``, then
    :func:`datagen.solvers.light_damping_modes`.

    Parameters
    ----------
    M : ndarray, shape (B, n, n)      baseline mass (the specimen's modal damping ``C_0`` is built on it)
    Mu : ndarray                      mass of each state for unit mass per length (:func:`truth_matrices`)
    K : ndarray, shape (B, 2, n, n)   truth stiffness of baseline and current state
    dC : ndarray, shape (B, n, n)     damage damping

    Returns
    -------
    lam : ndarray, complex, shape (B, 2, p)
    psi_meas : ndarray, complex, shape (B, 2, 4, p)   eq.-1.10 shapes at the measured DOFs
    omega2 : ndarray, shape (B, 2, p)                 undamped squared frequencies (rad^2/s^2)
    """
    sol = setup.cfg["solver"]
    ei, mpl = inp.EI_Nm2, inp.mass_per_length_kg_m
    w2s, V = ritz_modes(Mu, K / ei[:, None, None, None], setup.phi0, sol["subspace_iterations"])
    w2 = w2s * (ei / mpl)[:, None, None]
    phi = V / np.sqrt(mpl)[:, None, None, None]                  # (B,2,n,p), phi^T M phi = I
    d = 2 * setup.zeta * np.sqrt(w2[:, 0]) * inp.damping_scale[:, None]     # (B,p)
    X = phi.mT @ (M[:, None] @ phi[:, :1])                      # (B,2,p,p) = Phi_s^T M Phi_baseline
    c = (X * d[:, None, None, :]) @ X.mT
    if setup.C_local is not None:
        c += phi.mT @ setup.C_local @ phi
    c[:, 1] += phi[:, 1].mT @ dC @ phi[:, 1]
    c = 0.5 * (c + c.mT)
    lam, Z = light_damping_modes(w2, c, sol["damping_iterations"])
    at = phi[..., setup.meas, :] if setup.meas.ndim == 1 else setup.meas @ phi
    return lam, at @ Z, w2


def damage_frequency_drop(setup: Setup, inp: BatchInputs, Mu, K, dK, omega2):
    """Largest relative drop of the first four natural frequencies caused by the damage alone.

    Undamped frequencies (subspace iteration). Without day-to-day changes
    that is the drop between the two states' ``omega2`` (B, 2, p); otherwise
    the baseline stiffness plus ``dK`` is solved once more (unit masses ``Mu`` of both states), so
    temperature and re-clamping do not enter this label.

    Returns
    -------
    ndarray, shape (B,)   ``max_r (1 - f_r,damaged / f_r,baseline)`` (>= 0 for a stiffness loss or a mass
                          added; < 0 when every frequency rises, e.g. a mass lost)
    """
    used = setup.modes_idx
    if not setup.day_to_day:
        return np.max(1.0 - np.sqrt(omega2[:, 1, used] / omega2[:, 0, used]), axis=-1)
    Ks = (K[:, 0] + dK) / inp.EI_Nm2[:, None, None]
    K0 = K[:, 0] / inp.EI_Nm2[:, None, None]
    it = setup.cfg["solver"]["subspace_iterations"]
    w2, _ = ritz_modes(Mu, np.stack([K0, Ks], axis=1), setup.phi0, it)
    return np.max(1.0 - np.sqrt(w2[:, 1, used] / w2[:, 0, used]), axis=-1)


# --------------------------------------------------------------------------- measurement + updating
def measure_modes(setup, inp, lam4, psi4):
    """Noisy modal data from noise-free poles (B,2,4) and shapes (B,2,4,4): the modal-noise shortcut.

    Natural frequencies and damping ratios get relative Gaussian errors,
    shapes complex circular errors relative to each mode's largest entry,
    all scaled by the sample's ``modal_noise_scale`` (``measurement.modal_noise_scale``:
    identifications of real files vary beyond what the FRF noise level predicts); each std is
    combined in quadrature with the sample's ``frequency_scatter``, ``damping_scatter`` or
    ``shape_scatter`` (the repeatability of the tests: per-mode changes of each test that
    temperature and re-clamping do not describe), and each sensor's entries are multiplied by
    ``1 + gain_scatter n_gain`` (its channel's gain error in that test, common to its modes).
    The synthesised FRFs carry none of the repeatability terms.
    Standard deviations per mode: ``measurement.frequency_noise`` etc.
    ("fixed"), or ``sqrt((c level)^2 + (g floor)^2 + e^2)`` of the sample's FRF
    noise level and noise floor with the coefficients ``c`` (``*_noise``), ``g``
    (``*_noise_per_floor``) and ``e`` (``*_noise_floor``): "calibrated" against
    the identification ``classify`` runs (``experiments.benches.bench_modal_noise``); "output-only": the same form of
    the sample's sensor noise and record length (:func:`datagen.config.output_only_variables`), calibrated
    against SSI-cov of response records (:mod:`learn.output_only_calibration`).
    """
    mcfg = setup.cfg["measurement"]
    if mcfg["modal_noise"] in ("calibrated", "output-only"):
        coef = {k: per_mode(mcfg[k], setup.n_modes) for q in ("frequency", "damping", "shape")
                for k in (f"{q}_noise", f"{q}_noise_per_floor", f"{q}_noise_floor")}
        x, y = ((inp.noise_level, inp.noise_floor) if mcfg["modal_noise"] == "calibrated"
                else output_only_variables(inp.sensor_noise, inp.record_length_s))
        sig = calibrated_modal_std(coef, np.asarray(x, float)[:, None, None],
                                   np.asarray(y, float)[:, None, None])   # (B, 1, m)
    else:
        sig = {q: per_mode(mcfg[f"{q}_noise"], setup.n_modes) for q in ("frequency", "damping", "shape")}
    scale = np.asarray(inp.modal_noise_scale, float)[:, None, None]
    sig = {q: v * scale for q, v in sig.items()}
    for q in ("frequency", "damping", "shape"):
        sig[q] = np.hypot(sig[q], np.asarray(getattr(inp, f"{q}_scatter"), float)[:, None, None])
    f, z = modal_parameters(lam4)
    f_m = f * (1 + sig["frequency"] * inp.n_freq)
    z_m = z * (1 + sig["damping"] * inp.n_zeta)
    lam_m = eigenvalues_from_modal(f_m, z_m)
    scale = np.max(np.abs(psi4), axis=-2, keepdims=True) * np.expand_dims(sig["shape"], -2)
    noise = (inp.n_shape[..., 0] + 1j * inp.n_shape[..., 1]) / np.sqrt(2)
    gain = 1 + np.asarray(inp.gain_scatter, float)[:, None, None, None] * inp.n_gain[..., None]
    return lam_m, gain * (psi4 + scale * noise)


def per_mode(values, m: int) -> np.ndarray:
    """A number or per-mode list (modes 1, 2, ...) as ``m`` values, the last repeated beyond the list."""
    v = np.atleast_1d(np.asarray(values, float))
    return np.concatenate([v, np.full(max(m - v.size, 0), v[-1])])[:m]


def update_models(setup, Ma, lam_m, psi_m, batched=True):
    """Pilkey updating of both states on the analyst mass ``Ma`` (B,S,S) with ``S`` modes ``lam_m`` (B,2,S) and
    shapes ``psi_m`` (B,2,S,S): returns a dict of (B,2,...) arrays."""
    up = setup.cfg["updating"]
    B, S = Ma.shape[0], Ma.shape[-1]
    Ma2 = np.repeat(Ma[:, None], 2, axis=1).reshape(2 * B, S, S)
    kw = dict(tol=up["tol"], max_iter=up["max_iter"], raise_on_failure=False,
              check_spurious=False)  # modes of the truth mesh are never consistent with the 4-DOF M
    if batched:
        res = pilkey(Ma2, lam_m.reshape(2 * B, S), psi_m.reshape(2 * B, S, S), **kw)
        parts = {k: getattr(res, k) for k in ("C", "K", "converged", "iterations", "residual")}
    else:
        rs = [pilkey(Ma2[i], lam_m.reshape(2 * B, S)[i], psi_m.reshape(2 * B, S, S)[i], **kw)
              for i in range(2 * B)]
        parts = {k: np.stack([np.asarray(getattr(r, k)) for r in rs])
                 for k in ("C", "K", "converged", "iterations", "residual")}
    return {k: v.reshape((B, 2) + v.shape[1:]) for k, v in parts.items()}


#: Samples per vectorised chunk (cache-sized; fixed so results never depend on it).
CHUNK = 128

#: Drawn inputs recorded per sample (the columns of the samples table and the noise of the FRFs on read).
#: The damage model's parameters (``BatchInputs.damage``) are recorded next to them under their own names.
LABEL_FIELDS = ("EI_Nm2", "mass_per_length_kg_m", "damping_scale", "root_spring_Nm_rad", "n_damages", "x_m",
                "temperature_stiffness_change", "root_spring_change", "noise_level", "noise_floor", "noise_seed",
                "modal_noise_scale", "shear_flexibility", *REPEATABILITY, "support_changed")



def simulate_batch(setup: Setup, inp: BatchInputs, chunk: int = CHUNK) -> dict:
    """Batched pipeline for ``B`` samples, in vectorised chunks of ``chunk`` samples (see :func:`simulate_chunk`)."""
    parts = [simulate_chunk(setup, inp.take(slice(i, i + chunk))) for i in range(0, len(inp), chunk)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def simulate_shard(setup: Setup, seed_seq: np.random.SeedSequence, n: int, chunk: int = CHUNK):
    """Draw and simulate ``n`` samples from one shard's seed, chunk by chunk (bounded memory).

    Returns
    -------
    labels : dict of ndarray
        The drawn inputs (fields ``LABEL_FIELDS`` of :class:`BatchInputs`).
    outputs : dict of ndarray (see :func:`simulate_chunk`)
    """
    rng = np.random.default_rng(seed_seq)
    labs, outs = [], []
    for i in range(0, n, chunk):
        b = draw_batch(rng, min(chunk, n - i), setup)
        outs.append(simulate_chunk(setup, b))
        labs.append({**{k: getattr(b, k) for k in LABEL_FIELDS + OUTPUT_ONLY_VARIABLES if getattr(b, k) is not None},
                     **b.damage})
    cat = lambda parts: {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}  # noqa: E731
    return cat(labs), cat(outs)


def simulate_chunk(setup: Setup, inp: BatchInputs) -> dict:
    """Batched pipeline for ``B`` samples (no Python loop over samples or lines).

    Returns
    -------
    dict of ndarray (state axis 1: 0 = baseline, 1 = current)
        ``truth_poles`` (B,2,p) and ``truth_shapes`` (B,2,4,p): all ``p`` projected truth modes at the
        measured DOFs (and at the reference DOF, one more row, when it is no sensor; the measured FRFs are
        synthesised from them), ``eigenvalues_measured`` (B,2,4),
        ``eigenvectors_measured`` (B,2,4,4) (noisy), ``M_updated`` (B,4,4), ``C_updated``, ``K_updated``
        (B,2,4,4), ``updated_poles`` (B,2,4) and ``updated_residues`` (B,2,4,4) of the updated models
        (drive at the first measured DOF), ``frf_peak`` (B,2,4) (:func:`datagen.synth.measured_peak`),
        ``converged``, ``iterations``, ``residual`` (B,2) and ``damage_frequency_drop`` (B,).
    """
    M, Mu, K, dC, dK = truth_matrices(setup, inp)
    lam, psi, w2 = projected_modes(setup, inp, M, Mu, K, dC)
    used = setup.modes_idx
    B, S, d = len(inp), setup.n_meas, setup.drive_row
    lam_m, psi_m = measure_modes(setup, inp, lam[..., used], psi[..., :S, used])
    Ma = setup.analyst_mass(inp.mass_per_length_kg_m)
    if setup.n_update:
        up = update_models(setup, Ma, lam_m[..., :S], psi_m[..., :S])
        pr = poles_and_residues(Ma[:, None], up["C"], up["K"], np.arange(S), [setup.update_drive_row])
        poles, res = pr.eigenvalues, pr.residues[..., 0, :]
    else:  # fewer modes than sensors: no updated model (stated in the manifest)
        nan = np.full((B, 2, S, S), np.nan)
        up = {"C": nan, "K": nan.copy(), "converged": np.ones((B, 2), bool), "iterations": np.zeros((B, 2), int),
              "residual": np.zeros((B, 2))}
        poles, res = np.full((B, 2, S), np.nan + 0j), np.full((B, 2, S, S), np.nan + 0j)
    peak = measured_peak({"truth_poles": lam, "truth_shapes": psi, "drive_row": d, "n_responses": S,
                          "noise_floor": inp.noise_floor}, setup.omega_rad_s)
    return {"has_update": np.full(B, bool(setup.n_update)), "truth_poles_used": lam[..., used],
            "truth_poles": lam, "truth_shapes": psi, "eigenvalues_measured": lam_m, "eigenvectors_measured": psi_m,
            "M_updated": Ma, "C_updated": up["C"], "K_updated": up["K"], "updated_poles": poles,
            "updated_residues": res, "frf_peak": peak,
            "converged": up["converged"], "iterations": up["iterations"],
            "residual": up["residual"], "damage_frequency_drop": damage_frequency_drop(setup, inp, Mu, K, dK, w2)}
