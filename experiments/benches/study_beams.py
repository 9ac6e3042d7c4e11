"""The loop on every beam of the independent simulator's catalogue, scored per beam and per method.

Run: ``python -m experiments.benches.study_beams --out out/beams [--n-pairs 40] [--train-n 20000] [--only NAME]
[--seed 0] [--spread KEY=VALUE ...] [--json] [--before BEAMS_JSON] [--docs]``

For each beam of :data:`experiments.second_sim.beams.CATALOGUE` (any support, 1-12 sensors, its own band),
as the README's loop, through the CLI: the simulator writes ``beam.toml`` and ``--n-pairs`` (baseline, current)
UFF pairs; ``generate --beam beam.toml --config training --n TRAIN_N``; ``train``; ``classify --baseline B C
--json`` per pair. Per beam and method (``network``: the verdict's network answer; each classical method of
``classical_methods``; ``verdict``: the verdict itself):

* ``zone acc.``: damaged pairs called damaged with the slit's zone (the verdict's ``zone_edges_m``);
* ``detection``; ``|dx/L|``: median ``|x - x_true| / L`` over detected slits;
* ``false alarms``: intact pairs called damaged (%);
* ``size err.``: median ``|s / s_true - 1|`` of the hinge flexibility ``EI / (k L)`` over detected slits;
* ``1-sigma``: share of detected slits whose size (and place) lies within the reported standard deviation.

Where modes cannot tell the place (a symmetric support read on natural frequencies alone: one sensor, or a
frequency-only pair) classify folds every location onto ``x <= L / 2``; the truth is folded alike and the row
is marked ``folded``. Targets (network): zone accuracy >= the best classical method's, false alarms <= 2 %,
median ``|dx/L|`` <= 0.03 on beams read unfolded.

Writes ``beams.csv``, ``beams.json`` (rows, per-beam timings and training metrics, seed and config),
``beams.md`` and ``beams.png`` (zone accuracy, network vs best classical method, per beam) in ``--out``;
pairs, datasets, models and verdicts stay under ``--out/NAME`` and are reused by a rerun with the same sizes.
``--docs`` writes the per-beam summary (:func:`docs_markdown`: the network's zone accuracy, the best classical
method's, the network's location, false alarms and size, and the pooled row) into ``docs/classifier.md``, block
``study-beams``; ``--before BEAMS_JSON`` (the ``beams.json`` of an earlier run) adds that run's network zone
accuracy in parentheses.

``--spread KEY=VALUE`` changes a field of the pairs' distribution (:class:`experiments.second_sim.beams.Spread`,
e.g. ``suspension_change=0`` or ``bounce_over_f1=0.05,0.05``): new pairs, classified by the same models, and
the outputs named ``beams-KEY=VALUE...``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from dataclasses import fields, replace

import numpy as np

from experiments.benches.harness import cli_json, parser, publish
from experiments.second_sim.beams import CATALOGUE, SPREAD, Spread, simulate_beam_pairs, write_beam_pairs
from physics.io import atomic_write_bytes, atomic_write_text, figure_png, pyplot

__all__ = ["TARGETS", "docs_markdown", "fold", "folded", "main", "markdown", "parse_spread", "pooled", "run_beam",
           "score_beam", "targets"]

#: A slit is "small" when it lowers no mode of the band by this much (relative) on its own.
SMALL_DROP = 0.005

#: Targets of the network on every beam.
TARGETS = {"false_alarm_pct": 2.0, "median_dx_over_L": 0.03}


def _nan(v) -> float:
    return float("nan") if v is None else float(v)


def fold(x_m, length_m: float):
    """``min(x, L - x)``: a location on the half ``x <= L / 2``."""
    return np.minimum(x_m, length_m - np.asarray(x_m))


def _answers(v: dict) -> dict:
    """Method -> answer (dict, or None where the method gave none) of one verdict."""
    out = {"verdict": v, "network": v.get("network")}
    for c in v.get("classical_methods") or []:
        out[c["method"]] = c
    return out


def folded(v: dict, meta: dict) -> bool:
    """Whether classify folded this pair's locations (symmetric support read on frequencies alone)."""
    return bool(meta["symmetric"] and (len(meta["measured_x_m"]) == 1 or v.get("input_route") == "frequency"))


