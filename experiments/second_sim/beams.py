"""A catalogue of beams unlike the thesis's, and specimen pairs of each as a test system writes them.

Each :class:`CatalogueBeam` has its support (clamped-free, free-free, pinned-pinned, clamped-clamped),
material, section, sensors (1 to 12, anywhere; the drive point is one of them) and band (the nominal beam's
first ``n_modes`` bending modes). :data:`TEST_AS_RUN` holds tests that differ from what a usual beam file says:
the force where no sensor is (``drive_x_over_L``; the files' reference node is then a geometry node after the
sensors'), a beam file that names no drive point (``file_drive``), one file kind throughout (``kind``), a point
mass on the beam (``mass``, stated in the beam file as ``added_mass``), files without node geometry
(``geometry``) and a band of its own (``band``). :func:`beam_toml` writes its beam file in the project's format
(the TOML text is written here: nothing of the project is imported). :func:`simulate_beam_pairs` draws specimen pairs:

* specimen: EI within +-5 %, mass per length within +-3 %, modal damping ratios drawn per mode (the
  material's range);
* supports as built: a clamp is a rotational spring ``k L / EI`` log-uniform in [200, 2000]; a pinned end a
  bearing rotational spring, none on half the specimens and ``k L / EI`` log-uniform in [0.01, 0.1] on the
  others; a free-free beam hangs on two translational springs at its ends, the bounce mode at 2-8 % of the
  first bending frequency;
* between the two test days: temperature (EI +-0.4 %), re-clamping (clamp springs +-8 %), re-seating the
  bearings (+-20 %) or re-hanging the suspension (+-20 %);
* damaged on ~2/3 of the pairs: one slit (centre anywhere on the beam, between sensors too; width 1-10 mm, EI
  loss 30-90 %), redrawn until it lowers some mode of the band by >= 0.2 % on its own;
* measurement by accelerometers: noise on the accelerance, 0.5-2 % of ``|A|`` (log-uniform), a floor 2e-4 of
  each response's peak ``|A|`` and an H1 bias up to 2 %; each file is written as receptance, mobility or
  accelerance (cycling over the files; the exported quantity is the accelerance divided by ``(i w)^k``).

Files per beam: ``beam.toml``, ``pair-KKK_baseline.uff``, ``pair-KKK_current.uff`` (datasets 164, 15, 58:
node numbers in the beam file's sensor order, the drive point next when no sensor is there, coordinates in mm; a
beam with one geometry node also has its two ends as unmeasured geometry nodes, the line a test engineer draws,
since one point defines no beam axis),
``truth.csv`` and ``truth.json``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.linalg

from experiments.second_sim.fem import N_ELEMENTS, Beam, PointMass, Slit, assemble, mesh_elements, modes
from experiments.second_sim.response import Damping, Noise, measure, receptance
from experiments.second_sim.writers import KINDS, write_csv, write_json, write_text_atomic, write_uff

__all__ = ["CATALOGUE", "MATERIALS", "SPREAD", "SUPPORTS", "TEST_AS_RUN", "BeamPair", "CatalogueBeam", "Spread",
           "beam_toml", "default_zones", "excited_modes", "nominal_beam", "simulate_beam_pairs", "write_beam_pairs"]


#: Young's modulus (Pa), density (kg/m^3) and modal damping-ratio range of each material.
MATERIALS = {
    "steel": (210e9, 7850.0, (0.003, 0.012)),
    "aluminium": (70e9, 2700.0, (0.003, 0.012)),
    "pvc": (3.2e9, 1400.0, (0.01, 0.025)),
    "gfrp": (25e9, 1900.0, (0.005, 0.015)),
    "cfrp": (70e9, 1550.0, (0.004, 0.012)),
}

#: End conditions (root at x = 0, tip at x = L) of each support.
SUPPORTS = {"clamped-free": ("clamped", "free"), "free-free": ("free", "free"),
            "pinned-pinned": ("pinned", "pinned"), "clamped-clamped": ("clamped", "clamped")}


@dataclass(frozen=True)
class CatalogueBeam:
    """One beam of the catalogue; positions are fractions of the length (exact nodes of a uniform mesh)."""

    name: str
    bc: str
    material: str
    length_m: float
    width_m: float
    thickness_m: float
    sensors_x_over_L: tuple
    drive_sensor: int
    n_modes: int
    drive_x_over_L: float | None = None    # the force where no sensor is (then ``drive_sensor`` is not used)
    file_drive: bool = True                # the beam file states ``drive_x_m`` (else the files' geometry alone)
    kind: str | None = None                # every file written as this kind (None: cycling over KINDS)
    mass: tuple | None = None              # ``(x_over_L, mass_kg)``: a point mass on the beam (in the beam file)
    geometry: bool = True                  # the files carry node geometry (datasets 15)
    band: tuple | None = None              # the band measured (Hz); None: around the ``n_modes`` modes

    @property
    def EI_Nm2(self) -> float:
        return MATERIALS[self.material][0] * self.width_m * self.thickness_m ** 3 / 12

    @property
    def mass_per_length_kg_m(self) -> float:
        return MATERIALS[self.material][1] * self.width_m * self.thickness_m

    @property
    def sensors_x_m(self) -> tuple:
        return tuple(self.length_m * r for r in self.sensors_x_over_L)

    @property
    def drive_x_m(self) -> float:
        if self.drive_x_over_L is not None:
            return self.length_m * self.drive_x_over_L
        return self.sensors_x_m[self.drive_sensor]

    @property
    def drive_off_sensors(self) -> bool:
        return self.drive_x_over_L is not None

    @property
    def point_masses(self) -> tuple:
        return () if self.mass is None else (PointMass(self.length_m * self.mass[0], self.mass[1]),)

    @property
    def symmetric(self) -> bool:
        """Supports that are their own mirror image about midspan."""
        return SUPPORTS[self.bc][0] == SUPPORTS[self.bc][1]

    @property
    def n_elements(self) -> int:
        points = (*self.sensors_x_m, self.drive_x_m, *(m.x_m for m in self.point_masses))
        return mesh_elements(self.length_m, points, max(N_ELEMENTS, 16 * (self.n_modes + 2)))


CATALOGUE = (
    CatalogueBeam("steel-girder-pp-1s", "pinned-pinned", "steel", 2.0, 0.05, 0.02, (0.375,), 0, 5),
    CatalogueBeam("al-strip-cf-3s", "clamped-free", "aluminium", 0.3, 0.025, 0.003, (1 / 3, 2 / 3, 1.0), 2, 4),
    CatalogueBeam("steel-bar-ff-12s", "free-free", "steel", 1.2, 0.03, 0.008,
                  (0.0, *(k / 11 for k in range(1, 11)), 1.0), 0, 6),
    CatalogueBeam("pvc-bar-cc-5s", "clamped-clamped", "pvc", 0.8, 0.04, 0.012, (0.15, 0.3, 0.5, 0.65, 0.85), 0, 5),
    CatalogueBeam("gfrp-strip-ff-4s", "free-free", "gfrp", 0.6, 0.05, 0.006, (0.35, 0.1, 0.9, 0.6), 1, 4),
    CatalogueBeam("al-beam-pp-6s", "pinned-pinned", "aluminium", 3.0, 0.06, 0.03,
                  tuple(k / 7 for k in range(1, 7)), 1, 5),
    CatalogueBeam("steel-cantilever-cf-8s", "clamped-free", "steel", 1.5, 0.05, 0.01,
                  tuple(k / 8 for k in range(8, 0, -1)), 0, 5),
    CatalogueBeam("cfrp-strip-cc-2s", "clamped-clamped", "cfrp", 0.5, 0.03, 0.004, (0.3, 0.625), 0, 4),
)

#: Tests that differ from what the usual beam file says: the force where no sensor is, at a node of some modes,
#: a drive point the beam file leaves out, one accelerometer with a transfer FRF over a wide band.
TEST_AS_RUN = (
    # 6 accelerometers off the quarter points, the shaker at the tip (no sensor there), mobilities
    CatalogueBeam("al-cantilever-cf-6s-tipforce", "clamped-free", "aluminium", 0.8, 0.04, 0.006,
                  (0.1, 0.3, 0.45, 0.6, 0.7, 0.9), 0, 5, drive_x_over_L=1.0, kind="mobility"),
    # 5 accelerometers, the force at L/3 (a node of modes 3 and 6), receptances; the beam file names no drive point,
    # the files' geometry does
    CatalogueBeam("steel-pp-5s-drive-third", "pinned-pinned", "steel", 1.2, 0.05, 0.01,
                  (0.125, 0.25, 0.5, 0.75, 0.875), 0, 6, drive_x_over_L=1 / 3, file_drive=False, kind="receptance"),
    # an impact test: one accelerometer at the tip, the hammer near the clamp, a mass on the beam, accelerances over
    # a wide band from below mode 1 (23 Hz) past mode 5, no node geometry in the files
    CatalogueBeam("steel-cf-1acc-impact", "clamped-free", "steel", 0.6, 0.03, 0.01, (1.0,), 0, 5,
                  drive_x_over_L=0.15, kind="accelerance", mass=(0.5, 0.1), geometry=False, band=(10.0, 1600.0)),
)


def _ends(bc: str, EI_Nm2: float, length_m: float, clamp_rel=(math.inf, math.inf), pin_rel=(0.0, 0.0),
          suspension_N_m=(0.0, 0.0)) -> dict:
    """Spring keywords of :class:`Beam` for ``bc``: clamps and bearings as ``k L / EI``, suspension in N/m."""
    kw = {}
    for k, (end, side) in enumerate(zip(SUPPORTS[bc], ("root", "tip"))):
        if end == "clamped":
            kw[f"{side}_k_y_N_m"], kw[f"{side}_k_theta_Nm_rad"] = math.inf, clamp_rel[k] * EI_Nm2 / length_m
        elif end == "pinned":
            kw[f"{side}_k_y_N_m"], kw[f"{side}_k_theta_Nm_rad"] = math.inf, pin_rel[k] * EI_Nm2 / length_m
        else:
            kw[f"{side}_k_y_N_m"], kw[f"{side}_k_theta_Nm_rad"] = suspension_N_m[k], 0.0
    return kw


@functools.lru_cache(maxsize=None)
def nominal_beam(cb: CatalogueBeam) -> Beam:
    """The nominal beam on ideal supports (rigid clamps and pins, a free-free beam without suspension)."""
    return Beam(cb.length_m, cb.EI_Nm2, cb.mass_per_length_kg_m, n_elements=cb.n_elements, masses=cb.point_masses,
                **_ends(cb.bc, cb.EI_Nm2, cb.length_m))


def _rigid_modes(bc: str) -> int:
    return 2 if bc == "free-free" else 0


def bending_frequencies_hz(beam: Beam, bc: str, n: int) -> np.ndarray:
    """First ``n`` bending frequencies (Hz), rigid-body modes of a free-free beam left out.

    The lowest eigenvalues of the dense solver alone (relative accuracy ~1e-7 of the first mode's
    ``omega^2``), without the refinement of :func:`fem.modes`: enough for bands and frequency drops."""
    asm = assemble(beam)
    r = _rigid_modes(bc)
    w2 = scipy.linalg.eigh(asm.K, asm.M, eigvals_only=True, subset_by_index=[0, r + n - 1])
    return np.sqrt(np.clip(w2[r:], 0.0, None)) / (2 * math.pi)


def excited_modes(cb: CatalogueBeam, fraction: float = 0.05) -> tuple:
    """Bending modes (1-based, of the first ``n_modes``) of the nominal beam that the force excites: its shape at
    the drive point at least ``fraction`` of its largest translation along the beam."""
    asm = assemble(nominal_beam(cb))
    md = modes(asm)
    r = _rigid_modes(cb.bc)
    phi = md.phi[:, r:r + cb.n_modes]
    free = asm.translation_dofs([x for x in np.linspace(0.0, cb.length_m, cb.n_elements + 1)
                                 if asm.dof_index[2 * int(round(x / cb.length_m * cb.n_elements))] >= 0])
    at = np.abs(phi[asm.translation_dofs([cb.drive_x_m])[0]]) / np.abs(phi[free]).max(axis=0)
    return tuple(int(k) + 1 for k in np.flatnonzero(at >= fraction))


def _nice(v: float, up: bool) -> float:
    """``v`` rounded (down or up) to 2 significant digits."""
    e = math.floor(math.log10(v)) - 1
    return float(f"{(math.ceil(v / 10.0 ** e) if up else math.floor(v / 10.0 ** e))}e{e}")


@functools.lru_cache(maxsize=None)
def band_hz(cb: CatalogueBeam) -> tuple:
    """The band measured: ``cb.band``, else 0.6 times the first to 1.12 times the ``n_modes``-th nominal bending
    frequency."""
    if cb.band is not None:
        return tuple(map(float, cb.band))
    f = bending_frequencies_hz(nominal_beam(cb), cb.bc, cb.n_modes + 1)
    hi = min(1.12 * f[cb.n_modes - 1], 0.5 * (f[cb.n_modes - 1] + f[cb.n_modes]))
    return _nice(0.6 * f[0], up=False), _nice(hi, up=False)


def frequency_lines_hz(cb: CatalogueBeam) -> np.ndarray:
    """Lines from the band's low to its high end, ``df = hi / 4000`` (Hz)."""
    lo, hi = band_hz(cb)
    df = hi / 4000
    return lo + df * np.arange(int(math.floor((hi - lo) / df)) + 1)


