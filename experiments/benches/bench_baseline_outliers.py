"""Benchmark: how often the baseline-outlier rule (:mod:`learn.monitor.baseline_outliers`) leaves a test out of an
outlier-free Gaussian baseline, and how often it finds one planted outlier.

Run: ``python -m experiments.benches.bench_baseline_outliers [--draws 300] [--large-draws 4000] [--rate 0.01]
[--out out/bench_baseline_outliers]``

Each draw: ``n`` baseline tests of ``m`` log frequencies, one common factor (0.3 %, a temperature) plus independent
0.1 % scatter; ``pca`` (no conditions) and ``regression`` on the factor measured. Null: the share of draws that lose
a test (family-wise ``rate`` targeted). Planted: one test's mode 2 read ``k`` percent high; the share of draws that
name that test (and only it). ``--draws`` baselines go through :func:`exclude_baseline_outliers` itself (each round
fits the model and simulates its critical ratio: slow, and 300 draws resolve a 1 % rate only to about 0.6 %);
``--large-draws`` baselines read the first round's verdict vectorised (:func:`held_out_pca`,
:func:`held_out_regression`: the models' own held-out indices), against the simulated critical ratio (``pca``: of
the model fitted to the first draw; ``regression``: of each of 8 designs of the conditions, drawn once, a share of
the draws each) and against the Bonferroni read of the law at ``rate / n`` (the rule without the simulation).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.harness import parser, table  # noqa: E402
from learn.monitor.alarm_threshold import (held_out_novelty, held_out_pca, held_out_regression,  # noqa: E402
                                           minimum_baseline)
from learn.monitor.baseline_outliers import (candidate_ratio, exclude_baseline_outliers, held_out_leverage,  # noqa: E402
                                             simulated_critical_ratio)
from scipy import stats  # noqa: E402
from learn.monitor.normal_models import NORMAL_MODELS  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["CASES", "DESIGNS", "draw", "large_sample", "main"]

#: ``(baseline tests, modes)``.
CASES = ((15, 3), (35, 4))
#: Planted outliers: mode 2 read this many percent high.
PLANTED_PCT = (0.0, 1.0)
#: Designs of the regression's conditions in :func:`large_sample`, whose held-out indices are computed this many
#: baselines at a time.
DESIGNS, CHUNK = 8, 2000


def draw(n: int, m: int, seed: int, planted_pct: float = 0.0):
    """``(X (n, m) log frequencies, C (n, 1) the measured factor)``; test 0 with mode 2 ``planted_pct`` high."""
    rng = np.random.default_rng(seed)
    C = rng.standard_normal((n, 1))
    X = np.log(10.0 * np.arange(1, m + 1) ** 2) + 3e-3 * C + 1e-3 * rng.standard_normal((n, m))
    X[0, 1] += np.log1p(planted_pct / 100)
    return X, C


def _named(X, C, model_name: str, rate: float) -> list:
    n, m = X.shape
    q = 1 if model_name == "regression" else 0

    def fitted(rows):
        Cr = C[rows] if q else None
        model = NORMAL_MODELS[model_name](m, q).fit(X[rows], Cr)
        return model, {"residual": (held_out_novelty(model.with_choices, X[rows], Cr), None)}
    return exclude_baseline_outliers(fitted, np.arange(n), rate, minimum_baseline(m, q), q,
                                     conditions=C if q else None)[3].indices


def large_sample(n: int, m: int, model_name: str, draws: int, rate: float, planted_pct: float, seed: int = 1):
    """``(share losing a test by the Bonferroni law, by the simulated critical ratio, naming only test 0 by it)`` of
    ``draws`` baselines of :func:`draw`'s law (first round, vectorised)."""
    rng = np.random.default_rng(seed)
    groups = DESIGNS if model_name == "regression" else 1
    law = simulated = only = 0
    for g in range(groups):
        b = draws // groups
        C = np.broadcast_to(rng.standard_normal((n, 1)), (b, n, 1)) if groups > 1 else rng.standard_normal((b, n, 1))
        X = np.log(10.0 * np.arange(1, m + 1) ** 2) + 3e-3 * C + 1e-3 * rng.standard_normal((b, n, m))
        X[:, 0, 1] += np.log1p(planted_pct / 100)
        if model_name == "regression":
            model = NORMAL_MODELS["regression"](m, 1).fit(X[0], C[0])
            res = np.concatenate([held_out_regression(X[j:j + CHUNK], C[0]) for j in range(0, b, CHUNK)])
            h = held_out_leverage(C[0])
            d2, critical = n - 1 - m - 1, simulated_critical_ratio(model, n, rate, C[0])
        else:
            model = NORMAL_MODELS["pca"](m, 0).fit(X[0])
            res = np.concatenate([held_out_pca(X[j:j + CHUNK], model.k_)[0] for j in range(0, b, CHUNK)])
            h = 0.0
            d2, critical = n - 1 - model.dof_, simulated_critical_ratio(model, n, rate)
        d1 = model.dof_
        bonferroni = stats.f.ppf(1 - rate / n, d1, 1 / (1 / d2 + 1 / ((n - 1) * d1)))
        law += int(np.sum(candidate_ratio(res, d1, d2)[1] > bonferroni))
        i, r = candidate_ratio(res / (1 + h), d1, d2)
        simulated += int(np.sum(r > critical))
        only += int(np.sum((r > critical) & (i == 0)))
    total = groups * (draws // groups)
    return law / total, simulated / total, only / total


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs=None, out="out/bench_baseline_outliers")
    p.add_argument("--draws", type=int, default=300)
    p.add_argument("--large-draws", type=int, default=4000)
    p.add_argument("--rate", type=float, default=0.01)
    a = p.parse_args(argv)
    rows, lines = [], []
    for n, m in CASES if a.draws else ():
        for model_name in ("pca", "regression"):
            for k in PLANTED_PCT:
                named = [_named(*draw(n, m, 10_000 + s, k), model_name, a.rate) for s in range(a.draws)]
                any_ = float(np.mean([bool(v) for v in named]))
                exact = float(np.mean([v == [0] for v in named]))
                rows.append({"n": n, "modes": m, "model": model_name, "planted_pct": k, "any": any_,
                             "only_the_planted": exact, "draws": a.draws})
                lines.append([n, m, model_name, f"{k:g} %" if k else "none", f"{100 * any_:.1f} %",
                              f"{100 * exact:.1f} %" if k else "-"])
                print(json.dumps(rows[-1]), flush=True)
    md = table(["baseline tests", "modes", "model", "planted (mode 2 high)", "draws losing a test",
                "naming only the planted test"], lines)
    large, big = [], []
    if a.large_draws:
        for n, m in CASES:
            for model_name in ("pca", "regression"):
                for k in PLANTED_PCT:
                    law, sim, only = large_sample(n, m, model_name, a.large_draws, a.rate, k)
                    large.append({"n": n, "modes": m, "model": model_name, "planted_pct": k, "law": law,
                                  "simulated": sim, "only_the_planted": only, "draws": a.large_draws})
                    big.append([n, m, model_name, f"{k:g} %" if k else "none", f"{100 * law:.2f} %",
                                f"{100 * sim:.2f} %", f"{100 * only:.2f} %" if k else "-"])
                    print(json.dumps(large[-1]), flush=True)
        md += "\n\n" + table(["baseline tests", "modes", "model", "planted (mode 2 high)",
                               "losing a test: Bonferroni law", "losing a test: simulated ratio",
                               "naming only the planted test (simulated)"], big)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "baseline_outliers.json",
                      json.dumps({"config": vars(a), "rows": rows, "large_sample": large}, indent=1))
    atomic_write_text(out / "baseline_outliers.md", md + "\n")
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
