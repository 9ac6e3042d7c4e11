"""Benchmark: monitoring a beam over a year; true-positive rate at 1 % false alarms and detection delay, per method.

Run: ``python -m experiments.benches.bench_monitor --out out/monitor-bench [--sizes small medium large]
[--kinds frf output-only] [--n-tests 240] [--baseline-tests 80] [--n-train 12000] [--docs]``

The series are the independent simulator's (:mod:`experiments.second_sim.series`: a steel cantilever tested on
``--n-tests`` days over a year; temperature driving EI by about +-1 %, re-mounting, a bolted mass re-placed a few cm
each time, measurement noise; a slit appearing on day ``--damage-day``), one per slit size and record kind: FRFs
(UFF) and output-only response records (NPZ). Every series holds the same tests before the damage day. The first
``--baseline-tests`` tests are the baseline period (the first third of the year: winter and spring, so summer lies
beyond the temperatures the baseline saw). Methods, each through the CLI:

* ``monitor (temperature)`` / ``monitor``: ``beam-damage monitor TEST... --baseline-tests N --beam beam.toml
  --false-alarm-rate 0.01 --json``, with the measured temperatures (``--conditions conditions.csv``) and without;
* ``monitor (temperature), identify's modes`` (output-only): ``monitor`` on the modal JSON that
  ``identify --max-order 120`` gave each record (below), to separate the identification from the detection;
* ``classify, 1 baseline``: ``beam-damage classify --model M TEST... --baseline FIRST`` (the pair classifier
  against the first test; the model trained on the series' ``beam.toml`` by ``generate --config`` (training with
  the series' damping ratios, as classify's warning asks) and ``train``, cached under ``--out``);
* ``classify, N baselines``: the same with every test of the baseline period as ``--baseline`` (repeated; its
  ``--false-alarm-rate`` left at the default);
* ``frequency shift``: the signed mean relative frequency shift of each test against the first test (output-only:
  each of the first test's modes read as the test's nearest within half the smaller gap to its neighbours,
  :func:`paired_frequencies`), alarmed below the 1st percentile of the baseline period's shifts (a drop larger than
  99 % of the baseline's).

``monitor`` identifies each file once (its cache in ``--out``/monitor/KIND serves every size and both runs).
Output-only records are identified by ``beam-damage identify REC.npz --band 5 400 --max-order 120`` into modal
JSON for ``classify`` and the frequency shift (cached by content: the tests before the damage day once for every
size); ``monitor`` reads the records itself.

Scores per method and series: alarms on the intact tests after the baseline period (false-alarm rate), alarms on
the damaged tests (true-positive rate at the method's own threshold), the true-positive rate at 1 % false alarms of
the method's continuous score (novelty / threshold, probability of damage, frequency drop) with the threshold set
on the intact monitoring tests, and the delay: days from the slit's appearance to the first of ``--stay`` alarms in
a row. Writes ``monitor_bench.csv``, ``.json``, ``.md`` and ``monitor_bench.png`` in ``--out``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from pathlib import Path
import csv

# the simulator's matrices are small: one BLAS thread is fastest, and several stall on a shared machine
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.cli import build_parser  # noqa: E402
from experiments.second_sim.series import SERIES_KINDS, SLIT_SIZES, SeriesConfig, simulate_series, write_series  # noqa: E402
from experiments.benches.bench_real_series import mode_windows_hz  # noqa: E402
from experiments.benches.harness import cli_json, parser, publish  # noqa: E402
from physics.io import atomic_write_bytes, atomic_write_text, figure_png, pyplot  # noqa: E402

__all__ = ["main", "markdown", "paired_frequencies", "score_series"]

METHODS = ("monitor (temperature)", "monitor", "monitor (temperature), identify's modes", "classify, 1 baseline",
           "classify, N baselines", "frequency shift")
OUTPUT_ONLY_BAND_HZ = (5.0, 400.0)


def classify_takes_several_baselines() -> bool:
    """Whether this checkout's ``classify --baseline`` takes several files."""
    sub = next(a for a in build_parser(["classify"])._actions if isinstance(a, argparse._SubParsersAction))
    action = next(a for a in sub.choices["classify"]._actions if "--baseline" in a.option_strings)
    return isinstance(action, argparse._AppendAction) or action.nargs not in (None, 1)