def score_beam(verdicts: list[dict], meta: dict) -> list[dict]:
    """Rows (one per method) of one beam's verdicts against the simulator's truth (``truth.json``: ``meta``)."""
    truth = meta["pairs"]
    L = float(meta["length_m"])
    damaged = np.array([bool(t["damaged"]) for t in truth])
    folded_pairs = np.array([folded(v, meta) for v in verdicts])
    x_true = np.array([_nan(t["slit_x_m"]) for t in truth])
    x_true = np.where(folded_pairs, fold(x_true, L), x_true)
    s_true = np.array([float(t["hinge_flexibility"]) for t in truth])
    edges = np.asarray(verdicts[0]["zone_edges_m"], float)
    z_true = np.where(damaged, np.clip(np.searchsorted(edges, np.nan_to_num(x_true), side="right"), 1,
                                       edges.size - 1), 0)
    answers = [_answers(v) for v in verdicts]
    methods = list(dict.fromkeys(m for a in answers for m in a))
    rows = []
    for method in methods:
        a = [x.get(method) for x in answers]
        given = np.array([x is not None for x in a])
        a = [x or {"damaged": False} for x in a]
        called = np.array([bool(x["damaged"]) for x in a]) & given
        zone = np.array([int(x["location_zone"]) if x.get("location_zone") is not None else 0 for x in a])
        x_est = np.array([_nan(x.get("location_x_m")) for x in a])
        x_sd = np.array([_nan(x.get("location_std_m")) for x in a])
        s = np.array([_nan(x.get("size")) for x in a])
        s_sd = np.array([_nan(x.get("size_std")) for x in a])
        dm, im = damaged & given, ~damaged & given
        det = dm & called
        dx = np.abs(x_est[det] - x_true[det]) / L
        err = np.abs(s[det] / s_true[det] - 1)
        rows.append({
            "beam": meta["beam"], "bc": meta["bc"], "sensors": len(meta["measured_x_m"]), "method": method,
            "pairs": len(a), "answered": int(given.sum()), "damaged_pairs": int(dm.sum()),
            "intact_pairs": int(im.sum()), "folded": bool(folded_pairs.any()),
            "zone_accuracy": float(np.mean(det[dm] & (zone[dm] == z_true[dm]))) if dm.any() else float("nan"),
            "detection": float(np.mean(called[dm])) if dm.any() else float("nan"),
            "median_dx_over_L": float(np.median(dx)) if dx.size else float("nan"),
            "false_alarm_pct": float(100 * np.mean(called[im])) if im.any() else float("nan"),
            "false_alarms": int(np.sum(called[im])),
            "median_size_error": float(np.median(err)) if err.size else float("nan"),
            "size_one_sigma_cover": float(np.mean(np.abs(s[det] - s_true[det]) <= s_sd[det]))
            if np.isfinite(s_sd[det]).any() else float("nan"),
            "location_one_sigma_cover": float(np.mean(np.abs(x_est[det] - x_true[det]) <= x_sd[det]))
            if np.isfinite(x_sd[det]).any() else float("nan"),
        })
    classical = [r for r in rows if r["method"] not in ("network", "verdict")]
    best = max(classical, key=lambda r: np.nan_to_num(r["zone_accuracy"], nan=-1.0)) if classical else None
    ind = np.array([bool(v.get("in_distribution")) for v in verdicts])
    pct = np.array([_nan(v.get("training_percentile")) for v in verdicts])
    small = damaged & (np.array([float(t.get("max_frequency_drop_rel") or 0.0) for t in truth]) < SMALL_DROP)
    net_called = np.array([bool((v.get("network") or {}).get("damaged")) for v in verdicts])
    for r in rows:
        r["intact_training_percentile_median"] = float(np.nanmedian(pct[~damaged])) \
            if np.isfinite(pct[~damaged]).any() else float("nan")
        r["small_slits"] = int(small.sum())
        r["small_slits_detected_by_network"] = int((net_called & small).sum())
        r["best_classical"] = best["method"] if best else None
        r["in_distribution"] = float(ind.mean())
        r["zones_as_simulator"] = bool(np.allclose(edges, meta["zone_edges_m"], rtol=0, atol=1e-9 * L))
    return rows


