"""Benchmark: the detector's false alarms on later healthy tests, the healthy tests of monitored series re-split.

Run: ``python -m experiments.benches.bench_resplit MONITOR_JSON ... [--healthy 60] [--baseline 40] [--splits 4]
[--rate 0.01] [--gaussian] [--plug-in] [--formula-dof] [--seed 0]``

Each ``monitor.json`` (``beam-damage monitor --out DIR``; e.g. ``bench_unseen --kinds building``'s
``seedN/building/monitor``) gives its first ``--healthy`` tests' tracked frequencies. Each split draws ``--baseline``
of them as the baseline period at random and judges the others as later tests (:func:`learn.monitor.statistics.detect`
with the series' normal model refitted, the PCA by default): the share of later tests alarmed is the false-alarm
rate of new healthy tests, which the held-out baseline tests cannot show (below ``1 / (n + 1)`` per statistic their
threshold is at least their largest held-out index). ``--gaussian``: each series' features drawn again from a
Gaussian of their own mean and covariance (the same structure, Gaussian tails); ``--plug-in``: every threshold read
at its fitted scale, the scale's uncertainty not integrated out
(:meth:`learn.monitor.alarm_threshold.Threshold.law_at`); ``--formula-dof``: every law's denominator degrees of
freedom the formula's, none fitted to a heavy tail (:data:`learn.monitor.alarm_threshold.HEAVY_MIN` infinite).
Prints, per statistic, the later tests beyond its threshold against its rate times their count, and the family's
share.
"""

from __future__ import annotations

import json
import math
from contextlib import nullcontext
from dataclasses import replace
from unittest import mock

import numpy as np

from experiments.benches.harness import parser
from learn.monitor.alarm_threshold import Threshold
from learn.monitor.normal_models import NORMAL_MODELS
from learn.monitor.statistics import detect

__all__ = ["features", "main", "resplit"]


def features(path: str, n_healthy: int) -> np.ndarray:
    """``ln f`` (n_healthy, modes) of the first tests of a ``monitor.json`` (NaN: a mode not found)."""
    rows = json.loads(open(path).read())["tests"][:n_healthy]
    return np.log(np.array([[np.nan if v is None else v for v in r["frequencies_hz"]] for r in rows], float))


def resplit(X, n_baseline: int, splits: int, rate: float, rng, model: str = "pca") -> tuple:
    """``(beyond (K,), expected (K,), alarms, later, names)`` over ``splits`` random baseline/later splits of X."""
    beyond = expected = None
    alarms = later = 0
    names = ()
    for _ in range(splits):
        order = rng.permutation(len(X))
        b, r = np.sort(order[:n_baseline]), np.sort(order[n_baseline:])
        b, r = b[np.isfinite(X[b]).any(axis=1)], r[np.isfinite(X[r]).any(axis=1)]
        fitted = NORMAL_MODELS[model](X.shape[1], 0).fit(X[b], None)
        det = detect(fitted, fitted.with_choices, X, None, b, r, rate, 0)
        names = det.names
        over, exp = (det.ratios[r] > 1.0).sum(axis=0), det.rate_each * r.size
        beyond, expected = (over, exp) if beyond is None else (beyond + over, expected + exp)
        alarms, later = alarms + int(det.alarm[r].sum()), later + r.size
    return beyond, expected, alarms, later, names


def main(argv=None) -> int:
    p = parser(__file__, __doc__, seed=0)
    p.add_argument("files", nargs="+", help="monitor.json files")
    p.add_argument("--healthy", type=int, default=60, help="the first tests of each series, all healthy")
    p.add_argument("--baseline", type=int, default=40, help="baseline tests per split")
    p.add_argument("--splits", type=int, default=4)
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--gaussian", action="store_true", help="Gaussian features of each series' mean and covariance")
    p.add_argument("--plug-in", action="store_true", help="thresholds read at the fitted scale")
    p.add_argument("--formula-dof", action="store_true", help="no law's degrees of freedom fitted to a heavy tail")
    a = p.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    outs = []
    integrated = Threshold.law_at
    with mock.patch.object(Threshold, "law_at", lambda t, level: integrated(replace(t, scale_log_std=0.0), level)) \
            if a.plug_in else nullcontext(), \
            mock.patch("learn.monitor.alarm_threshold.HEAVY_MIN", math.inf) if a.formula_dof else nullcontext():
        for path in a.files:
            X = features(path, a.healthy)
            if a.gaussian:
                done = np.isfinite(X).all(axis=1)
                X = rng.multivariate_normal(X[done].mean(axis=0), np.cov(X[done].T), len(X))
            outs.append(resplit(X, a.baseline, a.splits, a.rate, rng))
    beyond, expected, alarms, later = (sum(column) for column in list(zip(*outs))[:4])
    names = outs[-1][4]
    print(f"{len(a.files)} series, {a.splits} splits each, {'Gaussian' if a.gaussian else 'measured'} features, "
          f"{'plug-in' if a.plug_in else 'integrated'} scale, {'formula' if a.formula_dof else 'fitted'} degrees "
          f"of freedom, rate {a.rate:g}")
    for nm, b, e in zip(names, beyond, expected):
        print(f"  {nm}: {int(b)} later tests beyond its threshold, {e:.1f} at its rate")
    print(f"  family: {alarms} of {later} later tests ({100 * alarms / later:.2f} %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
