"""Benchmark: the detector's statistics, their combination and the memory chart against the plainest tests, on
long frequency series of the independent simulator.

Run: ``python -m experiments.benches.bench_detection [--out out/bench_detection] [--seeds 0 1 2 3] [--rate 0.01]
[--cases daily 30min lab] [--shares residual=1 environment=0.25 shift=2] [--docs]`` (``--shares``: the
``combined`` column's shares instead of :data:`~learn.monitor.statistics.SHARES`)

Series (:func:`experiments.second_sim.series.frequency_series`: the monitoring cantilever's first four modes under
a seasonal, daily and weather temperature, its clamp re-made and its bolted mass re-placed, each frequency
identified with a relative scatter):

* ``daily``: a test a day over two years, clamp and mass re-made before every test, 0.03 % identification scatter;
  the first year the baseline period;
* ``30min``: a test every 30 min over two years, clamp and mass re-made weekly, 0.1 % identification scatter;
  the first year the baseline period;
* ``lab``: 100 tests of a lab beam (temperature 20 +- 1.5 degC), clamp and mass re-made before every test,
  0.03 % scatter; the first 35 tests the baseline period; ``lab6``: the same with six modes.

Each gets a lasting drop from day 500 (test 50 of ``lab``) of 0.25 to 2 % in mode 1 alone, or of every mode in the
pattern of a uniform loss of EI (the size their mean drop; the direction the temperature also moves the modes),
or a rise of every mode in the pattern of losing part of the bolted mass (the size their mean rise), imposed on
the same intact draws. Normal models: ``pca`` (no
conditions) and ``regression`` on the measured temperature. Methods, each at ``--rate`` on the same baseline:

* ``residual``, ``environment``, ``shift``: each statistic of :mod:`learn.monitor.statistics` alone at the rate
  (the shift signed: a drop and a rise at half the rate each);
* ``combined``: any statistic above its threshold, the rate shared by :data:`~learn.monitor.statistics.SHARES`
  and calibrated on their joint held-out distribution (``monitor``'s alarm with a baseline period of a year);
  ``combined, equal shares``: the same calibration with equal shares; ``combined, Šidák``: equal shares at the
  Šidák rate; ``extrapolated
  apart``: the combination less the tests beyond the baseline's environment alarmed by its environmental statistics
  alone (``monitor --extrapolated-alarms separate``: status ``change or unseen conditions``);
* ``chart``: the EWMA charts of :mod:`learn.monitor.charts` (``monitor``'s ``chart_alarm``); ``chart, Šidák``:
  the charts at Šidák's split instead of their joint calibration;
* ``plain shift``: the mean relative change of the frequencies from their baseline medians, alarmed below the
  baseline's own ``rate`` quantile (one-sided: it is told the change's sign, above the ``1 - rate`` quantile for the
  mass loss); ``plain shift, both signs``: below its ``rate / 2`` or above its ``1 - rate / 2`` quantile;
* ``plain per mode``: each mode's relative change, alarmed beyond the baseline's ``rate / m`` quantile of that mode
  (on the change's side).

The plain tests (:mod:`experiments.benches.plain_tests`) read their quantiles at the plotting position
``k / (n + 1)`` (``method="weibull"``), as ``monitor``'s thresholds are
(:func:`~learn.monitor.alarm_threshold.threshold`): a new test exchangeable with the ``n`` baseline values lies
beyond the quantile with probability ``rate``.

False alarms: the share of the intact series' monitoring tests alarmed (the plain tests: on the drop side), the
mean over the seeds in the table and each seed's under it, there with ``combined, not extrapolated``: the share of
the monitoring tests within the baseline's environment (not ``extrapolated``, :mod:`learn.monitor.coverage`)
alarmed, and the share extrapolated.
Detected: the share of the damaged tests alarmed (the chart from one day after the onset: ``30min`` 48 tests,
``daily`` 1 test). Delay: tests from the onset to the first alarm on a damaged test.
Writes ``detection.json`` and ``detection.md`` in ``--out``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.harness import parser, publish, table  # noqa: E402
from experiments.benches.plain_tests import plain_alarms  # noqa: E402
from experiments.second_sim.series import FrequencySeriesConfig, SeriesConfig, drop_pattern, frequency_series  # noqa: E402
from learn.monitor.alarm_threshold import minimum_baseline  # noqa: E402
from learn.monitor.baseline_outliers import exclude_baseline_outliers  # noqa: E402
from learn.monitor.charts import run_charts  # noqa: E402
from learn.monitor.normal_models import NORMAL_MODELS  # noqa: E402
from learn.monitor.coverage import coverage, environment_coordinates  # noqa: E402
from learn.monitor.statistics import SHARES, detect, environmental, held_out_statistics  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["CASES", "main", "methods_on"]

SIZES_PCT = (0.25, 0.5, 1.0, 1.5, 2.0)
DAMAGES = {"mode 1": (1,), "uniform EI": "stiffness", "mass loss": "mass"}
METHODS = ("residual", "environment", "shift", "combined", "combined, equal shares", "combined, Šidák",
           "extrapolated apart", "chart", "chart, Šidák",
           "plain shift", "plain shift, both signs", "plain per mode")


def _case(name: str, seed: int) -> tuple:
    """``(config, n_baseline, onset test, tests a day)`` of a named case."""
    if name == "daily":
        cfg = FrequencySeriesConfig(days=730, tests_per_day=1, seed=seed, remount_every_days=None,
                                    frequency_noise=3e-4, daily_amplitude_c=0.0)
        return cfg, 365, 500, 1
    if name == "30min":
        cfg = FrequencySeriesConfig(days=730, tests_per_day=48, seed=seed, frequency_noise=1e-3)
        return cfg, 365 * 48, 500 * 48, 48
    if name in ("lab", "lab6"):
        beam = SeriesConfig(damage_day=None, n_tests=2, temperature_mean_c=20.0, temperature_amplitude_c=0.0,
                            temperature_daily_sd_c=1.5, n_modes=6 if name == "lab6" else 4)
        cfg = FrequencySeriesConfig(beam=beam, days=100, tests_per_day=1, seed=seed, remount_every_days=None,
                                    frequency_noise=3e-4, daily_amplitude_c=0.0, weather_sd_c=0.0)
        return cfg, 35, 50, 1
    raise ValueError(f"unknown case {name!r}")


CASES = ("daily", "30min", "lab", "lab6")


def methods_on(F, C, nb: int, model_name: str, rate: float, seed: int = 0, sign: float = 1.0, held=None,
               shares=None, b_idx=None) -> dict:
    """Every method's alarms (n,) on one series (baseline period: the first ``nb`` tests; ``b_idx``: those the
    normal model learns from, all of them when None; ``held``: their
    :func:`~learn.monitor.statistics.held_out_statistics`, computed when None; ``shares``: the ``combined``
    method's, :data:`~learn.monitor.statistics.SHARES` when None). The plain tests take every test of the baseline
    period."""
    X = np.log(F)
    q = 0 if C is None else C.shape[1]
    b_idx = np.arange(nb) if b_idx is None else np.asarray(b_idx, int)
    model = NORMAL_MODELS[model_name](X.shape[1], q).fit(X[b_idx], None if C is None else C[b_idx])
    rest = np.arange(nb, len(X))
    if held is None:
        held = held_out_statistics(model.with_choices, X[b_idx], None if C is None else C[b_idx])
    det = detect(model, model.with_choices, X, C, b_idx, rest, rate, q, held=held, shares=shares)
    out = {}
    for k, nm in enumerate(det.names):
        alone = detect(model, model.with_choices, X, C, b_idx, rest, rate, q, (nm,), held={nm: held[nm]})
        out[nm] = alone.alarm
    out["combined"] = det.alarm
    out["combined, equal shares"] = detect(model, model.with_choices, X, C, b_idx, rest, rate, q, held=held,
                                           combination="equal").alarm
    out["combined, Šidák"] = detect(model, model.with_choices, X, C, b_idx, rest, rate, q, held=held,
                                    combination="sidak").alarm
    own = [k for k, nm in enumerate(det.names) if not environmental(model, nm)]
    env_only = ~(det.ratios[:, own] > 1.0).any(axis=1)
    out["extrapolated apart"] = det.alarm & ~(extrapolated_tests(model, X, C, b_idx, rest) & env_only)
    out["chart"] = run_charts(det.vectors, b_idx, rate, seed=seed).alarm
    out["chart, Šidák"] = run_charts(det.vectors, b_idx, rate, seed=seed, combination="sidak").alarm
    one, both = (plain_alarms(F, nb, rate, sides=s, sign=sign, method="weibull") for s in (1, 2))
    out.update({"plain shift": one["plain shift"], "plain shift, both signs": both["plain shift"],
                "plain per mode": one["plain per mode"]})
    return out


def extrapolated_tests(model, X, C, b_idx, rest) -> np.ndarray:
    """``(n,)`` bool: the tests ``rest`` beyond the baseline tests ``b_idx``'s environment in ``model``'s coordinates
    (:func:`~learn.monitor.coverage.coverage`, ``monitor``'s ``extrapolated``; none for a model without an
    environment); ``X`` log frequencies (n, m), ``C`` conditions (n, q) or None."""
    q = 0 if C is None else C.shape[1]
    names, E = environment_coordinates(model, X, C, tuple(f"condition {j + 1}" for j in range(q)))
    if E is None or not E.shape[1]:
        return np.zeros(len(X), bool)
    return coverage(names, E, b_idx, rest).extrapolated


def _scores(alarms: dict, damaged, onset: int, per_day: int) -> dict:
    out = {}
    for m, a in alarms.items():
        late = damaged & (np.arange(len(a)) >= onset + (per_day if m.startswith("chart") else 0))
        hits = np.flatnonzero(a & damaged)
        out[m] = {"detected": float(a[late].mean()), "delay_tests": int(hits[0] - onset) if hits.size else None}
    return out


def run_case(name: str, seed: int, rate: float, shares=None, keep_outliers: bool = False) -> list:
    """Every model, damage and size of case ``name`` (seed ``seed``); the baseline's outliers
    (:mod:`learn.monitor.baseline_outliers`, as ``monitor`` names them) left out of the normal model's baseline
    unless ``keep_outliers``."""
    cfg, nb, onset, per_day = _case(name, seed)
    fs = frequency_series(cfg)
    rows = []
    for model_name, C in (("pca", None), ("regression", fs.measured_temperature_c[:, None])):
        X = np.log(fs.frequencies_hz[:nb])
        q = 0 if C is None else C.shape[1]

        def fitted(rows_, X=X, C=C, q=q, model_name=model_name):
            Cb = None if C is None else C[rows_]
            mdl = NORMAL_MODELS[model_name](X.shape[1], q).fit(X[rows_], Cb)
            return mdl, held_out_statistics(mdl.with_choices, X[rows_], Cb)     # the baseline is never damaged
        b_idx, base, held, found = exclude_baseline_outliers(fitted, np.arange(nb), rate,
                                                             minimum_baseline(X.shape[1], q), q, keep_outliers, C)
        intact = methods_on(fs.frequencies_hz, C, nb, model_name, rate, seed, held=held, shares=shares,
                            b_idx=b_idx)
        fa = {m: float(a[nb:].mean()) for m, a in intact.items()}
        Xi = np.log(fs.frequencies_hz)
        mdl = NORMAL_MODELS[model_name](Xi.shape[1], q).fit(Xi[b_idx], None if C is None else C[b_idx])
        ext = extrapolated_tests(mdl, Xi, C, b_idx, np.arange(nb, len(Xi)))[nb:]
        fa["combined, not extrapolated"] = float(intact["combined"][nb:][~ext].mean()) if (~ext).any() else 0.0
        rows.append({"case": name, "seed": seed, "model": model_name, "damage": "none", "size_pct": 0.0,
                     "false_alarms": fa, "n_monitoring": len(fs.day) - nb, "extrapolated": float(ext.mean()),
                     "baseline_outliers": found.indices})
        print(json.dumps({"case": name, "seed": seed, "model": model_name, "baseline_outliers": found.indices,
                          "excluded": found.excluded}), flush=True)
        damaged = np.arange(len(fs.day)) >= onset
        for damage, which in DAMAGES.items():
            pattern = drop_pattern(cfg.beam, which)
            for size in SIZES_PCT:
                F = fs.frequencies_hz.copy()
                F[damaged] *= np.exp(pattern * np.log1p(-size / 100))
                res = _scores(methods_on(F, C, nb, model_name, rate, seed, -1.0 if which == "mass" else 1.0,
                                         held, shares, b_idx), damaged, onset, per_day)
                rows.append({"case": name, "seed": seed, "model": model_name, "damage": damage, "size_pct": size,
                             "scores": res})
                print(json.dumps({k: v for k, v in rows[-1].items() if k != "scores"}
                                 | {m: round(s["detected"], 3) for m, s in res.items()}), flush=True)
    return rows


def markdown(rows: list) -> str:
    """The table: per case, model and damage, each method's detection (%) averaged over the seeds, false alarms
    in the first row of each model."""
    head = ("| case | model | damage | " + " | ".join(METHODS) + " | delay combined / chart (tests) |\n"
            + "| --- | --- | --- | " + " | ".join("---" for _ in METHODS) + " | --- |")
    lines = [head]
    keys = list(dict.fromkeys((r["case"], r["model"]) for r in rows))
    for case, model in keys:
        mine = [r for r in rows if (r["case"], r["model"]) == (case, model)]
        fa = [r["false_alarms"] for r in mine if r["damage"] == "none"]
        lines.append(f"| {case} | {model} | false alarms (intact) | "
                     + " | ".join(f"{100 * np.mean([f[m] for f in fa if m in f]):.2f} %"
                                  if any(m in f for f in fa) else "-" for m in METHODS) + " | |")
        for damage in DAMAGES:
            for size in SIZES_PCT:
                sel = [r["scores"] for r in mine if r["damage"] == damage and r["size_pct"] == size]
                cells = [f"{100 * np.mean([s[m]['detected'] for s in sel]):.0f}" if all(m in s for s in sel)
                         else "-" for m in METHODS]
                d = [[s[m]["delay_tests"] for s in sel] for m in ("combined", "chart")]
                delay = " / ".join("never" if any(v is None for v in x) else f"{np.median(x):g}" for x in d)
                sign = "+" if DAMAGES[damage] == "mass" else "-"
                lines.append(f"| | | {damage} {sign}{size:g} % | " + " | ".join(cells) + f" | {delay} |")
    return "\n".join(lines)


#: The methods whose false alarms :func:`false_alarm_table` lists per seed.
FA_METHODS = ("combined", "combined, not extrapolated", "combined, equal shares", "combined, Šidák", "chart",
              "chart, Šidák", "plain shift", "plain shift, both signs", "plain per mode")


def false_alarm_table(rows: list) -> str:
    """Per case and model, each seed's false alarms (%) of :data:`FA_METHODS` and their mean (``combined, not
    extrapolated``: the share of the monitoring tests within the baseline's environment alarmed), and the share of
    the monitoring tests extrapolated (%)."""

    def cell(values):
        return " / ".join(f"{100 * v:.2f}" for v in values) + f" (mean {100 * np.mean(values):.2f})"

    lines = []
    for case, model in dict.fromkeys((r["case"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["case"], r["model"]) == (case, model) and r["damage"] == "none"]
        lines.append([case, model, " ".join(str(r["seed"]) for r in mine),
                      *(cell([r["false_alarms"].get(m, np.nan) for r in mine]) for m in FA_METHODS),
                      cell([r.get("extrapolated", np.nan) for r in mine])])
    return table(["case", "model", "seeds", *FA_METHODS, "extrapolated"], lines)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_detection")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    p.add_argument("--shares", nargs="+", metavar="NAME=WEIGHT",
                   help="the combined column's share of each statistic (default: learn.monitor.statistics.SHARES)")
    p.add_argument("--keep-baseline-outliers", action="store_true",
                   help="the normal model learns from every baseline test (default: monitor's, the baseline's "
                        "outliers left out)")
    a = p.parse_args(argv)
    shares = None
    if a.shares:
        shares = dict(SHARES)
        for item in a.shares:
            name, _, w = item.partition("=")
            if name not in SHARES or not w:
                p.error(f"--shares {item}: expected NAME=WEIGHT with NAME one of {', '.join(SHARES)}")
            shares[name] = float(w)
    if a.docs and shares:
        p.error("--docs writes the table of monitor's shares: leave --shares out")
    rows = [r for case in a.cases for seed in a.seeds
            for r in run_case(case, seed, a.rate, shares, a.keep_baseline_outliers)]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    md = markdown(rows) + "\n\nFalse alarms (%) of each seed's intact series:\n\n" + false_alarm_table(rows)
    atomic_write_text(out / "detection.json", json.dumps({"config": vars(a), "rows": rows}, indent=1))
    atomic_write_text(out / "detection.md", md + "\n")
    print(md)
    cases = "" if list(a.cases) == list(CASES) else " --cases " + " ".join(a.cases)
    cmd = ("`python -m experiments.benches.bench_detection --seeds " + " ".join(map(str, a.seeds))
           + f" --rate {a.rate:g}{cases} --docs`")
    publish(a, "detection", md + f"\n\nDetection in % of the damaged tests, averaged over {len(a.seeds)} seeds; "
            f"false alarms in % of the intact series' monitoring tests (the table: their mean over the seeds). "
            f"Written by {cmd}.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