def _series(out: Path, kind: str, size: str, a) -> Path:
    """The series of one record kind and slit size (written once)."""
    d = out / "series" / f"{kind}-{size}"
    if not (d / "truth.json").is_file():
        cfg = SeriesConfig(n_tests=a.n_tests, seed=a.seed, kind=kind, damage_day=a.damage_day,
                           slit_ei_loss=SLIT_SIZES[size])
        write_series(cfg, simulate_series(cfg), d)
    return d


def _model(out: Path, beam_toml: Path, damping_ratios, n_train: int, seed: int) -> Path:
    """The pair classifier trained on the series' beam file (generate with the series' damping, train); cached."""
    model = out / "model"
    if (model / "config.json").is_file():
        return model
    cfg = out / "generate.toml"
    atomic_write_text(cfg, 'base = "training"\n[specimen]\ndamping_ratios = ['
                      + ", ".join(f"{z:g}" for z in damping_ratios) + "]\n")
    cli_json(["generate", "--beam", str(beam_toml), "--config", str(cfg), "--n", str(n_train), "--seed", str(seed),
              "--out", str(out / "model-data"), "--workers", "2"])
    cli_json(["train", "--data", str(out / "model-data"), "--out", str(model)])
    return model


def _modal_json(cache: Path, record: Path) -> Path | None:
    """``identify`` of one response record into modal JSON, cached by the record's content; None if it fails."""
    key = hashlib.sha1(record.read_bytes()).hexdigest()[:16]
    target = cache / f"{key}.json"
    failed = cache / f"{key}.failed"
    if target.is_file():
        return target
    if failed.is_file():
        return None
    work = cache / f"id-{key}"
    try:
        cli_json(["identify", str(record), "--band", *(f"{v:g}" for v in OUTPUT_ONLY_BAND_HZ), "--max-order", "120",
                  "--out", str(work)])
    except RuntimeError as exc:
        failed.write_text(str(exc) + "\n")
        return None
    (work / "modal.json").replace(target)
    return target


def _classify(model: Path, tests: list, baselines: list, chunk: int = 40) -> list:
    """``classify --json`` of every test against ``baselines`` (one or several): one call for every test, else
    (a test refused) calls of ``chunk`` tests, else one per test; ``{"error": ...}`` for a test it refused."""
    def run(files):
        v = cli_json(["classify", "--model", str(model), *map(str, files),
                  *(x for b in baselines for x in ("--baseline", str(b)))])
        return v if isinstance(v, list) else [v]

    try:
        return run(tests)
    except RuntimeError:
        pass
    out = []
    for i in range(0, len(tests), chunk):
        part = tests[i:i + chunk]
        try:
            out += run(part)
        except RuntimeError:
            for f in part:
                try:
                    out += run([f])
                except RuntimeError as exc:
                    out.append({"error": str(exc)})
    return out


def _frequencies(verdicts: list, modal_files: list | None, n_modes: int) -> np.ndarray:
    """Identified frequencies per test (NaN where missing), shape (n_tests, n_modes): from the modal JSON files
    (output-only) or classify's identification (the first test's from its baseline entry)."""
    F = np.full((len(verdicts) + 1, n_modes), np.nan)
    if modal_files is not None:
        found = [np.asarray(json.loads(Path(p).read_text())["natural_frequencies_hz"], float) if p is not None
                 else np.zeros(0) for p in modal_files]
        ref = found[0][:n_modes]
        for k, f in enumerate(found):
            F[k, :ref.size] = paired_frequencies(f, ref)
        return F
    for k, v in enumerate(verdicts, start=1):
        ident = v.get("identification") or {}
        if k == 1 and ident.get("baseline_frequencies_hz"):
            F[0] = [np.nan if x is None else x for x in ident["baseline_frequencies_hz"][:n_modes]]
        if ident.get("measured_frequencies_hz"):
            F[k] = [np.nan if x is None else x for x in ident["measured_frequencies_hz"][:n_modes]]
    return F