def _complete(data: Path) -> bool:
    """A finished dataset (``generate`` refuses to resume a beam file's dataset whose config holds a tuple, so a
    finished one is reused without calling it)."""
    try:
        return bool(json.loads((data / "manifest.json").read_text()).get("complete"))
    except (OSError, ValueError):
        return False


def parse_spread(items: list[str]) -> tuple[dict, str]:
    """``KEY=VALUE`` items (a value with commas is a range) as :class:`Spread` fields, and their tag ('' if none).

    Raises ``ValueError`` naming the item and the expected form."""
    names = {f.name for f in fields(Spread)}
    out = {}
    for item in items:
        key, _, value = item.partition("=")
        try:
            nums = tuple(float(v) for v in value.split(","))
        except ValueError:
            nums = ()
        if key not in names or not nums or len(nums) > 2:
            raise ValueError(f"--spread {item!r}: expected KEY=NUMBER or KEY=LO,HI with KEY one of {sorted(names)}")
        out[key] = nums if len(nums) == 2 else nums[0]
    return out, "-".join(items)


def _step(timings: dict, key: str, done: bool, fn) -> None:
    """Run ``fn`` unless ``done``, recording its wall time (s) under ``key`` (a rerun keeps the first run's)."""
    if not done:
        t0 = time.perf_counter()
        fn()
        timings[key] = time.perf_counter() - t0


def run_beam(cb, out: Path, n_pairs: int, train_n: int, seed: int, workers: int = 2, spread: dict | None = None,
             tag: str = "", beam_file=None, model_tag: str = "", config: str = "training") -> tuple[list[dict], dict]:
    """Pairs, dataset, model and verdicts of one catalogue beam (reused when present); its rows and timings.
    ``spread`` (fields of :class:`Spread`, named by ``tag``) draws the pairs from a changed distribution;
    ``beam_file`` (default: the simulator's ``beam.toml``, e.g. one ``discrepancy`` calibrated) drives ``generate``,
    its dataset, model and verdicts named by ``model_tag``; ``config`` is the training config ``generate`` reads."""
    d = out / cb.name
    suffix = f"-{tag}" if tag else ""
    pairs = d / f"pairs-n{n_pairs}-s{seed}{suffix}"
    mt = f"-{model_tag}" if model_tag else ""
    data, model = d / f"data-n{train_n}-s{seed}{mt}", d / f"model-n{train_n}-s{seed}{mt}"
    tfile = d / "timings.json"
    t = json.loads(tfile.read_text()) if tfile.is_file() else {}
    spread_of = replace(SPREAD, **(spread or {}))
    _step(t, pairs.name, (pairs / "truth.json").is_file(),
          lambda: write_beam_pairs(cb, simulate_beam_pairs(cb, n_pairs, seed, spread_of), pairs, seed))
    _step(t, data.name, _complete(data),
          lambda: cli_json(["generate", "--beam", str(beam_file or pairs / "beam.toml"), "--config", config,
                        "--n", str(train_n),
                        "--seed", str(seed + 1), "--out", str(data), "--workers", str(workers)]))
    _step(t, model.name, (model / "config.json").is_file(),
          lambda: cli_json(["train", "--data", str(data), "--out", str(model)]))
    meta = json.loads((pairs / "truth.json").read_text())
    vfile = d / f"verdicts-n{n_pairs}-s{seed}-t{train_n}{suffix}{mt}.json"

    def classify_all():
        verdicts = []
        for p in meta["pairs"]:
            k = int(p["pair"])
            v = cli_json(["classify", "--model", str(model), "--baseline", str(pairs / f"pair-{k:03d}_baseline.uff"),
                      str(pairs / f"pair-{k:03d}_current.uff")])
            verdicts.append(v[0] if isinstance(v, list) else v)
        atomic_write_text(vfile, json.dumps(verdicts, indent=1))

    _step(t, vfile.name, vfile.is_file(), classify_all)
    atomic_write_text(tfile, json.dumps(t, indent=1))
    verdicts = json.loads(vfile.read_text())
    t = {"simulate_s": t.get(pairs.name), "generate_s": t.get(data.name), "train_s": t.get(model.name),
         "classify_s": t.get(vfile.name)}
    cfg = json.loads((model / "config.json").read_text())
    own = {m["method"]: {k: m.get(k) for k in ("element_accuracy", "false_alarm_rate", "median_location_error_mm",
                                                "detection_rate")}
           for m in cfg.get("test_metrics", []) if m.get("subset", "all") == "all"}
    info = {"beam": cb.name, "bc": cb.bc, "material": cb.material, "length_m": cb.length_m,
            "sensors": len(cb.sensors_x_m), "band_hz": meta["band_hz"], "modes": cfg["beam"]["test"]["modes"],
            "nominal_frequencies_hz": meta["nominal_frequencies_hz"], "timing_s": t,
            "training_split_metrics": own, "best_classical_on_training_split": cfg.get("best_classical")}
    return score_beam(verdicts, meta), info


