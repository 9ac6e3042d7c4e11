"""Diagnosis: the later tests of a real series (:mod:`experiments.benches.bench_real_series`) that ``monitor`` misses,
which of its statistics comes closest on each and why it stays under, and what flags them instead.

Run: ``python -m experiments.benches.diag_real_misses [--set ds11-b4.6] [--rate 0.01] [--out out/bench_real_series]
[--data experiments/data/real] [--variants rate=0.02 statistics=residual fft=1+3+4 ...]`` (``--out``: the folder of
``bench_real_series``' records and identification cache, which this diagnosis reuses; about 5 s per variant from the
cache).

Printed at ``--rate``: each statistic's per-statistic rate and, per set of modes found, its thresholds (the law's
value and the held-out indices' empirical quantile: their largest below a rate of ``1 / (n + 1)``); per missed later
test (identified, not flagged) each statistic's index and its index over its threshold (``Detection.ratios``), the
closest named; with one environmental component removed, each baseline test's signed score along it and the
one-sided thresholds of that score on each side (the law of
:func:`~learn.monitor.alarm_threshold.threshold` fitted to that side's squares, at half the environment's rate and
at half the whole rate: a reading of the environment the detector does not make, to tell whether any could flag the
misses). Then one line per variant (:data:`DEFAULT_VARIANTS`): the held-out baseline tests flagged and each later
group's share flagged with the tests missed. A variant is one of

* ``rate=R``: ``monitor`` at false-alarm rate ``R``;
* ``statistics=a+b``: those statistics combined (the residual always);
* ``model=NAME``: the normal model (:data:`learn.monitor.normal_models.NORMAL_MODELS`);
* ``keep-outliers``: the baseline outliers kept;
* ``fft=1+3``: the FFT peak for those modes (1-based), the identification for the others
  (:func:`learn.monitor.estimator_choice.choose_frequencies` patched for the run, restored after);
* ``equal-shift-weights``: the shift's weights equal over the modes (:func:`learn.monitor.statistics.shift_weights`
  patched; the held-out baseline statistics computed afresh, never read from or written to the cache).
"""

from __future__ import annotations

import os
import warnings
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import learn.monitor.alarms as alarms  # noqa: E402
import learn.monitor.statistics as statistics  # noqa: E402
from experiments.benches.bench_real_series import DATA, LOADERS, _flagged, _write_records  # noqa: E402
from experiments.benches.harness import parser  # noqa: E402
from learn.monitor import IdentificationSettings, SeriesInput, monitor_series  # noqa: E402
from learn.monitor.alarm_threshold import TAIL_SHARE, threshold, training_size  # noqa: E402
from learn.monitor.estimator_choice import FFT_PEAK  # noqa: E402

__all__ = ["DEFAULT_VARIANTS", "closest", "environment_sides", "flag_summary", "main", "parse_variant", "patched",
           "run_monitor"]

#: The variants judged unless ``--variants`` names others (module docstring).
DEFAULT_VARIANTS = ("rate=0.02", "rate=0.03", "rate=0.04", "rate=0.05", "rate=0.0625", "rate=0.1",
                    "statistics=residual", "statistics=residual+mode", "statistics=residual+environment+shift",
                    "equal-shift-weights", "fft=1+3+4", "fft=1+2+3+4", "fft=2+3+4", "fft=4", "fft=3",
                    "model=pca0", "model=pca2", "model=factor", "model=mixture", "keep-outliers")


def flag_summary(groups, labels, flags, n_baseline: int) -> dict:
    """``{"baseline": [labels of the baseline tests flagged], group: (share flagged, [labels missed])}`` for each later
    group in order of first appearance. ``groups``, ``labels``, ``flags`` (bool) (n,)."""
    groups, flags = np.asarray(groups), np.asarray(flags, bool)
    out = {"baseline": [labels[i] for i in np.flatnonzero(flags[:n_baseline])]}
    for g in dict.fromkeys(groups[n_baseline:]):
        sel = np.flatnonzero((groups == g) & (np.arange(groups.size) >= n_baseline))
        out[str(g)] = (float(flags[sel].mean()), [labels[i] for i in sel if not flags[i]])
    return out


