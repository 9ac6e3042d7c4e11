"""The classifier on data it did not make: pairs of UFF files from an independent simulator, through the CLI.

Run: ``.venv/bin/python -m experiments.benches.bench_foreign --model MODEL_DIR [--sets easy,eb,timoshenko] [--n 24]
[--seed 100] [--band-hz 2 500] [--out out/foreign] [--loop --train-n 60000] [--source-tree DIR --label before]``

The pairs come from :mod:`experiments.second_sim` (112-element Euler-Bernoulli or Timoshenko beams, its own
slit, damping, noise and frequency grid, files written through pyuff with node geometry and units; it shares
no code with the project). Every pair is classified as a user would: ``beam-damage classify --model M
--baseline pair-K_baseline.uff pair-K_current.uff --json``. Per set and method:

* ``element acc.``: damaged pairs called damaged with the slit in the right quarter of the beam (element 1-4);
* ``detection``: damaged pairs called damaged; ``false alarms``: intact pairs called damaged (in brackets, how
  many of them the method itself called "possibly damaged, but not detectable here");
* ``size err.``: median ``|s / s_true - 1|`` of the hinge flexibility ``w r / ((1 - r) L)`` over detected slits;
  ``1-sigma cover``: share of detected slits whose truth lies within the reported standard deviation;
* ``in distribution``: pairs the network answered (the others got the classical method's verdict), and the
  Mahalanobis distances of intact and damaged pairs against the training percentiles.

Methods: the verdict (network inside the training data, else the classical method), the network alone, and
every classical method on the LSCF/LSFD modes (``classical_methods`` of the verdict).

``--loop`` first runs the loop the README describes on each set: ``discrepancy`` on the first baseline file
(the calibrated beam), ``generate --beam cal/beam.toml --config training --n N``, ``train``; then classifies with
that model. ``--source-tree DIR`` runs ``classify`` of another checkout (e.g. an earlier commit, with a model it
trained) in a subprocess, for before/after tables; only the verdict's own keys are read from it.

Writes ``foreign.csv``, ``foreign.json``, ``foreign.md`` (the tables) and ``distances.png`` (Mahalanobis distances
of the pairs against the training percentiles) in ``--out``; ``--json`` prints the rows.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from experiments.second_sim import simulate_pairs, write_pairs
from experiments.second_sim.pairs import FREQ_HZ
from experiments.benches.harness import cli_json, parser, publish, table
from physics.io import atomic_write_bytes, atomic_write_text, figure_png, pyplot

__all__ = ["main"]

SETS = ("easy", "eb", "timoshenko")


def set_dir(out: Path, name: str, band_hz=None) -> Path:
    """Directory of a set's pairs (the band in its name when not the simulator's default)."""
    return out / "pairs" / (name if band_hz is None else f"{name}-{band_hz[0]:g}-{band_hz[1]:g}Hz")


def write_sets(out: Path, sets, n: int, seed: int, band_hz=None) -> dict:
    """The independent simulator's pair sets (``truth.json`` per set); ``band_hz`` (first, last line in Hz, 0.5 Hz
    apart) replaces the simulator's default lines."""
    freq_hz = FREQ_HZ if band_hz is None else band_hz[0] + 0.5 * np.arange(int(round((band_hz[1] - band_hz[0]) / 0.5))
                                                                          + 1)
    truths = {}
    for k, name in enumerate(sets):
        d = set_dir(out, name, band_hz)
        if not (d / "truth.json").is_file():
            write_pairs(simulate_pairs(name, n, seed + k, freq_hz), d)
        truths[name] = json.loads((d / "truth.json").read_text())["pairs"]
    return truths


def loop_model(out: Path, name: str, n_train: int, seed: int) -> Path:
    """The README's loop on one set: calibrate the beam on its first baseline file, generate, train."""
    d = out / "loop" / name
    model = d / "model"
    if (model / "config.json").is_file():
        return model
    base = set_dir(out, name) / "pair-000_baseline.uff"
    cli_json(["discrepancy", "--beam", "beam5", "--measured", str(base), "--out", str(d / "cal")])
    cli_json(["generate", "--beam", str(d / "cal" / "beam.toml"), "--config", "training", "--n", str(n_train),
          "--seed", str(seed), "--out", str(d / "data"), "--workers", "2"])
    cli_json(["train", "--data", str(d / "data"), "--out", str(model)])
    return model


def classify_set(model: Path, pair_dir: Path, truth: list, source_tree: str | None = None,
                 ext: str = "uff") -> list[dict]:
    """``classify --json`` of every pair of a set (one call per pair: every pair has its own baseline), on the
    UFF files (``ext="uff"``) or the modal-data files (``"json"``)."""
    verdicts = []
    for t in truth:
        k = int(t["pair"])
        verdicts.append(cli_json(["classify", "--model", str(model), "--baseline",
                              str(pair_dir / f"pair-{k:03d}_baseline.{ext}"),
                              str(pair_dir / f"pair-{k:03d}_current.{ext}")],
                             source_tree))
    return verdicts


