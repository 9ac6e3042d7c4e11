"""Train a damage classifier on generated datasets and evaluate it (the library behind ``train``/``evaluate``)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from datagen.config import recorded_config
from datagen.damage import damage_model
from datagen.store import package_version
from learn.explanations.classical import run_classical
from learn.network.estimator import DamageClassifier
from learn.network.evaluate import figures, metrics, table_rows
from learn.network.features import ROUTES, Pairs, feature_modes, features, labels, load_pairs, split_by_specimen
from learn.network.model_dir import (DEFAULT_ROUTE, MODEL_FORMAT, TrainedModel, json_default, save_model,
                                     sensitivity_of)
from learn.pairs.verdict import detectability_threshold, network_output
from physics.errors import BeamDamageError
from physics.io import atomic_write_text
from physics.modal import modal_parameters

__all__ = ["DAY_CHANGES", "MODE_ROUTES", "damping_ratio_range", "dataset_frfs", "day_changes", "evaluate",
           "targets", "train"]


def targets(pairs: Pairs) -> tuple[np.ndarray, dict]:
    """``y`` (n, 4) = [damaged, x/L, size, supports changed] and the full truth dict of
    :func:`labels`."""
    t = labels(pairs.table, pairs.beam)
    return np.stack([t["damaged"].astype(float), t["x_over_L"], t["size"],
                     t["support_changed"].astype(float)], axis=1), t


def damping_ratio_range(eigenvalues, coverage: float = 0.99) -> list[list[float]]:
    """Per mode, the central ``coverage`` range ``[lo, hi]`` of the measured baseline damping ratios of training
    pairs (``eigenvalues`` (n, 2, m)): what ``classify`` compares a test's damping with."""
    zeta = modal_parameters(np.asarray(eigenvalues)[:, 0])[1]
    q = np.nanquantile(zeta, [(1 - coverage) / 2, (1 + coverage) / 2], axis=0)
    return [[float(a), float(b)] for a, b in q.T]


def dataset_frfs(routes) -> tuple:
    """Dataset FRFs (:data:`datagen.synth.DATASET_FRFS`) the input routes need."""
    return tuple(r for r in routes if r not in ("modal", "frequency"))


#: Generator keys of the changes between two test days (datagen config section ``specimen``).
DAY_CHANGES = ("temperature_stiffness_change", "root_spring_change")


def day_changes(source: list) -> dict:
    """Temperature and re-clamping ranges of the first dataset's generator config."""
    return {k: recorded_config(source[0]["config"]).specimen[k] for k in DAY_CHANGES}



def _nominal_root_spring(source: list):
    r = recorded_config(source[0]["config"]).specimen["root_spring_relative"]
    return float(np.sqrt(r[0] * r[1])) if r else None


