"""A monitoring series of one cantilever: a test a day over a year, the environment changing, a slit appearing.

The beam is a steel cantilever (0.8 m, 40 x 8 mm) clamped by a rotational root spring (``k L / EI = 150``) with a
bolted mass (2 % of the beam's mass) at ``0.75 L``, accelerometers at ``L/3, 2L/3, L`` (configurable). Each test
of :func:`simulate_series` draws

* the temperature: a seasonal sine (coldest on ``coldest_day``) plus a day-to-day random part; the beam's ``EI``
  follows it linearly, ``EI = EI_0 (1 + dEI/dT (T - T_mean))`` (about +-1 % over the year), and a temperature
  sensor reads it with Gaussian noise (``conditions.csv``);
* re-mounting: the root spring times ``1 + U(-remount, remount)``;
* the removable mass re-placed ``U(-mass_shift_m, mass_shift_m)`` around its nominal place;
* modal damping ratios scattering by a few % from test to test;
* from ``damage_day`` on, a slit at ``slit_x_over_L`` (width, EI loss: its size); optionally a second slit whose EI
  loss grows linearly from ``growth_day`` to the end of the series.

Each test is written as a test system writes it: FRFs (``kind="frf"``: UFF datasets 164/15/58, accelerance at
the accelerometers from a hammer at ``hammer_x_over_L``, noise on the accelerance) or output-only response records
(``kind="output-only"``: NPZ of acceleration under white random forces at ``ambient_x_over_L``, sensor noise,
:func:`experiments.second_sim.ambient.ambient_record`). :func:`write_series` writes the files, ``conditions.csv``
(``file,time,temperature_c``: the measured temperature), ``truth.json`` (per test: day, true temperature, the
state of the beam, the true frequencies) and the nominal beam's ``beam.toml`` (project format; the root spring and
the mass at their nominal values, ``EI`` at the mean temperature).

:func:`frequency_series` draws long series of identified frequencies alone (a test every 30 min over two years,
a daily temperature cycle and the weather, the clamp and the mass re-made every week, identification scatter and
an imposed lasting drop of one or every mode), the FEM interpolated over the environment's parameters.

Uses only this package's :mod:`.fem`, :mod:`.response`, :mod:`.ambient` and :mod:`.writers`, numpy, scipy and
pyuff.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from experiments.second_sim.ambient import ambient_record, write_npz
from experiments.second_sim.fem import N_ELEMENTS, Beam, PointMass, Slit, assemble, mesh_elements, modes
from experiments.second_sim.response import Damping, Noise, measure, receptance
from experiments.second_sim.writers import write_csv, write_json, write_text_atomic, write_uff
import itertools

__all__ = ["SERIES_KINDS", "SLIT_SIZES", "FrequencySeries", "FrequencySeriesConfig", "SeriesConfig", "SeriesTest",
           "drop_pattern", "frequency_series", "mass_loss_pattern", "nominal_series_beam",
           "uniform_stiffness_pattern", "series_beam_toml",
           "simulate_series", "slit_frequency_drop", "test_beam", "write_series"]

#: The ways a test is recorded.
SERIES_KINDS = ("frf", "output-only")

#: Named slit sizes (EI loss of a 4 mm slit at ``0.15 L``): first-mode drops of about 0.26, 0.74 and 2.4 %
#: (the normal variation of the series: about 0.35 % standard deviation per mode, mostly temperature).
SLIT_SIZES = {"small": 0.3, "medium": 0.55, "large": 0.8}

_START = _dt.datetime(2026, 1, 1, 10, 0)


@dataclass(frozen=True)
class SeriesConfig:
    """A monitoring series (module docstring). Lengths in m, temperatures in degC, positions as fractions of L."""

    n_tests: int = 365
    days: float = 365.0
    seed: int = 0
    kind: str = "frf"
    # the beam
    length_m: float = 0.8
    width_m: float = 0.04
    thickness_m: float = 0.008
    youngs_modulus_pa: float = 210e9
    density_kg_m3: float = 7850.0
    root_k_L_over_EI: float = 150.0
    sensors_x_over_L: tuple = (1 / 3, 2 / 3, 1.0)
    hammer_x_over_L: float = 1.0
    damping_ratios: tuple = (0.008, 0.006, 0.005, 0.005)
    damping_scatter: float = 0.05
    n_modes: int = 4
    min_elements: int = N_ELEMENTS
    # the environment and the handling between tests
    temperature_mean_c: float = 10.0
    temperature_amplitude_c: float = 12.0
    temperature_daily_sd_c: float = 3.0
    temperature_sensor_sd_c: float = 0.3
    coldest_day: float = 15.0
    ei_per_c: float = -8e-4
    remount: float = 0.04
    mass_fraction: float = 0.02
    mass_x_over_L: float = 0.75
    mass_shift_m: float = 0.03
    # measurement
    band_hz: tuple = (5.0, 400.0)
    df_hz: float = 0.25
    noise_level: float = 0.01
    noise_floor: float = 2e-4
    duration_s: float = 60.0
    sampling_frequency_hz: float = 1000.0
    ambient_x_over_L: tuple = (0.5, 1.0)
    sensor_noise: float = 0.02
    coloured: bool = True
    # damage
    damage_day: float | None = 270.0
    slit_x_over_L: float = 0.15
    slit_width_m: float = 0.004
    slit_ei_loss: float = SLIT_SIZES["medium"]
    growth_day: float | None = None
    growth_x_over_L: float = 0.55
    growth_max_ei_loss: float = 0.6

    def __post_init__(self):
        if self.kind not in SERIES_KINDS:
            raise ValueError(f"kind must be one of {', '.join(SERIES_KINDS)}, got {self.kind!r}")
        if self.n_tests < 2 or not self.days > 0:
            raise ValueError(f"n_tests must be >= 2 and days > 0, got {self.n_tests} and {self.days}")
        if not 0 <= self.slit_ei_loss < 1 or not 0 <= self.growth_max_ei_loss < 1:
            raise ValueError("slit_ei_loss and growth_max_ei_loss must be in [0, 1)")
        if not 0 < self.band_hz[0] < self.band_hz[1] or not 0 < self.df_hz < self.band_hz[1] - self.band_hz[0]:
            raise ValueError(f"band_hz must be 0 < lo < hi with df_hz below hi - lo, got {self.band_hz}, {self.df_hz}")

    @property
    def EI_Nm2(self) -> float:
        return self.youngs_modulus_pa * self.width_m * self.thickness_m ** 3 / 12

    @property
    def mass_per_length_kg_m(self) -> float:
        return self.density_kg_m3 * self.width_m * self.thickness_m

    @property
    def mass_kg(self) -> float:
        return self.mass_fraction * self.mass_per_length_kg_m * self.length_m

    @property
    def sensors_x_m(self) -> tuple:
        return tuple(self.length_m * r for r in self.sensors_x_over_L)

    @property
    def freq_hz(self) -> np.ndarray:
        lo, hi = self.band_hz
        return lo + self.df_hz * np.arange(int(math.floor((hi - lo) / self.df_hz + 1e-9)) + 1)

    @property
    def n_elements(self) -> int:
        pts = (*self.sensors_x_m, self.hammer_x_over_L * self.length_m,
               *(r * self.length_m for r in self.ambient_x_over_L))
        return mesh_elements(self.length_m, pts, self.min_elements)


@dataclass(frozen=True)
class SeriesTest:
    """One test of the series: its truth and, for FRF series, the measured receptance (m/N) or, for output-only
    series, the response record."""

    index: int
    truth: dict
    H: np.ndarray | None = None
    record: object = None


def nominal_series_beam(cfg: SeriesConfig) -> Beam:
    """The nominal beam: EI at the mean temperature, nominal root spring, the mass at its nominal place."""
    return Beam(cfg.length_m, cfg.EI_Nm2, cfg.mass_per_length_kg_m, n_elements=cfg.n_elements,
                root_k_theta_Nm_rad=cfg.root_k_L_over_EI * cfg.EI_Nm2 / cfg.length_m,
                masses=(PointMass(cfg.mass_x_over_L * cfg.length_m, cfg.mass_kg),))


def test_beam(cfg: SeriesConfig, truth: dict) -> Beam:
    """The beam of one test from its truth record."""
    nominal = nominal_series_beam(cfg)
    slits = [Slit(s["x_m"], s["width_m"], s["ei_loss_fraction"]) for s in truth["slits"]]
    return replace(nominal, EI_Nm2=cfg.EI_Nm2 * truth["ei_factor"],
                   root_k_theta_Nm_rad=nominal.root_k_theta_Nm_rad * truth["root_spring_factor"],
                   masses=(PointMass(truth["mass_x_m"], cfg.mass_kg),), slits=tuple(slits))


def slit_frequency_drop(cfg: SeriesConfig) -> np.ndarray:
    """Relative frequency drop of each of the first ``n_modes`` modes that the slit alone gives the nominal beam."""
    nominal = nominal_series_beam(cfg)
    slit = Slit(cfg.slit_x_over_L * cfg.length_m, cfg.slit_width_m, cfg.slit_ei_loss)
    f0, f1 = (modes(assemble(b), n_refine=cfg.n_modes).frequencies_hz[:cfg.n_modes]
              for b in (nominal, replace(nominal, slits=(slit,))))
    return 1.0 - f1 / f0


def _draws(cfg: SeriesConfig) -> list[dict]:
    """The truth of every test (vectorised draws over the series)."""
    rng = np.random.default_rng([cfg.seed, 31])
    n = cfg.n_tests
    day = np.arange(n) * (cfg.days / n)
    t_true = (cfg.temperature_mean_c - cfg.temperature_amplitude_c * np.cos(2 * math.pi * (day - cfg.coldest_day)
                                                                            / 365.0)
              + cfg.temperature_daily_sd_c * rng.standard_normal(n))
    t_meas = t_true + cfg.temperature_sensor_sd_c * rng.standard_normal(n)
    ei = 1 + cfg.ei_per_c * (t_true - cfg.temperature_mean_c)
    root = 1 + rng.uniform(-cfg.remount, cfg.remount, n)
    mass_x = cfg.mass_x_over_L * cfg.length_m + rng.uniform(-cfg.mass_shift_m, cfg.mass_shift_m, n)
    zeta = np.asarray(cfg.damping_ratios)[None, :] * (1 + cfg.damping_scatter * rng.standard_normal(
        (n, len(cfg.damping_ratios))))
    minutes = rng.uniform(0, 120, n)
    rows = []
    for k in range(n):
        slits = []
        if cfg.damage_day is not None and day[k] >= cfg.damage_day and cfg.slit_ei_loss > 0:
            slits.append({"x_m": cfg.slit_x_over_L * cfg.length_m, "width_m": cfg.slit_width_m,
                          "ei_loss_fraction": cfg.slit_ei_loss})
        if cfg.growth_day is not None and day[k] >= cfg.growth_day:
            grown = cfg.growth_max_ei_loss * (day[k] - cfg.growth_day) / max(cfg.days - cfg.growth_day, 1e-9)
            if grown > 0:
                slits.append({"x_m": cfg.growth_x_over_L * cfg.length_m, "width_m": cfg.slit_width_m,
                              "ei_loss_fraction": float(min(grown, cfg.growth_max_ei_loss))})
        when = _START + _dt.timedelta(days=float(day[k]), minutes=float(minutes[k]))
        rows.append({"test": k, "day": float(day[k]), "time": when.isoformat(timespec="minutes"),
                     "temperature_c": float(t_true[k]), "measured_temperature_c": float(t_meas[k]),
                     "ei_factor": float(ei[k]), "root_spring_factor": float(root[k]), "mass_x_m": float(mass_x[k]),
                     "damping_ratios": [float(z) for z in zeta[k]], "damaged": bool(slits), "slits": slits})
    return rows


def simulate_series(cfg: SeriesConfig) -> list[SeriesTest]:
    """Every test of the series (module docstring), reproducible from ``cfg.seed``.

    The draws of the environment do not depend on ``kind`` or the damage, so two series that differ only in
    their slit share their tests before ``damage_day`` (FRF noise and records: the same seeds too)."""
    freq_hz = cfg.freq_hz
    w2 = (2 * math.pi * freq_hz) ** 2
    noise = Noise(cfg.noise_level, cfg.noise_floor)
    L = cfg.length_m
    out = []
    for truth in _draws(cfg):
        k = truth["test"]
        beam = test_beam(cfg, truth)
        damping = Damping("modal", tuple(truth["damping_ratios"]))
        asm = assemble(beam)
        md = modes(asm, n_refine=cfg.n_modes + 2)
        truth["frequencies_hz"] = [float(f) for f in md.frequencies_hz[:cfg.n_modes]]
        truth["slit_size"] = (cfg.slit_ei_loss if truth["damaged"] else 0.0)
        if cfg.kind == "frf":
            dofs = asm.translation_dofs(cfg.sensors_x_m)
            ref = asm.translation_dofs([cfg.hammer_x_over_L * L])[0]
            H = receptance(asm, md, damping, freq_hz, dofs, ref)
            rng = np.random.default_rng([cfg.seed, 58, k])
            out.append(SeriesTest(k, truth, H=measure(-w2 * H, noise, rng) / -w2))
        else:
            rec = ambient_record(beam, cfg.sensors_x_m, duration_s=cfg.duration_s,
                                 sampling_frequency_hz=cfg.sampling_frequency_hz, damping=truth["damping_ratios"],
                                 input_x_m=[r * L for r in cfg.ambient_x_over_L], noise=cfg.sensor_noise,
                                 n_modes=cfg.n_modes, coloured=cfg.coloured, seed=cfg.seed * 100003 + k)
            out.append(SeriesTest(k, truth, record=rec))
    return out


def _num(v) -> str:
    return f"{float(v):.10g}"


def series_beam_toml(cfg: SeriesConfig) -> str:
    """The nominal beam's file in the project's format (sensors in ascending position = node numbers 1..n)."""
    xs = sorted(cfg.sensors_x_m)
    nominal = nominal_series_beam(cfg)
    return "\n".join([
        "# monitoring-series cantilever, written by experiments.second_sim.series (nominal beam: EI at the mean "
        "temperature, the root spring and the bolted mass at their nominal values)",
        'name = "series-cantilever"', 'bc = "clamped-free"', f"length_m = {_num(cfg.length_m)}",
        f"width_m = {_num(cfg.width_m)}", f"thickness_m = {_num(cfg.thickness_m)}", f"EI_Nm2 = {_num(cfg.EI_Nm2)}",
        f"mass_per_length_kg_m = {_num(cfg.mass_per_length_kg_m)}",
        "measured_x_m = [" + ", ".join(_num(x) for x in xs) + "]",
        f"drive_x_m = {_num(cfg.hammer_x_over_L * cfg.length_m)}",
        f"band_hz = [{_num(cfg.band_hz[0])}, {_num(cfg.band_hz[1])}]", "",
        "[effects.root_flexibility]", f"k_theta_Nm_rad = {_num(nominal.root_k_theta_Nm_rad)}", "",
        "[effects.added_mass]", f"mass_kg = {_num(cfg.mass_kg)}", f"x_m = {_num(cfg.mass_x_over_L * cfg.length_m)}",
        ""])


def write_series(cfg: SeriesConfig, tests: list[SeriesTest], out_dir) -> Path:
    """``beam.toml``, one file per test (``test-NNN.uff`` or ``test-NNN.npz``), ``conditions.csv`` and
    ``truth.json`` in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "beam.toml", series_beam_toml(cfg))
    L = cfg.length_m
    order = np.argsort(cfg.sensors_x_m)
    sensors = [cfg.sensors_x_m[i] for i in order]
    nodes = list(range(1, len(sensors) + 1))
    hammer = cfg.hammer_x_over_L * L
    geometry = list(sensors)
    if not any(abs(hammer - x) < 1e-9 * L for x in geometry):
        geometry.append(hammer)
    geometry += [x for x in (0.0, L) if not any(abs(x - g) < 1e-9 * L for g in geometry)]
    geometry_nodes = list(range(1, len(geometry) + 1))
    ref_node = geometry_nodes[int(np.argmin(np.abs(np.asarray(geometry) - hammer)))]
    width = max(3, len(str(cfg.n_tests - 1)))
    conditions, rows = [], []
    for t in tests:
        name = f"test-{t.index:0{width}d}." + ("uff" if cfg.kind == "frf" else "npz")
        if cfg.kind == "frf":
            write_uff(out / name, cfg.freq_hz, t.H[order], geometry, nodes, ref_node, kind="accelerance",
                      description=f"second_sim series test {t.index} day {t.truth['day']:.1f}",
                      node_numbers=geometry_nodes)
        else:
            rec = replace(t.record, signals=t.record.signals[order].astype(np.float32))
            write_npz(out / name, rec, dofs=[f"{n}:+Y" for n in nodes])
        conditions.append({"file": name, "time": t.truth["time"],
                           "temperature_c": f"{t.truth['measured_temperature_c']:.2f}"})
        rows.append({"file": name, **t.truth})
    write_csv(out / "conditions.csv", conditions)
    damaged = [r["day"] for r in rows if r["damaged"]]
    write_json(out / "truth.json", {
        "config": asdict(cfg), "kind": cfg.kind, "beam_toml": "beam.toml", "sensors_x_m": sensors,
        "node_numbers": nodes, "hammer_x_m": hammer, "EI_Nm2": cfg.EI_Nm2,
        "mass_per_length_kg_m": cfg.mass_per_length_kg_m, "mass_kg": cfg.mass_kg,
        "slit_frequency_drop": [float(v) for v in slit_frequency_drop(cfg)],
        "first_damaged_test": next((r["test"] for r in rows if r["damaged"]), None),
        "first_damaged_day": damaged[0] if damaged else None, "tests": rows})
    return out