def closest(ratios, names) -> str:
    """The name of the largest finite ratio (a statistic's index over its threshold); ``"-"`` when none is finite."""
    r = np.asarray(ratios, float)
    ok = np.isfinite(r)
    return names[int(np.argmax(np.where(ok, r, -np.inf)))] if ok.any() else "-"


def environment_sides(scores, rate: float, n_train: int) -> list:
    """``[(sign, held-out tests on that side, |score| threshold, largest |score|)]`` for ``sign`` -1 and +1: the
    one-sided threshold of a signed score (``scores`` (n,), the baseline tests' held-out scores along the one removed
    component, in its standard deviations) on each side at ``rate`` split in half between the sides, as the shift's
    sides are set (the law fitted to the largest :data:`~learn.monitor.alarm_threshold.TAIL_SHARE` of that side's
    squares, read at ``1 - rate / 2 / side share``)."""
    z = np.asarray(scores, float)
    z = z[np.isfinite(z)]
    out = []
    for sign in (-1.0, 1.0):
        y = (sign * z)[sign * z > 0] ** 2
        if y.size < 2:
            out.append((sign, int(y.size), float("nan"), float(np.sqrt(y.max())) if y.size else float("nan")))
            continue
        t = threshold(y, 0.5 * rate, 1, n_train, 0, TAIL_SHARE, y.size / z.size)
        out.append((sign, int(y.size), float(np.sqrt(t.value)), float(np.sqrt(y.max()))))
    return out


def parse_variant(spec: str) -> tuple:
    """``(monitor_series keywords, patch or None)`` of a variant (module docstring); ``ValueError`` on another."""
    key, _, value = spec.partition("=")
    if key == "rate" and value:
        return {"false_alarm_rate": float(value)}, None
    if key == "statistics" and value:
        return {"statistics": tuple(value.split("+"))}, None
    if key == "model" and value:
        return {"normal_model": value}, None
    if spec == "keep-outliers":
        return {"keep_baseline_outliers": True}, None
    if key == "fft" and value:
        return {}, ("fft", frozenset(int(v) - 1 for v in value.split("+")))
    if spec == "equal-shift-weights":
        return {}, ("equal", None)
    raise ValueError(f"variant {spec!r}: expected rate=R, statistics=a+b, model=NAME, keep-outliers, fft=1+2 or "
                     "equal-shift-weights")


def _fft_for(modes, choose):
    def choose_fixed(tests, files, ref, F, cols, base, cache_dir, workers):
        c = choose(tests, files, ref, F, cols, base, cache_dir, workers)
        if c is None:
            return None
        est = tuple(FFT_PEAK if r in modes else c.default for r in range(len(c.estimators)))
        chosen = np.array([e == FFT_PEAK for e in est])
        out = np.array(F, float)
        out[:, chosen] = np.where(cols[:, chosen] >= 0, c.fft_hz[:, chosen], np.nan)
        return replace(c, estimators=est, frequencies_hz=out)
    return choose_fixed


@contextmanager
def patched(patch):
    """The variant's patch of ``monitor``'s estimator choice or shift weights for the block, restored after."""
    saved = alarms.choose_frequencies, alarms.held_out_cached, statistics.shift_weights
    try:
        if patch is not None and patch[0] == "fft":
            alarms.choose_frequencies = _fft_for(patch[1], saved[0])
        elif patch is not None and patch[0] == "equal":
            statistics.shift_weights = lambda cov: np.full(len(cov), 1.0 / len(cov))
            alarms.held_out_cached = lambda model, Xb, Cb=None, cache_dir=None: statistics.held_out_statistics(
                model.with_choices, Xb, Cb)
        yield
    finally:
        alarms.choose_frequencies, alarms.held_out_cached, statistics.shift_weights = saved


def run_monitor(series, files, cache, rate: float, patch=None, **kwargs):
    """``monitor_series`` on the series' records at ``rate`` (``kwargs`` its keywords, which may override the rate),
    warnings silenced, under the variant's ``patch``."""
    kwargs = {"false_alarm_rate": rate, **kwargs}
    with patched(patch), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return monitor_series(SeriesInput.from_files(files), series.n_baseline,
                              IdentificationSettings(tuple(series.band_hz)), cache, progress=False, chart="none",
                              **kwargs)


