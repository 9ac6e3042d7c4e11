"""Study ``damage-study``: localisation and sizing accuracy against noise, size and position.

Evaluates a trained classifier (``--model``-style directory; by default the demo's
``out/demo/model``, trained on a small ``training``-config dataset when absent) and every
classical method on the same held-out test pairs (``generate --config training``, other
seed), and draws one figure per metric with the breakdowns of
:func:`learn.network.evaluate.subsets` (FRF noise level, damage-size tercile, element of the
4-element grid with the tip zone x/L >= 0.85 apart) and one line per method.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from datagen.config import load_config, merge
from datagen.generation import generate
from experiments.studies.report import Figure, Section, Table
from learn.network.model_dir import load_model
from learn.network.training import evaluate, train
from physics.io import atomic_write_bytes, figure_png, pyplot

__all__ = ["run"]

METRICS = (("roc_auc", "detection ROC AUC"), ("element_accuracy", "element accuracy"),
           ("median_location_error_mm", "median location error (mm)"), ("median_size_error", "median size error"))


def _figure(rows, metric, label, path):
    plt = pyplot()

    subsets = list(dict.fromkeys(r["subset"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig, ax = plt.subplots(figsize=(10, 4.2))
    x = np.arange(len(subsets))
    for m in methods:
        y = [next((r[metric] for r in rows if r["method"] == m and r["subset"] == s), np.nan) for s in subsets]
        ax.plot(x, np.asarray(y, float), "o-", lw=1, ms=4, label=m)
    ax.set_xticks(x, subsets, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel(label)
    ax.set_xlabel("test subset (FRF noise level, damage size, position)")
    ax.set_title(f"{label} by noise, size and position")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    atomic_write_bytes(path, figure_png(fig))


def run(out_dir, model_dir="out/demo/model", n_test: int = 4000, n_train: int = 6000) -> tuple[dict, list]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model_dir = Path(model_dir)
    if not (model_dir / "config.json").exists():
        generate(out / "train-data", load_config("training"), n=n_train, seed=0, workers=2, progress=True)
        model_dir = out / "model"
        train(out / "train-data", model_dir, epochs=30, seed=0, progress=True)
    model = load_model(model_dir)
    beam = model.recorded.beam
    cfg = load_config("training")
    if beam:   # the model's own truth beam (e.g. the calibrated one of the demo)
        cfg = merge({"beam": beam}, base=cfg)
    generate(out / "test-data", cfg, n=n_test, seed=7, workers=2, progress=True)
    res = evaluate(model, out / "test-data", out / "evaluate", progress=True)
    rows = res["rows"]
    figs = []
    for metric, label in METRICS:
        path = out / f"damage_{metric}.png"
        _figure(rows, metric, label, path)
        figs.append(Figure(f"{label} of the network and every classical method by noise, size and position", str(path)))
    cols = ("method", "subset", "n_damaged", "roc_auc", "element_accuracy", "within_one_element",
            "median_location_error_mm", "median_size_error", "false_alarm_rate")
    table = [{c: r.get(c) for c in cols} for r in rows]
    summary = {"model": str(model_dir), "test_pairs": res["pairs"], "rows": rows}
    sec = Section("Damage study: localisation and sizing against noise, size and position",
                  (f"{res['pairs']} held-out test pairs (training config, seed 7) for the model in `{model_dir}`. "
                   "Sizes are terciles of the damage size (a slit's hinge flexibility); "
                   "intact pairs count in every subset's false alarms.",),
                  (Table.from_records("Every method on every subset", table),), tuple(figs))
    return summary, [sec]