@dataclass(frozen=True)
class FrequencySeriesConfig:
    """A long series of identified natural frequencies (no records written): the beam and environment of ``beam``
    (its seasonal and day-to-day temperature, clamp and mass), ``tests_per_day`` tests a day over ``days``, a
    daily temperature cycle and a weather anomaly (AR(1), correlation time ``weather_days``), the clamp re-made and
    the mass re-placed every ``remount_every_days`` (None: before every test), each identified frequency scattered
    by ``frequency_noise`` (relative std, one value or one per mode), and from ``step_day`` on a lasting relative
    drop ``step_fraction`` of the modes ``step_modes`` (1-based), or with ``step_modes=None`` of every mode in the
    pattern of a uniform loss of ``EI`` (:func:`uniform_stiffness_pattern`: the direction the temperature moves the
    modes too), ``step_fraction`` their mean drop."""

    beam: SeriesConfig = SeriesConfig(damage_day=None, n_tests=2)
    days: float = 730.0
    tests_per_day: int = 48
    seed: int = 0
    daily_amplitude_c: float = 4.0
    weather_sd_c: float = 3.0
    weather_days: float = 3.0
    remount_every_days: float | None = 7.0
    frequency_noise: float | tuple = 1e-3
    step_day: float | None = None
    step_fraction: float = 0.0
    step_modes: tuple | None = None