def default_zones(cb: CatalogueBeam) -> tuple:
    """Zone edges (m): the spans between neighbouring sensors (and from each end to the nearest) when that gives
    3 or more zones, else 4 equal spans."""
    L = cb.length_m
    inner = sorted({x for x in cb.sensors_x_m if 1e-9 * L < x < L - 1e-9 * L})
    edges = (0.0, *inner, L)
    return edges if len(edges) >= 4 else tuple(L * k / 4 for k in range(5))


def beam_toml(cb: CatalogueBeam) -> str:
    """The beam file of ``cb`` (project format: SI keys, sensors in the catalogue's order, band)."""
    lo, hi = band_hz(cb)

    def num(v):
        return f"{float(v):.10g}"

    return "\n".join([
        f"# {cb.name}: {cb.material} {cb.bc} beam, {len(cb.sensors_x_m)} sensor(s); written by "
        "experiments.second_sim.beams",
        f'name = "{cb.name}"', f'bc = "{cb.bc}"', f"length_m = {num(cb.length_m)}", f"width_m = {num(cb.width_m)}",
        f"thickness_m = {num(cb.thickness_m)}", f"EI_Nm2 = {num(cb.EI_Nm2)}",
        f"mass_per_length_kg_m = {num(cb.mass_per_length_kg_m)}",
        "measured_x_m = [" + ", ".join(num(x) for x in cb.sensors_x_m) + "]",
        *([f"drive_x_m = {num(cb.drive_x_m)}"] if cb.file_drive else []), f"band_hz = [{num(lo)}, {num(hi)}]",
        *([f"[effects.added_mass]\nmass_kg = {num(cb.mass[1])}\nx_m = {num(cb.length_m * cb.mass[0])}"]
          if cb.mass else []), ""])


