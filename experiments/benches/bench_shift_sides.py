"""Benchmark: where ``monitor``'s combination stands against the plain mean-shift tests on a change common to the
modes, on the independent simulator's long series without measured conditions (``pca``).

Run: ``python -m experiments.benches.bench_shift_sides [--cases daily 30min] [--seeds 0 1] [--rate 0.01]
[--sides 0.5 0.75] [--out out/bench_shift_sides] [--docs]``

The series, baseline and damages are those of :mod:`experiments.benches.bench_detection` (the baseline's outliers
left out as ``monitor`` does), the damages a drop of every mode in the pattern of a uniform loss of ``EI`` (the
direction the temperature moves the modes) and the same pattern rising, at 0.25 / 0.5 / 1 % (their mean), a drop of
mode 1 alone and a mass loss at 0.25 %. Per case, seed and drop share ``d`` of ``--sides`` (the shift's rate split
``(d, 1 - d)`` between its drop and its rise, :data:`~learn.monitor.statistics.SHIFT_SIDES` the default):

* ``combined``: ``monitor``'s alarm (:func:`~learn.monitor.statistics.detect`, every statistic, ``SHARES``);
* ``shift alone``: the shift statistic alone at the whole rate, split ``(d, 1 - d)``;
* ``plain shift`` (one-sided, told the sign) and ``plain shift, both signs`` (:mod:`experiments.benches.plain_tests`).

The statistic's efficiency: the signal-to-noise ratio of a uniform ``EI`` loss (per unit of its mean ``ln f``
change) of the shift's weights (:func:`~learn.monitor.statistics.shift_weights`, ``(w . p) / sqrt(w^T cov w)``),
of equal weights, and its bound, the generalised least squares along the pattern ``sqrt(p^T cov^-1 p)``, ``cov``
the normal model's baseline covariance; and the rate the combination leaves each side of the shift (the union's
calibration). Writes ``shift_sides.json`` and ``shift_sides.md`` in ``--out``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.bench_detection import _case  # noqa: E402
from experiments.benches.harness import parser, publish, table  # noqa: E402
from experiments.benches.plain_tests import plain_alarms  # noqa: E402
from experiments.second_sim.series import drop_pattern, frequency_series  # noqa: E402
from learn.monitor.alarm_threshold import minimum_baseline  # noqa: E402
from learn.monitor.baseline_outliers import exclude_baseline_outliers  # noqa: E402
from learn.monitor.normal_models import NORMAL_MODELS  # noqa: E402
from learn.monitor.statistics import detect, held_out_statistics, shift_weights  # noqa: E402
from physics.io import atomic_write_text  # noqa: E402

__all__ = ["DAMAGES", "main", "run_case"]

#: ``(label, pattern source, size %, sign)``: the pattern's ``d ln f`` per unit drop times ``log1p(-size)``, and
#: ``sign`` the side the one-sided plain shift is told (``-1``: a rise).
DAMAGES = (("uniform EI -0.25 %", "stiffness", 0.25, 1.0), ("uniform EI -0.5 %", "stiffness", 0.5, 1.0),
           ("uniform EI -1 %", "stiffness", 1.0, 1.0), ("uniform EI +0.25 %", "stiffness", -0.25, -1.0),
           ("uniform EI +0.5 %", "stiffness", -0.5, -1.0), ("uniform EI +1 %", "stiffness", -1.0, -1.0),
           ("mode 1 -0.25 %", (1,), 0.25, 1.0), ("mass loss +0.25 %", "mass", 0.25, -1.0))
METHODS = ("combined", "shift alone", "plain shift", "plain shift, both signs")


def _efficiency(model, pattern) -> dict:
    """Signal-to-noise ratios of a change along ``pattern`` (m,) per unit: the shift's weights, equal weights, and
    the generalised least squares' bound."""
    cov = model.cov_
    w, e = shift_weights(cov), np.full(len(cov), 1.0 / len(cov))
    return {"shift weights": float(w @ pattern / np.sqrt(w @ cov @ w)),
            "equal weights": float(e @ pattern / np.sqrt(e @ cov @ e)),
            "GLS bound": float(np.sqrt(pattern @ np.linalg.solve(cov, pattern)))}


