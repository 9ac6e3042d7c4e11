"""Benchmark: how much of the long series' false-alarm excess is chance, and the held-out statistics corrected for
the baseline's autocorrelation (:mod:`experiments.benches.effective_size`), beside the plain tests.

Run: ``python -m experiments.benches.bench_effective_size [--cases daily 30min] [--models pca] [--seeds 0 1 2 3]
[--rate 0.01] [--draws 2000] [--false-alarms-only] [--out out/bench_effective_size]``; ``python -m
experiments.benches.bench_effective_size --real DIR [bench_real_series's options]``: ``bench_real_series`` with
``monitor``'s held-out statistics corrected (its output in ``DIR``; copy ``out/bench_real_series/cache`` there first
to reuse the identifications)

Series and damages as :mod:`experiments.benches.bench_detection` (``daily``, ``30min``; every damage and size of
its table). Per seed and model:

* ``combined``: ``monitor``'s alarm (:func:`~learn.monitor.statistics.detect`, the union's level);
  ``combined, n_eff``: the same with the held-out statistics scaled by the prediction factor of their effective
  sample size (:func:`~experiments.benches.effective_size.inflate_held`); ``plain shift, both signs``,
  ``plain per mode``
  (:func:`~experiments.benches.plain_tests.plain_alarms`, plotting position).
* chance (a model of the series): the lag-1 autocorrelation of the normal scores of ``combined``'s ratio over
  the intact second year (``rho_1``), and the AR(1) coefficient matched to its autocorrelation at one day's lag
  (``rho_day``, the ``tests a day``-th root; ``rho_1`` for the daily series); per case, for their median over the
  seeds, the share of :func:`~experiments.benches.effective_size.false_alarm_spread`'s draws above twice the rate: a
  detector exact at the rate (``exact``) and one whose threshold is the plotting-position quantile of a baseline
  year of the same AR(1) series (``from baseline``).
* chance (the alarms' own episodes): the sizes of ``combined``'s alarm episodes (alarms at most a day apart) on the
  held-out baseline year and on the intact second year, pooled over the seeds; a detector exact at the rate alarms
  on a Poisson number of episodes of those sizes (:func:`~experiments.benches.effective_size.episode_spread`;
  ``n_eff = n E[S] / E[S^2]``), ``from baseline`` its share on the second year less its share on the first plus the
  rate (a threshold at the first year's quantile: ``1 - F(q) = rate + F_1(q) - F(q)`` to first order).

Each seed's row is cached in ``--out``/rows (delete it to run again); writes ``effective_size.json`` and
``effective_size.md`` in ``--out``.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import learn.monitor.alarms as monitor_alarms  # noqa: E402
from experiments.benches import bench_real_series  # noqa: E402
from experiments.benches.bench_detection import DAMAGES, SIZES_PCT, _case  # noqa: E402
from experiments.benches.harness import parser, table  # noqa: E402
from experiments.benches.plain_tests import plain_alarms  # noqa: E402
from experiments.second_sim.series import drop_pattern, frequency_series  # noqa: E402
from experiments.benches.effective_size import (alarm_episodes, effective_size, episode_spread,  # noqa: E402
                                          false_alarm_spread, inflate_held, lag1_autocorrelation,
                                          prediction_inflation)
from learn.monitor.normal_models import NORMAL_MODELS  # noqa: E402
from learn.monitor.statistics import detect, held_out_statistics  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["COLUMNS", "main", "run_case"]

COLUMNS = ("combined", "combined, n_eff", "plain shift, both signs", "plain per mode")


def _normal_scores(x) -> np.ndarray:
    x = np.asarray(x, float)
    return stats.norm.ppf((stats.rankdata(x) - 0.5) / len(x))


def _lag_corr(x, lag: int) -> float:
    x = x - x.mean()
    return float(x[lag:] @ x[:-lag] / (x @ x) * len(x) / (len(x) - lag))


def run_case(case: str, model_name: str, seed: int, rate: float, damages: bool = True) -> dict:
    """One seed's false alarms and detections (%) per column of :data:`COLUMNS`, the effective sizes and the
    autocorrelation of ``combined``'s ratio over the intact second year."""
    cfg, nb, onset, per_day = _case(case, seed)
    fs = frequency_series(cfg)
    C = None if model_name == "pca" else fs.measured_temperature_c[:, None]
    q = 0 if C is None else 1
    model = NORMAL_MODELS[model_name](4, q).fit(np.log(fs.frequencies_hz[:nb]), None if C is None else C[:nb])
    held = held_out_statistics(model.with_choices, np.log(fs.frequencies_hz[:nb]), None if C is None else C[:nb])
    corrected = inflate_held(held)
    n_eff = {nm: [round(effective_size(v[:, j]), 1) for j in range(v.shape[1])]
             for nm, (_, v) in held.items() if v is not None}
    factor = {nm: [round(prediction_inflation(nb, e), 4) for e in es] for nm, es in n_eff.items()}
    b_idx, rest = np.arange(nb), np.arange(nb, len(fs.day))

    def columns(F, sel, sign):
        out, first = {}, None
        for col, h in (("combined", held), ("combined, n_eff", corrected)):
            det = detect(model, model.with_choices, np.log(F), C, b_idx, rest, rate, q, held=h)
            out[col] = float(100 * det.alarm[sel].mean())
            first = det if first is None else first
        one, both = (plain_alarms(F, nb, rate, sides=s, sign=sign, method="weibull") for s in (1, 2))
        out["plain shift, both signs"] = float(100 * both["plain shift"][sel].mean())
        out["plain per mode"] = float(100 * one["plain per mode"][sel].mean())
        return out, first

    fa, det = columns(fs.frequencies_hz, np.arange(len(fs.day)) >= nb, 1.0)
    z = _normal_scores(det.ratio[nb:])
    row = {"case": case, "model": model_name, "seed": seed, "n_baseline": nb, "n_monitoring": len(fs.day) - nb,
           "n_eff": n_eff, "factor": factor, "rho_1": lag1_autocorrelation(z),
           "rho_day": max(_lag_corr(z, per_day), 0.0) ** (1.0 / per_day), "false_alarms": fa, "detected": {},
           "episodes_baseline": alarm_episodes(det.alarm[:nb], per_day).tolist(),
           "episodes_later": alarm_episodes(det.alarm[nb:], per_day).tolist()}
    damaged = np.arange(len(fs.day)) >= onset
    for name, which in (DAMAGES.items() if damages else ()):
        pattern = drop_pattern(cfg.beam, which)
        for size in SIZES_PCT:
            F = fs.frequencies_hz.copy()
            F[damaged] *= np.exp(pattern * np.log1p(-size / 100))
            key = f"{name} {'+' if which == 'mass' else '-'}{size:g} %"
            row["detected"][key] = columns(F, damaged, -1.0 if which == "mass" else 1.0)[0]
    print(json.dumps({k: v for k, v in row.items() if k != "detected"}), flush=True)
    return row