@dataclass(frozen=True)
class Spread:
    """The distribution of the pairs (module docstring); ranges are ``(lo, hi)``, spreads relative ``+-``."""

    ei: float = 0.05
    mass: float = 0.03
    clamp_k_L_over_EI: tuple = (200.0, 2000.0)
    bearing_k_L_over_EI: tuple = (0.01, 0.1)
    bearing_share: float = 0.5
    bounce_over_f1: tuple = (0.02, 0.08)
    temperature_ei: float = 0.004
    clamp_change: float = 0.08
    bearing_change: float = 0.2
    suspension_change: float = 0.2
    noise_level: tuple = (0.005, 0.02)
    noise_floor: float = 2e-4
    h1_bias: float = 0.02
    damaged_fraction: float = 2 / 3
    min_drop: float = 0.002
    damping_ratio: tuple | None = None     # (lo, hi) of every mode's ratio; None: the material's range
    damage: str = "slit"                   # what a damaged pair's current test has: "slit" or "mass_change"
    mass_added: tuple = (0.01, 0.2)        # a mass added: a point mass of this share of the beam's mass
    mass_lost: tuple = (0.01, 0.08)        # a mass lost: this share of the beam's mass ...
    mass_lost_length: tuple = (0.1, 0.25)  # ... taken evenly off this share of the length (at most half of it)