@dataclass(frozen=True)
class FrequencySeries:
    """A simulated frequency series: ``day`` (n,), the true and measured temperatures (n,) in degC, the identified
    frequencies ``frequencies_hz`` (n, m), the beam's ``true_hz`` (n, m) before the step, ``damaged`` (n,), and each
    test's ``ei_factor``, ``root_spring_factor`` and ``mass_x_m`` (n,)."""

    day: np.ndarray
    temperature_c: np.ndarray
    measured_temperature_c: np.ndarray
    frequencies_hz: np.ndarray
    true_hz: np.ndarray
    damaged: np.ndarray
    ei_factor: np.ndarray
    root_spring_factor: np.ndarray
    mass_x_m: np.ndarray


def _cubic_terms(P):
    """Every monomial of degree <= 3 of the columns of ``P`` (n, 3) in [-1, 1]: (n, 20)."""

    cols = [np.ones(len(P))]
    for deg in (1, 2, 3):
        cols += [np.prod(P[:, list(c)], axis=1) for c in itertools.combinations_with_replacement(range(3), deg)]
    return np.stack(cols, axis=1)


def _frequency_surface(cfg: SeriesConfig, ei, root, mass_x):
    """``ln`` of the first ``cfg.n_modes`` frequencies at each ``(EI factor, root-spring factor, mass place)``: the
    FEM on a 5 x 5 x 5 grid spanning the draws, a cubic polynomial in the three parameters fitted to it by least
    squares (125 eigen-solutions instead of one per test; within 1e-5 of the FEM, far below the identification
    scatter)."""
    V = np.c_[ei, root, mass_x]
    lo, hi = V.min(axis=0) - 1e-6, V.max(axis=0) + 1e-6
    grid = np.stack(np.meshgrid(*(np.linspace(-1, 1, 5),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    nominal = nominal_series_beam(cfg)
    logF = []
    for g in grid:
        e, r, x = lo + (g + 1) / 2 * (hi - lo)
        beam = replace(nominal, EI_Nm2=cfg.EI_Nm2 * e, root_k_theta_Nm_rad=nominal.root_k_theta_Nm_rad * r,
                       masses=(PointMass(x, cfg.mass_kg),))
        logF.append(np.log(modes(assemble(beam), n_refine=cfg.n_modes).frequencies_hz[:cfg.n_modes]))
    coef = np.linalg.lstsq(_cubic_terms(grid), np.asarray(logF), rcond=None)[0]
    return _cubic_terms(2 * (V - lo) / (hi - lo) - 1) @ coef


def frequency_series(cfg: FrequencySeriesConfig) -> FrequencySeries:
    """The series of ``cfg`` (:class:`FrequencySeriesConfig`), reproducible from ``cfg.seed``; the environment's
    draws do not depend on the step, so two series differing only in their step share their intact tests."""
    b = cfg.beam
    rng = np.random.default_rng([cfg.seed, 97])
    n = int(round(cfg.days * cfg.tests_per_day))
    day = np.arange(n) / cfg.tests_per_day
    phi = math.exp(-1.0 / (cfg.weather_days * cfg.tests_per_day))
    from scipy.signal import lfilter

    weather = lfilter([math.sqrt(1 - phi**2)], [1.0, -phi], rng.standard_normal(n)) * cfg.weather_sd_c
    t_true = (b.temperature_mean_c - b.temperature_amplitude_c * np.cos(2 * math.pi * (day - b.coldest_day) / 365.0)
              - cfg.daily_amplitude_c * np.cos(2 * math.pi * (day % 1.0 - 0.125)) + weather)
    t_meas = t_true + b.temperature_sensor_sd_c * rng.standard_normal(n)
    epoch = (np.arange(n) if cfg.remount_every_days is None
             else np.floor(day / cfg.remount_every_days).astype(int))              # the mounting of each test
    k = int(epoch.max()) + 1
    root = (1 + rng.uniform(-b.remount, b.remount, k))[epoch]
    mass_x = (b.mass_x_over_L * b.length_m + rng.uniform(-b.mass_shift_m, b.mass_shift_m, k))[epoch]
    ei = 1 + b.ei_per_c * (t_true - b.temperature_mean_c)
    true_hz = np.exp(_frequency_surface(b, ei, root, mass_x))
    noise = np.broadcast_to(np.asarray(cfg.frequency_noise, float), (b.n_modes,))
    F = true_hz * np.exp(noise * rng.standard_normal((n, b.n_modes)))
    damaged = np.zeros(n, bool) if cfg.step_day is None else day >= cfg.step_day
    if cfg.step_modes is None:
        F[damaged] *= np.exp(uniform_stiffness_pattern(b) * math.log1p(-cfg.step_fraction))
    else:
        F[np.ix_(damaged, np.asarray(cfg.step_modes) - 1)] *= 1.0 - cfg.step_fraction
    return FrequencySeries(day, t_true, t_meas, F, true_hz, damaged, ei, root, mass_x)


def uniform_stiffness_pattern(cfg: SeriesConfig) -> np.ndarray:
    """Each mode's ``d ln f`` of a uniform loss of ``EI`` over the nominal beam relative to their mean (m,): about
    one each, mode 1 less (its root spring does not soften)."""
    nominal = nominal_series_beam(cfg)
    f0, f1 = (modes(assemble(replace(nominal, EI_Nm2=cfg.EI_Nm2 * e)), n_refine=cfg.n_modes).frequencies_hz[
        :cfg.n_modes] for e in (1.0, 0.99))
    d = np.log(f0 / f1)
    return d / d.mean()


def drop_pattern(cfg: SeriesConfig, which) -> np.ndarray:
    """The ``d ln f`` per unit drop of each mode (m,) of a damage: ``"stiffness"`` a uniform loss of ``EI``
    (:func:`uniform_stiffness_pattern`), ``"mass"`` a mass loss (:func:`mass_loss_pattern`, negated: the modes
    rise), a tuple the modes (1-based) that drop alone (1 each, 0 elsewhere)."""
    if which == "stiffness":
        return uniform_stiffness_pattern(cfg)
    if which == "mass":
        return -mass_loss_pattern(cfg)
    p = np.zeros(cfg.n_modes)
    p[np.asarray(which) - 1] = 1.0
    return p


def mass_loss_pattern(cfg: SeriesConfig, loss: float = 0.5) -> np.ndarray:
    """Each mode's ``d ln f`` of losing the share ``loss`` of the bolted mass relative to their mean (m,): positive,
    the modes rise, those with a large amplitude at the mass most."""
    nominal = nominal_series_beam(cfg)
    lighter = replace(nominal, masses=(PointMass(cfg.mass_x_over_L * cfg.length_m, cfg.mass_kg * (1 - loss)),))
    f0, f1 = (modes(assemble(b), n_refine=cfg.n_modes).frequencies_hz[:cfg.n_modes] for b in (nominal, lighter))
    d = np.log(f1 / f0)
    return d / d.mean()
