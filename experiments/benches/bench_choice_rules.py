"""Benchmark: rules for choosing each mode's frequency estimator, judged by ``monitor``'s detection on the real series.

Run: ``python -m experiments.benches.bench_choice_rules [--data experiments/data/real] [--sets ...] [--rules raw
one-residual one-volume mode-residual short-term] [--out out/bench_real_series]`` (``--out``: the folder of
``bench_real_series``' records and identification cache, which this bench reuses; a minute or two from the cache).

Each rule replaces :func:`learn.monitor.estimator_choice.choose_frequencies` inside ``monitor`` (patched for the run,
restored after); the eligibility of the FFT peak for a mode stays :func:`~learn.monitor.estimator_choice
.choose_estimators`' (it reads the mode in every baseline test the identification does, at least ``2 MIN_HALF``
tests hold both, no more gross readings than the identification). The rules:

* ``raw``: ``monitor``'s own (per mode, the smaller robust scatter of ``ln f`` over the baseline);
* ``one-residual``: one estimator for every eligible mode, the FFT peak when the geometric mean over the modes of the
  robust scatter of the held-out residual about the normal model's prediction (each baseline test predicted by the
  model fitted to the others) is the smaller;
* ``one-volume``: the same, by the generalised variance of the components the model keeps (the sum of the logs of
  their variances; the same number of components removed with either estimator, else the identification);
* ``mode-residual``: per eligible mode, the FFT peak where that mode's held-out residual scatter is the smaller, the
  model fitted with each estimator throughout;
* ``short-term``: per eligible mode, the FFT peak where its short-term scatter is the smaller
  (:func:`short_term_scatter`, over the baseline tests holding both in time order: the robust scatter of the
  successive differences of ``ln f`` over ``sqrt 2``, in which a variation of the structure slow against the tests'
  spacing cancels, von Neumann's successive differences).

Per set and group: ``monitor``'s share flagged, and the plain tests on the FFT peaks
(:func:`~experiments.benches.plain_tests.plain_p_values`) matched to ``monitor``'s alarms on the healthy tests
(the held-out baseline and ``intact``) under that rule. Prints a Markdown table and the choices.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import learn.monitor.alarms as alarms  # noqa: E402
from experiments.benches.bench_real_series import (DATA, LOADERS, _flagged, _write_records,  # noqa: E402
                                                   fft_frequencies, mode_windows_hz, reference_fft_modes)
from experiments.benches.harness import parser, table  # noqa: E402
from experiments.benches.plain_tests import matched_alarms, plain_p_values  # noqa: E402
from learn.monitor import IdentificationSettings, SeriesInput, monitor_series  # noqa: E402
from learn.monitor.estimator_choice import (FFT_PEAK, MIN_HALF, FrequencyChoice,  # noqa: E402
                                            choose_frequencies)
from learn.monitor.normal_models import DEFAULT_LATENT, NORMAL_MODELS  # noqa: E402
from learn.pairs.noise_calibration import robust_std  # noqa: E402

__all__ = ["RULES", "held_out_residuals", "main", "rule_choice", "short_term_scatter"]

RULES = ("raw", "one-residual", "one-volume", "mode-residual", "short-term")
HEALTHY = ("baseline", "intact")


def held_out_residuals(X) -> tuple:
    """``(R (n, m), k)``: each baseline test's residual about the prediction of the default latent model
    (:data:`~learn.monitor.normal_models.DEFAULT_LATENT`) fitted to the other tests of ``X`` (n, m) (NaN where
    ``X`` is missing), and the number of components the model fitted to all of them removes."""
    X = np.asarray(X, float)
    full = NORMAL_MODELS[DEFAULT_LATENT](X.shape[1], 0).fit(X)
    R = np.full(X.shape, np.nan)
    for i in range(len(X)):
        mdl = full.with_choices().fit(np.delete(X, i, axis=0))
        R[i] = X[i] - mdl.expected(X[i:i + 1])[0]
    R[~np.isfinite(X)] = np.nan
    return R, full.k_


def short_term_scatter(x) -> float:
    """The 1.4826 MAD of the successive differences of ``x`` (k,) (time order, NaN dropped) over ``sqrt 2``: the
    standard deviation of a white error on top of a variation slow against the values' spacing; NaN below 2
    values."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return robust_std(np.diff(x)) / np.sqrt(2.0) if x.size > 1 else float("nan")


def rule_choice(rule: str, X_id, X_fft, eligible) -> tuple:
    """``(chosen bool (m,), text)``: the modes read by the FFT peak under ``rule`` from the baseline's ``ln f`` by the
    identification ``X_id`` (n, m) and with every eligible mode's the FFT peak ``X_fft`` (n, m)."""
    el = np.asarray(eligible, bool)
    none = np.zeros_like(el)
    if rule == "short-term":
        both = np.isfinite(X_id) & np.isfinite(X_fft)
        sa = np.array([short_term_scatter(X_id[both[:, r], r]) for r in range(el.size)])
        sb = np.array([short_term_scatter(X_fft[both[:, r], r]) for r in range(el.size)])
        return el & ~(sa < sb), "short-term scatter " + ", ".join(f"{a:.3g}/{b:.3g}" for a, b in zip(sa, sb))
    if rule == "one-volume":
        a = NORMAL_MODELS[DEFAULT_LATENT](el.size, 0).fit(X_id)
        b = NORMAL_MODELS[DEFAULT_LATENT](el.size, 0).fit(X_fft)
        va, vb = np.sum(np.log(a.var_[a.k_:])), np.sum(np.log(b.var_[b.k_:]))
        pick = el.any() and a.k_ == b.k_ and vb <= va
        return (el.copy() if pick else none), f"ln det kept {va:.3g} (k={a.k_}) against FFT {vb:.3g} (k={b.k_})"
    Ra, ka = held_out_residuals(X_id)
    Rb, kb = held_out_residuals(X_fft)
    sa = np.array([robust_std(r) for r in Ra.T])
    sb = np.array([robust_std(r) for r in Rb.T])
    if rule == "one-residual":
        ga, gb = np.exp(np.nanmean(np.log(sa))), np.exp(np.nanmean(np.log(sb)))
        return (el.copy() if el.any() and gb <= ga else none), \
            f"residual scatter (geometric mean) {ga:.3g} (k={ka}) against FFT {gb:.3g} (k={kb})"
    return el & (sb <= sa), "residual scatter " + ", ".join(f"{a:.3g}/{b:.3g}" for a, b in zip(sa, sb))