#: The catalogue pairs' distribution.
SPREAD = Spread()


@dataclass(frozen=True)
class BeamPair:
    """One specimen's two tests of a catalogue beam: receptances (m/N) at the sensors (catalogue order) driven
    at the drive sensor, the kind each file is written as, and the truth."""

    pair: int
    truth: dict
    freq_hz: np.ndarray
    baseline: np.ndarray
    current: np.ndarray
    kinds: tuple


def _loguniform(rng, lo, hi):
    return math.exp(rng.uniform(math.log(lo), math.log(hi)))


#: Points a lost mass is taken off at, evenly over its length.
LOST_POINTS = 24


def _mass_change(rng, cb: CatalogueBeam, beam: Beam, f0_hz: np.ndarray, sp: Spread) -> tuple[tuple, dict, float]:
    """A mass added (half the draws: one point mass of ``sp.mass_added`` of the beam's mass) or lost
    (``sp.mass_lost`` of it taken evenly off a length ``sp.mass_lost_length`` of L, at most half the beam's own
    mass there, as :data:`LOST_POINTS` negative point masses), redrawn until some mode of the band changes by
    ``sp.min_drop`` or more (either sign). Returns the point masses, the truth and the largest change."""
    L = cb.length_m
    beam_kg = beam.mass_per_length_kg_m * L
    for _ in range(1000):
        if rng.random() < 0.5:
            x = rng.uniform(0.0, L)
            ratio, width = rng.uniform(*sp.mass_added), 0.0
            points = (PointMass(x, ratio * beam_kg),)
        else:
            width = rng.uniform(*sp.mass_lost_length) * L
            x = rng.uniform(width / 2, L - width / 2)
            ratio = -min(rng.uniform(*sp.mass_lost), 0.5 * width / L)
            xs = x - width / 2 + (np.arange(LOST_POINTS) + 0.5) * width / LOST_POINTS
            points = tuple(PointMass(float(p), ratio * beam_kg / LOST_POINTS) for p in xs)
        try:
            f = bending_frequencies_hz(replace(beam, masses=beam.masses + points), cb.bc, f0_hz.size)
        except np.linalg.LinAlgError:      # a loss the mass matrix does not hold: drawn again
            continue
        change = float(np.max(np.abs(f / f0_hz - 1)))
        if change >= sp.min_drop:
            return points, {"mass_x_m": x, "mass_ratio": ratio, "mass_kg": ratio * beam_kg, "mass_width_m": width}, \
                change
    raise RuntimeError(f"{cb.name}: no mass change reached the minimum frequency change in 1000 draws")