def _answers(v: dict) -> dict:
    """Method name -> answer dict (damaged, location_element, size[, size_std]), None
    where the method gave no answer (the network on a pair missing some of modes 1-4)."""
    out = {"verdict": v}
    if "network" in v:
        out["network"] = v["network"]
        for c in v.get("classical_methods") or []:
            out[c["method"]] = c
    return out


def score(verdicts: list[dict], truth: list) -> list[dict]:
    """Table rows (one per method) of a set's verdicts against the simulator's truth."""
    damaged = np.array([bool(t["damaged"]) for t in truth])
    element = np.array([int(t["element"]) if t["damaged"] else 0 for t in truth])
    size = np.array([float(t["hinge_flexibility"]) for t in truth])
    answers = [_answers(v) for v in verdicts]
    rows = []
    for method in answers[0]:
        given = np.array([x.get(method) is not None for x in answers])
        a = [x.get(method) or {"damaged": False} for x in answers]
        called = np.array([bool(x["damaged"]) for x in a])
        faint = called & np.array([x.get("detectable") is False for x in a])  # "possibly damaged, not detectable"
        el = np.array([int(x["location_element"]) if x.get("location_element") is not None else 0 for x in a])
        s = np.array([float(x["size"]) if x.get("size") is not None else np.nan for x in a])
        sd = np.array([float(x["size_std"]) if x.get("size_std") is not None else np.nan for x in a])
        det = damaged & called
        err = np.abs(s[det] / size[det] - 1)
        cover = np.abs(s[det] - size[det]) <= sd[det]
        dm, im = damaged & given, ~damaged & given          # scored on the pairs the method answered
        rows.append({"method": method, "pairs": len(a), "answered": int(given.sum()), "damaged_pairs": int(dm.sum()),
                     "element_accuracy": float(np.mean(det[dm] & (el[dm] == element[dm])))
                     if dm.any() else float("nan"),
                     "detection": float(np.mean(called[dm])) if dm.any() else float("nan"),
                     "false_alarms": int(np.sum(called[im])), "intact_pairs": int(im.sum()),
                     "false_alarms_not_detectable": int(np.sum(faint[im])),
                     "median_size_error": float(np.median(err)) if err.size else float("nan"),
                     "size_one_sigma_cover": float(np.mean(cover)) if np.isfinite(sd[det]).any() else float("nan")})
    if "in_distribution" in verdicts[0]:
        ind = np.array([bool(v["in_distribution"]) for v in verdicts])
        pct = np.array([np.nan if v["training_percentile"] is None else float(v["training_percentile"])
                        for v in verdicts])
        has = np.isfinite(pct)
        for r in rows:
            r.update(in_distribution=float(ind.mean()),
                     median_percentile_intact=float(np.median(pct[~damaged & has])) if (~damaged & has).any()
                     else float("nan"),
                     median_percentile_damaged=float(np.median(pct[damaged & has])) if (damaged & has).any()
                     else float("nan"))
    return rows


def batch_rate(model: Path, pair_dir: Path, n: int) -> dict:
    """Pairs per second of one ``classify`` call with ``n`` MEASURED files (one baseline) and one pair's wall time
    in a fresh process (imports included)."""
    files = [str(pair_dir / f"pair-{k:03d}_current.uff") for k in range(n)]
    base = str(pair_dir / "pair-000_baseline.uff")
    t0 = time.perf_counter()
    cli_json(["classify", "--model", str(model), "--baseline", base, *files])
    t_batch = time.perf_counter() - t0
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "experiments.cli", "classify", "--model", str(model), "--baseline", base,
                    files[0], "--json"], capture_output=True, check=True)
    return {"pairs": n, "batch_seconds": t_batch, "pairs_per_second": n / t_batch,
            "one_pair_wall_seconds": time.perf_counter() - t0}


def _method_label(r: dict) -> str:
    answered = r.get("answered", r["pairs"])
    return r["method"] if answered == r["pairs"] else f"{r['method']} ({answered} of {r['pairs']} pairs answered)"


def _false_alarms(r: dict) -> str:
    """``"k of n"``, with how many of the k the method itself called not detectable."""
    faint = r.get("false_alarms_not_detectable", 0)
    return f"{r['false_alarms']} of {r['intact_pairs']}" + (f" ({faint} not detectable)" if faint else "")


def markdown(rows: list[dict]) -> str:
    def f(v):
        return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{v:.0%}"

    return table(["set", "model", "method", "element acc.", "detection", "false alarms", "size err.", "1-sigma cover",
                  "in distribution"],
                 [[r["set"], r["model"], _method_label(r), f(r["element_accuracy"]), f(r["detection"]),
                   _false_alarms(r), f(r["median_size_error"]), f(r["size_one_sigma_cover"]),
                   f(r.get("in_distribution"))] for r in rows]) + "\n"


