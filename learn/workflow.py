"""Train, store, evaluate and apply a damage classifier (the library behind ``train``/``evaluate``/``classify``).

Model directory
---------------
``config.json``          beam it was trained for (name, length, DOF set, mass model; and the training data's
                         truth beam from its manifest), default input route, estimator parameters and
                         temperature per route, training data (paths, manifest checksums, generator config
                         with its temperature/re-clamping ranges), detection threshold, classical-method
                         thresholds, seed, package version, training time, test metrics
``weights-<route>.pt``   ``torch.save`` of the network's state dict plus the input normalisation and the
                         training features' precision matrix (loaded with ``weights_only=True``)
``metrics.csv``          test-split metrics of the network(s) and the classical methods

A model trained on the FRF route also carries a modal-route network, used for
inputs that are modal data only (the thesis's measured data).
"""

from __future__ import annotations

import functools

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from learn.classical import MethodOutput, run_classical
from learn.estimator import DamageClassifier
from learn.evaluate import MIN_DROP, metrics, table_rows
from learn.features import (DOFS, GRID_RAD_S, ROUTES, BeamSpec, Pairs, features, frf_features, labels, load_pairs,
                            map_frf_to_grid, modal_features, real_shapes, split_by_specimen)
from learn.sensitivity import beam_sensitivity
from physics.errors import BeamDamageError, FileFormatError
from physics.io import read_json
from physics.modal import mac

__all__ = ["DAY_CHANGES", "DEFAULT_ROUTE", "IDENTIFICATION", "IDENTIFICATION_BAND_FACTOR", "IN_DISTRIBUTION_PERCENTILE",
           "MODEL_FORMAT", "RATIO_TOLERANCE", "REFERENCE_WIDTH_M", "TrainedModel", "classify", "classify_many",
           "dataset_frfs", "day_changes", "detectability_threshold", "equivalent_depth", "evaluate", "frf_rows",
           "identification_band_hz", "identify_modes", "load_model", "ModalPair", "modal_pair", "network_output",
           "nominal_ratio_range", "on_model_dofs", "ood_percentile", "pair_modes", "save_model", "sensitivity_of",
           "targets", "train"]


#: Input route used by default (the winner of ``python -m experiments.bench_learn``).
DEFAULT_ROUTE = "modal"
#: Width assumed when a hinge flexibility is turned into a slit depth (m): middle of the training widths.
REFERENCE_WIDTH_M = 0.0055
MODEL_FORMAT = "beam-damage-model/3"


def targets(pairs: Pairs) -> tuple[np.ndarray, dict]:
    """``y`` (n, 3) = [damaged, x/L, hinge flexibility] and the full truth dict of :func:`labels`."""
    t = labels(pairs.table, pairs.beam.length_m)
    return np.stack([t["damaged"].astype(float), t["x_over_L"], t["hinge_flexibility"]], axis=1), t


def dataset_frfs(routes) -> tuple:
    """Dataset FRFs (:data:`datagen.synth.DATASET_FRFS`) the input routes need."""
    return tuple(r for r in routes if r != "modal")


#: Generator keys of the changes between two test days (datagen config section ``specimen``).
DAY_CHANGES = ("temperature_stiffness_change", "root_spring_change")


def day_changes(source: list) -> dict:
    """Temperature and re-clamping ranges of the first dataset's generator config."""
    spec = source[0]["config"]["specimen"]
    return {k: spec[k] for k in DAY_CHANGES}


# --------------------------------------------------------------------------- model directory
@dataclass
class TrainedModel:
    """A loaded model directory."""

    path: Path
    config: dict
    networks: dict = field(default_factory=dict)   # route -> DamageClassifier

    @property
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


def save_model(out_dir, config: dict, networks: dict) -> None:
    """Write the model directory atomically file by file (temp file, then rename)."""
    from physics.io import atomic_write_bytes, atomic_write_text
    import io

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for route, est in networks.items():
        tensors, meta = est.get_state()
        buf = io.BytesIO()
        torch.save(tensors, buf)
        atomic_write_bytes(out / f"weights-{route}.pt", buf.getvalue())
        config.setdefault("networks", {})[route] = meta
    atomic_write_text(out / "config.json", json.dumps(config, indent=1, sort_keys=True, default=_json_default))


def load_model(model_dir, device=None) -> TrainedModel:
    """Read a model directory (weights with ``torch.load(..., weights_only=True)``)."""
    path = Path(model_dir)
    cfg_path = path / "config.json"
    if not cfg_path.is_file():
        raise FileFormatError(f"{path}: not a model directory (no config.json); create one with 'beam-damage train'")
    config = read_json(cfg_path)
    if config.get("format") != MODEL_FORMAT:
        raise FileFormatError(f"{cfg_path}: field 'format' is {config.get('format')!r}, expected {MODEL_FORMAT!r} "
                              "(fields and features differ between formats): re-create the model with "
                              "'beam-damage train'")
    for key, kind in (("route", str), ("networks", dict), ("beam", dict), ("classical_thresholds", dict),
                      ("best_classical", str), ("reference_width_m", float)):
        if not isinstance(config.get(key), kind):
            raise FileFormatError(f"{cfg_path}: field {key!r} missing or not a {kind.__name__}; "
                                  f"re-create the model with 'beam-damage train'")
    model = TrainedModel(path, config)
    for route, meta in config.get("networks", {}).items():
        w = path / f"weights-{route}.pt"
        try:
            tensors = torch.load(w, map_location="cpu", weights_only=True)
        except FileNotFoundError:
            raise FileFormatError(f"{w}: weights file missing") from None
        except Exception as exc:  # noqa: BLE001 - any unpickling failure is a bad file
            why = " ".join(str(exc).split())[:160]
            raise FileFormatError(f"{w}: not a weights file readable with weights_only=True ({why})") from None
        try:
            model.networks[route] = DamageClassifier.from_state(tensors, meta, device=device)
        except (KeyError, TypeError, ValueError, AttributeError, RuntimeError) as exc:
            why = " ".join(str(exc).split())[:160]
            raise FileFormatError(f"{w}: weights do not match the network described in {cfg_path.name} "
                                  f"({type(exc).__name__}: {why})") from None
    if config["route"] not in model.networks:
        raise FileFormatError(f"{cfg_path}: no network for its route {config['route']!r}")
    return model