def _slit(rng, cb: CatalogueBeam, beam: Beam, f0_hz: np.ndarray, min_drop: float) -> tuple[Slit, float]:
    for _ in range(1000):
        w = rng.uniform(1e-3, 10e-3)
        x = rng.uniform(w / 2, cb.length_m - w / 2)
        s = Slit(x_m=x, width_m=w, ei_loss_fraction=rng.uniform(0.3, 0.9))
        drop = float(np.max(1 - bending_frequencies_hz(replace(beam, slits=(s,)), cb.bc, f0_hz.size) / f0_hz))
        if drop >= min_drop:
            return s, drop
    raise RuntimeError(f"{cb.name}: no slit reached the minimum frequency drop in 1000 draws")


@functools.lru_cache(maxsize=None)
def _nominal_f1_hz(cb: CatalogueBeam) -> float:
    return float(bending_frequencies_hz(nominal_beam(cb), cb.bc, 1)[0])


def _specimen(cb: CatalogueBeam, rng, sp: Spread) -> tuple[Beam, dict]:
    """A specimen on its supports as built, and the drawn support parameters."""
    EI = cb.EI_Nm2 * (1 + rng.uniform(-sp.ei, sp.ei))
    m = cb.mass_per_length_kg_m * (1 + rng.uniform(-sp.mass, sp.mass))
    clamp = tuple(_loguniform(rng, *sp.clamp_k_L_over_EI) for _ in range(2))
    pin = tuple(_loguniform(rng, *sp.bearing_k_L_over_EI) for _ in range(2)) if rng.random() < sp.bearing_share \
        else (0.0, 0.0)
    bounce = rng.uniform(*sp.bounce_over_f1)
    f1 = _nominal_f1_hz(cb)
    k_susp = 0.5 * m * cb.length_m * (2 * math.pi * bounce * f1) ** 2 if cb.bc == "free-free" else 0.0
    beam = Beam(cb.length_m, EI, m, n_elements=cb.n_elements, masses=cb.point_masses,
                **_ends(cb.bc, EI, cb.length_m, clamp, pin, (k_susp, k_susp)))
    return beam, {"EI_Nm2": EI, "mass_per_length_kg_m": m, "clamp_k_L_over_EI": list(clamp),
                  "bearing_k_L_over_EI": list(pin), "suspension_bounce_over_f1": bounce if k_susp else None,
                  "suspension_k_N_m": k_susp}


