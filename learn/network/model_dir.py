"""The model directory: what a trained classifier is, how it is written and read back.

Model directory
---------------
``config.json``          beam it was trained for (name, length, DOF set, mass model; and the training data's
                         truth beam from its manifest), default classifier input, estimator parameters and
                         probability calibration (logit scale, bias) per input, training data (paths, manifest
                         checksums, generator config with its temperature/re-clamping ranges), detection
                         threshold, classical-method thresholds, seed, package version, training time, test
                         metrics
``weights-<input>.npz``  the network's state dict plus the input normalisation and the training features'
                         statistics, as NumPy arrays (read without pickle; the network answers in NumPy,
                         :mod:`learn.network.forward`); a directory written before holds ``weights-<input>.pt``
                         (``torch.save``, loaded with ``weights_only=True``)
``metrics.csv``          test-split metrics of the network(s) and the classical methods

A model trained on an FRF input also carries a modal-input network, used for inputs that are modal data only
(the thesis's measured data).

Format 4 (:data:`MODEL_FORMAT`): the modal- and frequency-input networks answer pairs with missing modes (their
estimator parameters record ``feature_modes``; the weights hold the training covariance and reference rows of the
out-of-distribution check on the present features). A format-3 directory (:data:`READ_FORMATS`) is read and
behaves as it did: its networks answer pairs holding every mode of the model, the others get the classical verdict.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from datagen.config import RecordedConfig, recorded_config
from learn.network.features import BeamSpec
from datagen.damage import DAMAGE_MODELS, applies_to, beam_section
from learn.explanations.refine import NominalBeam, nominal_beam
from learn.explanations.sensitivity import Sensitivity, beam_sensitivity
from learn.pairs.verdict import DamageWords, verdict_text
from physics.beam import load_beam
from physics.io.inputs import check_input_file
from physics.errors import BeamDamageError, FileFormatError
from physics.io import atomic_write_bytes, atomic_write_text, read_json
from physics.properties import PRESETS, beam_preset
from physics.effects import effect_of

__all__ = ["DEFAULT_ROUTE", "MODEL_FORMAT", "READ_FORMATS", "TrainedModel", "json_default",
           "load_model", "save_model", "sensitivity_of", "truth_numbers"]


#: Input route used by default (the winner of ``python -m experiments.benches.bench_learn``).
DEFAULT_ROUTE = "modal"
MODEL_FORMAT = "beam-damage-model/4"
#: Formats :func:`load_model` reads: format 3 differs only in networks that need every mode.
READ_FORMATS = ("beam-damage-model/3", MODEL_FORMAT)


@dataclass
class TrainedModel:
    """A loaded model directory."""

    path: Path
    config: dict
    networks: dict = field(default_factory=dict)   # route -> DamageClassifier

    @cached_property
    def beam(self) -> BeamSpec:
        return BeamSpec.from_dict(self.config["beam"])

    @property
    def route(self) -> str:
        return self.config["route"]

    def check_beam(self, other: BeamSpec, what: str = "data") -> None:
        """Refuse data of another beam, DOF set or mass model (a frequency grid may differ)."""
        diff = self.beam.differences(other)
        if diff:
            raise BeamDamageError(f"model {self.path} was trained for {self.beam.name} ({self.beam.length_m:g} m, "
                                  f"DOFs {', '.join(self.beam.dofs)}, {self.beam.mass_model} mass); the {what} has "
                                  + "; ".join(diff))

    @cached_property
    def sensitivity(self) -> Sensitivity:
        """FE sensitivities of the truth beam the model records (:func:`sensitivity_of`)."""
        return sensitivity_of(self.beam, self.config.get("root_spring_relative"), self.config.get("truth_beam"),
                              self.config.get("generator_config"))

    @cached_property
    def truth(self) -> dict:
        """The truth beam's mapping the model records, over its preset's fields (a beam named after a preset; the
        preset's alone when it records none), with the generator config's ``section`` keys: what a damage kind's
        ``size_range`` and ``describe`` read."""
        truth, base = self.config.get("truth_beam") or {}, {}
        if self.beam.name in PRESETS:
            p = beam_preset(self.beam.name)
            base = {"name": p.name, "EI_Nm2": p.EI_Nm2, "mass_per_length_kg_m": p.mass_per_length_kg_m,
                    "length_m": p.length_m, "width_m": p.width_m, "thickness_m": p.thickness_m}
        return {**base, **(truth if "EI_Nm2" in truth else {}), **(self.recorded.section or {})}

    @cached_property
    def words(self) -> DamageWords:
        """The words of the model's damage kind on its truth beam and section, in which its verdicts are told."""
        return DamageWords(self.recorded.kind, self.truth, self.recorded.section)

    @cached_property
    def kind_sensitivities(self) -> dict:
        """Damage kind -> FE sensitivities of the truth beam to it (:func:`sensitivity_of`), for each registered kind
        the beam's section holds (:func:`datagen.damage.applies_to`): what the competing explanations weigh."""
        gen = self.config.get("generator_config") or {}
        section = beam_section(self.recorded.beam)
        return {name: sensitivity_of(self.beam, self.config.get("root_spring_relative"),
                                     self.config.get("truth_beam"), {**gen, "damage": {"kind": name}})
                for name in DAMAGE_MODELS if applies_to(name, section)}

    @cached_property
    def nominal(self) -> NominalBeam:
        """The nominal FE beam of the sensitivities (:func:`learn.explanations.refine.nominal_beam`), on which the
        explanations' damage kinds are fitted exactly."""
        cfg, n_modes = self.config, self.sensitivity.frequency.shape[0]
        return nominal_beam(truth_numbers(self.beam, cfg.get("truth_beam"), cfg.get("generator_config")),
                            cfg.get("root_spring_relative"), self.beam.test, n_modes=n_modes)

    def measured_beam(self, beam: str | None = None, mass_model: str | None = None):
        """The beam spec of measured data and the sensor positions a beam file gives: ``(BeamSpec, x_m or None)``.

        Parameters
        ----------
        beam : str, optional
            The model's preset name (default), another preset name, or a beam file (``.toml``) whose
            ``measured_x_m`` places the measured DOFs of files without node geometry.
        mass_model : str, optional
            Mass model of the data's updating (default: the model's).

        Raises :class:`BeamDamageError` when the data's beam is not the model's (:meth:`check_beam`).
        """
        b = self.beam
        mass_model = mass_model or b.mass_model
        beam_x_m = None
        if beam and Path(beam).suffix.lower() == ".toml":
            fb = load_beam(beam)
            spec = BeamSpec(b.name, fb.length_m, b.dofs, mass_model, b.test)
            beam_x_m = fb.measured_x_m if fb.measured_x_given else None
        else:
            length_m = b.length_m if beam in (None, b.name) else beam_preset(beam).length_m
            spec = BeamSpec(beam or b.name, length_m, b.dofs, mass_model, b.test if beam in (None, b.name) else None)
        self.check_beam(spec, "measured beam")
        return spec, beam_x_m

    @cached_property
    def recorded(self) -> RecordedConfig:
        """The generator config of the training data (:func:`datagen.config.recorded_config`)."""
        return recorded_config(self.config.get("generator_config"))

    def verdict_text(self, result: dict) -> str:
        """The verdict of one classified pair as a reader sees it, in the words of the model's damage kind
        (:func:`learn.pairs.verdict.verdict_text` in its :attr:`words`)."""
        return verdict_text(result, self.words)


def save_model(out_dir, config: dict, networks: dict) -> None:
    """Write the model directory atomically file by file (temp file, then rename)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for route, est in networks.items():
        arrays, meta = est.get_state()
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        atomic_write_bytes(out / f"weights-{route}.npz", buf.getvalue())
        config.setdefault("networks", {})[route] = meta
    atomic_write_text(out / "config.json", json.dumps(config, indent=1, sort_keys=True, default=json_default))


def _weights(path: Path, route: str) -> tuple[dict, Path]:
    """The arrays of a network's weights file and the file: ``weights-<route>.npz`` (read without pickle), or an
    older directory's ``weights-<route>.pt`` (``torch.load(..., weights_only=True)``)."""
    w = path / f"weights-{route}.npz"
    if w.is_file():
        try:
            with np.load(io.BytesIO(w.read_bytes()), allow_pickle=False) as z:
                return {k: z[k] for k in z.files}, w
        except Exception as exc:  # noqa: BLE001 - any unreadable archive is a bad file
            why = ("neither a zip archive nor an array file" if "allow_pickle" in str(exc)     # numpy's guess, not ours
                   else " ".join(str(exc).split())[:160])
            raise FileFormatError(f"{w}: not a weights file readable as NumPy arrays ({why}); 'beam-damage train' "
                                  "writes it") from None
    w = path / f"weights-{route}.pt"
    try:
        import torch  # torch: an older directory's weights file

        return torch.load(w, map_location="cpu", weights_only=True), w
    except FileNotFoundError:
        raise FileFormatError(f"{path / f'weights-{route}.npz'}: weights file missing") from None
    except Exception as exc:  # noqa: BLE001 - any unpickling failure is a bad file
        why = " ".join(str(exc).split())[:160]
        raise FileFormatError(f"{w}: not a weights file readable with weights_only=True ({why})") from None


def load_model(model_dir, device=None) -> TrainedModel:
    """Read a model directory (:func:`_weights`); its networks answer without torch (:mod:`learn.network.forward`)."""
    from learn.network.estimator import DamageClassifier  # scipy.special: the networks' forward pass

    path = Path(model_dir)
    cfg_path = path / "config.json"
    if cfg_path.exists() or cfg_path.is_symlink():  # there, but perhaps a device, a FIFO or a dangling link
        check_input_file(cfg_path, "json", what="a model directory's config.json")
    if not cfg_path.is_file():
        raise FileFormatError(f"{path}: not a model directory (no config.json); create one with 'beam-damage train'")
    config = read_json(cfg_path)
    if config.get("format") not in READ_FORMATS:
        raise FileFormatError(f"{cfg_path}: field 'format' is {config.get('format')!r}, expected {MODEL_FORMAT!r} "
                              "(fields and features differ between formats): re-create the model with "
                              "'beam-damage train'")
    for key, kind in (("route", str), ("networks", dict), ("beam", dict), ("classical_thresholds", dict),
                      ("best_classical", str)):
        if not isinstance(config.get(key), kind):
            raise FileFormatError(f"{cfg_path}: field {key!r} missing or not a {kind.__name__}; "
                                  f"re-create the model with 'beam-damage train'")
    model = TrainedModel(path, config)
    for route, meta in config.get("networks", {}).items():
        arrays, w = _weights(path, route)
        try:
            model.networks[route] = DamageClassifier.from_state(arrays, meta, device=device)
        except (KeyError, TypeError, ValueError, AttributeError, RuntimeError) as exc:
            why = " ".join(str(exc).split())[:160]
            raise FileFormatError(f"{w}: weights do not match the network described in {cfg_path.name} "
                                  f"({type(exc).__name__}: {why})") from None
    if config["route"] not in model.networks:
        raise FileFormatError(f"{cfg_path}: no network for its route {config['route']!r}")
    return model



def json_default(obj):
    """numpy values in ``json.dumps`` (NaN stays NaN, which ``json.loads`` reads back)."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.bool_, np.integer, np.floating)):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def sensitivity_of(beam: BeamSpec, config_root_spring=None, truth_beam: dict | None = None,
                   generator_config: dict | None = None):
    """FE sensitivities of the truth beam a dataset or model records (:func:`truth_numbers`), to the damage kind of
    its generator config (the default kind when it records none)."""
    return beam_sensitivity(truth_numbers(beam, truth_beam, generator_config), config_root_spring,
                            kind=recorded_config(generator_config).kind, test=beam.test)


def truth_numbers(beam: BeamSpec, truth_beam: dict | None = None, generator_config: dict | None = None):
    """The nominal beam a dataset or model records, as :func:`learn.explanations.sensitivity.beam_sensitivity` takes it:
    its ``(length_m, EI_Nm2, mass_per_length_kg_m, added masses)`` (the added masses of the generator config's beam
    file), or its preset's name when it records none."""
    if truth_beam and "EI_Nm2" in truth_beam:
        masses = tuple((float(p.get("x_m", truth_beam["length_m"])), float(p["mass_kg"]))    # the beam file's
                       for k, p in recorded_config(generator_config).effects.items() if effect_of(k) == "added_mass")
        return (truth_beam["length_m"], truth_beam["EI_Nm2"], truth_beam["mass_per_length_kg_m"], masses)
    return beam.name