def _baseline_used(res, n_baseline: int) -> np.ndarray:
    return np.array([i for i, r in enumerate(res.rows[:n_baseline])
                     if r["identified"] and r["status"] != alarms.BASELINE_OUTLIER], int)


def _report(res, series, rate: float) -> list:
    det, labels = res.detection, series.labels
    lines = [f"{series.name} at {rate:g}: per-statistic rates "
             + ", ".join(f"{nm} {r:.3g}" for nm, r in zip(det.names, det.rate_each)) + f" ({det.calibration})"]
    sets = {"the baseline's set": {nm: [t] for nm, t in zip(det.names, det.thresholds)}, **{
        f"modes {k} missing": v for k, v in det.patterns.items()}}
    if det.shift_rise is not None:
        sets["the baseline's set"]["shift"] = [det.thresholds[det.names.index("shift")], det.shift_rise]
    for key, ths in sets.items():
        lines.append(f"  thresholds, {key}: " + "; ".join(
            f"{nm} " + " / ".join(f"{t.value:.3g} (law {t.law_value:.3g}, held-out {t.empirical_quantile:.3g})"
                                  for t in ts) for nm, ts in ths.items()))
    flags = _flagged([r["status"] for r in res.rows])
    later = np.arange(len(flags)) >= series.n_baseline
    for i in np.flatnonzero(later & ~flags & np.array([r["identified"] for r in res.rows])):
        lines.append(f"  missed {labels[i]} ({series.groups[i]}): closest {closest(det.ratios[i], det.names)}; "
                     + ", ".join(f"{nm} {det.values[i, k]:.3g} ({det.ratios[i, k]:.2f})"
                                 for k, nm in enumerate(det.names)))
    env = det.vectors.get("environment")
    if env is not None and env.shape[1] == 1:
        b = _baseline_used(res, series.n_baseline)
        n_train = training_size(b.size)
        share = det.rate_each[det.names.index("environment")]
        lines.append("  environmental score (signed, baseline held out): " + " ".join(f"{v:+.2f}" for v in env[b, 0]))
        for what, r in (("the environment's rate", share), ("the whole rate", rate)):
            lines.append(f"  one-sided thresholds at {what}: " + "; ".join(
                f"side {s:+.0f}: {n} tests, |score| {th:.2f} (largest {mx:.2f})"
                for s, n, th, mx in environment_sides(env[b, 0], r, n_train)))
        for g in dict.fromkeys(np.asarray(series.groups)[later]):
            sel = np.flatnonzero((np.asarray(series.groups) == g) & later)
            lines.append(f"  {g}: score {env[sel, 0].min():+.2f} to {env[sel, 0].max():+.2f}")
    return lines


def _summary_text(summary: dict) -> str:
    parts = [f"baseline flagged {', '.join(summary['baseline']) or 'none'}"]
    parts += [f"{g} {100 * share:.0f} % (missed {', '.join(m) or 'none'})" for g, v in summary.items()
              if g != "baseline" for share, m in [v]]
    return "; ".join(parts)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, out="out/bench_real_series")
    p.add_argument("--data", default=DATA, help=f"folder of the real sets (default {DATA})")
    p.add_argument("--set", choices=list(LOADERS), default="ds11-b4.6")
    p.add_argument("--rate", type=float, default=0.01, help="false-alarm rate (default 0.01)")
    p.add_argument("--variants", nargs="*", default=list(DEFAULT_VARIANTS), help="variants judged (docstring)")
    a = p.parse_args(argv)
    variants = [(v, *parse_variant(v)) for v in a.variants]
    file, load = LOADERS[a.set]
    series = load(Path(a.data) / file, False)
    out = Path(a.out)
    files = _write_records(series, out / "records" / series.name)
    res = run_monitor(series, files, out / "cache", a.rate)
    print("\n".join(_report(res, series, a.rate)))
    short = [lb.split()[-1] for lb in series.labels]
    print(f"monitor at {a.rate:g}: " + _summary_text(flag_summary(
        series.groups, short, _flagged([r["status"] for r in res.rows]), series.n_baseline)))
    for name, kwargs, patch in variants:
        r = run_monitor(series, files, out / "cache", a.rate, patch, **kwargs)
        print(f"{name}: " + _summary_text(flag_summary(series.groups, short, _flagged([x["status"] for x in r.rows]),
                                                       series.n_baseline)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