def _next_day(cb: CatalogueBeam, beam: Beam, rng, sp: Spread) -> tuple[Beam, dict]:
    """The specimen on the second test day: temperature, and the supports re-made."""
    temp = 1 + rng.uniform(-sp.temperature_ei, sp.temperature_ei)
    kw, factors = {"EI_Nm2": beam.EI_Nm2 * temp}, {"temperature_ei_factor": temp}
    for side in ("root", "tip"):
        end = SUPPORTS[cb.bc][0 if side == "root" else 1]
        name = f"{side}_k_y_N_m" if end == "free" else f"{side}_k_theta_Nm_rad"
        spread = {"clamped": sp.clamp_change, "pinned": sp.bearing_change, "free": sp.suspension_change}[end]
        f = 1 + rng.uniform(-spread, spread)
        kw[name] = getattr(beam, name) * f
        factors[f"{side}_support_factor"] = f
    return replace(beam, **kw), factors


def _measured_receptance(H: np.ndarray, freq_hz: np.ndarray, noise: Noise, rng) -> np.ndarray:
    """Receptance (m/N) of a test measured by accelerometers: the noise acts on the accelerance ``-w^2 H``."""
    w2 = (2 * math.pi * np.asarray(freq_hz)) ** 2
    return measure(-w2 * H, noise, rng) / -w2


def simulate_pair(cb: CatalogueBeam, pair: int, rng: np.random.Generator, sp: Spread = SPREAD) -> BeamPair:
    """Draw one specimen of ``cb`` (and a slit, if damaged) and simulate its two tests (module docstring)."""
    freq_hz = frequency_lines_hz(cb)
    specimen, support = _specimen(cb, rng, sp)
    zeta = MATERIALS[cb.material][2] if sp.damping_ratio is None else sp.damping_ratio
    damping = Damping("modal", tuple(rng.uniform(*zeta, _rigid_modes(cb.bc) + cb.n_modes + 2)))
    damaged = bool(rng.random() < sp.damaged_fraction)
    f_base = bending_frequencies_hz(specimen, cb.bc, cb.n_modes)
    slit, drop, lost, mass = None, 0.0, (), None
    if damaged and sp.damage == "mass_change":
        lost, mass, drop = _mass_change(rng, cb, specimen, f_base, sp)
    elif damaged:
        slit, drop = _slit(rng, cb, specimen, f_base, sp.min_drop)
    current, day = _next_day(cb, specimen, rng, sp)
    current = replace(current, slits=(slit,) if slit else (), masses=current.masses + lost)
    noise = Noise(_loguniform(rng, *sp.noise_level), sp.noise_floor, rng.uniform(0.0, sp.h1_bias))
    H, f_true = [], []
    for beam in (specimen, current):
        asm = assemble(beam)
        md = modes(asm)
        dofs = asm.translation_dofs(cb.sensors_x_m)
        drive = asm.translation_dofs([cb.drive_x_m])[0]
        H.append(_measured_receptance(receptance(asm, md, damping, freq_hz, dofs, drive), freq_hz, noise, rng))
        f_true.append(md.frequencies_hz[_rigid_modes(cb.bc):_rigid_modes(cb.bc) + cb.n_modes])
    kinds = tuple(cb.kind or list(KINDS)[(2 * pair + day_k) % 3] for day_k in range(2))
    L = cb.length_m
    zones = np.asarray(default_zones(cb))
    truth = {
        "pair": pair, "beam": cb.name, "bc": cb.bc, "damaged": damaged, "intact": not damaged,
        "slit_x_m": slit.x_m if slit else None, "slit_x_over_L": slit.x_m / L if slit else None,
        "slit_x_folded_m": min(slit.x_m, L - slit.x_m) if slit else None,
        "zone": int(np.clip(np.searchsorted(zones, slit.x_m, side="right"), 1, zones.size - 1)) if slit else None,
        "width_m": slit.width_m if slit else None, "ei_loss_fraction": slit.ei_loss_fraction if slit else None,
        "hinge_flexibility": slit.hinge_flexibility(L) if slit else 0.0,
        "damage_kind": (sp.damage if damaged else None),
        "damage_x_m": slit.x_m if slit else (mass["mass_x_m"] if mass else None),
        "damage_size": slit.hinge_flexibility(L) if slit else (mass["mass_ratio"] if mass else 0.0),
        **(mass or {}),
        "stiffness_loss_Nm3": slit.stiffness_loss_Nm3(support["EI_Nm2"]) if slit else 0.0,
        "max_frequency_drop_rel": drop, "noise_level": noise.level, "noise_floor": noise.floor,
        "h1_bias": noise.h1_bias, **day, **support, "length_m": L, "damping_ratios": list(damping.ratios),
        "n_elements": specimen.n_elements, "baseline_kind": kinds[0], "current_kind": kinds[1],
        "baseline_frequencies_hz": [float(v) for v in f_true[0]],
        "current_frequencies_hz": [float(v) for v in f_true[1]],
    }
    return BeamPair(pair, truth, freq_hz, H[0], H[1], kinds)