def paired_frequencies(f_hz: np.ndarray, ref_hz: np.ndarray) -> np.ndarray:
    """Each reference mode's reading among one test's identified frequencies ``f_hz``: the nearest within the mode's
    window (:func:`~experiments.benches.bench_real_series.mode_windows_hz`: half the smaller log gap to its
    neighbours; NaN where none lies there), shape ``ref_hz.shape``; an extra pole (a mode split in two) then takes
    no other mode's place."""
    f_hz, ref_hz = np.asarray(f_hz, float), np.asarray(ref_hz, float)
    if not f_hz.size or not ref_hz.size:
        return np.full(ref_hz.shape, np.nan)
    w = mode_windows_hz(ref_hz, (0.0, np.inf))
    d = np.abs(np.log(f_hz[None]) - np.log(ref_hz[:, None]))            # (modes, found)
    d = np.where((f_hz[None] >= w[:, :1]) & (f_hz[None] <= w[:, 1:]), d, np.inf)
    j = np.argmin(d, axis=1)
    return np.where(np.isfinite(d[np.arange(ref_hz.size), j]), f_hz[j], np.nan)


def frequency_shift(F: np.ndarray, n_baseline: int) -> tuple[np.ndarray, np.ndarray]:
    """Score (the drop: minus the signed mean relative shift against test 0) and alarms (score above the 99th
    percentile of the baseline period's tests 1..N-1)."""
    drop = -np.nanmean((F - F[0]) / F[0], axis=1)
    threshold = np.nanpercentile(drop[1:n_baseline], 99)
    return drop, drop > threshold


def score_series(day: np.ndarray, damaged: np.ndarray, alarm: np.ndarray, score: np.ndarray, n_baseline: int,
                 damage_day: float, stay: int = 5) -> dict:
    """Rates and delay of one method on one series.

    Parameters
    ----------
    day : ndarray, shape (n,)
        Day of each test.
    damaged : ndarray of bool, shape (n,)
    alarm : ndarray of float, shape (n,)
        1 alarmed, 0 not, NaN not answered.
    score : ndarray, shape (n,)
        The method's continuous score (larger: more likely damaged), NaN where not answered.
    n_baseline : int
        Tests of the baseline period (not scored).
    damage_day : float
    stay : int
        Alarms in a row that make a detection.

    Returns
    -------
    dict
        ``false_alarm_rate`` and ``true_positive_rate`` at the method's own threshold, ``tpr_at_1pct`` of the
        score (threshold: the 99th percentile of the intact monitoring tests' scores), ``delay_days`` (None: no
        ``stay`` alarms in a row), ``answered`` and the test counts.
    """
    mon = np.arange(day.size) >= n_baseline
    neg, pos = mon & ~damaged, mon & damaged
    a = np.asarray(alarm, float)
    s = np.asarray(score, float)
    ok = np.isfinite(a)
    fpr = float(np.mean(a[neg & ok])) if (neg & ok).any() else float("nan")
    tpr = float(np.mean(a[pos & ok])) if (pos & ok).any() else float("nan")
    sn, sp = s[neg & np.isfinite(s)], s[pos & np.isfinite(s)]
    tpr1 = float(np.mean(sp > np.percentile(sn, 99))) if sn.size and sp.size else float("nan")
    delay = None
    hit = np.where(pos, np.nan_to_num(a) > 0, False)
    idx = np.flatnonzero(pos)
    for i in idx:
        run = hit[i:i + stay]
        if run.size == min(stay, idx[-1] + 1 - i) and run.all():
            delay = float(day[i] - damage_day)
            break
    return {"false_alarm_rate": fpr, "true_positive_rate": tpr, "tpr_at_1pct": tpr1, "delay_days": delay,
            "answered": int(ok[mon].sum()), "intact_tests": int(neg.sum()), "damaged_tests": int(pos.sum())}


