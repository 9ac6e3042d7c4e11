"""Benchmark: the detector's family calibrated on the union of the held-out baseline tests' alarms against the
Gaussian copula of their ranks, beside the plain tests, on the long frequency series of the independent simulator.

Run: ``python -m experiments.benches.bench_family_calibration [--cases daily 30min] [--models pca regression]
[--seeds 0 1 2 3] [--rate 0.01] [--false-alarms-only] [--folds interleaved|contiguous]
[--out out/bench_family_calibration] [--docs]``

Series and damages as :mod:`experiments.benches.bench_detection` (its ``daily`` and ``30min`` cases; a lasting
uniform loss of ``EI`` of 0.25, 0.5 and 1 %, a 0.25 % drop of mode 1, a 0.25 % mass loss from day 500). Columns:

* ``union``: ``monitor``'s alarm (:func:`~learn.monitor.statistics.detect`): the shares' level at which the
  held-out baseline tests alarm on some statistic at the rate at the plotting position
  (:mod:`learn.monitor.union_calibration`);
* ``copula``: the same shares, their level from the Gaussian copula of the held-out statistics' ranks
  (:func:`~learn.monitor.statistics.joint_rates`);
* ``plain shift, both signs`` and ``plain per mode``: :func:`experiments.benches.plain_tests.plain_alarms` (Weibull
  plotting position; the shift on both sides, per mode on the damage's side).

False alarms: each seed's share of the intact series' monitoring tests alarmed (the second year), and their mean.
Detected: the share of the damaged tests alarmed, averaged over the seeds. ``--folds contiguous``: the held-out
statistics from :data:`~learn.monitor.alarm_threshold.N_FOLDS` contiguous blocks of the baseline tests instead of
interleaved folds (a held-out test's neighbours held out with it), for the autocorrelation's share of the false
alarms. Writes ``calibration.json`` in ``--out``; ``--docs`` the
table into docs/monitoring.md (block ``family-calibration``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import learn.monitor.statistics as monitor_statistics  # noqa: E402
from learn.monitor.alarm_threshold import LOO_MAX, N_FOLDS  # noqa: E402
from experiments.benches.bench_detection import _case  # noqa: E402
from experiments.benches.harness import parser, publish, table  # noqa: E402
from experiments.benches.plain_tests import plain_alarms  # noqa: E402
from experiments.second_sim.series import drop_pattern, frequency_series  # noqa: E402
from learn.monitor.normal_models import NORMAL_MODELS  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["COLUMNS", "DAMAGES", "main", "run_case"]

#: (name, pattern, size %): ``stiffness`` a uniform loss of EI, ``mass`` a mass loss (the modes rise), a tuple the
#: modes (1-based) that drop alone.
DAMAGES = (("uniform EI", "stiffness", 0.25), ("uniform EI", "stiffness", 0.5), ("uniform EI", "stiffness", 1.0),
           ("mode 1", (1,), 0.25), ("mass loss", "mass", 0.25))
COLUMNS = ("union", "copula", "plain shift, both signs", "plain per mode")


def _detect(model, F, C, nb, rate, q, held, calibration):
    """``monitor``'s alarm (n,); ``calibration="copula"``: the shares' level from the Gaussian copula."""
    union = monitor_statistics._union_rates
    if calibration == "copula":
        monitor_statistics._union_rates = lambda *a, **k: None
    try:
        det = monitor_statistics.detect(model, model.with_choices, np.log(F), C, np.arange(nb),
                                        np.arange(nb, len(F)), rate, q, held=held)
    finally:
        monitor_statistics._union_rates = union
    return det.alarm


def _contiguous_folds(n: int) -> list:
    """Leave-one-out up to :data:`~learn.monitor.alarm_threshold.LOO_MAX` tests, else ``N_FOLDS`` contiguous
    blocks."""
    if n <= LOO_MAX:
        return [np.array([i]) for i in range(n)]
    return np.array_split(np.arange(n), N_FOLDS)


def run_case(case: str, model_name: str, seed: int, rate: float, damages=DAMAGES, folds: str = "interleaved") -> dict:
    """One seed's false alarms and detections (%) per column: ``{"false_alarms": {...}, "detected": {damage:
    {...}}}``; ``folds``: the held-out statistics' folds (``interleaved``: ``monitor``'s, ``contiguous``)."""
    cfg, nb, onset, _ = _case(case, seed)
    fs = frequency_series(cfg)
    C = None if model_name == "pca" else fs.measured_temperature_c[:, None]
    q = 0 if C is None else C.shape[1]
    X = np.log(fs.frequencies_hz[:nb])
    model = NORMAL_MODELS[model_name](X.shape[1], q).fit(X, None if C is None else C[:nb])
    interleaved = monitor_statistics._folds
    if folds == "contiguous":
        monitor_statistics._folds = _contiguous_folds
    try:
        held = monitor_statistics.held_out_statistics(model.with_choices, X, None if C is None else C[:nb])
    finally:
        monitor_statistics._folds = interleaved
    damaged = np.arange(len(fs.day)) >= onset

    def columns(F, sel, sign):
        out = {cal: float(100 * _detect(model, F, C, nb, rate, q, held, cal)[sel].mean())
               for cal in ("union", "copula")}
        one, both = (plain_alarms(F, nb, rate, sides=s, sign=sign, method="weibull") for s in (1, 2))
        plain = {"plain shift, both signs": both["plain shift"], "plain per mode": one["plain per mode"]}
        out.update({nm: float(100 * plain[nm][sel].mean()) for nm in COLUMNS[2:]})
        return out

    row = {"case": case, "model": model_name, "seed": seed,
           "false_alarms": columns(fs.frequencies_hz, np.arange(len(fs.day)) >= nb, 1.0), "detected": {}}
    for name, which, size in damages:
        F = fs.frequencies_hz.copy()
        F[damaged] *= np.exp(drop_pattern(cfg.beam, which) * np.log1p(-size / 100))
        row["detected"][f"{name} {'+' if which == 'mass' else '-'}{size:g} %"] = columns(
            F, damaged, -1.0 if which == "mass" else 1.0)
    print(json.dumps(row), flush=True)
    return row


def markdown(rows: list) -> str:
    """Per case and model: each seed's false alarms, then each damage's detection averaged over the seeds."""
    body = []
    for case, model in dict.fromkeys((r["case"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["case"], r["model"]) == (case, model)]
        seeds = " ".join(str(r["seed"]) for r in mine)
        body.append([case, model, f"false alarms, seeds {seeds} (%)", *(
            " / ".join(f"{r['false_alarms'][c]:.2f}" for r in mine)
            + f" (mean {np.mean([r['false_alarms'][c] for r in mine]):.2f})" for c in COLUMNS)])
        body += [["", "", f"{damage} (%)", *(f"{np.mean([r['detected'][damage][c] for r in mine]):.1f}"
                                             for c in COLUMNS)] for damage in mine[0]["detected"]]
    return table(["case", "model", "row", *COLUMNS], body)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_family_calibration")
    p.add_argument("--cases", nargs="+", choices=("daily", "30min"), default=["daily", "30min"])
    p.add_argument("--models", nargs="+", choices=("pca", "regression"), default=["pca", "regression"])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--false-alarms-only", action="store_true", help="the intact series alone (no damage)")
    p.add_argument("--folds", choices=("interleaved", "contiguous"), default="interleaved",
                   help="the held-out statistics' folds (monitor's: interleaved)")
    a = p.parse_args(argv)
    if a.docs and (a.false_alarms_only or a.folds != "interleaved"):
        p.error("--docs writes the table of monitor's detector: leave --false-alarms-only and --folds out")
    damages = () if a.false_alarms_only else DAMAGES
    rows = [run_case(c, m, s, a.rate, damages, a.folds) for c in a.cases for m in a.models for s in a.seeds]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "calibration.json", json.dumps({"config": vars(a), "rows": rows}, indent=1))
    md = markdown(rows)
    print(md)
    publish(a, "family-calibration", md + f"\n\nFalse alarms and detection in % at the rate {a.rate:g}; detection "
            f"averaged over {len(a.seeds)} seeds.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