def simulate_beam_pairs(cb: CatalogueBeam, n: int, seed: int, sp: Spread = SPREAD) -> list[BeamPair]:
    """``n`` pairs of ``cb`` drawn from ``sp``, reproducible from ``seed`` and the beam's place in
    :data:`CATALOGUE` + :data:`TEST_AS_RUN`."""
    every = CATALOGUE + TEST_AS_RUN
    index = next((k for k, c in enumerate(every) if c.name == cb.name), len(every))
    rng = np.random.default_rng([seed, index])
    return [simulate_pair(cb, k, rng, sp) for k in range(n)]


def write_beam_pairs(cb: CatalogueBeam, records: list[BeamPair], out_dir, seed: int | None = None) -> Path:
    """``beam.toml``, the pairs' UFF files, ``truth.csv`` and ``truth.json`` of one beam in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "beam.toml", beam_toml(cb))
    nodes = list(range(1, len(cb.sensors_x_m) + 1))
    geometry_x_m = list(cb.sensors_x_m) + ([cb.drive_x_m] if cb.drive_off_sensors else [])
    ref_node = len(nodes) + 1 if cb.drive_off_sensors else nodes[cb.drive_sensor]
    geometry_x_m += [0.0, cb.length_m] if len(geometry_x_m) == 1 else []
    geometry_nodes = list(range(1, len(geometry_x_m) + 1))
    for r in records:
        for day, H, kind in (("baseline", r.baseline, r.kinds[0]), ("current", r.current, r.kinds[1])):
            write_uff(out / f"pair-{r.pair:03d}_{day}.uff", r.freq_hz, H, geometry_x_m, nodes,
                      ref_node, kind=kind, description=f"second_sim {cb.name} pair {r.pair} {day}",
                      node_numbers=geometry_nodes, geometry=cb.geometry)
    rows = [r.truth for r in records]
    lo, hi = band_hz(cb)
    write_json(out / "truth.json", {
        "beam": cb.name, "bc": cb.bc, "material": cb.material, "length_m": cb.length_m, "width_m": cb.width_m,
        "thickness_m": cb.thickness_m, "EI_Nm2": cb.EI_Nm2, "mass_per_length_kg_m": cb.mass_per_length_kg_m,
        "measured_x_m": list(cb.sensors_x_m), "node_numbers": nodes,
        "geometry_x_m": geometry_x_m if cb.geometry else None, "drive_x_m": cb.drive_x_m,
        "drive_off_sensors": cb.drive_off_sensors, "beam_file_names_drive": cb.file_drive,
        "band_hz": [lo, hi], "n_modes": cb.n_modes, "symmetric": cb.symmetric,
        "zone_edges_m": list(default_zones(cb)), "seed": seed,
        "nominal_frequencies_hz": [float(v) for v in bending_frequencies_hz(nominal_beam(cb), cb.bc, cb.n_modes)],
        "pairs": rows})
    flat = [{k: (";".join(f"{x:.6g}" if x is not None else "" for x in v) if isinstance(v, list) else v)
             for k, v in row.items()} for row in rows]
    write_csv(out / "truth.csv", flat)
    return out