def chance(rows: list, rate: float, draws: int) -> list:
    """Per case: the median ``rho_1`` and ``rho_day`` over the seeds and, for each, the share of draws of
    :func:`~experiments.benches.effective_size.false_alarm_spread` above twice the rate (exact; from a baseline
    year)."""
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        mine = [r for r in rows if r["case"] == case]
        n_m, nb = mine[0]["n_monitoring"], mine[0]["n_baseline"]
        res = {"case": case, "n_monitoring": n_m, "n_baseline": nb}
        for key in ("rho_1", "rho_day"):
            rho = float(np.median([r[key] for r in mine]))
            exact = false_alarm_spread(n_m, rate, rho, draws=draws, seed=1)
            base = false_alarm_spread(n_m, rate, rho, n_baseline=nb, draws=draws, seed=2)
            res[key] = {"rho": rho, "n_eff_monitoring": n_m * (1 - rho) / (1 + rho),
                        "p_above_2x_exact": float(np.mean(exact > 2 * rate)),
                        "p_above_2x_from_baseline": float(np.mean(base > 2 * rate)),
                        "sd_pct_exact": float(100 * exact.std()), "sd_pct_from_baseline": float(100 * base.std())}
        for key in ("episodes_baseline", "episodes_later"):
            sizes = [e for r in mine for e in r.get(key, [])]
            if not sizes:
                continue
            later = episode_spread(n_m, rate, sizes, draws=20 * draws, seed=3)
            base = episode_spread(nb, rate, sizes, draws=20 * draws, seed=4)
            res[key] = {"episodes": len(sizes), "mean_size": float(np.mean(sizes)),
                        "n_eff_monitoring": n_m * np.mean(sizes) / np.mean(np.square(sizes)),
                        "p_above_2x_exact": float(np.mean(later > 2 * rate)),
                        "p_above_2x_from_baseline": float(np.mean(later - base + rate > 2 * rate))}
        print(json.dumps(res), flush=True)
        out.append(res)
    return out