def _json_default(obj):
    """numpy values in ``json.dumps`` (NaN stays NaN, which ``json.loads`` reads back)."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.bool_, np.integer, np.floating)):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


# --------------------------------------------------------------------------- network outputs
def detectability_threshold() -> float:
    """Largest first-order frequency drop below which a slit counts as not detectable (0.2 %)."""
    return MIN_DROP


def network_output(est: DamageClassifier, X, sens, name="network") -> tuple[MethodOutput, object]:
    """Network answers as a :class:`MethodOutput` plus the full :class:`learn.estimator.DamagePrediction`."""
    d = est.predict_details(X)
    detectable = sens.largest_drop(d.x_over_L, d.hinge_flexibility) >= detectability_threshold()
    out = MethodOutput(name, d.probability_damaged, d.probability_damaged >= est.threshold_, d.x_over_L,
                       d.hinge_flexibility,
                       probability=d.probability_damaged, x_std_over_L=d.x_std_over_L,
                       hinge_flexibility_std=d.hinge_flexibility_std, detectable=detectable)
    return out, d


def sensitivity_of(beam: BeamSpec, config_root_spring=None, truth_beam: dict | None = None,
                   generator_config: dict | None = None):
    """FE sensitivities of the truth beam a dataset or model records (its preset when it records none), to the
    damage kind of its generator config (slits when it records none)."""
    kind = ((generator_config or {}).get("damage") or {}).get("kind", "slit")
    if truth_beam and "EI_Nm2" in truth_beam:
        key = (truth_beam["length_m"], truth_beam["EI_Nm2"], truth_beam["mass_per_length_kg_m"])
        return beam_sensitivity(key, config_root_spring, kind=kind)
    return beam_sensitivity(beam.name, config_root_spring, kind=kind)


def _nominal_root_spring(source: list):
    r = source[0]["config"]["specimen"]["root_spring_relative"]
    return float(np.sqrt(r[0] * r[1])) if r else None


# --------------------------------------------------------------------------- train
def train(data, out_dir, *, epochs: int = 60, seed: int = 0, route: str | None = None, progress: bool = False,
          test_fraction: float = 0.15, threads: int | None = 1) -> dict:
    """Train the default-route network (and a modal-route companion), score it and the classical methods, save.

    Parameters
    ----------
    data : path or sequence of paths
        Dataset directories of one beam, made by ``beam-damage generate --config training`` (intact and
        damaged specimens, temperature and re-clamping changes between the two test days).
    out_dir : model directory to write
    route : input route (default :data:`DEFAULT_ROUTE`)
    threads : torch CPU threads of the networks (``DamageClassifier.n_threads``; default 1)

    Returns
    -------
    dict  summary (route, sizes, training seconds, test metrics)
    """
    route = DEFAULT_ROUTE if route is None else route
    if route not in ROUTES:
        raise BeamDamageError(f"--route {route!r} must be one of {', '.join(ROUTES)}")
    routes = [route] + (["modal"] if route != "modal" else [])
    t0 = time.perf_counter()
    pairs = load_pairs(data, frfs=dataset_frfs(routes))
    y, truth = targets(pairs)
    if truth["damaged"].all() or not truth["damaged"].any():
        raise BeamDamageError("training data must hold both intact and damaged pairs: generate them with "
                              "'beam-damage generate --config training'")
    changes = day_changes(pairs.source)
    warnings = [] if any(v != [0.0, 0.0] for v in changes.values()) else [
        "the training data have no temperature/re-clamping changes between the test days: a model trained on "
        "them will call such changes damage; generate with --config training"]
    tr, _, te = split_by_specimen(pairs.groups, (1 - test_fraction, 0.0, test_fraction), seed=seed)
    load_s = time.perf_counter() - t0
    sens = sensitivity_of(pairs.beam, _nominal_root_spring(pairs.source), pairs.source[0].get("truth_beam"),
                          pairs.source[0].get("config"))
    networks, outputs, fit_s = {}, [], {}
    for r in routes:
        X = features(pairs, r)
        est = DamageClassifier(epochs=epochs, random_state=seed, n_threads=threads, verbose=progress)
        est.fit(X[tr], y[tr], pairs.groups[tr])
        networks[r] = est
        fit_s[r] = est.train_seconds_
        outputs.append(network_output(est, X[te], sens, f"network ({r})")[0])
        del X
    classical, thresholds = run_classical(pairs.eigenvalues[tr], pairs.eigenvectors[tr], sens,
                                          damaged=truth["damaged"][tr])
    classical, _ = run_classical(pairs.eigenvalues[te], pairs.eigenvectors[te], sens, thresholds)
    truth_te = {k: v[te] for k, v in truth.items()}
    rows = table_rows(outputs + classical, truth_te, pairs.table.iloc[te].reset_index(drop=True), pairs.beam.length_m)
    base_all = [metrics(o, truth_te, None, "all", pairs.beam.length_m) for o in classical]
    best = max(base_all, key=lambda m: (np.nan_to_num(m.element_accuracy), -np.nan_to_num(m.median_location_error_mm)))
    config = {
        "format": MODEL_FORMAT, "route": route, "beam": pairs.beam.to_dict(), "seed": seed, "epochs": epochs,
        "grid_rad_s": GRID_RAD_S, "dofs": list(DOFS),
        "training_data": [{k: s[k] for k in ("path", "manifest_checksum", "samples")} for s in pairs.source],
        "generator_config": pairs.source[0]["config"],
        "root_spring_relative": _nominal_root_spring(pairs.source),
        "truth_beam": pairs.source[0]["truth_beam"], "day_changes": changes,
        "detect_min_drop": detectability_threshold(),
        "reference_width_m": REFERENCE_WIDTH_M, "classical_thresholds": thresholds, "best_classical": best.method,
        "split": {"train_pairs": int(len(tr)), "test_pairs": int(len(te)), "by": "specimen"},
        "train_seconds": fit_s, "load_seconds": load_s, "package_version": _version(),
        "test_metrics": [m for m in rows if m["subset"] == "all"],
    }
    save_model(out_dir, config, networks)
    from physics.io import atomic_write_text
    atomic_write_text(Path(out_dir) / "metrics.csv", pd.DataFrame(rows).to_csv(index=False))
    return {"model": str(out_dir), "route": route, "train_pairs": int(len(tr)), "test_pairs": int(len(te)),
            "train_seconds": fit_s, "load_seconds": load_s, "best_classical": best.method,
            "test_metrics": config["test_metrics"], "warnings": warnings}


def _version() -> str:
    from datagen.store import package_version
    return package_version()


# --------------------------------------------------------------------------- evaluate
def evaluate(model: TrainedModel, data, out_dir=None, *, extra_outputs=None, progress: bool = False) -> dict:
    """Network(s) and classical methods on dataset(s) of the model's beam; table and figures."""
    from learn.evaluate import figures

    routes = list(model.networks)
    pairs = load_pairs(data, frfs=dataset_frfs(routes))
    model.check_beam(pairs.beam, f"dataset {pairs.source[0]['path']}")
    _, truth = targets(pairs)
    sens = sensitivity_of(model.beam, model.config.get("root_spring_relative"), model.config.get("truth_beam"),
                          model.config.get("generator_config"))
    from tqdm.auto import tqdm

    outs = []
    for r in tqdm([model.route] + [q for q in routes if q != model.route], desc="evaluate networks",
                  disable=not progress):
        outs.append(network_output(model.networks[r], features(pairs, r), sens, f"network ({r})")[0])
    classical, _ = run_classical(pairs.eigenvalues, pairs.eigenvectors, sens, model.config["classical_thresholds"])
    outs += classical + list(extra_outputs or [])
    rows = table_rows(outs, truth, pairs.table, pairs.beam.length_m)
    result = {"model": str(model.path), "data": [s["path"] for s in pairs.source], "pairs": len(pairs),
              "rows": rows, "figures": []}
    if out_dir is not None:
        from physics.io import atomic_write_text
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "metrics.csv", pd.DataFrame(rows).to_csv(index=False))
        atomic_write_text(out / "metrics.json", json.dumps(rows, indent=1, default=_json_default))
        result["figures"] = figures(outs, truth, out, pairs.beam.length_m)
    return result