def _monitor(files: list, conditions: Path | None, n_baseline: int, beam: Path, band_hz, out: Path) -> tuple:
    """``monitor --json`` of the series (its files, or the ``conditions`` CSV listing them with the measured
    temperatures); alarms and novelty / threshold per test."""
    argv = ["monitor", *(["--conditions", str(conditions)] if conditions else map(str, files)),
            "--baseline-tests", str(n_baseline), "--beam", str(beam), "--false-alarm-rate", "0.01", "--out", str(out)]
    if band_hz is not None:
        argv += ["--band", *(f"{v:g}" for v in band_hz)]
    res = cli_json(argv)
    by_file = {Path(t["file"]).name: t for t in res["tests"]}
    rows = [by_file.get(Path(f).name, {}) for f in files]
    alarm = np.array([np.nan if r.get("alarm") is None else float(bool(r["alarm"])) for r in rows])
    score = np.array([np.nan if r.get("novelty") is None or not r.get("threshold") else
                      float(r["novelty"]) / float(r["threshold"]) for r in rows])
    return alarm, score


def _modal_conditions(series: Path, modal: list, path: Path) -> Path:
    """``conditions.csv`` of the series with each record replaced by its identified modal JSON (absolute paths)."""
    rows = list(csv.DictReader((series / "conditions.csv").open()))
    lines = ["file,time,temperature_c"] + [f"{m.resolve()},{r['time']},{r['temperature_c']}"
                                           for r, m in zip(rows, modal) if m is not None]
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


def _cached(path: Path, compute):
    """``(alarm, score)`` of one method on one series, computed once and kept in ``path``, or an error text."""
    if path.is_file():
        d = json.loads(path.read_text())
        return np.array(d["alarm"], float), np.array(d["score"], float)

    v = compute()
    if isinstance(v, str):                              # an error is not kept: the next run tries again
        return v
    atomic_write_text(path, json.dumps({"alarm": [None if not np.isfinite(x) else x for x in v[0]],
                                        "score": [None if not np.isfinite(x) else x for x in v[1]]}))
    return v


def run_series(series: Path, model: Path | None, a, out: Path) -> dict:
    """Every method on one series: ``{method: (alarm, score) or error text}`` and the truth (each method's answer
    cached in ``out/results``)."""
    truth = json.loads((series / "truth.json").read_text())
    kind = truth["kind"]
    files = [series / t["file"] for t in truth["tests"]]
    n_b = a.baseline_tests
    cache = out / "results" / f"{series.name}-b{n_b}"
    cache.mkdir(parents=True, exist_ok=True)
    res: dict = {}

    beam = series / "beam.toml"
    band = OUTPUT_ONLY_BAND_HZ if kind == "output-only" else None

    def monitor(test_files, conditions, directory):
        try:
            return _monitor(test_files, conditions, n_b, beam, band, out / "monitor" / directory)
        except RuntimeError as exc:
            return str(exc).splitlines()[0][:300]

    # one directory per record kind: its identification cache (keyed by file content) serves every size
    res["monitor (temperature)"] = _cached(cache / "monitor-1.json",
                                           lambda: monitor(files, series / "conditions.csv", kind))
    res["monitor"] = _cached(cache / "monitor-0.json", lambda: monitor(files, None, kind))
    modal = [_modal_json(out / "identified", f) for f in files] if kind == "output-only" else None
    if modal is not None:
        band = None
        res["monitor (temperature), identify's modes"] = _cached(cache / "monitor-modal.json", lambda: monitor(
            modal, _modal_conditions(series, modal, cache / "conditions-modal.csv"), "modal"))
    inputs = modal if modal is not None else files
    idx = [k for k in range(1, len(inputs)) if inputs[k] is not None]

    def classify(baselines, first=1):
        tested = [k for k in idx if k >= first]
        try:
            v = _classify(model, [inputs[k] for k in tested], baselines)
        except RuntimeError as exc:
            return str(exc).splitlines()[0][:300]
        alarm, score = np.full(len(files), np.nan), np.full(len(files), np.nan)
        for k, r in zip(tested, v):
            if "damaged" in r:
                alarm[k] = float(bool(r["damaged"]))     # the classical verdict has no probability: its call
                score[k] = alarm[k] if r.get("probability_damaged") is None else float(r["probability_damaged"])
        if len(baselines) == 1:                          # the frequencies classify identified, for the shift
            F = _frequencies([{}] * (len(files) - 1) if modal is not None else
                             [dict(zip(idx, v)).get(k, {}) for k in range(1, len(files))], modal,
                             truth["config"]["n_modes"])
            atomic_write_text(cache / "frequencies.json", json.dumps(np.where(np.isfinite(F), F, -1.0).tolist()))
        return alarm, score


    if model is not None and inputs[0] is not None:
        res["classify, 1 baseline"] = _cached(cache / "classify-1.json", lambda: classify([inputs[0]]))
        if classify_takes_several_baselines():              # the tests after the baseline period only
            res["classify, N baselines"] = _cached(cache / "classify-n.json", lambda: classify(
                [p for p in inputs[:n_b] if p is not None], first=n_b))
        else:
            res["classify, N baselines"] = "not run: this checkout's classify takes one --baseline"
    if (cache / "frequencies.json").is_file():
        F = np.array(json.loads((cache / "frequencies.json").read_text()), float)
        F[F < 0] = np.nan
        drop, alarm = frequency_shift(F, n_b)
        res["frequency shift"] = (np.where(np.isfinite(drop), alarm, np.nan), drop)
    return {"truth": truth, "results": res}