# --------------------------------------------------------------------------- train
def train(data, out_dir, *, epochs: int = 60, seed: int = 0, route: str | None = None, progress: bool = False,
          test_fraction: float = 0.15, threads: int | None = 1) -> dict:
    """Train the default-route network (and modal- and frequency-route companions), score it and the classical
    methods, save.

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
    routes = [route] + [r for r in ("modal", "frequency") if r != route]
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
    kind = recorded_config(pairs.source[0].get("config")).kind
    params = dict(epochs=epochs, random_state=seed, n_threads=threads, verbose=progress,
                  size_transform=damage_model(kind).size_transform)
    if pairs.beam.test is not None:
        params["zone_edges"] = [float(v) for v in pairs.beam.zone_edges_m / pairs.beam.length_m]
    networks, outputs, fit_s = _fit_networks(pairs, routes, y, (tr, te), sens, params)
    # classical thresholds on the day-to-day changes alone: no classical method tells a support change from damage
    day = tr[~truth["support_changed"][tr]]
    classical, thresholds = run_classical(pairs.eigenvalues[day], pairs.eigenvectors[day], sens,
                                          damaged=truth["damaged"][day])
    classical, _ = run_classical(pairs.eigenvalues[te], pairs.eigenvectors[te], sens, thresholds)
    truth_te = {k: v[te] for k, v in truth.items()}
    rows = table_rows(outputs + classical, truth_te, pairs.table.iloc[te].reset_index(drop=True), pairs.beam)
    base_all = [metrics(o, truth_te, None, "all", pairs.beam) for o in classical]
    best = max(base_all, key=lambda m: (np.nan_to_num(m.element_accuracy), -np.nan_to_num(m.median_location_error_mm)))
    config = {
        "format": MODEL_FORMAT, "route": route, "beam": pairs.beam.to_dict(), "seed": seed, "epochs": epochs,
        "grid_rad_s": pairs.beam.grid_rad_s, "dofs": list(pairs.beam.dofs),
        "training_data": [{k: s[k] for k in ("path", "manifest_checksum", "samples")} for s in pairs.source],
        "generator_config": pairs.source[0]["config"],
        "root_spring_relative": _nominal_root_spring(pairs.source),
        "truth_beam": pairs.source[0]["truth_beam"], "day_changes": changes,
        "detect_min_drop": detectability_threshold(),
        "classical_thresholds": thresholds, "best_classical": best.method,
        "split": {"train_pairs": int(len(tr)), "test_pairs": int(len(te)), "by": "specimen"},
        "train_seconds": fit_s, "load_seconds": load_s, "package_version": package_version(),
        "test_metrics": [m for m in rows if m["subset"] == "all"],
        "damping_ratio_range": damping_ratio_range(pairs.eigenvalues[tr]),
    }
    save_model(out_dir, config, networks)
    atomic_write_text(Path(out_dir) / "metrics.csv", pd.DataFrame(rows).to_csv(index=False))
    return {"model": str(out_dir), "route": route, "train_pairs": int(len(tr)), "test_pairs": int(len(te)),
            "train_seconds": fit_s, "load_seconds": load_s, "best_classical": best.method,
            "test_metrics": config["test_metrics"], "warnings": warnings}


#: Classifier inputs whose features are per mode: their networks answer pairs with missing modes.
MODE_ROUTES = ("modal", "frequency")


def _fit_networks(pairs: Pairs, routes: list, y, split: tuple, sens, params: dict):
    """One network per classifier input fitted on the training split and scored on the test split: the networks,
    their test outputs and fit seconds (``{input: DamageClassifier}``, list of MethodOutput, ``{input: s}``). The
    networks of :data:`MODE_ROUTES` answer pairs with missing modes (``DamageClassifier.feature_modes``)."""
    tr, te = split
    networks, outputs, fit_s = {}, [], {}
    for r in routes:
        X = features(pairs, r)
        masked = {"feature_modes": feature_modes(X.shape[1], pairs.beam.n_modes)} if r in MODE_ROUTES else {}
        test = pairs.beam.test                 # classify folds a symmetric beam read on frequencies alone
        mirrored = bool(test is not None and test.support.symmetric and (test.n_sensors == 1 or r == "frequency"))
        est = DamageClassifier(**params, **masked, mirrored=mirrored)
        est.fit(X[tr], y[tr], pairs.groups[tr])
        networks[r] = est
        fit_s[r] = est.train_seconds_
        outputs.append(network_output(est, X[te], sens, f"network ({r})")[0])
        del X
    return networks, outputs, fit_s


def evaluate(model: TrainedModel, data, out_dir=None, *, extra_outputs=None, progress: bool = False) -> dict:
    """Network(s) and classical methods on dataset(s) of the model's beam; table and figures."""
    routes = list(model.networks)
    pairs = load_pairs(data, frfs=dataset_frfs(routes))
    model.check_beam(pairs.beam, f"dataset {pairs.source[0]['path']}")
    _, truth = targets(pairs)
    sens = model.sensitivity
    outs = []
    for r in tqdm([model.route] + [q for q in routes if q != model.route], desc="evaluate networks",
                  disable=None if progress else True):          # None: only on a terminal
        outs.append(network_output(model.networks[r], features(pairs, r), sens, f"network ({r})")[0])
    classical, _ = run_classical(pairs.eigenvalues, pairs.eigenvectors, sens, model.config["classical_thresholds"])
    outs += classical + list(extra_outputs or [])
    rows = table_rows(outs, truth, pairs.table, pairs.beam)
    result = {"model": str(model.path), "data": [s["path"] for s in pairs.source], "pairs": len(pairs),
              "rows": rows, "figures": []}
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "metrics.csv", pd.DataFrame(rows).to_csv(index=False))
        atomic_write_text(out / "metrics.json", json.dumps(rows, indent=1, default=json_default))
        result["figures"] = figures(outs, truth, out, pairs.beam)
    return result