# --------------------------------------------------------------------------- classify measured data
def on_model_dofs(data, beam: BeamSpec, beam_x_m=None, where: str = "measured data"):
    """Measured data moved onto the model's DOFs by position: ``(data on beam.dofs, DofMap or None)``.

    Positions come from the file's node geometry (FRF files that carry it), else a beam file's
    ``beam_x_m``, else the quarter-point convention (:func:`physics.io.map_measured_dofs`); each measured DOF
    at a node of the model's 4-element grid is used (others, e.g. extra sensors between the quarter points, are
    left out and named in the map's detail), and the model's DOFs (:attr:`BeamSpec.dofs`) must all be measured
    (refused naming the missing ones). Rows are selected and ordered as ``beam.dofs`` and
    relabelled with them; FRF references get the model DOF at their position too. DOFs labelled with a
    negative sense (``"3:-Y"``) are turned to the positive one first. An FRF file whose references, not its
    responses, cover the model's DOFs (a roving hammer, one accelerometer) is read by reciprocity
    (:meth:`physics.io.MeasuredFRF.reciprocal`). Modal data without ``dofs`` labels are returned as they are
    (rows taken as the model's DOFs, with a warning later).
    """
    from dataclasses import replace

    from physics.io import MeasuredFRF, map_frf_dofs, map_measured_dofs

    n = len(beam.dofs)
    grid_x = np.linspace(0.0, beam.length_m, n + 1)
    grid = tuple(f"{k}:y" for k in range(1, n + 2))
    kw = dict(length_m=beam.length_m, n_elements=n, beam_x_m=beam_x_m)
    data = data.with_positive_directions()
    if isinstance(data, MeasuredFRF):
        labels = tuple(dict.fromkeys(data.response_dofs + data.reference_dofs))
        dof_map = map_frf_dofs(data, labels, grid_x, grid, off_grid="ignore", **kw)
        to_model = dict(zip(labels, dof_map.model_dofs))
        at = lambda dofs: {to_model[d] for d in dofs}  # noqa: E731
        if not set(beam.dofs) <= at(data.response_dofs) and set(beam.dofs) <= at(data.reference_dofs):
            data = data.reciprocal()  # a roving-hammer test: the hammer positions are the responses
            dof_map = replace(dof_map, detail=dof_map.detail + "; responses at the hammer positions by "
                              "reciprocity (H_ij = H_ji, a roving-hammer test)")
        resp_map = replace(dof_map, dofs=data.response_dofs,
                           model_dofs=tuple(to_model[d] for d in data.response_dofs))
        resp = resp_map.rows(beam.dofs, where)
        return replace(data, frf=data.frf[resp], response_dofs=tuple(beam.dofs),
                       reference_dofs=tuple(to_model[d] or d for d in data.reference_dofs)), dof_map
    if not data.dofs or data.eigenvectors is None:
        return data, None
    dof_map = map_measured_dofs(data.dofs, grid_x, grid, where=where, off_grid="ignore", **kw)
    rows = dof_map.rows(beam.dofs, where)
    return replace(data, eigenvectors=data.eigenvectors[rows], dofs=tuple(beam.dofs)), dof_map


