"""Generator configuration: defaults, TOML loading and validation of every key.

A configuration is a nested mapping of sections; a TOML file overrides any
subset of the defaults below. Unknown sections/keys and bad values raise
:class:`physics.errors.ConfigError` naming the dotted key (``damage.depth_m``).

Ranges ``[lo, hi]`` are sampled uniformly (``root_spring_relative`` log-uniformly);
``lo == hi`` fixes the value. Bands ``b`` are relative: a factor uniform in
``[1 - b, 1 + b]`` around the preset.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from datagen.checks import number as _num, value_range as _range
from datagen.damage import DEFAULT_KIND, GENERIC_DEFAULTS, applies_to, beam_section, damage_defaults, damage_model
from datagen.specimen import DEFAULT_SECTION
from physics.io.inputs import check_input_file
from physics.errors import BeamDamageError, ConfigError
from physics.properties import PRESETS
from physics.updating import mass_model_name

__all__ = ["CONFIG_DIR", "DEFAULTS", "MAX_MODAL_NOISE", "MAX_SHEAR_FLEXIBILITY", "MIN_ROOT_SPRING_RELATIVE",
           "MODAL_NOISE_MODES", "OUTPUT_ONLY_VARIABLES", "REPEATABILITY", "REPEATABILITY_MAX", "RecordedConfig",
           "calibrated_modal_std", "load_config", "merge", "modal_noise_calibration", "named_configs",
           "output_only_variables", "recorded_config", "validate"]


#: Default configuration (SI units). See docs/datasets.md.
DEFAULTS: dict = {
    "preset": "beam5",
    "beam": {},                        # a beam file's mapping (generate --beam FILE): the truth instead of the preset
    "mesh": {
        "truth_elements": 20,          # multiple of 4 so nodes sit at the thesis's nodes 2..5
    },
    "section": dict(DEFAULT_SECTION),  # the sandwich's face thickness and core modulus (datagen.specimen)
    "specimen": {
        "ei_band": 0.05,
        "mass_band": 0.03,
        "damping_band": 0.2,
        "root_spring_relative": [300.0, 3000.0],   # k_r L / EI, log-uniform; [] = rigid clamp
        "damping_ratios": [0.001623, 0.002481, 0.003105, 0.00421],  # thesis beam 5, modes 1..4
        "temperature_stiffness_change": [0.0, 0.0],  # relative EI change of the current test day (uniform)
        "root_spring_change": [0.0, 0.0],            # relative root-spring change on re-clamping (uniform)
        "support_change_fraction": 0.0,  # share of the intact specimens whose supports change between the days
                                         # beyond re-clamping (label support_changed)
        "support_change_factor": [2.0, 5.0],  # those supports' springs that many times softer or stiffer
                                              # (log-uniform, either way alike)
        "shear_flexibility": [0.0, 0.0],  # EI / (kGA L^2) of the specimen (uniform; 0: Euler-Bernoulli elements)
    },
    "damage": damage_defaults(DEFAULT_KIND),   # keys of the default kind; another damage.kind has its own
    "measurement": {
        "modal_noise": "fixed",        # "fixed": the three stds below; "calibrated": per-mode coefficients times the
                                       # sample's FRF noise level (configs/modal_noise.json,
                                       # experiments.benches.bench_modal_noise); "output-only": per-mode
                                       # coefficients of the
                                       # sample's sensor noise and record length (SSI-cov of response records,
                                       # learn.pairs.output_only_calibration; generate --modal-noise output-only)
        "frequency_noise": 0.0005,     # relative std of natural frequencies (number, or one per mode 1..4)
        "damping_noise": 0.02,         # relative std of damping ratios
        "shape_noise": 0.002,          # complex std relative to the largest entry of each mode
        "frequency_noise_floor": 0.0,  # "calibrated" only: std = sqrt((coefficient * level)^2 + floor^2), per mode
        "damping_noise_floor": 0.0,
        "shape_noise_floor": 0.0,
        "frequency_noise_per_floor": 0.0,  # "calibrated" only: + (coefficient * FRF noise floor)^2 under the root
        "damping_noise_per_floor": 0.0,
        "shape_noise_per_floor": 0.0,
        "modal_noise_scale": [1.0, 1.0],  # factor on the modal noise's stds, log-uniform per sample
        "frequency_scatter": [0.0, 0.0],  # relative std of independent per-mode frequency changes of each test
                                          # (log-uniform per sample; repeatability beyond temperature/re-clamping)
        "damping_scatter": [0.0, 0.0],    # relative std of independent per-mode damping-ratio changes of each test
        "shape_scatter": [0.0, 0.0],      # complex std, relative to each mode's largest entry, of independent
                                          # per-sensor, per-mode shape changes of each test
        "gain_scatter": [0.0, 0.0],       # relative std of each sensor channel's gain in each test (all its modes)
        "identification": None,       # derived: the identification the calibrated modal noise describes (read-only)
        "sensor_noise": [0.005, 0.03],   # "output-only" only: sensor noise std relative to each channel's response
                                         # RMS (or [lo, hi], log-uniform per sample)
        "record_length_s": [120.0, 900.0],  # "output-only" only: record length of each test (s; or [lo, hi],
                                            # log-uniform per sample)
        "frf_noise": 0.005,            # complex std relative to |H| per line (or [lo, hi], log-uniform per sample)
        "frf_noise_floor": 0.0,        # complex std relative to each FRF's peak (or [lo, hi], log-uniform)
        "band_rad_s": [1.0, 5000.0],   # thesis Program A grid limits
        "lines": 1024,
    },
    "updating": {
        "mass_model": "iirs",          # "iirs" (4-element FE reduced to nodes 2..5) or "lumped" (eq. 4.6)
        "tol": 1e-10,
        "max_iter": 500,
    },
    "solver": {
        "projection_modes": 8,         # undamped modes kept for the light-damping complex modes
        "subspace_iterations": 3,
        "damping_iterations": 3,
    },
    "output": {
        "shard_size": 1000,
        "frf_dtype": "complex64",      # of the FRFs synthesised when read (and of --store-frf)
        "store_frf": False,            # also write the FRFs into the shards (opt-in; they are synthesised on read)
    },
}


#: Largest relative modal noise std (frequency, damping ratio, shape), fixed or implied by calibrated FRF noise.
MAX_MODAL_NOISE = 0.5

#: The repeatability ranges of ``measurement`` (per-sample stds of each test's own changes, log-uniform) and
#: their largest accepted values (docs/datasets.md, "Repeatability of the tests").
REPEATABILITY_MAX = {"frequency_scatter": 0.01, "damping_scatter": 0.5, "shape_scatter": 0.1, "gain_scatter": 0.1}
#: Those keys, in the order a batch draws them (:func:`datagen.batch_inputs.draw_batch`).
REPEATABILITY = tuple(REPEATABILITY_MAX)
#: The per-sample variables of ``measurement.modal_noise = "output-only"`` (:func:`output_only_variables`).
OUTPUT_ONLY_VARIABLES = ("sensor_noise", "record_length_s")


#: Largest specimen shear flexibility ``EI / (kGA L^2)``: mode 4 of a cantilever then lies about half
#: below its Euler-Bernoulli frequency.
MAX_SHEAR_FLEXIBILITY = 0.02


@dataclass(frozen=True)
class RecordedConfig:
    """What the readers of a dataset or model take from the generator config it records (:func:`recorded_config`).

    Attributes
    ----------
    kind : str               ``damage.kind`` (:data:`datagen.damage.DEFAULT_KIND` for a config that names none)
    damage : dict            section ``damage`` ({} when none)
    section : dict or None   section ``section`` (the sandwich's keys)
    beam : dict or None      section ``beam`` (a beam file's mapping; None when empty)
    effects : dict           the beam file's ``effects`` ({} when none)
    specimen : dict          section ``specimen`` ({} when none)
    measurement : dict       section ``measurement`` ({} when none)
    """

    kind: str
    damage: dict
    section: dict | None
    beam: dict | None
    effects: dict
    specimen: dict
    measurement: dict


def recorded_config(config: dict | None) -> RecordedConfig:
    """The :class:`RecordedConfig` view of a recorded generator config (``None``: a dataset or model recording
    none)."""
    c = config or {}
    damage, beam = c.get("damage") or {}, c.get("beam") or None
    return RecordedConfig(damage.get("kind", DEFAULT_KIND), damage, c.get("section"), beam,
                          (beam or {}).get("effects") or {}, c.get("specimen") or {}, c.get("measurement") or {})


def calibrated_modal_std(meas: dict, level, floor) -> dict:
    """Relative std of each modal quantity, ``sqrt((c level)^2 + (g floor)^2 + e^2)`` per mode.

    ``c``, ``g`` and ``e`` are ``measurement.{q}_noise``, ``{q}_noise_per_floor`` and ``{q}_noise_floor``;
    ``level`` and ``floor`` (FRF noise level and floor, or the output-only variables of
    :func:`output_only_variables`) broadcast against the modes.
    Returns ``{"frequency", "damping", "shape"}`` -> ndarray.
    """
    return {q: np.sqrt((np.asarray(meas[f"{q}_noise"], float) * level) ** 2
                       + (np.asarray(meas[f"{q}_noise_per_floor"], float) * floor) ** 2
                       + np.asarray(meas[f"{q}_noise_floor"], float) ** 2)
            for q in ("frequency", "damping", "shape")}


def output_only_variables(sensor_noise, record_length_s):
    """``(sensor_noise / sqrt(T), 1 / sqrt(T))`` of a record of ``T = record_length_s`` seconds: the variables
    that take the FRF noise level's and floor's places in :func:`calibrated_modal_std` for ``modal_noise =
    "output-only"``, so that ``std^2 = ((c noise)^2 + g^2) / T + e^2`` (the errors of an output-only
    identification fall as one over the square root of the record length; sensor noise adds to them)."""
    t = np.asarray(record_length_s, float)
    return np.asarray(sensor_noise, float) / np.sqrt(t), 1.0 / np.sqrt(t)


def _max_calibrated_level(meas, floor, limit):
    """Largest FRF noise level whose calibrated modal noise stds (at noise floor ``floor``) all stay <= ``limit``."""
    return min(math.sqrt(max(limit**2 - (g * floor) ** 2 - e**2, 0.0)) / c if c > 0 else math.inf
               for q in ("frequency", "damping", "shape")
               for c, g, e in zip(meas[f"{q}_noise"], meas[f"{q}_noise_per_floor"], meas[f"{q}_noise_floor"]))


def validate(cfg: dict) -> dict:
    """Check every key of a full configuration; returns a normalised deep copy.

    Raises
    ------
    ConfigError
        Unknown key, missing key, wrong type or out-of-range value (names the key).
    """
    cfg = copy.deepcopy(cfg)
    _check_sections(cfg)
    _check_beam(cfg)
    _check_specimen(cfg["specimen"])
    calibrated = _check_measurement(cfg["measurement"])
    if calibrated == "calibrated":
        _check_calibrated_noise(cfg["measurement"])
    elif calibrated == "output-only":
        _check_output_only_noise(cfg["measurement"])
    _check_updating(cfg["updating"])
    _check_solver(cfg["solver"], cfg["mesh"]["truth_elements"])
    _check_damage(cfg)
    _check_output(cfg["output"])
    return cfg


def _check_sections(cfg: dict) -> None:
    """Every section of :data:`DEFAULTS` present, with exactly its keys (``beam`` is free-form)."""
    for sec in cfg:
        if sec not in DEFAULTS:
            raise ConfigError(f"unknown config key {sec!r}; expected one of {sorted(DEFAULTS)}")
    for sec, d in DEFAULTS.items():
        if sec not in cfg:
            raise ConfigError(f"config key {sec!r} missing")
        if sec == "beam":  # free-form: validated by physics.beam when the setup is built
            if not isinstance(cfg[sec], dict):
                raise ConfigError("config key 'beam' must be a table (a beam file's keys)")
            continue
        if isinstance(d, dict):
            if not isinstance(cfg[sec], dict):
                raise ConfigError(f"config key {sec!r} must be a table")
            if sec == "damage":  # the keys of its kind
                d = damage_defaults(cfg[sec].get("kind", DEFAULT_KIND))
            for k in cfg[sec]:
                if k not in d:
                    raise ConfigError(f"unknown config key '{sec}.{k}'; expected one of {sorted(d)}")
            for k in d:
                if k not in cfg[sec]:
                    raise ConfigError(f"config key '{sec}.{k}' missing")


def _check_beam(cfg: dict) -> None:
    """``preset``, ``mesh`` and ``section``."""
    if not isinstance(cfg["preset"], str):
        raise ConfigError("config key 'preset' must be a string such as 'beam5'")
    if cfg["preset"] not in PRESETS:
        raise ConfigError(f"config key 'preset': unknown beam preset {cfg['preset']!r}; expected one of "
                          f"{sorted(PRESETS)}")
    m, s = cfg["mesh"], cfg["section"]
    m["truth_elements"] = _num("mesh.truth_elements", m["truth_elements"], lo=4, hi=400, integer=True)
    if m["truth_elements"] % 4:
        raise ConfigError(f"config key 'mesh.truth_elements' must be a multiple of 4 (the thesis's measured nodes "
                          f"sit at quarter points), got {m['truth_elements']}")
    s["face_thickness_m"] = _num("section.face_thickness_m", s["face_thickness_m"], lo=0, hi=0.003, strict_lo=True)
    s["core_modulus_pa"] = _num("section.core_modulus_pa", s["core_modulus_pa"], lo=0)


#: Smallest upper bound of ``specimen.root_spring_relative`` accepted: below it most updated models are not
#: positive definite (20 of 20 samples at 0.001, 11 at 0.003, 4 at 0.01, none at 0.03: tests/datagen/test_status.py).
MIN_ROOT_SPRING_RELATIVE = 0.01


def _check_specimen(dmg: dict) -> None:
    """Section ``specimen``: variability bands, root spring, day-to-day changes, damping ratios."""
    for k in ("ei_band", "mass_band", "damping_band"):
        dmg[k] = _num(f"specimen.{k}", dmg[k], lo=0, hi=0.5)
    rs = dmg["root_spring_relative"] = _range("specimen.root_spring_relative", dmg["root_spring_relative"],
                                              lo=1e-3, allow_empty=True)
    if rs and rs[1] < MIN_ROOT_SPRING_RELATIVE:
        raise ConfigError(f"config key 'specimen.root_spring_relative' = {rs}: a root spring this soft (k_r L / EI "
                          f"< {MIN_ROOT_SPRING_RELATIVE:g}) leaves a nearly free rigid-body mode whose updated "
                          f"stiffness is not positive definite in most samples; give a range reaching at least "
                          f"{MIN_ROOT_SPRING_RELATIVE:g}")
    for k in ("temperature_stiffness_change", "root_spring_change"):
        dmg[k] = _range(f"specimen.{k}", dmg[k], lo=-0.5, hi=0.5)
    dmg["support_change_fraction"] = _num("specimen.support_change_fraction", dmg["support_change_fraction"], lo=0,
                                          hi=1)
    dmg["support_change_factor"] = _range("specimen.support_change_factor", dmg["support_change_factor"], lo=1.0,
                                          hi=1e3)
    dmg["shear_flexibility"] = _range("specimen.shear_flexibility", dmg["shear_flexibility"], lo=0.0,
                                      hi=MAX_SHEAR_FLEXIBILITY)
    zr = dmg["damping_ratios"]
    if not (isinstance(zr, list) and len(zr) >= 1 and all(isinstance(z, (int, float)) and 0 < z < 0.2 for z in zr)):
        raise ConfigError(f"config key 'specimen.damping_ratios' must be a list of ratios in (0, 0.2), got {zr!r}")
    dmg["damping_ratios"] = [float(z) for z in zr]


def _check_damage(cfg: dict) -> None:
    """Section ``damage``: kind, intact fraction, positions, the kind's own keys (its ``validate``), then whether the
    truth beam's section holds the kind (its ``sections``)."""
    d = cfg["damage"]
    model = damage_model(d["kind"])
    d["position_fraction"] = _range("damage.position_fraction", d["position_fraction"], lo=0.0, hi=1.0)
    d["intact_fraction"] = _num("damage.intact_fraction", d["intact_fraction"], lo=0.0, hi=1.0)
    model.validate(d, cfg)
    section = beam_section(cfg.get("beam"))
    if not applies_to(d["kind"], section):
        raise ConfigError(f"config key 'damage.kind' = {d['kind']!r} needs a {' or '.join(model.sections)} section; "
                          f"config key 'beam' has section = {section!r}")


#: What ``measurement.modal_noise`` may be.
MODAL_NOISE_MODES = ("fixed", "calibrated", "output-only")


def _check_measurement(meas: dict) -> str:
    """Section ``measurement``: modal noise (fixed stds, the FRF calibration or the output-only one), FRF noise,
    sensor noise and record length, band, lines.

    Returns ``measurement.modal_noise``; ``meas["identification"]`` is set to the identification the calibrated
    modal noise describes (``{"method": "lscf", ...}`` of the shipped file, ``{"method": "ssi", ...}`` for
    "output-only", None for "fixed").
    """
    noise_model = meas["modal_noise"]
    if noise_model not in MODAL_NOISE_MODES:
        raise ConfigError(f"config key 'measurement.modal_noise' must be one of {', '.join(MODAL_NOISE_MODES)}, "
                          f"got {noise_model!r}")
    calib = modal_noise_calibration() if noise_model == "calibrated" else {}
    meas["identification"] = calib.get("identification")
    for k in ("frequency_noise", "damping_noise", "shape_noise", "frequency_noise_floor", "damping_noise_floor",
              "shape_noise_floor", "frequency_noise_per_floor", "damping_noise_per_floor", "shape_noise_per_floor"):
        v = meas[k]
        if isinstance(v, list):
            if not 1 <= len(v) <= 100:
                raise ConfigError(f"config key 'measurement.{k}' must be a number or one number per mode (modes 1, "
                                  f"2, ...; the last repeats beyond the list), got {v!r}")
            hi = MAX_MODAL_NOISE if noise_model == "fixed" else 1e4
            meas[k] = [_num(f"measurement.{k}", x, lo=0, hi=hi) for x in v]
        elif noise_model == "output-only":
            raise ConfigError(f"config key 'measurement.{k}': modal_noise 'output-only' takes one coefficient per "
                              "mode, calibrated on the test by 'beam-damage generate --modal-noise output-only'; "
                              f"got {v!r}")
        elif calib:  # a number in calibrated mode: the shipped per-mode coefficients
            q = k.split("_")[0]
            meas[k] = [float(x) for x in calib[q + k.removeprefix(f"{q}_noise")]]
        else:
            meas[k] = _num(f"measurement.{k}", v, lo=0, hi=MAX_MODAL_NOISE)
    if noise_model == "output-only":
        meas["identification"] = {"method": "ssi", "n_modes": len(meas["frequency_noise"])}
    # a number fixes the value; a range draws it per sample
    for k, lo, hi in (("frf_noise", 0.0, 0.5), ("frf_noise_floor", 0.0, 0.5), ("sensor_noise", 0.0, 0.5),
                      ("record_length_s", 1.0, 1e6)):
        v = meas[k]
        is_number = isinstance(v, (int, float)) and not isinstance(v, bool)
        meas[k] = (_num(f"measurement.{k}", v, lo=lo, hi=hi) if is_number
                   else _range(f"measurement.{k}", v, lo=lo, hi=hi))
    meas["modal_noise_scale"] = _range("measurement.modal_noise_scale", meas["modal_noise_scale"], lo=0.01, hi=100.0)
    for k, hi in REPEATABILITY_MAX.items():
        meas[k] = _range(f"measurement.{k}", meas[k], lo=0.0, hi=hi)
    meas["band_rad_s"] = _range("measurement.band_rad_s", meas["band_rad_s"], lo=0.0)
    if meas["band_rad_s"][0] >= meas["band_rad_s"][1]:
        raise ConfigError("config key 'measurement.band_rad_s' must have low < high")
    meas["lines"] = _num("measurement.lines", meas["lines"], lo=2, hi=200000, integer=True)
    return noise_model


def _check_calibrated_noise(meas: dict) -> None:
    """The modal noise the FRF noise implies must lie where the fixed stds may (<= :data:`MAX_MODAL_NOISE`)."""
    level = max(meas["frf_noise"]) if isinstance(meas["frf_noise"], list) else meas["frf_noise"]
    floor = max(meas["frf_noise_floor"]) if isinstance(meas["frf_noise_floor"], list) else meas["frf_noise_floor"]
    for q, std in calibrated_modal_std(meas, level, floor).items():
        if std.max() > MAX_MODAL_NOISE:
            raise ConfigError(f"config key 'measurement.frf_noise': {level:g} implies a calibrated relative "
                              f"{q} noise std of {std.max():.3g} (> {MAX_MODAL_NOISE:g}: measured modes with "
                              f"negative damping or lost shapes); keep frf_noise <= "
                              f"{_max_calibrated_level(meas, floor, MAX_MODAL_NOISE):.3g}")


def _check_output_only_noise(meas: dict) -> None:
    """The output-only modal noise of the noisiest, shortest record must stay <= :data:`MAX_MODAL_NOISE`."""
    noise, length_s = meas["sensor_noise"], meas["record_length_s"]
    noise, length_s = (max(noise) if isinstance(noise, list) else noise,
                       min(length_s) if isinstance(length_s, list) else length_s)
    for q, std in calibrated_modal_std(meas, *output_only_variables(noise, length_s)).items():
        if std.max() > MAX_MODAL_NOISE:
            raise ConfigError(f"config key 'measurement.record_length_s': {length_s:g} s with sensor noise "
                              f"{noise:g} implies an output-only relative {q} noise std of {std.max():.3g} "
                              f"(> {MAX_MODAL_NOISE:g}); give longer records or less sensor noise")


def _check_updating(up: dict) -> None:
    """Section ``updating``: mass model, tolerance, iterations."""
    try:  # one mass-model name set (physics.updating.MASS_MODELS); "reduced" is accepted for "iirs"
        up["mass_model"] = mass_model_name(up["mass_model"], parameter="updating.mass_model")
    except BeamDamageError as exc:
        raise ConfigError(f"config key 'updating.mass_model': {exc}") from None
    up["tol"] = _num("updating.tol", up["tol"], lo=0, hi=1e-2, strict_lo=True)
    up["max_iter"] = _num("updating.max_iter", up["max_iter"], lo=1, hi=100000, integer=True)


def _check_solver(sol: dict, truth_elements: int) -> None:
    """Section ``solver``; the projection modes fit in the truth model's ``2 truth_elements`` DOFs."""
    sol["projection_modes"] = _num("solver.projection_modes", sol["projection_modes"], lo=4, hi=64, integer=True)
    if sol["projection_modes"] > 2 * truth_elements:
        raise ConfigError("config key 'solver.projection_modes' exceeds the truth model's DOFs")
    sol["subspace_iterations"] = _num("solver.subspace_iterations", sol["subspace_iterations"], lo=1, hi=50,
                                      integer=True)
    sol["damping_iterations"] = _num("solver.damping_iterations", sol["damping_iterations"], lo=1, hi=50,
                                     integer=True)


def _check_output(out: dict) -> None:
    """Section ``output``: shard size, stored FRFs, FRF dtype."""
    out["shard_size"] = _num("output.shard_size", out["shard_size"], lo=1, hi=10**6, integer=True)
    if not isinstance(out["store_frf"], bool):
        raise ConfigError(f"config key 'output.store_frf' must be true or false, got {out['store_frf']!r}")
    if out["frf_dtype"] not in ("complex64", "complex128"):
        raise ConfigError(f"config key 'output.frf_dtype' must be 'complex64' or 'complex128', "
                          f"got {out['frf_dtype']!r}")


def modal_noise_calibration() -> dict:
    """Per-mode coefficients of the calibrated modal noise, std ``sqrt((c level)^2 + (g floor)^2 + e^2)`` of the
    FRF noise level and floor: ``c`` under "frequency", "damping", "shape", ``g`` under "<quantity>_per_floor",
    ``e`` under "<quantity>_floor" (0 when the file has none)."""
    calib = json.loads((Path(__file__).parent / "configs" / "modal_noise.json").read_text())
    return {**{f"{q}{s}": [0.0] * 4 for q in ("frequency", "damping", "shape") for s in ("_floor", "_per_floor")},
            **calib}


def merge(overrides: dict | None = None, base: dict | None = None) -> dict:
    """Defaults (or ``base``) updated section by section with ``overrides``; validated."""
    cfg = copy.deepcopy(DEFAULTS if base is None else base)
    for k, v in (overrides or {}).items():
        if k not in DEFAULTS:
            raise ConfigError(f"unknown config key {k!r}; expected one of {sorted(DEFAULTS)}")
        if k == "beam":
            cfg[k] = copy.deepcopy(v)
            continue
        if isinstance(DEFAULTS[k], dict):
            if not isinstance(v, dict):
                raise ConfigError(f"config key {k!r} must be a table")
            keys = DEFAULTS[k]
            if k == "damage" and v.get("kind", cfg[k].get("kind")) != cfg[k].get("kind"):
                cfg[k] = damage_defaults(v["kind"])   # another kind: its own defaults
            if k == "damage":
                keys = damage_defaults(cfg[k].get("kind", DEFAULT_KIND))
            for kk in v:
                if kk not in keys:
                    raise ConfigError(f"unknown config key '{k}.{kk}'; expected one of {sorted(keys)}")
            cfg[k].update(copy.deepcopy(v))
        else:
            cfg[k] = v
    return validate(cfg)


#: Named configurations shipped with the package (``datagen/configs/NAME.toml``).
CONFIG_DIR = Path(__file__).parent / "configs"


def named_configs() -> list[str]:
    """Names accepted by ``generate --config NAME``."""
    return sorted(p.stem for p in CONFIG_DIR.glob("*.toml"))


def _read_toml(p: Path) -> dict:
    if not p.exists() and not p.is_symlink():
        raise ConfigError(f"config {str(p)!r}: no such file, and not one of the named configs {named_configs()}")
    check_input_file(p, "toml", ConfigError, "a TOML config file")
    try:
        return tomllib.loads(p.read_bytes().decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not UTF-8 text (byte {exc.start}); a config is a TOML file") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a directory, expected a TOML config file") from None
    except FileNotFoundError:
        raise ConfigError(f"config {str(p)!r}: no such file, and not one of the named configs "
                          f"{named_configs()}") from None


def _overrides(name_or_path, depth=0) -> dict:
    """Overrides of a named config or a TOML file, resolving a top-level ``base = "NAME"`` first."""
    if depth > 4:
        raise ConfigError("config key 'base': chain of base configs too long (a cycle?)")
    s = str(name_or_path)
    p = CONFIG_DIR / f"{s}.toml" if s in named_configs() else Path(s)
    over = _read_toml(p)
    base = over.pop("base", None)
    if base is None:
        return over
    if not isinstance(base, str) or base not in named_configs():
        raise ConfigError(f"{p}: config key 'base' must name a shipped config {named_configs()}, got {base!r}")
    merged = _overrides(base, depth + 1)
    for k, v in over.items():
        if k == "damage" and isinstance(v, dict) and isinstance(merged.get(k), dict) \
                and v.get("kind", DEFAULT_KIND) != merged[k].get("kind", DEFAULT_KIND):
            merged[k] = {kk: x for kk, x in merged[k].items() if kk in GENERIC_DEFAULTS} | v   # another kind
        elif isinstance(v, dict) and isinstance(merged.get(k), dict):
            merged[k] = {**merged[k], **v}
        else:
            merged[k] = v
    return merged


def load_config(name_or_path=None, *, preset: str | None = None) -> dict:
    """A named config (:func:`named_configs`) or a TOML file over the defaults; ``preset`` overrides the file's.

    A TOML file may start from a named config with a top-level ``base = "training"``
    and override any of its keys (e.g. robustness sets: more damages, more noise).
    """
    over = {} if name_or_path is None else _overrides(name_or_path)
    if preset is not None:
        over["preset"] = preset
    try:
        return merge(over)
    except ConfigError as exc:                      # a key of the user's file: the file is named
        if name_or_path is None or str(name_or_path) in named_configs():
            raise
        raise ConfigError(f"{name_or_path}: {exc}", parameter=exc.parameter) from None