def _patched(rule: str, log: dict):
    """A :func:`choose_frequencies` with its choice replaced by ``rule``'s, recording it in ``log``."""
    def choose(tests, files, ref, F, cols, baseline, cache_dir=None, workers=1):
        ch = choose_frequencies(tests, files, ref, F, cols, baseline, cache_dir, workers)
        if ch is None or rule == "raw":
            log["chosen"] = None if ch is None else ch.chosen.tolist()
            return ch
        base = np.array([int(i) for i in baseline])
        F, cols = np.asarray(F, float), np.asarray(cols, int)
        el = ch.complete & (ch.n_tests >= 2 * MIN_HALF) & (ch.gross[:, 1] <= ch.gross[:, 0])
        with_fft = F.copy()
        with_fft[:, el] = np.where(cols[:, el] >= 0, ch.fft_hz[:, el], np.nan)
        chosen, log["text"] = rule_choice(rule, np.log(F[base]), np.log(with_fft[base]), el)
        log["chosen"] = chosen.tolist()
        out = F.copy()
        out[:, chosen] = np.where(cols[:, chosen] >= 0, ch.fft_hz[:, chosen], np.nan)
        return FrequencyChoice(ch.default, tuple(FFT_PEAK if c else ch.default for c in chosen), ch.scatter_hz,
                               ch.halves_hz, ch.n_tests, ch.complete, ch.fft_hz, out, ch.gross)
    return choose


def _run(rule: str, files, series, settings, cache, rate: float) -> tuple:
    log = {}
    alarms.choose_frequencies = _patched(rule, log)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = monitor_series(SeriesInput.from_files(files), series.n_baseline, settings, cache, rate,
                                 progress=False, chart="none")
    finally:
        alarms.choose_frequencies = choose_frequencies
    return _flagged([r["status"] for r in res.rows]), log


def main(argv=None) -> int:
    p = parser(__file__, __doc__, out="out/bench_real_series")
    p.add_argument("--data", default=DATA, help=f"folder of the real sets (default {DATA})")
    p.add_argument("--sets", nargs="+", choices=list(LOADERS), default=list(LOADERS))
    p.add_argument("--rules", nargs="+", choices=RULES, default=list(RULES))
    p.add_argument("--rate", type=float, default=0.01, help="false-alarm rate (default 0.01)")
    a = p.parse_args(argv)
    out = Path(a.out)
    lines, notes = [], []
    later = {r: 0 for r in a.rules}
    healthy_flagged = {r: 0 for r in a.rules}
    for name in a.sets:
        file, load = LOADERS[name]
        if not (Path(a.data) / file).is_file():
            print(f"{name}: absent, skipped")
            continue
        series = load(Path(a.data) / file, False)
        files = _write_records(series, out / "records" / series.name)
        settings = IdentificationSettings(tuple(series.band_hz))
        nb = series.n_baseline
        ref = reference_fft_modes(series.records[:nb], series.sampling_frequency_hz[:nb], series.band_hz)
        pv = plain_p_values(fft_frequencies(series.records, series.sampling_frequency_hz,
                                            mode_windows_hz(ref, series.band_hz)), nb)
        groups = np.asarray(series.groups)
        healthy = np.isin(groups, HEALTHY)
        cells = {}
        for rule in a.rules:
            fl, log = _run(rule, files, series, settings, out / "cache", a.rate)
            allowed = int(fl[healthy].sum())
            healthy_flagged[rule] += allowed
            later[rule] += int(fl[~healthy].sum())
            matched = {k: matched_alarms(v, healthy, allowed) for k, v in pv.items()}
            cells[rule] = {g: f"{100 * fl[groups == g].mean():.0f} / " + " / ".join(
                f"{100 * m[groups == g].mean():.0f}" for m in matched.values()) for g in dict.fromkeys(groups)}
            notes.append(f"{name}, {rule}: FFT peak for modes "
                         f"{[r + 1 for r, c in enumerate(log.get('chosen') or []) if c]} {log.get('text', '')}")
        for k, g in enumerate(dict.fromkeys(groups)):
            lines.append([name if k == 0 else "", "baseline (held out)" if g == "baseline" else g,
                          int((groups == g).sum()), *[cells[r][g] for r in a.rules]])
    md = table(["set", "tests", "n", *[f"{r}: monitor / shift, matched / per mode, matched" for r in a.rules]], lines)
    md += "\n\nLater tests flagged by monitor (all sets): " + ", ".join(f"{r} {v}" for r, v in later.items())
    md += "; healthy tests flagged: " + ", ".join(f"{r} {v}" for r, v in healthy_flagged.items())
    print(md + "\n\n" + "\n".join(notes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