@dataclass(frozen=True)
class ModalPair:
    """The modes of one (baseline, current) pair on the model's DOFs that both tests hold.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (2, c)          baseline and current, ascending frequency
    eigenvectors : ndarray, complex, shape (2, n_dofs, c)
    modes : ndarray, int, shape (c,)                      0-based nominal modes they are (``[0, 1, 2, 3]`` when
                                                          both tests hold 4 modes)
    missing : tuple of str                                which of modes 1-4 a test lacks, and why (empty when
                                                          complete)
    warnings : tuple of str
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    modes: np.ndarray
    missing: tuple = ()
    warnings: tuple = ()

    @property
    def complete(self) -> bool:
        """Both tests hold modes 1-4 (what the modal network reads)."""
        return self.modes.size == 4


def pair_modes(frequencies_hz, nominal_hz, tolerance: float | None = None) -> np.ndarray:
    """The nominal mode each identified mode is: 0-based indices into ``nominal_hz``, -1 for none.

    The identified modes and the nominal beam's are aligned in frequency order: each identified mode pairs with
    one nominal mode or none, each nominal mode with at most one, minimising the sum of the squared log frequency
    ratios plus ``ln(1 + tolerance)^2`` per identified mode left unpaired (a spurious mode). A pairing farther
    than a factor ``1 + tolerance`` is never kept; modes 1-4 of a cantilever lie a factor 1.96 or more apart.

    Parameters
    ----------
    frequencies_hz : array, shape (k,)     identified natural frequencies (Hz), any order
    nominal_hz : array, shape (m,)         the nominal beam's natural frequencies (Hz), ascending
    tolerance : float, optional            default :data:`RATIO_TOLERANCE`

    Returns
    -------
    ndarray, int, shape (k,)  e.g. ``[0, 1, 3]`` for modes 1, 2 and 4 of a test that misses mode 3.
    """
    from itertools import combinations

    f = np.asarray(frequencies_hz, float)
    nominal = np.asarray(nominal_hz, float)
    order = np.argsort(f)
    cost = np.log(f[order, None] / nominal[None]) ** 2                 # (k, m)
    skip = np.log1p(RATIO_TOLERANCE if tolerance is None else tolerance) ** 2
    best, best_cost = np.full(f.size, -1), skip * f.size
    for r in range(1, min(f.size, nominal.size) + 1):
        for kept in combinations(range(f.size), r):
            for target in combinations(range(nominal.size), r):
                c = cost[kept, target].sum() + skip * (f.size - r)
                if c < best_cost:
                    best_cost = c
                    best = np.full(f.size, -1)
                    best[list(kept)] = target
    out = np.empty(f.size, int)
    out[order] = best
    return out


def modal_pair(baseline, current, beam: BeamSpec, nominal_hz, names=("baseline", "measured"),
               found=None) -> ModalPair:
    """The modes two :class:`physics.io.ModalData` of the model's DOFs both hold.

    Two tests of 4 or more modes give their 4 lowest. When either holds fewer, each test's modes are paired with
    the nominal beam's (:func:`pair_modes`, against ``nominal_hz``) and the modes both hold are kept; ``found``
    (one text per test, e.g. ``"LSCF/LSFD found 2 modes in 2-500 Hz"``) says in :attr:`ModalPair.missing` where
    the others went.
    """
    warnings = []
    lams, vecs = [], []
    for name, d in zip(names, (baseline, current)):
        if d.eigenvectors is None:
            raise FileFormatError(f"{name} modal data: field 'eigenvectors' is required "
                                  f"(rows = {', '.join(beam.dofs)})")
        dofs = tuple(_canonical_dof(x) for x in d.dofs) if d.dofs else None
        if dofs is None:
            if d.eigenvectors.shape[0] != len(beam.dofs):
                raise BeamDamageError(f"{name} modal data has {d.eigenvectors.shape[0]} DOFs but the model was trained "
                                      f"on {len(beam.dofs)} ({', '.join(beam.dofs)})")
            warnings.append(f"{name} modal data has no 'dofs': rows taken as {', '.join(beam.dofs)}")
        elif dofs != tuple(beam.dofs):
            raise BeamDamageError(f"{name} modal data: DOF set {list(d.dofs)} differs from the model's "
                                  f"{list(beam.dofs)}")
        o = np.argsort(np.abs(d.eigenvalues))[:4]
        lams.append(d.eigenvalues[o])
        vecs.append(d.eigenvectors[:, o])
    if all(x.size == 4 for x in lams):
        return ModalPair(np.stack(lams), np.stack(vecs), np.arange(4), (), tuple(warnings))
    found = [how or f"it holds {x.size} mode{'s' * (x.size != 1)}" for how, x in zip(found or (None, None), lams)]
    which = [pair_modes(np.abs(x) / (2 * np.pi), nominal_hz[:4]) for x in lams]
    common = np.intersect1d(*which)
    common = common[common >= 0]
    missing = []
    for name, how, k in zip(names, found, which):
        absent = [j + 1 for j in range(4) if j not in k]
        if absent:
            missing.append(f"mode{'s' * (len(absent) > 1)} {', '.join(map(str, absent))} not identified in {name} "
                           f"({how})")
    take = [[int(np.flatnonzero(k == j)[0]) for j in common] for k in which]
    return ModalPair(np.stack([x[t] for x, t in zip(lams, take)]), np.stack([v[:, t] for v, t in zip(vecs, take)]),
                     common, tuple(missing), tuple(warnings))


def _canonical_dof(label: str) -> str:
    from physics.io import parse_dof
    node, direction = parse_dof(label)
    names = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}
    return f"{node}:{names.get(abs(direction), str(direction))}"


def frf_rows(frf, beam: BeamSpec):
    """Receptances at the model's DOFs driven at its first DOF, shape (4, F); None if the file lacks some."""
    f = frf.to_kind("receptance") if frf.frequency_hz[0] > 0 else frf.select_band(fmin_hz=1e-9).to_kind("receptance")
    resp = [_canonical_dof(d) for d in f.response_dofs]
    ref = [_canonical_dof(d) for d in f.reference_dofs]
    if beam.dofs[0] not in ref or any(d not in resp for d in beam.dofs):
        return None, f
    j = ref.index(beam.dofs[0])
    return np.stack([f.frf[resp.index(d), j] for d in beam.dofs]), f