def run_case(name: str, seed: int, rate: float, sides) -> dict:
    """One case and seed (``pca``): each drop share's false alarms and detections, the efficiency and the rates."""
    cfg, nb, onset, _ = _case(name, seed)
    fs = frequency_series(cfg)
    X = np.log(fs.frequencies_hz[:nb])

    def fitted(rows_):
        mdl = NORMAL_MODELS["pca"](X.shape[1], 0).fit(X[rows_])
        return mdl, held_out_statistics(mdl.with_choices, X[rows_])
    b_idx, model, held, _ = exclude_baseline_outliers(fitted, np.arange(nb), rate, minimum_baseline(X.shape[1]), 0)
    rest = np.arange(nb, len(fs.day))
    damaged = np.arange(len(fs.day)) >= onset
    out = {"case": name, "seed": seed,
           "efficiency": _efficiency(model, drop_pattern(cfg.beam, "stiffness")), "by_sides": {}}
    for d in sides:
        split = (float(d), 1.0 - float(d))
        rows, rates = {}, {}
        for label, which, size, sign in (("none", None, 0.0, 1.0), *DAMAGES):
            F = fs.frequencies_hz.copy()
            if which is not None:
                F[damaged] *= np.exp(drop_pattern(cfg.beam, which) * np.log1p(-size / 100))
            Xa = np.log(F)
            det = detect(model, model.with_choices, Xa, None, b_idx, rest, rate, held=held, shift_sides=split)
            alone = detect(model, model.with_choices, Xa, None, b_idx, rest, rate, 0, ("shift",),
                           held={"shift": held["shift"]}, shift_sides=split)
            one, both = (plain_alarms(F, nb, rate, sides=s, sign=sign, method="weibull") for s in (1, 2))
            sel = rest if which is None else damaged
            rows[label] = {m: 100 * float(a[sel].mean()) for m, a in
                           zip(METHODS, (det.alarm, alone.alarm, one["plain shift"], both["plain shift"]))}
            if which is None:
                k = det.names.index("shift")
                rates = {"shift drop %": 100 * split[0] * float(det.rate_each[k]),
                         "shift rise %": 100 * split[1] * float(det.rate_each[k]),
                         "residual %": 100 * float(det.rate_each[det.names.index("residual")])}
        out["by_sides"][f"{d:g}"] = {"detection": rows, "rates": rates}
        print(json.dumps({"case": name, "seed": seed, "drop share": d, "rates": rates,
                          **{k: [round(v, 1) for v in r.values()] for k, r in rows.items()}}), flush=True)
    return out


def markdown(results: list, sides) -> str:
    """Per case and drop share, each method's false alarms and detection (%) averaged over the seeds; the
    efficiency and the shift's rates under it."""
    lines = []
    for case in dict.fromkeys(r["case"] for r in results):
        mine = [r for r in results if r["case"] == case]
        for d in sides:
            key = f"{d:g}"
            for label in ("none", *(x[0] for x in DAMAGES)):
                cells = [f"{np.mean([r['by_sides'][key]['detection'][label][m] for r in mine]):.1f}" for m in METHODS]
                lines.append([case, key, "false alarms (intact)" if label == "none" else label, *cells])
    md = table(["case", "drop share", "damage", *METHODS], lines)
    eff = [[r["case"], r["seed"], *(f"{v:.1f}" for v in r["efficiency"].values()),
            *(" / ".join(f"{r['by_sides'][f'{d:g}']['rates'][k]:.3f}" for d in sides)
              for k in ("shift drop %", "shift rise %", "residual %"))] for r in results]
    return md + "\n\n" + table(["case", "seed", "SNR shift weights", "SNR equal weights", "SNR GLS bound",
                                "shift drop rate % (per drop share)", "shift rise rate %", "residual rate %"], eff)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_shift_sides")
    p.add_argument("--cases", nargs="+", choices=("daily", "30min"), default=["daily", "30min"])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    p.add_argument("--rate", type=float, default=0.01)
    p.add_argument("--sides", type=float, nargs="+", default=[0.5, 0.75],
                   help="the drop's shares of the shift's rate (each in (0, 1); the rise gets the rest)")
    a = p.parse_args(argv)
    if any(not 0.0 < d < 1.0 for d in a.sides):
        p.error(f"--sides: each drop share must lie in (0, 1), not {a.sides}")
    results = [run_case(case, seed, a.rate, a.sides) for case in a.cases for seed in a.seeds]
    md = markdown(results, a.sides)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "shift_sides.json", json.dumps({"config": vars(a), "results": results}, indent=1))
    atomic_write_text(out / "shift_sides.md", md + "\n")
    print(md)
    cmd = ("`python -m experiments.benches.bench_shift_sides --cases " + " ".join(a.cases) + " --seeds "
           + " ".join(map(str, a.seeds)) + " --sides " + " ".join(f"{d:g}" for d in a.sides) + " --docs`")
    publish(a, "shift-sides", md + f"\n\nDetection and false alarms in % of the tests (the mean over seeds "
            f"{' '.join(map(str, a.seeds))}); signal-to-noise ratios per unit mean `ln f` change of a uniform EI "
            f"loss. Written by {cmd}.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
