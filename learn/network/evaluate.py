"""Metrics of damage detection, location and sizing, with breakdowns and figures.

All methods (network and classical methods) are scored by :func:`metrics` from the same
truth labels (:func:`learn.network.features.labels`) and a :class:`learn.explanations.classical.MethodOutput`.

Definitions
-----------
* *detectable* damage: its largest noise-free relative frequency drop exceeds
  ``min_drop`` (0.2 %); ROC AUC is computed on detectable damage against intact pairs.
* element accuracy / within one element: on detectable damage, the thesis's
  4-element grid (element ``floor(4 x / L) + 1``).
* location error (mm) and relative size error ``|s_hat / s - 1|``: medians over detectable damage.
* false-alarm rate: share of intact pairs called damaged.
* ECE: expected calibration error of ``probability`` (15 equal-width bins).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from learn.explanations.classical import FREQUENCY_METHODS
from learn.network.features import as_spec
from physics.io import atomic_write_bytes, figure_png, pyplot

__all__ = ["MIN_DROP", "Metrics", "NOISE_EDGES", "TIP_ZONE", "figures", "metrics", "mirrored_method", "reliability",
           "roc_auc", "roc_curve", "subsets", "table_rows"]

MIN_DROP = 0.002
TIP_ZONE = 0.85
#: Edges of the noise-level breakdown (FRF noise std relative to |H|; training range 0.1-3 %).
NOISE_EDGES = (0.0, 0.003, 0.01, 0.03, np.inf)


@dataclass(frozen=True)
class Metrics:
    """Scores of one method on one subset (NaN where undefined)."""

    method: str
    subset: str
    n_pairs: int
    n_damaged: int
    roc_auc: float
    accuracy: float
    false_alarm_rate: float
    detection_rate: float
    element_accuracy: float
    within_one_element: float
    median_location_error_mm: float
    median_size_error: float
    ece: float

    def row(self) -> dict:
        return asdict(self)


def roc_auc(score, positive) -> float:
    """Area under the ROC curve (Mann-Whitney, ties counted half); NaN if a class is missing."""
    s = np.asarray(score, float)
    y = np.asarray(positive, bool)
    if y.all() or not y.any():
        return float("nan")
    from scipy.stats import rankdata

    r = rankdata(s)
    n1, n0 = y.sum(), (~y).sum()
    return float((r[y].sum() - n1 * (n1 + 1) / 2) / (n1 * n0))


def roc_curve(score, positive):
    """False- and true-positive rates over all thresholds (descending score)."""
    s = np.asarray(score, float)
    y = np.asarray(positive, bool)
    o = np.argsort(-s, kind="stable")
    tp = np.concatenate([[0], np.cumsum(y[o])]) / max(y.sum(), 1)
    fp = np.concatenate([[0], np.cumsum(~y[o])]) / max((~y).sum(), 1)
    return fp, tp


def reliability(probability, outcome, n_bins: int = 15):
    """Reliability curve and expected calibration error.

    Returns
    -------
    confidence, frequency, count : ndarray, shape (n_bins,)   (NaN in empty bins)
    ece : float
    """
    p = np.asarray(probability, float)
    y = np.asarray(outcome, float)
    b = np.clip((p * n_bins).astype(int), 0, n_bins - 1)
    count = np.bincount(b, minlength=n_bins).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        conf = np.bincount(b, p, n_bins) / count
        freq = np.bincount(b, y, n_bins) / count
    ece = float(np.nansum(count * np.abs(conf - freq)) / max(count.sum(), 1))
    return conf, freq, count, ece


def mirrored_method(beam, name: str) -> bool:
    """Whether a method's location on ``beam`` is the mirror-ambiguous one: a symmetric beam
    (:attr:`physics.supports.Support.symmetric`) read with one sensor, or by a method that reads natural frequencies
    alone (the frequency route's network, Cawley-Adams, DLAC, MDLAC); such locations are scored folded onto
    ``x <= L / 2``."""
    test = as_spec(beam).test
    if test is None or not test.support.symmetric:
        return False
    return test.n_sensors == 1 or name == "network (frequency)" or name in FREQUENCY_METHODS


def metrics(out, truth: dict, mask=None, subset: str = "all", length_m: float = 0.6095,
            min_drop: float = MIN_DROP) -> Metrics:
    """Scores of ``out`` (:class:`learn.explanations.classical.MethodOutput`) against ``truth`` on rows ``mask``;
    ``length_m`` the beam's length or its :class:`learn.network.features.BeamSpec` (whose zones the element accuracy
    counts)."""
    spec = as_spec(length_m)
    length_m = spec.length_m
    n = len(truth["damaged"])
    m = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
    dam = truth["damaged"] & m
    intact = ~truth["damaged"] & m
    det = dam & (truth["max_drop"] > min_drop)
    verdict = np.asarray(out.damaged, bool)
    auc = roc_auc(out.score[det | intact], det[det | intact])
    acc = float(np.mean(verdict[m] == truth["damaged"][m])) if m.any() else float("nan")
    fa = float(np.mean(verdict[intact])) if intact.any() else float("nan")
    dr = float(np.mean(verdict[det])) if det.any() else float("nan")
    nan = float("nan")
    if det.any():
        x_true, x_hat = truth["x_over_L"][det], np.nan_to_num(out.x_over_L[det])
        el_true = truth["element"][det]
        if mirrored_method(spec, out.name):     # scored on the half x <= L/2, as classify answers
            x_true, x_hat = np.minimum(x_true, 1 - x_true), np.minimum(x_hat, 1 - x_hat)
            el_true = spec.zone_of_x_over_L(x_true)
        el_hat = spec.zone_of_x_over_L(x_hat)
        el_acc = float(np.mean(el_hat == el_true))
        within = float(np.mean(np.abs(el_hat - el_true) <= 1))
        loc = float(np.median(np.abs(x_hat - x_true)) * length_m * 1000)
        size = float(np.median(np.abs(out.size[det] / truth["size"][det] - 1)))
    else:
        el_acc = within = loc = size = nan
    ece = nan
    if out.probability is not None and m.any():
        ece = reliability(out.probability[m], truth["damaged"][m])[3]
    return Metrics(out.name, subset, int(m.sum()), int(dam.sum()), auc, acc, fa, dr, el_acc, within, loc, size, ece)


def subsets(truth: dict, table) -> dict:
    """Named row masks for the breakdowns: FRF noise level, size tercile, position (tip zone separately)."""
    n = len(truth["damaged"])
    out = {"all": np.ones(n, bool)}
    if "noise_level" in table:  # per-sample FRF noise (std relative to |H|)
        lvl = table["noise_level"].to_numpy(float)
        for lo, hi in zip(NOISE_EDGES[:-1], NOISE_EDGES[1:]):
            sel = (lvl >= lo) & (lvl < hi)
            if sel.any():
                out[f"noise {100 * lo:g}-{100 * hi:g} %" if np.isfinite(hi) else f"noise >= {100 * lo:g} %"] = sel
    dam = truth["damaged"]
    s = np.abs(truth["size"])              # a signed size (a mass lost) by its magnitude
    if dam.sum() >= 3:
        q = np.quantile(s[dam], [1 / 3, 2 / 3])
        for name, sel in (("size small", s <= q[0]), ("size medium", (s > q[0]) & (s <= q[1])),
                          ("size large", s > q[1])):
            out[f"{name}"] = ~dam | sel
    x = truth["x_over_L"]
    for k in range(1, 5):
        lo, hi = (k - 1) / 4, min(k / 4, TIP_ZONE) if k == 4 else k / 4
        out[f"element {k}" + (" (x/L<0.85)" if k == 4 else "")] = ~dam | ((x >= lo) & (x < hi))
    out["tip zone x/L>=0.85"] = ~dam | (x >= TIP_ZONE)
    return out


def table_rows(outputs, truth, table, length_m) -> list[dict]:
    """One row per (method, subset)."""
    rows = []
    for name, mask in subsets(truth, table).items():
        for o in outputs:
            rows.append(metrics(o, truth, mask, name, length_m).row())
    return rows


# --------------------------------------------------------------------------- figures
def figures(outputs, truth, out_dir, length_m: float, n_bins: int = 15) -> list[str]:
    """ROC, confusion matrix (zones, network), location error vs position, reliability (PNG, Agg); ``length_m`` the
    beam's length or its :class:`learn.network.features.BeamSpec`."""
    plt = pyplot()

    spec = as_spec(length_m)
    length_m = spec.length_m
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    det = truth["damaged"] & (truth["max_drop"] > MIN_DROP)
    intact = ~truth["damaged"]
    keep = det | intact
    paths = []

    fig, ax = plt.subplots(figsize=(5, 4.5))
    for o in outputs:
        fp, tp = roc_curve(o.score[keep], det[keep])
        ax.plot(fp, tp, label=f"{o.name} (AUC {roc_auc(o.score[keep], det[keep]):.3f})")
    ax.set(xlabel="false-positive rate (intact pairs)", ylabel=f"true-positive rate (largest drop > {MIN_DROP:.1%})",
           title="Detection ROC", xscale="log", xlim=(1e-3, 1))
    ax.legend(fontsize=7)
    paths.append(_save(fig, out_dir / "roc.png"))

    net = outputs[0]
    el_hat = np.where(net.damaged, spec.zone_of_x_over_L(np.nan_to_num(net.x_over_L)), 0)
    k = spec.zone_edges_m.size
    cm = np.zeros((k, k), int)
    np.add.at(cm, (truth["element"], el_hat), 1)
    fig, ax = plt.subplots(figsize=(4.5, 4))
    ax.imshow(cm, cmap="Blues")
    for i in range(k):
        for j in range(k):
            ax.text(j, i, cm[i, j], ha="center", va="center", fontsize=8)
    lab = ["intact"] + [str(z) for z in range(1, k)]
    what = "element" if spec.test is None else "zone"
    ax.set(xticks=range(k), yticks=range(k), xticklabels=lab, yticklabels=lab, xlabel=f"{net.name}: predicted",
           ylabel=f"true {what}", title=f"Confusion matrix ({k - 1} {what}s)")
    paths.append(_save(fig, out_dir / "confusion.png"))

    fig, ax = plt.subplots(figsize=(6, 4))
    dam = truth["damaged"]
    edges = np.linspace(0, 1, 21)
    c = 0.5 * (edges[1:] + edges[:-1])
    for o in outputs:
        err = np.abs(o.x_over_L - truth["x_over_L"]) * length_m * 1000
        b = np.clip(np.digitize(truth["x_over_L"], edges) - 1, 0, 19)
        med = [np.median(err[dam & (b == k)]) if (dam & (b == k)).any() else np.nan for k in range(20)]
        ax.plot(c, med, marker=".", label=o.name)
    ax.axvline(TIP_ZONE, color="grey", ls=":")
    ax.set(xlabel="true damage position x/L", ylabel="median location error (mm)", yscale="log",
           title="Location error vs position (all damaged pairs)")
    ax.legend(fontsize=7)
    paths.append(_save(fig, out_dir / "location_error.png"))

    fig, ax = plt.subplots(figsize=(4.5, 4.5))
    ax.plot([0, 1], [0, 1], color="grey", ls=":")
    for o in outputs:
        if o.probability is not None:
            conf, freq, cnt, ece = reliability(o.probability, truth["damaged"], n_bins)
            ax.plot(conf, freq, marker="o", label=f"{o.name} (ECE {ece:.3f})")
    ax.set(xlabel="predicted probability of damage", ylabel="observed frequency of damage", title="Reliability")
    ax.legend(fontsize=7)
    paths.append(_save(fig, out_dir / "reliability.png"))
    return paths


def _save(fig, path) -> str:
    atomic_write_bytes(path, figure_png(fig, bbox_inches="tight"))
    return str(path)