def ood_percentile(est: DamageClassifier, X) -> tuple[np.ndarray, np.ndarray]:
    """Mahalanobis distances of feature rows to the training features, and the percentage of training pairs
    at or below each distance: arrays of shape (n,)."""
    d = est.mahalanobis(X)
    return d, np.searchsorted(est.reference_distances_, d, side="right") / est.reference_distances_.size * 100


#: Training percentile of the Mahalanobis distance above which a pair counts as outside the training data.
IN_DISTRIBUTION_PERCENTILE = 99.9

#: The identification ``classify`` runs on FRF files: LSCF poles and LSFD residues, the 4 lowest modes. The
#: training data's modal noise (``measurement.modal_noise = "calibrated"``) is calibrated against this path
#: (``experiments.bench_modal_noise``), and the dataset records it (``measurement.identification``).
IDENTIFICATION = {"method": "lscf", "n_modes": 4}
#: The band identified ends at this multiple of the model's nominal mode-4 frequency (mode 5 of a cantilever
#: lies at 1.65 times mode 4; above the band, modes act through the upper residual).
IDENTIFICATION_BAND_FACTOR = 1.4


def identification_band_hz(frf, fmax_hz: float | None = None) -> tuple[float, float]:
    """Band (Hz) :func:`identify_modes` fits: the file's lines from the first above 0 Hz up to ``fmax_hz``."""
    f = frf.frequency_hz
    return float(f[f > 0][0]), float(f[-1] if fmax_hz is None else min(f[-1], fmax_hz))


def identify_modes(frf, fmax_hz: float | None = None, where: str = "FRF file"):
    """Modal data of one FRF file by :data:`IDENTIFICATION` (the path the training data's modal noise describes).

    Parameters
    ----------
    frf : :class:`physics.io.MeasuredFRF` on the model's DOFs
    fmax_hz : float, optional
        Upper end of the band fitted (Hz), between the beam's modes 4 and 5, so that the 4 modes identified are
        the 4 lowest.

    Returns
    -------
    :class:`physics.io.ModalData` with the modes identified in the band (at most 4; fewer when the band stops
    below mode 4 or a mode sinks into the noise floor: :func:`pair_modes` tells which they are).
    """
    import warnings

    from physics.identification import identify_frf

    band = None
    if fmax_hz is not None and frf.frequency_hz[-1] > fmax_hz:
        band = identification_band_hz(frf, fmax_hz)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ident = identify_frf(frf, method=IDENTIFICATION["method"], n_modes=IDENTIFICATION["n_modes"],
                                 band_hz=band)
    except (np.linalg.LinAlgError, RuntimeError) as exc:
        raise BeamDamageError(f"{where}: LSCF/LSFD identification failed ({exc})") from None
    return ident.modal_data


#: Tolerance on the measured frequency ratios ``f_k / f_1`` against the model's nominal beam: wide enough for
#: another stiffness, root or shear flexibility (shear lowers f4/f1 by about 10 %), narrow against a missing or
#: spurious mode (which moves a ratio by a factor of 2.6 or more).
RATIO_TOLERANCE = 0.35