def markdown(rows: list) -> str:
    """The benchmark table."""

    def pct(v):
        return "-" if v is None or not np.isfinite(v) else f"{100 * v:.0f} %"

    lines = ["| record | slit (mode-1 drop) | method | false alarms (intact tests) | detected (damaged tests) | "
             "detected at 1 % false alarms | delay (days) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if r.get("error"):
            lines.append(f"| {r['kind']} | {r['size']} ({r['drop_pct']:.2f} %) | {r['method']} | "
                         f"{r['error']} | | | |")
            continue
        delay = "never" if r["delay_days"] is None else f"{r['delay_days']:.0f}"
        lines.append(f"| {r['kind']} | {r['size']} ({r['drop_pct']:.2f} %) | {r['method']} | "
                     f"{pct(r['false_alarm_rate'])} of {r['intact_tests']} | {pct(r['true_positive_rate'])} of "
                     f"{r['damaged_tests']} | {pct(r['tpr_at_1pct'])} | {delay} |")
    return "\n".join(lines) + "\n"


def docs_text(rows: list, a) -> str:
    """The docs block: what was run, the table, how to reproduce it."""
    return (f"The independent simulator's monitoring series (`python -m experiments.second_sim series`: a steel "
            f"cantilever 0.8 m, 40 x 8 mm, 3 accelerometers, tested {a.n_tests} times over a year; temperature "
            f"(seasonal +-12 degC and +-3 degC day to day) driving EI by -0.08 %/degC, the clamp re-made (+-4 %) and a "
            f"bolted mass of 2 % re-placed +-3 cm before each test; a 4 mm slit at 0.15 L from day "
            f"{a.damage_day:g}). The first {a.baseline_tests} tests (January to April) are the baseline period. "
            f"False alarms: alarms on the intact tests after the baseline period; detected: alarms on the damaged "
            f"tests (both at the method's own threshold, `monitor --false-alarm-rate 0.01`); detected at 1 % false "
            f"alarms: of the method's score with the threshold at the 99th percentile of the intact tests' scores; "
            f"delay: days from the slit's appearance to the first of {a.stay} alarms in a row.\n\n"
            + markdown(rows)
            + f"\n`python -m experiments.benches.bench_monitor --out out/monitor-bench --n-tests {a.n_tests} "
              f"--baseline-tests {a.baseline_tests} --docs` (the classifier: `generate --config training` with the "
              f"series' damping ratios, {a.n_train} pairs, then `train`).\n")


def _figure(rows: list, path: Path) -> None:
    plt = pyplot()

    kinds = sorted({r["kind"] for r in rows})
    sizes = list(dict.fromkeys(r["size"] for r in rows))
    fig, axes = plt.subplots(len(kinds), 2, figsize=(12, 3.6 * len(kinds)), squeeze=False)
    width = 0.8 / len(METHODS)
    for i, kind in enumerate(kinds):
        for j, (key, label) in enumerate((("true_positive_rate", "detected (own threshold)"),
                                          ("false_alarm_rate", "false alarms (own threshold)"))):
            ax = axes[i, j]
            for m, method in enumerate(METHODS):
                vals = [next((r.get(key) for r in rows if r["kind"] == kind and r["size"] == s
                              and r["method"] == method and not r.get("error")), None) for s in sizes]
                ax.bar(np.arange(len(sizes)) + m * width, [np.nan if v is None else 100 * v for v in vals], width,
                       label=method)
            ax.set_xticks(np.arange(len(sizes)) + 0.4 - width / 2, sizes)
            ax.set_ylabel(f"{label} (%)")
            ax.set_title(f"{kind}")
            if key == "false_alarm_rate":
                ax.axhline(1.0, color="k", lw=0.8, ls=":")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    atomic_write_bytes(path, figure_png(fig))


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/monitor-bench", seed=0)
    p.add_argument("--kinds", nargs="+", choices=SERIES_KINDS, default=list(SERIES_KINDS))
    p.add_argument("--sizes", nargs="+", choices=list(SLIT_SIZES), default=list(SLIT_SIZES))
    p.add_argument("--n-tests", type=int, default=240, help="tests over the year (default 240)")
    p.add_argument("--baseline-tests", type=int, default=80, help="tests of the baseline period (default 80)")
    p.add_argument("--damage-day", type=float, default=270.0)
    p.add_argument("--n-train", type=int, default=12000, help="pairs generated for the classifier (default 12000)")
    p.add_argument("--stay", type=int, default=5, help="alarms in a row that make a detection (default 5)")
    a = p.parse_args(argv)

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, series_out = [], {}
    model = None
    for kind in a.kinds:
        for size in a.sizes:
            d = _series(out, kind, size, a)
            truth = json.loads((d / "truth.json").read_text())
            if model is None:
                model = _model(out, d / "beam.toml", truth["config"]["damping_ratios"], a.n_train, a.seed)
            r = run_series(d, model, a, out)
            tests = truth["tests"]
            day = np.array([t["day"] for t in tests])
            damaged = np.array([t["damaged"] for t in tests])
            drop = 100 * truth["slit_frequency_drop"][0]
            series_out[d.name] = {}
            for method in METHODS:
                v = r["results"].get(method)
                base = {"kind": kind, "size": size, "drop_pct": drop, "method": method}
                if v is None:                           # not a method of this record kind
                    continue
                if isinstance(v, str):
                    rows.append({**base, "error": v})
                    continue
                alarm, score = v
                rows.append({**base, **score_series(day, damaged, alarm, score, a.baseline_tests,
                                                    a.damage_day, a.stay)})
                series_out[d.name][method] = {"alarm": alarm.tolist(), "score": score.tolist()}
            print(markdown([x for x in rows if x["kind"] == kind and x["size"] == size]), file=sys.stderr)
    md = markdown(rows)
    sys.stdout.write(md)
    import pandas as pd

    atomic_write_text(out / "monitor_bench.csv", pd.DataFrame(rows).to_csv(index=False))
    atomic_write_text(out / "monitor_bench.json", json.dumps({"config": vars(a), "rows": rows,
                                                              "series": series_out}, indent=1, default=str))
    atomic_write_text(out / "monitor_bench.md", md)
    _figure(rows, out / "monitor_bench.png")
    publish(a, "monitor", docs_text(rows, a))
    return 0


if __name__ == "__main__":
    sys.exit(main())
