"""``beam-damage monitor``: a series of tests of one beam against the normal variation of its baseline period."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from experiments.cli.args import check_out_dir
from learn.monitor import (DEFAULT_LATENT, NORMAL_MODELS, SeriesInput, alarm_verdicts, identification_settings,
                           monitor_series, read_conditions)
from physics.errors import ConfigError
from physics.io import FRF, MODAL, TIME, accepted, atomic_write_bytes, atomic_write_text, to_jsonable
from datagen.store import package_version
from learn.model_dir import load_model
from physics.beam import load_beam
from experiments.studies.report import Section, Table, figure, write_report

__all__ = ["add_parser", "run"]


def add_parser(sub):
    p = sub.add_parser(
        "monitor",
        description="Each TEST (FRF file: " + accepted(FRF) + "; response records without a force: "
                    + accepted(TIME) + "; modal data: " + accepted(MODAL) + ") is identified once (LSCF/LSFD for "
                    "FRFs, SSI-cov for response records; cached in DIR/cache), its modes tracked across the tests by "
                    "frequency and MAC. The first N tests (--baseline-tests) are the baseline period: the normal "
                    "variation of the log natural frequencies is learnt there (a regression on the measured "
                    "conditions of --conditions, else a latent-variable model), and each test's novelty index (a "
                    "squared Mahalanobis distance of its residual) is compared with a threshold set by cross-"
                    "validation on the baseline period for the false-alarm rate. An alarm says what changed mode by "
                    "mode, and with --model weighs the competing explanations with the measured scatter and gives "
                    "the network's verdict. Writes monitor.json, monitor.csv, monitor.png and report.html in DIR.")
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
    p.add_argument("--normal-model", choices=list(NORMAL_MODELS), default=None,
                   help="normal-variation model (default: regression with measured conditions, else "
                        f"{DEFAULT_LATENT}; docs/monitoring.md compares them)")
    p.add_argument("--chart", choices=("ewma", "none"), default="ewma",
                   help="memory chart of the statistics (EWMA; limits held out on the baseline period with its "
                        "autocorrelation): chart_alarm and onset of each test (default %(default)s)")
    p.add_argument("--statistics", nargs="+", choices=("residual", "environment", "shift"),
                   default=["residual", "environment", "shift"], metavar="NAME",
                   help="statistics combined at the false-alarm rate (residual, environment, shift; the residual "
                        "always): leave environment and shift out when the baseline period does not cover the "
                        "conditions the tests meet (default: all)")
    p.add_argument("--out", metavar="DIR", help="outputs and the identification cache (default without --json: "
                                                "out/monitor)")
    p.add_argument("--json", action="store_true",
                   help='print {"tests": [...], "baseline_tests", "false_alarm_rate", "normal_variation", '
                        '"first_alarm", "version", "config"}')
    p.set_defaults(func=run, flags={"n_baseline": "--baseline-tests"})


def _series(args) -> SeriesInput:
    if args.conditions and args.tests:
        raise ConfigError("give the tests either as TEST... or in --conditions CSV, not both")
    if args.conditions:
        return read_conditions(args.conditions)
    if not args.tests:
        raise ConfigError("no test: give TEST... or --conditions CSV")
    return SeriesInput.from_files(args.tests)


def run(args) -> dict:

    if args.band and not (np.all(np.isfinite(args.band)) and 0 <= args.band[0] < args.band[1]):
        raise ConfigError(f"--band {args.band[0]:g} {args.band[1]:g}: F0 and F1 must be finite with 0 <= F0 < F1")
    if not args.json and not args.out:
        args.out = "out/monitor"
    if args.out:
        check_out_dir(args.out)
    series = _series(args)
    model = beam = beam_x_m = None
    if args.model:

        model = load_model(args.model)
        _, beam_x_m = model.measured_beam(args.beam)
    elif args.beam:

        beam = load_beam(args.beam)
    settings = identification_settings(args.band, beam, model)
    cache = Path(args.out) / "cache" if args.out else None
    res = monitor_series(series, args.baseline_tests, settings, cache, args.false_alarm_rate, args.normal_model,
                         progress=not args.json, chart=getattr(args, "chart", "ewma"),
                         statistics=tuple(getattr(args, "statistics", None) or ("residual", "environment", "shift")))
    verdicts = alarm_verdicts(res, model, beam_x_m)
    for i, v in verdicts.items():
        res.rows[i]["verdict"] = v
    first = res.first_alarm
    out = {"tests": res.rows, "baseline_tests": args.baseline_tests, "false_alarm_rate": args.false_alarm_rate,
           "normal_variation": res.normal_variation, "threshold": res.threshold.to_dict(),
           "first_alarm": None if first is None else {"index": first, "file": res.rows[first]["file"],
                                                      "time": res.rows[first]["time"]},
           "detector": res.detection.to_dict(), "charts": None if res.charts is None else res.charts.to_dict(),
           "n_alarms_after_baseline": sum(r["alarm"] for r in res.rows if not r["baseline"]),
           "n_not_identified": sum(not r["identified"] for r in res.rows),
           "version": package_version(),
           "config": {"identification": settings.to_dict(), "conditions": args.conditions,
                      "condition_names": list(res.series.condition_names), "beam": args.beam, "model": args.model,
                      "normal_model": res.normal_variation["model"], "seed": 0}}
    if args.out:
        out["outputs"] = _write(args.out, out, res)
    if not args.json:
        _print(out, res)
    return out


CSV_COLUMNS = ("file", "time", "baseline", "identified", "alarm", "novelty", "threshold", "error")


def _csv(out: dict, m: int) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    conds = out["config"]["condition_names"]
    w.writerow([*CSV_COLUMNS, *conds, *(f"f{r + 1}_hz" for r in range(m)), *(f"z{r + 1}" for r in range(m)),
                *(f"change{r + 1}_pct" for r in range(m))])
    for r in out["tests"]:
        c = r["conditions"] or {}
        w.writerow([*("" if r[k] is None else r[k] for k in CSV_COLUMNS), *(c.get(k) for k in conds),
                    *r["frequencies_hz"], *r["mode_z_scores"], *r["change_pct"]])
    return buf.getvalue()


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
    alarms = [r for r in out["tests"] if r["alarm"] and not r["baseline"]]
    first = out["first_alarm"]
    summary = Section("Summary", paragraphs=(
        f"{len(out['tests'])} tests, the first {out['baseline_tests']} the baseline period; {m} modes tracked; "
        f"normal variation: {nv['model']}; threshold {thr['value']:.4g} for a false-alarm rate of "
        f"{out['false_alarm_rate']:g} (held-out baseline rate {thr['held_out_false_alarm_rate']:.3g}).",
        f"{len(alarms)} alarms after the baseline period"
        + (f"; the first: {first['file']}{_when(first)}." if first else "."),
        f"{out['n_not_identified']} tests not identified (see the table)." if out["n_not_identified"] else ""))
    modes = Table("Reference modes of the baseline period and their normal variation",
                  ("mode", "frequency (Hz)", "std (%)", "tracking tolerance (%)", "presence",
                   "tests where a narrow-band re-identification found it"),
                  tuple((r + 1, res.reference.frequencies_hz[r], 100 * res.sigma[r],
                         100 * (np.exp(res.reference.tolerance[r]) - 1), res.reference.presence[r],
                         sum("narrow band" in (t["identified_by"][r] or "") for t in out["tests"]
                             if t.get("identified_by")))
                        for r in range(m)))
    alarm_rows = tuple((r["file"], r["time"], r["novelty"], r["verdict"]["summary"],
                        r["verdict"].get("hypotheses_summary") or "–") for r in alarms[:50])
    tables = [modes]
    if "r2" in nv:
        tables.append(Table("Regression on the measured conditions", ("mode", "R^2", *nv["conditions"]),
                            tuple((r + 1, nv["r2"][r], *nv["slope_per_condition"][r]) for r in range(m))))
    if alarm_rows:
        tables.append(Table("Alarms (first 50): what changed against the baseline population",
                            ("file", "time", "novelty", "changed", "explanations"), alarm_rows))
    bad = tuple((r["file"], r["error"]) for r in out["tests"] if not r["identified"])
    if bad:
        tables.append(Table("Tests not identified", ("file", "error"), bad, collapsed=True))
    section = Section("Control chart", figures=(figure(root / "monitor.png"),), tables=tuple(tables))
    written = write_report(root, "Monitoring series", (section,), summary)
    return {**paths, "report.html": written["html"], "report.md": written["markdown"]}


def _figure(res) -> bytes:
    """PNG: each mode's frequency relative to its baseline median and the novelty index over the tests, with the
    threshold, the baseline period shaded and the alarms marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r["time_value"] for r in res.rows])
    base = np.array([r["baseline"] for r in res.rows])
    alarm = np.array([r["alarm"] for r in res.rows])
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    rel = 100 * (res.frequencies_hz / res.reference.frequencies_hz - 1)
    for r in range(rel.shape[1]):
        a1.plot(t, rel[:, r], ".-", ms=3, lw=0.6, label=f"mode {r + 1} ({res.reference.frequencies_hz[r]:.4g} Hz)")
    a1.set(ylabel="frequency - baseline median (%)", title="Natural frequencies")
    a1.legend(fontsize=7, ncol=2)
    nov = res.novelty
    a2.semilogy(t, np.maximum(nov, 1e-3), ".", color="k", ms=4, label="novelty index")
    a2.semilogy(t[alarm], np.maximum(nov[alarm], 1e-3), "o", mfc="none", color="tab:red", ms=7, label="alarm")
    a2.axhline(res.threshold.value, color="tab:red", ls="--",
               label=f"threshold ({100 * res.threshold.rate:g} % false alarms)")
    a2.set(xlabel="time (days)" if res.series.times[0] is not None else "test", ylabel="novelty index",
           title=f"Novelty index ({res.normal_variation['model']})")
    a2.legend(fontsize=7)
    if base.any():
        hi = t[base].max()
        for ax in (a1, a2):
            ax.axvspan(t[base].min(), hi, color="tab:green", alpha=0.1, lw=0)
        a1.text(t[base].min(), 1.0, " baseline period", transform=a1.get_xaxis_transform(), va="top", fontsize=7)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def _when(first: dict) -> str:
    return f" (test {first['index'] + 1}" + (f", time {first['time']})" if first["time"] is not None else ")")