def nominal_ratio_range(sens) -> np.ndarray:
    """Accepted range of the frequency ratios ``f_k / f_1`` (k = 2..4), shape (3, 2): the nominal beam's ratios
    times ``1 -+ RATIO_TOLERANCE``."""
    r = sens.frequencies_hz[1:4] / sens.frequencies_hz[0]
    return np.stack([r * (1 - RATIO_TOLERANCE), r * (1 + RATIO_TOLERANCE)], axis=1)


def _mode_checks(lam, vecs, ratio_range) -> list[list[str]]:
    """Per pair, reasons it lies outside what the modal network was trained on: a frequency ratio ``f_k / f_1``
    outside the accepted range (a missing or spurious mode), or baseline and current modes that do not pair
    (MAC < 0.8)."""
    f = np.abs(lam) / (2 * np.pi)                                 # (n, 2, 4)
    ratio = f[..., 1:] / f[..., :1]                               # (n, 2, 3)
    u = real_shapes(vecs)                                         # (n, 2, 4, m)
    pairing = np.diagonal(mac(u[:, 0], u[:, 1]), axis1=-2, axis2=-1)  # (n, m)
    reasons = []
    for i in range(f.shape[0]):
        r = [f"{name} f{k + 2}/f1 = {ratio[i, s, k]:.4g} lies outside the nominal beam's "
             f"{ratio_range[k, 0]:.4g}-{ratio_range[k, 1]:.4g} (a missing or spurious mode)"
             for s, name in enumerate(("baseline", "measured")) for k in range(3)
             if not ratio_range[k, 0] <= ratio[i, s, k] <= ratio_range[k, 1]]
        r += [f"mode {k + 1} of the baseline and the measured test do not pair (MAC {pairing[i, k]:.2f} < 0.8)"
              for k in range(4) if pairing[i, k] < 0.8]
        reasons.append(r)
    return reasons


def _modal_inputs(model: TrainedModel, baseline, currents: list, names: list[str], sens):
    """Modal data of the baseline and every current input: ``(ModalData, list of ModalData, identified, found)``,
    ``found`` one text per input on the modes it holds (e.g. "LSCF/LSFD found 2 modes in 2-500 Hz")."""
    from physics.io import MeasuredFRF

    inputs = [baseline, *currents]
    kinds = {isinstance(d, MeasuredFRF) for d in inputs}
    if len(kinds) > 1:
        raise BeamDamageError("BASELINE and MEASURED must all be FRF files or all modal data")
    if not kinds.pop():
        return baseline, list(currents), False, None
    fmax = IDENTIFICATION_BAND_FACTOR * float(sens.frequencies_hz[3])
    try:
        ids = [identify_modes(d, fmax, n) for d, n in zip(inputs, names)]
    except BeamDamageError:
        if model.route == "modal":
            raise
        return None, None, True, None          # an FRF-route model classifies the FRFs without modes
    found = []
    for d, md in zip(inputs, ids):
        k = md.eigenvalues.size
        lo, hi = identification_band_hz(d, fmax)
        found.append(f"LSCF/LSFD found {k} mode{'s' * (k != 1)} in {lo:.4g}-{hi:.4g} Hz")
    return ids[0], ids[1:], True, found


def _frf_route_features(model: TrainedModel, baseline, currents, warnings: list):
    """Grid features of the model's FRF route for (baseline, current) FRF pairs, or None if the files lack DOFs."""
    rows_b = frf_rows(baseline, model.beam)
    rows_c = [frf_rows(c, model.beam) for c in currents]
    if rows_b[0] is None or any(r[0] is None for r in rows_c):
        return None
    if model.route == "updated":
        warnings.append("the updated-model route is fed with the measured FRFs (no updating of measured FRFs here)")

    def grid(r):
        H, f = r
        w = f.omega_rad_s
        if w[0] > GRID_RAD_S[0] * 1.001 or w[-1] < GRID_RAD_S[-1] * 0.999:
            msg = (f"FRF lines cover {w[0]:.4g}-{w[-1]:.4g} rad/s, the model's grid "
                   f"{GRID_RAD_S[0]:.4g}-{GRID_RAD_S[-1]:.4g} rad/s: nearest values used outside")
            if msg not in warnings:
                warnings.append(msg)
        return map_frf_to_grid(H, w)

    gb = grid(rows_b)
    return frf_features(np.stack([np.stack([gb, grid(r)]) for r in rows_c]))


def _network_answer(d, i, out, L, depth) -> dict:
    return {"damaged": bool(out.damaged[i]), "probability_damaged": float(d.probability_damaged[i]),
            "location_x_over_L": float(d.x_over_L[i]), "location_x_m": float(d.x_over_L[i] * L),
            "location_std_m": float(d.x_std_over_L[i] * L), "location_element": int(d.element[i]),
            "element_probabilities": [float(v) for v in d.element_probabilities[i]],
            "hinge_flexibility": float(d.hinge_flexibility[i]),
            "hinge_flexibility_std": float(d.hinge_flexibility_std[i]),
            "depth_m": depth, "detectable": bool(out.detectable[i])}


def _classical_answer(o: MethodOutput, i, L) -> dict:
    return {"method": o.name, "damaged": bool(o.damaged[i]), "location_x_over_L": float(o.x_over_L[i]),
            "location_x_m": float(o.x_over_L[i] * L), "location_element": int(min(int(o.x_over_L[i] * 4) + 1, 4)),
            "hinge_flexibility": float(o.hinge_flexibility[i]), "score": float(o.score[i])}