def _f(v, pct=True, digits=3) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    return f"{v:.0%}" if pct else f"{v:.{digits}g}"


def markdown(rows: list[dict]) -> str:
    """The table: one line per beam and method."""
    head = ("| beam | bc | sensors | method | zone acc. | detection | median abs(dx)/L | false alarms | size err. | "
            "size 1-sigma | place 1-sigma | note |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        note = []
        if r["folded"]:
            note.append("folded to x <= L/2")
        if r["method"] == r.get("best_classical"):
            note.append("best classical")
        if r["answered"] < r["pairs"]:
            note.append(f"{r['answered']} of {r['pairs']} answered")
        lines.append(f"| {r['beam']} | {r['bc']} | {r['sensors']} | {r['method']} | {_f(r['zone_accuracy'])} | "
                     f"{_f(r['detection'])} | {_f(r['median_dx_over_L'], False)} | "
                     f"{r['false_alarms']} of {r['intact_pairs']} ({_f(r['false_alarm_pct'], False)} %) | "
                     f"{_f(r['median_size_error'])} | {_f(r['size_one_sigma_cover'])} | "
                     f"{_f(r['location_one_sigma_cover'])} | {', '.join(note)} |\n")
    return head + "".join(lines)


def targets(rows: list[dict]) -> list[dict]:
    """Per beam: the network's targets met or missed."""
    out = []
    for beam in dict.fromkeys(r["beam"] for r in rows):
        net = next(r for r in rows if r["beam"] == beam and r["method"] == "network")
        best = next((r for r in rows if r["beam"] == beam and r["method"] == net["best_classical"]), None)
        out.append({"beam": beam, "zone_accuracy_network": net["zone_accuracy"],
                    "zone_accuracy_best_classical": best["zone_accuracy"] if best else float("nan"),
                    "best_classical": net["best_classical"],
                    "zone_ok": bool(best is None or net["zone_accuracy"] >= best["zone_accuracy"]),
                    "false_alarms_ok": bool(net["false_alarm_pct"] <= TARGETS["false_alarm_pct"]),
                    "dx_ok": None if net["folded"] else bool(net["median_dx_over_L"] <= TARGETS["median_dx_over_L"]),
                    "folded": net["folded"]})
    return out


def diagnosis_markdown(rows: list[dict], infos: list[dict]) -> str:
    """Per beam: the network on the independent pairs next to the network on its own training data's test split,
    its detection of small slits, and where the intact pairs fall among the training pairs' Mahalanobis distances
    (a median far above 50 % is a shift between the simulator's pairs and the training data)."""
    head = ("| beam | modes | zone acc. (independent) | element acc. (training split) | detection (independent) | "
            "detection (training split) | small slits (drop < 0.5 %) detected | intact pairs: median training "
            "percentile |\n|---|---|---|---|---|---|---|---|\n")
    lines = []
    for info in infos:
        net = next(r for r in rows if r["beam"] == info["beam"] and r["method"] == "network")
        own = info["training_split_metrics"].get("network (modal)", {})
        lines.append(f"| {info['beam']} | {len(info['modes'])} | {_f(net['zone_accuracy'])} | "
                     f"{_f(own.get('element_accuracy'))} | {_f(net['detection'])} | {_f(own.get('detection_rate'))} | "
                     f"{net['small_slits_detected_by_network']} of {net['small_slits']} | "
                     f"{_f(net['intact_training_percentile_median'], False)} % |\n")
    return head + "".join(lines)


def pooled(rows: list[dict]) -> list[dict]:
    """Over all beams: the network's, the verdict's and the best classical method's (per beam) zone accuracy,
    detection and false alarms, weighted by each beam's damaged and intact pairs."""
    out = []
    for label, pick in (("network", lambda r: r["method"] == "network"),
                        ("verdict", lambda r: r["method"] == "verdict"),
                        ("best classical (per beam)", lambda r: r["method"] == r["best_classical"])):
        sel = [r for r in rows if pick(r)]
        dm = sum(r["damaged_pairs"] for r in sel)
        im = sum(r["intact_pairs"] for r in sel)
        fa = sum(r["false_alarms"] for r in sel)
        out.append({"method": label, "beams": len(sel), "damaged_pairs": dm, "intact_pairs": im,
                    "zone_accuracy": sum(np.nan_to_num(r["zone_accuracy"]) * r["damaged_pairs"] for r in sel) / dm
                    if dm else float("nan"),
                    "detection": sum(np.nan_to_num(r["detection"]) * r["damaged_pairs"] for r in sel) / dm
                    if dm else float("nan"),
                    "false_alarms": fa, "false_alarm_pct": 100 * fa / im if im else float("nan")})
    return out


def pooled_markdown(rows: list[dict]) -> str:
    return ("| all beams | beams | zone acc. | detection | false alarms |\n|---|---|---|---|---|\n"
            + "".join(f"| {p['method']} | {p['beams']} | {_f(p['zone_accuracy'])} of {p['damaged_pairs']} | "
                      f"{_f(p['detection'])} | {p['false_alarms']} of {p['intact_pairs']} "
                      f"({_f(p['false_alarm_pct'], False)} %) |\n" for p in pooled(rows)))


def docs_markdown(rows: list[dict], infos: list[dict], before: list[dict] | None = None) -> str:
    """The summary in ``docs/classifier.md``: per beam the network's zone accuracy of its damaged pairs (in
    parentheses that of the ``before`` rows, an earlier run's ``rows``, where given), the best classical method's,
    the network's median ``|dx|/L`` (``folded`` where classify folded), false alarms, median size error and size
    1-sigma cover; then the pooled row (false alarms of the best classical methods in parentheses)."""
    beams = {info["beam"] for info in infos}
    net_before = {r["beam"]: r for r in before or [] if r["method"] == "network" and r["beam"] in beams}
    head = ["beam", "support", "sensors", "modes", "network zone acc." + (" (before)" if before else ""),
            "best classical: zone acc.", "network median abs(dx)/L", "false alarms (network)", "size err.",
            "size 1-sigma"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for info in infos:
        net = next(r for r in rows if r["beam"] == info["beam"] and r["method"] == "network")
        best = next((r for r in rows if r["beam"] == info["beam"] and r["method"] == net["best_classical"]), None)
        was = net_before.get(info["beam"])
        dx = _f(net["median_dx_over_L"], False) if not np.isfinite(net["median_dx_over_L"]) \
            else f"{net['median_dx_over_L']:.4f}"
        lines.append(f"| {info['beam']} | {net['bc']} | {net['sensors']} | {len(info['modes'])} | "
                     f"{_f(net['zone_accuracy'])} of {net['damaged_pairs']}"
                     + (f" ({_f(was['zone_accuracy'])})" if was else "") + " | "
                     + (f"{best['method']} {_f(best['zone_accuracy'])}" if best else "-") + " | "
                     f"{dx}{' (folded)' if net['folded'] else ''} | {net['false_alarms']} of {net['intact_pairs']} | "
                     f"{_f(net['median_size_error'])} | {_f(net['size_one_sigma_cover'])} |")
    pool = {p["method"]: p for p in pooled(rows)}
    net, cl = pool["network"], pool["best classical (per beam)"]
    was = {p["method"]: p for p in pooled(list(net_before.values()))}.get("network") if before else None
    lines.append(f"| all {len(infos)} | | | | {_f(net['zone_accuracy'])} of {net['damaged_pairs']}"
                 + (f" ({_f(was['zone_accuracy'])})" if was else "") + f" | {_f(cl['zone_accuracy'])} | | "
                 f"{net['false_alarms']} of {net['intact_pairs']} (classical {cl['false_alarms']}) | | |")
    return "\n".join(lines)


def _figure(rows: list[dict], path: Path) -> None:
    plt = pyplot()


    tg = targets(rows)
    k = np.arange(len(tg))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(tg) + 2), 3.8))
    ax.bar(k - 0.2, [t["zone_accuracy_network"] for t in tg], 0.4, label="network")
    ax.bar(k + 0.2, [t["zone_accuracy_best_classical"] for t in tg], 0.4, label="best classical method")
    for i, t in enumerate(tg):
        ax.text(i + 0.2, 0.02, t["best_classical"] or "", rotation=90, fontsize=7, ha="center", va="bottom")
        if t["folded"]:
            ax.text(i, 1.02, "folded", fontsize=7, ha="center")
    ax.set_xticks(k, [t["beam"] for t in tg], rotation=25, ha="right", fontsize=8)
    ax.set_ylim(0, 1.25)
    ax.set_ylabel("zone accuracy (damaged pairs)")
    ax.set_title("Independent pairs per beam: network vs best classical method")
    ax.legend(fontsize=8, loc="upper right", ncol=2)
    fig.tight_layout()

    atomic_write_bytes(path, figure_png(fig))


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="classifier.md", json=True, out="out/beams", seed=0, workers=2)
    ap.add_argument("--n-pairs", type=int, default=40, help="independent pairs per beam (default 40)")
    ap.add_argument("--train-n", type=int, default=20000, help="specimens generated per beam (default 20000)")
    ap.add_argument("--only", default=None, help="one catalogue beam by name")
    ap.add_argument("--spread", action="append", default=[], metavar="KEY=VALUE",
                    help="a field of the pairs' distribution (second_sim.beams.Spread), e.g. suspension_change=0")
    ap.add_argument("--before", metavar="BEAMS_JSON", help="beams.json of an earlier run: its network zone accuracy "
                    "in parentheses in the --docs table")
    a = ap.parse_args(argv)

    names = [c.name for c in CATALOGUE]
    if a.only is not None and a.only not in names:
        print(f"study_beams: error: --only: unknown beam {a.only!r}; expected one of {', '.join(names)}",
              file=sys.stderr)
        return 2
    if a.n_pairs < 1 or a.train_n < 100:
        print(f"study_beams: error: --n-pairs must be >= 1 and --train-n >= 100, got {a.n_pairs} and {a.train_n}",
              file=sys.stderr)
        return 2
    try:
        spread, tag = parse_spread(a.spread)
    except ValueError as exc:
        print(f"study_beams: error: {exc}", file=sys.stderr)
        return 2
    before = None
    if a.before is not None:
        try:
            before = json.loads(Path(a.before).read_text())["rows"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            print(f"study_beams: error: --before {a.before}: expected the beams.json of a study_beams run ({exc})",
                  file=sys.stderr)
            return 2
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, infos = [], []
    t0 = time.perf_counter()
    for cb in CATALOGUE:
        if a.only in (None, cb.name):
            r, info = run_beam(cb, out, a.n_pairs, a.train_n, a.seed, a.workers, spread, tag)
            rows += r
            infos.append(info)
            print(f"{cb.name}: " + ", ".join(f"{k} {_f(v, False)}" for k, v in info["timing_s"].items()),
                  file=sys.stderr)

    import pandas as pd

    config = {"n_pairs": a.n_pairs, "train_n": a.train_n, "seed": a.seed, "config": "training", "spread": spread,
              "beams": [i["beam"] for i in infos], "targets": TARGETS, "seconds": time.perf_counter() - t0}
    stem = "beams" + (f"-{tag}" if tag else "")
    atomic_write_text(out / f"{stem}.csv", pd.DataFrame(rows).to_csv(index=False))
    atomic_write_text(out / f"{stem}.json", json.dumps({"config": config, "beams": infos, "targets": targets(rows),
                                                      "pooled": pooled(rows), "rows": rows}, indent=1))
    atomic_write_text(out / f"{stem}.md", markdown(rows) + "\n" + pooled_markdown(rows) + "\n"
                      + diagnosis_markdown(rows, infos))
    _figure(rows, out / f"{stem}.png")
    if a.json:
        print(json.dumps({"config": config, "targets": targets(rows), "pooled": pooled(rows), "rows": rows}, indent=1))
    else:
        print(markdown(rows) + "\n" + pooled_markdown(rows) + "\n" + diagnosis_markdown(rows, infos))
    publish(a, "study-beams", docs_markdown(rows, infos, before))
    return 0


if __name__ == "__main__":
    sys.exit(main())