def markdown(rows: list, odds: list) -> str:
    lines = []
    for case, model in dict.fromkeys((r["case"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["case"], r["model"]) == (case, model)]
        lines.append([case, model, "false alarms, seeds " + " ".join(str(r["seed"]) for r in mine) + " (%)",
                      *(" / ".join(f"{r['false_alarms'][c]:.2f}" for r in mine)
                        + f" (mean {np.mean([r['false_alarms'][c] for r in mine]):.2f})" for c in COLUMNS)])
        for damage in mine[0]["detected"]:
            lines.append(["", "", f"{damage} (%)", *(f"{np.mean([r['detected'][damage][c] for r in mine]):.1f}"
                                                     for c in COLUMNS)])
    md = table(["case", "model", "row", *COLUMNS], lines)
    chance_rows = [[o["case"], str(o["n_baseline"]), str(o["n_monitoring"]), k, f"{o[k]['rho']:.3f}",
                    f"{o[k]['n_eff_monitoring']:.0f}", f"{100 * o[k]['p_above_2x_exact']:.1f} %",
                    f"{100 * o[k]['p_above_2x_from_baseline']:.1f} %"] for o in odds for k in ("rho_1", "rho_day")]
    chance_rows += [[o["case"], str(o["n_baseline"]), str(o["n_monitoring"]),
                     f"{o[k]['episodes']} {k.split('_')[1]} episodes (mean {o[k]['mean_size']:.1f} tests)", "",
                     f"{o[k]['n_eff_monitoring']:.0f}", f"{100 * o[k]['p_above_2x_exact']:.1f} %",
                     f"{100 * o[k]['p_above_2x_from_baseline']:.1f} %"]
                    for o in odds for k in ("episodes_baseline", "episodes_later") if k in o]
    return md + "\n\n" + table(["case", "baseline tests", "later tests", "AR(1) from", "rho", "n_eff (later)",
                                "P(FA > 2 rate), exact", "P(FA > 2 rate), threshold from a baseline year"],
                               chance_rows)


def real_series_corrected(argv) -> int:
    """:func:`experiments.benches.bench_real_series.main` on ``argv`` with ``monitor``'s held-out statistics
    scaled by :func:`~experiments.benches.effective_size.inflate_held`."""
    cached = monitor_alarms.held_out_cached
    monitor_alarms.held_out_cached = lambda *a, **k: inflate_held(cached(*a, **k))
    try:
        return bench_real_series.main(argv)
    finally:
        monitor_alarms.held_out_cached = cached


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--real"]:
        if len(argv) < 2:
            raise SystemExit("--real DIR: the output folder of bench_real_series under the correction")
        return real_series_corrected(["--out", argv[1], *argv[2:]])
    p = parser(__file__, __doc__, out="out/bench_effective_size")
    p.add_argument("--cases", nargs="+", choices=("daily", "30min"), default=["daily", "30min"])
    p.add_argument("--models", nargs="+", choices=("pca", "regression"), default=["pca"])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--draws", type=int, default=2000, help="draws of the AR(1) series per case (default 2000)")
    p.add_argument("--false-alarms-only", action="store_true", help="the intact series alone (no damage)")
    a = p.parse_args(argv)
    out = Path(a.out)
    (out / "rows").mkdir(parents=True, exist_ok=True)
    rows = []
    for case in a.cases:
        for model in a.models:
            for seed in a.seeds:
                path = out / "rows" / f"{case}_{model}_{seed}_{a.rate:g}{'_fa' if a.false_alarms_only else ''}_v2.json"
                if path.is_file():
                    rows.append(json.loads(path.read_text()))
                    continue
                rows.append(run_case(case, model, seed, a.rate, not a.false_alarms_only))
                atomic_write_text(path, json.dumps(rows[-1]))
    odds = chance(rows, a.rate, a.draws)
    md = markdown(rows, odds)
    atomic_write_text(out / "effective_size.json", json.dumps({"config": vars(a), "rows": rows, "chance": odds},
                                                              indent=1))
    atomic_write_text(out / "effective_size.md", md + "\n")
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
