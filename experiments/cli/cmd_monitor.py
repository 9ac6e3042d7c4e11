"""``beam-damage monitor``: a series of tests of one beam against the normal variation of its baseline period."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from experiments.cli.args import check_out_dir, counted
from learn.monitor import (DEFAULT_LATENT, NORMAL_MODELS, SeriesInput, alarm_verdicts, identification_settings,
                           monitor_series, read_conditions)
from learn.monitor.alarms import BASELINE_OUTLIER, EXTRAPOLATED, EXTRAPOLATED_ALARMS, MODE_LOST, MODE_MOVED, STATUSES
from learn.monitor.baseline_trend import series_baseline_trend
from learn.monitor.coverage import baseline_scatter, series_coverage
from learn.monitor.seasons import covers_seasons
from learn.monitor.estimator_choice import FREQUENCY_ESTIMATORS
from learn.monitor.events import group_events, identification_change, lost_modes_change
from learn.monitor.verdicts import event_verdicts
from learn.pairs.measured import on_model_dofs
from physics.errors import BeamDamageError, ConfigError
from physics.identification.output_only import DEFAULT_OUTPUT_ONLY, RECORDS_METHODS
from physics.io import (FRF, MODAL, TIME, accepted, atomic_write_bytes, atomic_write_text, figure_png, modal_or_frf,
                        pyplot, read, to_jsonable)
from datagen.cluster import connect
from datagen.store import package_version
from learn.network.model_dir import load_model
from physics.beam import load_beam
from experiments.studies.report import Section, Table, figure, write_report
import warnings

__all__ = ["JSON_KEYS", "add_parser", "chart", "chart_axis", "judged", "run", "threshold_label", "threshold_text"]


#: The keys of the ``--json`` result (and of monitor.json, which adds ``outputs``).
JSON_KEYS = ("tests", "events", "counts", "identification_change", "lost_modes_change", "baseline_scatter",
             "baseline_trend", "coverage", "normal_variation", "threshold", "first_alarm", "n_alarms_after_baseline",
             "n_not_identified", "n_not_judged", "baseline_tests", "false_alarm_rate", "version", "detector", "charts",
             "config", "warnings")


def add_parser(sub):
    p = sub.add_parser(
        "monitor",
        description="Each TEST (FRF file: " + accepted(FRF) + "; response records without a force: "
                    + accepted(TIME) + "; modal data: " + accepted(MODAL) + ") is identified once (LSCF/LSFD for "
                    "FRFs; for response records as identify picks: ERA for a free response, else SSI-cov; cached in "
                    "DIR/cache), its modes tracked across the tests by "
                    "frequency and MAC. The first N tests (--baseline-tests) are the baseline period: the normal "
                    "variation of the log natural frequencies is learnt there (a regression on the measured "
                    "conditions of --conditions, else a latent-variable model), and each test's novelty index (a "
                    "squared Mahalanobis distance of its residual) is compared with a threshold set by cross-"
                    "validation on the baseline period for the false-alarm rate. A test that could not be identified "
                    "is counted beside the alarms (a run of them, beyond the baseline's share, is a change); a test "
                    "beyond the baseline's conditions is flagged extrapolated. Consecutive alarms are grouped into "
                    "events that say which modes moved, by how much and which way; with --model each event weighs "
                    "the competing explanations with the measured scatter and gives the network's verdict. Writes "
                    "monitor.json, monitor.csv, monitor.png and report.html in DIR.")
    p.add_argument("tests", nargs="*", metavar="TEST", help="test files in time order (or --conditions)")
    p.add_argument("--baseline-tests", type=int, required=True, metavar="N",
                   help="the first N tests are the baseline period (intact beam)")
    p.add_argument("--conditions", metavar="CSV",
                   help="the tests and their measured conditions: columns file (relative to the CSV or absolute), "
                        "time (ISO date or number) and any conditions (e.g. temperature_c); rows sorted by time")
    p.add_argument("--beam", metavar="PRESET|FILE",
                   help="beam preset or TOML beam file: its band (or up to 1.4 times its nominal mode 4) is "
                        "identified, as classify does (default: the model's, else every mode in each file's band)")
    p.add_argument("--model", metavar="MODEL_DIR",
                   help="trained model: explanations and the network's verdict for each alarm")
    p.add_argument("--false-alarm-rate", type=float, default=0.01, metavar="RATE",
                   help="share of intact tests allowed to alarm (default %(default)s)")
    p.add_argument("--band", nargs=2, type=float, metavar=("F0", "F1"), help="identification band in Hz")
    p.add_argument("--records-method", choices=RECORDS_METHODS, default=DEFAULT_OUTPUT_ONLY,
                   help="response records: the output-only method of every test ('auto', default: per record, era "
                        "for a free response, else ssi; 'ssi' for a series known to be ambient)")
    p.add_argument("--normal-model", choices=list(NORMAL_MODELS), default=None,
                   help="normal-variation model (default: regression with measured conditions, else "
                        f"{DEFAULT_LATENT}; docs/monitoring.md compares them)")
    p.add_argument("--chart", choices=("ewma", "none"), default="ewma",
                   help="memory chart of the statistics (EWMA; limits held out on the baseline period with its "
                        "autocorrelation): chart_alarm and onset of each test (default %(default)s)")
    p.add_argument("--statistics", nargs="+", choices=("residual", "environment", "shift", "mode"),
                   default=["residual", "environment", "shift", "mode"], metavar="NAME",
                   help="statistics combined at the false-alarm rate (residual, environment, shift, mode: each "
                        "mode against its own prediction interval about the removed components, with the PCA; the "
                        "residual always): leave environment and shift out when the baseline period does not cover "
                        "the conditions the tests meet (default: residual environment shift mode)")
    p.add_argument("--extrapolated-alarms", choices=EXTRAPOLATED_ALARMS, default="auto",
                   help="a later test beyond the baseline's environment alarmed only by the environment or the shift "
                        f"about the baseline mean: 'separate' reports it as '{EXTRAPOLATED}', beside the alarms; "
                        "'alarm' keeps it an alarm; 'auto' (default) keeps it an alarm when the baseline period is "
                        "known to cover the seasons (dated tests over at least 330 days), else separates it")
    p.add_argument("--frequency-estimator", choices=FREQUENCY_ESTIMATORS, default="choose",
                   help="response records: 'choose' (default) estimates each mode's frequency by the more repeatable "
                        "over the baseline period of the identification and the record's FFT peak (the identification "
                        "kept where its scatter is the smaller, else the FFT peak where it reads every baseline test; "
                        "damping and shapes stay the identification's); "
                        "'identification' always by the identification")
    p.add_argument("--keep-baseline-outliers", action="store_true",
                   help="keep a baseline test whose held-out novelty lies beyond the baseline's family-wise threshold "
                        "(rate / n, the law fitted without it) in the baseline period (default: named, left out, "
                        "status 'baseline outlier')")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="processes identifying the tests (default 1; the results do not depend on it)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="identify the tests on a Dask cluster, e.g. tcp://host:8786, instead of --workers (needs the "
                        "'dask' extra; its workers read the tests and DIR/cache at the paths given here: a shared "
                        "file system; the results do not depend on it)")
    p.add_argument("--out", metavar="DIR", help="outputs and the identification cache (default without --json: "
                                                "out/monitor)")
    p.add_argument("--json", action="store_true",
                   help="print {" + ", ".join(f'"{k}": [...]' if k in ("tests", "events") else f'"{k}"'
                                              for k in JSON_KEYS) + '}, and "outputs" with --out')
    p.set_defaults(func=run, flags={"n_baseline": "--baseline-tests", "workers": "--workers",
                                    "scheduler": "--scheduler"})


def _series(args) -> SeriesInput:
    if args.conditions and args.tests:
        raise ConfigError("give the tests either as TEST... or in --conditions CSV, not both")
    if args.conditions:
        return read_conditions(args.conditions)
    if not args.tests:
        raise ConfigError("no test: give TEST... or --conditions CSV")
    folders = [t for t in args.tests if Path(t).is_dir()]
    if folders:
        raise ConfigError(f"TEST {folders[0]}: is a directory; give its test files in time order "
                          f"({Path(folders[0]) / '*'}) or list them in --conditions CSV")
    return SeriesInput.from_files(args.tests)


def run(args) -> dict:

    if args.band and not (np.all(np.isfinite(args.band)) and 0 <= args.band[0] < args.band[1]):
        raise ConfigError(f"--band {args.band[0]:g} {args.band[1]:g}: F0 and F1 must be finite with 0 <= F0 < F1")
    if not args.json and not args.out:
        args.out = "out/monitor"
        check_out_dir(args.out)                             # the default (a given --out is checked before run)
    series = _series(args)
    model = beam = beam_x_m = None
    if args.model:
        model = _flagged("--model", load_model, args.model)
        _, beam_x_m = _flagged("--beam", model.measured_beam, args.beam)
        _warn_other_beam(args.model, series.files[0], model, beam_x_m)
    elif args.beam:
        beam = _flagged("--beam", load_beam, args.beam)
    settings = replace(identification_settings(args.band, beam, model), records_method=args.records_method)
    cache = Path(args.out) / "cache" if args.out else None
    client = connect(args.scheduler) if args.scheduler else None
    with warnings.catch_warnings(record=True) as caught:    # kept in the result (and monitor.json), said once
        warnings.simplefilter("always")
        try:
            res = monitor_series(series, args.baseline_tests, settings, cache, args.false_alarm_rate,
                                 args.normal_model, progress=not args.json, chart=args.chart,
                                 statistics=tuple(args.statistics), workers=args.workers if client is None else client,
                                 extrapolated_alarms=args.extrapolated_alarms,
                                 frequency_estimator=args.frequency_estimator,
                                 keep_baseline_outliers=args.keep_baseline_outliers)
        finally:
            if client is not None:
                client.close()
        out = judged(res, args.false_alarm_rate, model, beam_x_m)
    out["warnings"] = list(dict.fromkeys(" ".join(str(w.message).split()) for w in caught
                                         if issubclass(w.category, UserWarning)))
    for message in out["warnings"]:                         # on stderr too, --json or not (experiments.cli.main)
        warnings.warn(message)
    out.update(baseline_tests=args.baseline_tests, false_alarm_rate=args.false_alarm_rate, version=package_version(),
               detector=res.detection.to_dict(), charts=None if res.charts is None else res.charts.to_dict(),
               config={"identification": settings.to_dict(), "conditions": args.conditions,
                       "condition_names": list(res.series.condition_names), "beam": args.beam, "model": args.model,
                       "normal_model": res.normal_variation["model"], "chart": args.chart,
                       "statistics": list(args.statistics), "extrapolated_alarms": args.extrapolated_alarms,
                       "frequency_estimator": args.frequency_estimator,
                       "keep_baseline_outliers": args.keep_baseline_outliers,
                       "seed": 0})
    if args.out:
        out["outputs"] = _write(args.out, out, res)
    if not args.json:
        _print(out, res)
    return out


def _warn_other_beam(model_dir, path, model, beam_x_m) -> None:
    """Warn when the first test's FRFs or modes do not lie on the model's DOFs (its node geometry, or its DOF labels by
    the model's convention, :func:`learn.pairs.measured.on_model_dofs`): the tests are of another beam, the band is
    the model's, and no event gets explanations. Response records (shapes identified later) and a file that does not
    read (its row says why) are left to the series."""
    try:
        data = read(path, modal_or_frf(path))
    except (BeamDamageError, OSError):
        return
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            on_model_dofs(data, model.beam, beam_x_m, str(path))
    except BeamDamageError as exc:
        warnings.warn(f"--model {model_dir}: the tests may be of another beam: {exc}; the identification band is "
                      "the model's, and the events get no explanations")


def _flagged(flag: str, load, value):
    """``load(value)``, its refusal prefixed with ``flag`` (``--beam nosuch: neither a beam preset ...``)."""
    try:
        return load(value)
    except BeamDamageError as exc:
        text = str(exc)
        raise ConfigError(f"{flag} {text}" if value is not None and text.startswith(str(value)) else
                          f"{flag}: {text}") from None


def judged(res, false_alarm_rate: float, model=None, beam_x_m=None) -> dict:
    """A monitored series judged: every row's coverage (``extrapolated``), its alarm's ``verdict`` (what changed,
    the event it belongs to; ``extrapolated`` in its summary), the ``events``, the ``counts`` of every status, the
    test of the tests not identified against the baseline's share and the scatter of the later healthy-looking tests
    against the baseline's; with a trained model each event's explanations and the network's verdict. Warnings
    (``warnings.warn``) for a lost identification, a baseline period narrower than the later tests and records
    identified after clipping in their leading part (``record_crop``)."""

    rows = res.rows
    cov = series_coverage(res)
    for i, v in alarm_verdicts(res).items():
        if rows[i]["extrapolated"]:
            v["summary"] += f"; extrapolated: {rows[i]['extrapolated_because']}"
        rows[i]["verdict"] = v
    events = group_events(rows, false_alarm_rate,
                          against="residual" if res.normal_variation["model"] == "regression" else "before")
    for k, (ev, v) in enumerate(zip(events, event_verdicts(res, events, model, beam_x_m))):
        for i in ev.members:
            if "verdict" in rows[i]:
                rows[i]["verdict"]["event"] = k
        if v is not None:
            events[k] = replace(ev, verdict=v)
    cropped = [f"{r['file']}: {r['record_crop']}" for r in rows if r.get("record_crop")]
    if cropped:
        more = "; ..." if len(cropped) > 3 else ""
        warnings.warn(f"{counted(len(cropped), 'test')} clipped in the leading part of the record, identified "
                      f"from the samples after the clipping: {'; '.join(cropped[:3])}{more}")
    ident = identification_change(rows, false_alarm_rate)
    lost = lost_modes_change(rows, false_alarm_rate)
    if lost["change"]:
        warnings.warn(lost["text"])
    scatter = baseline_scatter(rows, res.series.times[0] is not None)
    if ident["change"]:
        warnings.warn(ident["text"])
    if scatter.warning:
        warnings.warn(scatter.warning)
    trend = series_baseline_trend(rows, res.normal_variation["model"],
                                  covers_seasons(res.series.times, res.series.time_values,
                                                 sum(r["baseline"] for r in rows)))
    if trend.warning:
        warnings.warn(trend.warning)
    later = [r for r in rows if not r["baseline"]]
    counts = {s: sum(r["status"] == s for r in later) for s in STATUSES}
    counts.update(extrapolated=sum(r["extrapolated"] for r in later), events=len(events),
                  changes=sum(e.change for e in events), chart_alarms=sum(bool(r.get("chart_alarm")) for r in later))
    first = res.first_alarm
    return {"tests": rows, "events": [e.to_dict() for e in events], "counts": counts,
            "identification_change": ident, "lost_modes_change": lost, "baseline_scatter": scatter.to_dict(),
            "baseline_trend": trend.to_dict(),
            "coverage": None if cov is None else {"coordinates": list(cov.names), "low": cov.low.tolist(),
                                                  "high": cov.high.tolist(),
                                                  "mahalanobis_max": None if not np.isfinite(cov.mahalanobis_max)
                                                  else cov.mahalanobis_max},
            "normal_variation": res.normal_variation, "threshold": res.threshold.to_dict(),
            "first_alarm": None if first is None else {"index": first, "file": rows[first]["file"],
                                                       "time": rows[first]["time"]},
            "n_alarms_after_baseline": counts["alarm"],
            "n_not_identified": sum(r["status"] == "not identified" for r in rows),
            "n_not_judged": sum(r["status"] == "not judged" for r in rows)}


CSV_COLUMNS = ("file", "time", "baseline", "status", "identified", "alarm", "alarmed_by", "chart_alarm", "onset",
               "extrapolated", "novelty", "threshold", "shift_pct", "error")


def _csv_cell(value):
    """A CSV cell: empty for None, ``+``-joined for a list (``alarmed_by``: ``residual+shift``)."""
    if value is None:
        return ""
    return "+".join(map(str, value)) if isinstance(value, list) else value


def _csv(out: dict, m: int) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    conds = out["config"]["condition_names"]
    w.writerow([*CSV_COLUMNS, *conds, *(f"f{r + 1}_hz" for r in range(m)), *(f"z{r + 1}" for r in range(m)),
                *(f"change{r + 1}_pct" for r in range(m))])
    for r in out["tests"]:
        c = r["conditions"] or {}
        w.writerow([*(_csv_cell(r.get(k)) for k in CSV_COLUMNS), *(c.get(k) for k in conds),
                    *r["frequencies_hz"], *r["mode_z_scores"], *r["change_pct"]])
    return buf.getvalue()


def _estimator_texts(nv: dict) -> tuple:
    """The frequency estimator of each mode (response records), e.g. ``Frequency estimators over the baseline
    period: mode 3: FFT peak, scatter 2.6 Hz against era 9.28 Hz ...``; empty for FRFs and modal data."""
    choice = nv.get("frequency_estimators")
    return (f"Frequency estimators over the baseline period: {'; '.join(choice['texts'])}.",) if choice else ()


def _write(out_dir, out: dict, res) -> dict:
    """monitor.png, monitor.csv, monitor.json and report.html (report.md beside it), each written atomically."""
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    paths = {k: str(root / k) for k in ("monitor.png", "monitor.csv", "monitor.json")}
    m = res.reference.frequencies_hz.size
    png = _figure(res)
    atomic_write_bytes(root / "monitor.png", png)
    atomic_write_text(root / "monitor.csv", _csv(out, m))
    atomic_write_text(root / "monitor.json", json.dumps(to_jsonable({**out, "outputs": paths}), indent=1))
    nv = res.normal_variation
    thr = out["threshold"]
    first = out["first_alarm"]
    cnt = out["counts"]
    later = len(out["tests"]) - out["baseline_tests"]
    summary = Section("Summary", paragraphs=(
        f"{len(out['tests'])} tests, the first {out['baseline_tests']} the baseline period; {m} modes tracked; "
        f"normal variation: {nv['model']}; {threshold_text(out)}; held-out baseline rate "
        f"{thr['held_out_false_alarm_rate']:.3g}.",
        f"Of the {later} later tests: {cnt['alarm']} alarms, {cnt[MODE_MOVED]} {MODE_MOVED} and {cnt[MODE_LOST]} "
        f"{MODE_LOST} beyond their bands, {cnt['not identified']} not identified, "
        f"{cnt['no alarm']} without an alarm, {cnt['not judged']} not judged (another kind, band or beam; conditions "
        f"not measured), {cnt[EXTRAPOLATED]} {EXTRAPOLATED} (extrapolated, alarmed by the environmental statistics "
        f"alone); {cnt['extrapolated']} beyond the baseline's conditions (extrapolated). "
        f"{counted(cnt['events'], 'event')}, {cnt['changes']} of them changes"
        + (f"; the first alarm: {first['file']}{_when(first)}." if first else "."),
        *((chart_text(out) + ".",) if out.get("charts") else ()),
        out["identification_change"]["text"] + ".",
        out["lost_modes_change"]["text"] + ".",
        out["baseline_scatter"]["warning"] or _scatter_text(out["baseline_scatter"]),
        *((out["baseline_trend"]["warning"],) if out["baseline_trend"]["warning"] else ()),
        *((nv["baseline_sessions"]["text"] + ".",) if nv.get("baseline_sessions") else ()),
        *_estimator_texts(nv)))
    modes = Table("Reference modes of the baseline period and their normal variation",
                  ("mode", "frequency (Hz)", "std (%)", "tracking tolerance (%)", "presence",
                   "tests where a narrow-band re-identification found it"),
                  tuple((r + 1, res.reference.frequencies_hz[r], 100 * res.sigma[r],
                         100 * (np.exp(res.reference.tolerance[r]) - 1), res.reference.presence[r],
                         sum("narrow band" in (t["identified_by"][r] or "") for t in out["tests"]
                             if t.get("identified_by")))
                        for r in range(m)))
    tables = [modes]
    if "r2" in nv:
        tables.append(Table("Regression on the measured conditions", ("mode", "R^2", *nv["conditions"]),
                            tuple((r + 1, nv["r2"][r], *nv["slope_per_condition"][r]) for r in range(m))))
    events = out["events"]
    if events:
        tables.append(Table(f"Events ({len(events)}; first 50): consecutive alarms and tests not identified",
                            ("first", "last", "tests", "alarms", "not identified", "modes moved", "direction",
                             "mean size (%)", "first / last alarm (%)", "extrapolated", "change", "explanations"),
                            tuple((e["first_file"], e["last_file"], e["n_tests"], e["n_alarms"],
                                   e["n_not_identified"], ", ".join(map(str, e["moved"])) or "–", e["direction"],
                                   "–" if e["size_pct"] is None else f"{e['size_pct']:.3g}",
                                   "–" if e["size_first_pct"] is None else
                                   f"{e['size_first_pct']:.3g} / {e['size_last_pct']:.3g}",
                                   e["n_extrapolated"], "yes" if e["change"] else "no",
                                   ((e["verdict"] or {}).get("hypotheses_summary") or "–"))
                                  for e in events[:50])))
    bad = tuple((r["file"], r["status"], r["error"]) for r in out["tests"] if not r["identified"])
    if bad:
        tables.append(Table("Tests not identified or not judged", ("file", "status", "error"), bad, collapsed=True))
    caption = ("Each mode's frequency relative to its baseline median (%) and the novelty index (residual "
               "statistic) against its threshold; the baseline period shaded")
    section = Section("Control chart", figures=(figure(root / "monitor.png", caption),), tables=tuple(tables))
    written = write_report(root, "Monitoring series", (section,), summary)
    return {**paths, "report.html": written["html"], "report.md": written["markdown"]}


def _figure(res) -> bytes:
    """PNG of :func:`chart`."""
    fig = chart(res)
    fig.tight_layout()
    return figure_png(fig)


def chart(res):
    """The control chart (a matplotlib figure): each mode's frequency relative to its baseline median and the
    novelty index over the tests, with the threshold, the baseline period shaded, the alarms circled, the
    extrapolated tests boxed, the baseline outliers left out diamonded (their index by the model fitted without
    them), the tests whose mode moved or was lost beyond its band marked (triangles up, down), the memory chart's
    alarms ticked at the bottom edge and the tests not identified crossed at the top edge of the index's panel; a
    mode moved beyond its band is drawn at its moved frequency (hollow markers)."""
    plt = pyplot()

    t, xlabel = chart_axis(res.series.times, np.array([r["time_value"] for r in res.rows]))
    base = np.array([r["baseline"] for r in res.rows])
    alarm = np.array([r["alarm"] for r in res.rows])
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    rel = 100 * (res.frequencies_hz / res.reference.frequencies_hz - 1)
    for r in range(rel.shape[1]):
        line = a1.plot(t, rel[:, r], ".-", ms=3, lw=0.6,
                       label=f"mode {r + 1} ({res.reference.frequencies_hz[r]:.4g} Hz)")[0]
        if res.beyond is not None and np.isfinite(res.beyond.moved_hz[:, r]).any():
            a1.plot(t, 100 * (res.beyond.moved_hz[:, r] / res.reference.frequencies_hz[r] - 1), "o", mfc="none",
                    ms=4, color=line.get_color())
    a1.set(ylabel="frequency - baseline median (%)", title="Natural frequencies")
    a1.legend(fontsize=7, ncol=2)
    nov = res.novelty
    a2.semilogy(t, np.maximum(nov, 1e-3), ".", color="k", ms=4, label="novelty index")
    a2.semilogy(t[alarm], np.maximum(nov[alarm], 1e-3), "o", mfc="none", color="tab:red", ms=7, label="alarm")
    out = np.array([r.get("status") == BASELINE_OUTLIER for r in res.rows])
    if out.any():                                   # its index by the model fitted without it
        a2.semilogy(t[out], np.maximum(nov[out], 1e-3), "D", mfc="none", color="tab:gray", ms=8,
                    label=f"baseline outlier, left out ({out.sum()})")
    ext = np.array([bool(r.get("extrapolated")) for r in res.rows])
    if ext.any():
        a2.semilogy(t[ext], np.maximum(nov[ext], 1e-3), "s", mfc="none", color="tab:purple", ms=9,
                    label=f"extrapolated ({ext.sum()}: beyond the baseline's conditions)")
    for status, mark, color in ((MODE_MOVED, "^", "tab:red"), (MODE_LOST, "v", "tab:red")):
        hit = np.array([r.get("status") == status for r in res.rows])
        if hit.any():                               # no alarm of the index: drawn at the top edge, counted
            a2.plot(t[hit], np.full(hit.sum(), 0.9), mark, color=color, ms=6, transform=a2.get_xaxis_transform(),
                    label=f"{status} beyond its band ({hit.sum()})")
    memory = np.array([bool(r.get("chart_alarm")) for r in res.rows])
    if memory.any():                                # the memory chart's alarms: a band along the bottom edge
        a2.plot(t[memory], np.full(memory.sum(), 0.04), "|", color="tab:red", ms=10, mew=2,
                transform=a2.get_xaxis_transform(), label=f"memory chart above its limit ({memory.sum()})")
    lost = np.array([r.get("status") == "not identified" for r in res.rows])
    if lost.any():                                  # no index: drawn at the top edge, counted in the legend
        a2.plot(t[lost], np.full(lost.sum(), 0.96), "x", color="tab:orange", ms=7, mew=1.5,
                transform=a2.get_xaxis_transform(), label=f"not identified ({lost.sum()})")
    det = res.detection
    a2.axhline(res.threshold.value, color="tab:red", ls="--",
               label=threshold_label(res.threshold.rate, det.rate if det else res.threshold.rate,
                                     len(det.names) if det else 1))
    a2.set(xlabel=xlabel, ylabel="novelty index (residual statistic)",
           title=f"Novelty index ({res.normal_variation['model']})")
    if res.series.times[0] is None:
        a2.xaxis.set_major_locator(plt.MaxNLocator(integer=True))
    a2.legend(fontsize=7)
    if base.any():
        hi = t[base].max()
        for ax in (a1, a2):
            ax.axvspan(t[base].min(), hi, color="tab:green", alpha=0.1, lw=0)
        a1.text(t[base].min(), 1.0, " baseline period", transform=a1.get_xaxis_transform(), va="top", fontsize=7)
    return fig


def chart_axis(times, time_values) -> tuple:
    """The chart's abscissa and its label: the test number from 1 (as the text and the events count them) without
    times, else the time values, days since the first test for ISO dates, the numbers as given otherwise."""
    if times[0] is None:
        return np.arange(1, len(time_values) + 1, dtype=float), "test (1 = the first)"
    try:
        float(times[0])
    except (TypeError, ValueError):
        return time_values, "time (days since the first test)"
    return time_values, "time (the time column of --conditions, its unit)"


def threshold_label(rate: float, family_rate: float, n_statistics: int) -> str:
    """The legend of the novelty index's threshold: its own rate and, when several statistics share the
    false-alarm rate, the family-wise rate it is a share of."""
    own = f"threshold ({100 * rate:.3g} % false alarms"
    if n_statistics > 1:
        return own + f"; {100 * family_rate:.3g} % over the {n_statistics} statistics)"
    return own + ")"


def threshold_text(out: dict) -> str:
    """The novelty index's threshold in words, with its own rate and the family-wise false-alarm rate it is a share
    of, e.g. ``threshold 581.4 of the residual statistic at 0.312 % false alarms (1 % over the 4 statistics)``."""
    thr, names = out["threshold"], (out.get("detector") or {}).get("statistics") or ("residual",)
    text = (f"threshold {thr['value']:.4g} of the residual statistic at {100 * thr['false_alarm_rate']:.3g} % false "
            "alarms")
    if len(names) > 1:
        text += f" ({100 * out['false_alarm_rate']:.3g} % over the {len(names)} statistics)"
    return text


def _scatter_text(sc: dict) -> str:
    if sc["ratio"] is None:
        return f"Too few later tests without an alarm ({sc['n_later']}) to compare their scatter with the baseline's."
    return (f"The {sc['n_later']} later tests without an alarm scatter {sc['ratio']:.2f} times as much as the baseline "
            f"tests about the normal model (a baseline period too narrow is named above {sc['warn_above']:g}).")


def _when(first: dict) -> str:
    return f" (test {first['index'] + 1}" + (f", time {first['time']})" if first["time"] is not None else ")")


def chart_text(out: dict) -> str:
    """The memory chart's alarms after the baseline period in words: how many, the first and the onset it dates
    (``memory chart (EWMA): 4 later tests above its limit, the first t21.json, its change dated from t18.json``)."""
    rows = out["tests"]
    hit = [i for i, r in enumerate(rows) if not r["baseline"] and r.get("chart_alarm")]
    if not hit:
        return "memory chart (EWMA): no later test above its limit"
    first, onset = rows[hit[0]], rows[hit[0]].get("onset")
    dated = (f", its change dated from {rows[onset]['file']}{_when({**rows[onset], 'index': onset})}"
             if onset is not None else "")
    return (f"memory chart (EWMA): {counted(len(hit), 'later test')} above its limit, the first {first['file']}"
            f"{_when({**first, 'index': hit[0]})}{dated}")


def _print(out: dict, res) -> None:
    thr = out["threshold"]
    nv = res.normal_variation
    print(f"{len(out['tests'])} tests, baseline {out['baseline_tests']}; {res.reference.frequencies_hz.size} modes "
          f"tracked at " + ", ".join(f"{f:.4g}" for f in res.reference.frequencies_hz) + " Hz (std "
          + ", ".join(f"{100 * s:.2g}" for s in res.sigma) + " %)")
    extra = ("; R^2 " + ", ".join(f"{v:.3f}" for v in nv["r2"])) if "r2" in nv else ""
    print(f"normal variation: {nv['model']}{extra}; {threshold_text(out)}; held-out baseline rate "
          f"{thr['held_out_false_alarm_rate']:.3g}")
    for r in out["tests"]:
        if r["error"]:
            error = r["error"].removeprefix(f"{r['file']}: ")           # the file is named once
            print(f"  {r['file']}: {r['status']}: {error}")
    cnt = out["counts"]
    print(f"after the baseline period: {cnt['alarm']} alarms, {cnt[MODE_MOVED]} {MODE_MOVED}, {cnt[MODE_LOST]} "
          f"{MODE_LOST}, {cnt['not identified']} not identified, "
          f"{cnt['no alarm']} without an alarm, {cnt['not judged']} not judged, {cnt[EXTRAPOLATED]} {EXTRAPOLATED}; "
          f"{cnt['extrapolated']} extrapolated"
          + (f"; first alarm {out['first_alarm']['file']}{_when(out['first_alarm'])}" if out["first_alarm"] else ""))
    if out.get("charts"):
        print(chart_text(out))
    print(out["identification_change"]["text"])
    print(out["lost_modes_change"]["text"])
    print(f"{counted(cnt['events'], 'event')}, {counted(cnt['changes'], 'change')}:")
    for e in out["events"][:10]:
        print(f"  {e['text']}")
        v = e["verdict"] or {}
        if v.get("hypotheses_summary"):
            print(f"    {v['hypotheses_summary']}")
        if v.get("network"):
            n = v["network"]
            against = (f"{v['network_baselines']} baseline tests" if v["network_baselines"] != 1
                       else v["network_baseline"])
            print(f"    network ({v['representative']} against {against}): "
                  f"{'damaged' if n['damaged'] else 'no damage detected'} (probability of damage "
                  f"{n['probability_damaged']:.1%})")
    if len(out["events"]) > 10:
        print(f"  ... {len(out['events']) - 10} more in monitor.json")
    for name, p in out.get("outputs", {}).items():
        print(f"wrote {p}")