def _figure(verdicts_by_set: dict, path: Path) -> None:
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for k, (name, (verdicts, truth)) in enumerate(verdicts_by_set.items()):
        if not verdicts or "training_percentile" not in verdicts[0]:
            continue
        for dmg, marker in ((False, "o"), (True, "x")):
            p = [v["training_percentile"] for v, t in zip(verdicts, truth)
                 if bool(t["damaged"]) == dmg and v["training_percentile"] is not None]
            ax.scatter(np.full(len(p), k) + (0.15 if dmg else -0.15), p, marker=marker,
                       color="tab:red" if dmg else "tab:blue",
                       label=("damaged" if dmg else "intact") if k == 0 else None)
    ax.axhline(99.9, color="grey", ls="--", label="in-distribution limit (99.9th percentile)")
    ax.set_xticks(range(len(verdicts_by_set)), list(verdicts_by_set))
    ax.set_ylabel("training percentile of the\nMahalanobis distance (%)")
    ax.set_title("Independent pairs against the training distribution")
    ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_write_bytes(path, figure_png(fig))


def main(argv=None):
    ap = parser(__file__, __doc__, docs="classifier.md", json=True, out="out/foreign", seed=100)
    ap.add_argument("--model", help="model directory used for every set (else --loop)")
    ap.add_argument("--sets", default=",".join(SETS))
    ap.add_argument("--n", type=int, default=24, help="pairs per set")
    ap.add_argument("--band-hz", type=float, nargs=2, metavar=("F_MIN", "F_MAX"),
                    help="first and last frequency line of the simulated files (Hz, 0.5 Hz apart; default the "
                         "simulator's 2 800); a band stopping below mode 4 leaves the network without an answer")
    ap.add_argument("--loop", action="store_true", help="calibrate, generate and train per set first")
    ap.add_argument("--train-n", type=int, default=60000, help="specimens generated per set by --loop")
    ap.add_argument("--source-tree", help="run classify of this checkout (subprocess)")
    ap.add_argument("--label", default=None, help="model label in the tables (default: the model's path)")
    ap.add_argument("--input", choices=("uff", "modal"), default="uff",
                    help="classify the UFF files (default) or the simulator's modal-data JSON files (its own modal "
                         "noise: 0.03 %% on frequencies, 0.5 %% on shapes)")
    a = ap.parse_args(argv)
    if not a.model and not a.loop:
        ap.error("give --model or --loop")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    sets = [s for s in a.sets.split(",") if s]
    if a.loop and a.band_hz:
        ap.error("--loop calibrates on the default band: give --model with --band-hz")
    truths = write_sets(out, sets, a.n, a.seed, a.band_hz)
    rows, by_set, timing = [], {}, None
    for name in sets:
        model = loop_model(out, name, a.train_n, a.seed + 50) if a.loop else Path(a.model)
        label = a.label or ("loop: calibrated on the set's first baseline" if a.loop else str(model))
        pairs = set_dir(out, name, a.band_hz)
        verdicts = classify_set(model, pairs, truths[name], a.source_tree, "json" if a.input == "modal" else "uff")
        by_set[name] = (verdicts, truths[name])
        rows += [{"set": name, "model": label, **r} for r in score(verdicts, truths[name])]
        if timing is None and a.source_tree is None and a.input == "uff":
            timing = batch_rate(model, pairs, min(a.n, 24))
    tag = "" if a.label is None else f"-{a.label}"

    import pandas as pd

    atomic_write_text(out / f"foreign{tag}.csv", pd.DataFrame(rows).to_csv(index=False))
    atomic_write_text(out / f"foreign{tag}.json", json.dumps({"rows": rows, "timing": timing, "n": a.n,
                                                              "seed": a.seed, "sets": sets}, indent=1))
    atomic_write_text(out / f"foreign{tag}.md", markdown(rows))
    atomic_write_text(out / f"verdicts{tag}.json", json.dumps({k: v[0] for k, v in by_set.items()}, indent=1))
    _figure(by_set, out / f"distances{tag}.png")
    if a.json:
        print(json.dumps({"rows": rows, "timing": timing}, indent=1))
    else:
        print(markdown(rows))
        if timing:
            print(f"classify: {timing['pairs']} pairs in one call {timing['batch_seconds']:.2f} s "
                  f"({timing['pairs_per_second']:.1f} pairs/s); one pair in a fresh process "
                  f"{timing['one_pair_wall_seconds']:.2f} s wall")
    publish(a, "classifier-independent", markdown(rows))
    return rows


if __name__ == "__main__":
    main()