def _print(out: dict, res) -> None:
    thr = out["threshold"]
    nv = res.normal_variation
    print(f"{len(out['tests'])} tests, baseline {out['baseline_tests']}; {res.reference.frequencies_hz.size} modes "
          f"tracked at " + ", ".join(f"{f:.4g}" for f in res.reference.frequencies_hz) + " Hz (std "
          + ", ".join(f"{100 * s:.2g}" for s in res.sigma) + " %)")
    extra = ("; R^2 " + ", ".join(f"{v:.3f}" for v in nv["r2"])) if "r2" in nv else ""
    print(f"normal variation: {nv['model']}{extra}; threshold {thr['value']:.4g} at {out['false_alarm_rate']:g} "
          f"false alarms (held-out baseline: {thr['held_out_false_alarm_rate']:.3g})")
    for r in out["tests"]:
        if r["error"]:
            print(f"  {r['file']}: not used: {r['error']}")
    alarms = [r for r in out["tests"] if r["alarm"] and not r["baseline"]]
    print(f"{len(alarms)} alarms after the baseline period"
          + (f"; first {out['first_alarm']['file']}{_when(out['first_alarm'])}" if alarms else ""))
    for r in alarms[:10]:
        v = r["verdict"]
        print(f"  {r['file']}: novelty {r['novelty']:.4g}: {v['summary']}")
        if v.get("hypotheses_summary"):
            print(f"    {v['hypotheses_summary']}")
        if v.get("network"):
            n = v["network"]
            against = (f"{v['network_baselines']} baseline tests" if v["network_baselines"] != 1
                       else v["network_baseline"])
            print(f"    network (against {against}): damaged {n['damaged']}, P = {n['probability_damaged']}")
    if len(alarms) > 10:
        print(f"  ... {len(alarms) - 10} more in monitor.json")
    for name, p in out.get("outputs", {}).items():
        print(f"wrote {p}")