def classify(model: TrainedModel, baseline, current) -> dict:
    """Verdict for one measured pair: :func:`classify_many` with one current input."""
    return classify_many(model, baseline, [current])[0]


def classify_many(model: TrainedModel, baseline, currents: list, names: list[str] | None = None) -> list[dict]:
    """Verdicts for tests of one beam against the same baseline (one network call for all pairs).

    Parameters
    ----------
    baseline : :class:`physics.io.ModalData` or :class:`physics.io.MeasuredFRF`
        The undamaged state, on the model's DOFs (:func:`on_model_dofs`).
    currents : list of the same kind as ``baseline``
    names : list of str, optional
        Names of the inputs (baseline first) for messages.

    FRF files are identified by :data:`IDENTIFICATION` (LSCF/LSFD, the path the training data's modal noise
    describes); the modal-route network and every classical method read those modes. A model on an FRF route
    reads the FRFs themselves (any frequency lines, mapped onto its grid).

    A pair whose tests do not both hold modes 1-4 (a band that stops below mode 4, a mode lost in the noise
    floor) is classified on the modes both hold (:func:`modal_pair`) by every classical method; the modal
    network, trained on 4 modes, gives no answer for it (``network`` None). Fewer than 2 common modes are refused
    when the modal network would have to read them.

    Returns
    -------
    list of dict, one verdict per current input. The verdict keys (``damaged``, ``location_*``,
    ``hinge_flexibility*``...) are the network's answer when the pair lies inside the training data
    (``in_distribution``: its Mahalanobis distance within the :data:`IN_DISTRIBUTION_PERCENTILE` percentile of
    the training pairs', its modes 1-4 all present, in their training ranges and paired), else the classical
    method's (``verdict_from``); ``network`` and ``classical`` hold both answers, ``classical_methods`` every
    method's.
    """
    names = list(names) if names else ["baseline"] + [f"measured {k + 1}" for k in range(len(currents))]
    warnings: list[str] = []
    sens = sensitivity_of(model.beam, model.config.get("root_spring_relative"), model.config.get("truth_beam"),
                          model.config.get("generator_config"))
    base_md, cur_md, identified, found = _modal_inputs(model, baseline, currents, names, sens)
    pairs = None
    if base_md is not None:
        found = found or [None] * len(names)
        pairs = [modal_pair(base_md, c, model.beam, sens.frequencies_hz, (names[0], n), (found[0], f))
                 for c, n, f in zip(cur_md, names[1:], found[1:])]
        warnings += list(dict.fromkeys(w for p in pairs for w in p.warnings))
    else:
        warnings.append("LSCF/LSFD identification failed: no classical answer; the FRF-route network alone")
    route, X, rows = _network_inputs(model, baseline, currents, pairs, identified, warnings)
    if route == "modal":
        for p, n in zip(pairs, names[1:]):
            if p.modes.size < 2:
                raise BeamDamageError(f"{n}: {p.modes.size} of modes 1-4 found in both it and {names[0]} ("
                                      + "; ".join(p.missing) + "); classify needs at least 2 common modes")
    est = model.networks[route]
    at = {i: r for r, i in enumerate(rows)}
    if rows:
        out, d = network_output(est, X, sens)
        dist, pct = ood_percentile(est, X)
    answers, mode_reasons, mode_sens = _classical_answers(model, pairs, len(currents), sens)
    depth = functools.partial(equivalent_depth, preset=model.config.get("truth_beam") or model.beam.name,
                              width_m=model.config["reference_width_m"])
    L = model.beam.length_m
    results = []
    for i in range(len(currents)):
        r = at.get(i)
        net = None if r is None else _network_answer(d, r, out, L, depth(float(d.hinge_flexibility[r])))
        cl = next((a for a in answers[i] if a["method"] == model.config["best_classical"]),
                  answers[i][0] if answers[i] else None)
        p = pairs[i] if pairs else None
        reasons = list(mode_reasons[i])
        if net is None:
            reasons.append("; ".join(p.missing) + ": the network needs modes 1-4")
        elif pct[r] > IN_DISTRIBUTION_PERCENTILE:
            reasons.insert(0, f"Mahalanobis distance {dist[r]:.3g} from the training data, beyond "
                              f"{pct[r]:.2f}% of training pairs")
        inside = not reasons
        w = list(warnings)
        modes_text = ", ".join(str(j + 1) for j in p.modes) if p is not None else ""
        if net is None:
            w.append(f"the network gives no answer for this pair (it needs modes 1-4): the verdict is the classical "
                     f"method's ({cl['method']}) on modes {modes_text}")
            verdict = _classical_verdict(cl, mode_sens[i], depth)
        elif inside or cl is None:
            verdict = dict(net)
            if not inside:
                w.append("the pair lies outside the training data (" + "; ".join(reasons) + ") and no classical "
                         "answer is available: treat the network's verdict with caution")
        else:
            w.append("the pair lies outside the training data (" + "; ".join(reasons) + "): the verdict is the "
                     f"classical method's ({cl['method']}"
                     + ("" if p is None or p.complete else f" on modes {modes_text}")
                     + "); the network's answer is shown beside it")
            verdict = _classical_verdict(cl, mode_sens[i], depth)
        from_network = net is not None and (inside or cl is None)
        if p is None:
            freqs, modes = ([], []), []
        elif p.complete:
            freqs, modes = np.abs(p.eigenvalues) / (2 * np.pi), [1, 2, 3, 4]
        else:                      # every mode found, paired or not
            freqs = [np.sort(np.abs(md.eigenvalues)) / (2 * np.pi) for md in (base_md, cur_md[i])]
            modes = [int(j) + 1 for j in p.modes]
        results.append({
            "measured": names[i + 1], **verdict, "verdict_from": "network" if from_network else "classical",
            "in_distribution": inside, "out_of_distribution_reasons": reasons,
            "mahalanobis_distance": None if r is None else float(dist[r]),
            "training_percentile": None if r is None else float(pct[r]),
            "network": net, "classical": cl,
            "classical_methods": answers[i],
            "identification": {**IDENTIFICATION, "source": "identified from FRFs" if identified else "modal data",
                               "baseline_frequencies_hz": [float(x) for x in freqs[0]],
                               "measured_frequencies_hz": [float(x) for x in freqs[1]],
                               "modes_classified": modes},
            "input_route": route, "warnings": w,
            "_extra": {"location_distribution": None if r is None else d.location_distribution[r]},
        })
    return results


def _classical_answers(model: TrainedModel, pairs, n: int, sens):
    """Every classical method's answers per pair, the reasons a complete pair's modes lie outside the training
    data, and the sensitivities of the modes each pair was classified on: three lists of ``n``.

    Complete pairs are classified in one call on modes 1-4; the others each on the modes both tests hold (the
    sensitivities of those modes alone), none below 2 common modes."""
    L = model.beam.length_m
    thresholds = model.config["classical_thresholds"]
    answers, reasons, mode_sens = [[] for _ in range(n)], [[] for _ in range(n)], [sens] * n
    if pairs is None:
        return answers, reasons, mode_sens
    full = [i for i, p in enumerate(pairs) if p.complete]
    if full:
        lam = np.stack([pairs[i].eigenvalues for i in full])
        vecs = np.stack([pairs[i].eigenvectors for i in full])
        outs, _ = run_classical(lam, vecs, sens, thresholds)
        for j, (i, why) in enumerate(zip(full, _mode_checks(lam, vecs, nominal_ratio_range(sens)))):
            answers[i], reasons[i] = [_classical_answer(o, j, L) for o in outs], why
    for i, p in enumerate(pairs):
        if not p.complete and p.modes.size >= 2:
            mode_sens[i] = sens.modes(p.modes)
            outs, _ = run_classical(p.eigenvalues[None], p.eigenvectors[None], mode_sens[i], thresholds)
            answers[i] = [_classical_answer(o, 0, L) for o in outs]
    return answers, reasons, mode_sens


def _network_inputs(model: TrainedModel, baseline, currents: list, pairs, identified: bool, warnings: list):
    """Route, feature rows and the pairs they belong to: ``(route, X, rows)``.

    ``X`` are the FRF-route features of every pair when the model reads FRFs and the inputs are FRF files, else
    the modal features of the pairs whose tests both hold modes 1-4 (``rows``: their indices; ``X`` None when
    there are none). Warnings are appended to ``warnings``.
    """
    if identified and model.route in ("measured", "updated"):
        X = _frf_route_features(model, baseline, currents, warnings)
        if X is not None:
            return model.route, X, list(range(len(currents)))
    if pairs is None:
        raise BeamDamageError(f"the files hold neither the FRFs the model's {model.route} route reads "
                              "nor identifiable modes")
    if "modal" not in model.networks:
        raise BeamDamageError("this model has no modal-route network; give FRF files holding receptances at "
                              f"{', '.join(model.beam.dofs)} driven at {model.beam.dofs[0]}")
    rows = [i for i, p in enumerate(pairs) if p.complete]
    X = None
    if rows:
        X = modal_features(np.stack([pairs[i].eigenvalues for i in rows]),
                           np.stack([pairs[i].eigenvectors for i in rows]))
    calibrated = (model.config.get("generator_config") or {}).get("measurement", {}).get("identification")
    if identified and calibrated != IDENTIFICATION:
        warnings.append("the training data's modal noise was not calibrated against the identification run "
                        "here: retrain on data from 'beam-damage generate --config training'")
    return "modal", X, rows


def _classical_verdict(cl: dict, sens, depth) -> dict:
    """The verdict keys from the classical method's answer ``cl`` (no probabilities or spreads)."""
    detectable = sens.largest_drop(np.array([cl["location_x_over_L"]]), np.array([cl["hinge_flexibility"]]))[0]
    return {"damaged": cl["damaged"], "probability_damaged": None,
            "location_x_over_L": cl["location_x_over_L"], "location_x_m": cl["location_x_m"],
            "location_std_m": None, "location_element": cl["location_element"],
            "element_probabilities": None, "hinge_flexibility": cl["hinge_flexibility"],
            "hinge_flexibility_std": None, "depth_m": depth(cl["hinge_flexibility"]),
            "detectable": bool(detectable >= detectability_threshold())}


def equivalent_depth(hinge_flexibility: float, preset, width_m: float) -> float | None:
    """Depth (m) of a slit ``width_m`` wide of that hinge flexibility (:func:`datagen.damage.slit.equivalent_depth`)."""
    from datagen.config import DEFAULTS
    from datagen.damage.slit import equivalent_depth as slit_depth

    return slit_depth(hinge_flexibility, preset, width_m, DEFAULTS["section"])
