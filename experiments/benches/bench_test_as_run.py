"""Tests run otherwise than the beam file says, through the CLI: the force where no sensor is, at a node of some
modes, a drive point the beam file leaves out, one accelerometer with a transfer FRF over a wide band.

Run: ``python -m experiments.benches.bench_test_as_run --out out/test-as-run [--n-pairs 36] [--train-n 10000] [--seed 0]
[--only NAME] [--before MAIN_CHECKOUT] [--docs] [--json]``

For each beam of :data:`experiments.second_sim.beams.TEST_AS_RUN` (the independent simulator's, sharing no code
with the package) the loop of :func:`experiments.benches.study_beams.run_beam`: the simulator writes ``beam.toml`` and
``--n-pairs`` UFF pairs; ``generate --beam beam.toml --config training --n TRAIN_N``; ``train``; ``classify``
per pair. A beam file that leaves ``drive_x_m`` out (the files' geometry places the reference DOF) is run twice:
as written (the model trained for a force at the first sensor), and as the README's loop calibrates it
(``discrepancy`` on the first baseline file writes the files' drive point into its beam file). Printed per beam
and model: the network's answer rate, zone accuracy, detection and false alarms of the network, the verdict and
the best classical method; and the modes ``identify --band`` (the identification ``classify`` runs) finds in
the baseline files against the modes the simulator put in the band that the force excites (``--before``: also
another checkout's).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from experiments.benches.study_beams import run_beam
from experiments.second_sim.beams import TEST_AS_RUN, excited_modes
from experiments.benches.harness import cli_json, parser, publish, table
from physics.io import atomic_write_text

__all__ = ["main", "modes_found"]


def modes_found(pairs: Path, meta: dict, excited=None, tolerance: float = 0.03, source_tree: str | None = None
                ) -> dict:
    """Per baseline file: the simulator's bending modes in the band that the force excites (``excited``, 1-based:
    :func:`experiments.second_sim.beams.excited_modes`) and those ``identify --band`` finds (within
    ``tolerance``, relative; ``source_tree``: another checkout's ``identify``); pooled counts and the files
    missing a mode."""
    lo, hi = meta["band_hz"]
    present = found = 0
    missing = []
    for p in meta["pairs"]:
        k = int(p["pair"])
        truth = np.asarray(p["baseline_frequencies_hz"])
        if excited is not None:
            truth = truth[np.asarray(excited, int) - 1]
        truth = truth[(truth >= lo) & (truth <= hi)]
        out = cli_json(["identify", str((pairs / f"pair-{k:03d}_baseline.uff").resolve()), "--band", str(lo), str(hi)],
                       source_tree)
        f = np.array([m["frequency_hz"] for m in out["modes"]])
        hit = np.array([f.size > 0 and np.min(np.abs(f / t - 1)) <= tolerance for t in truth])
        present += truth.size
        found += int(hit.sum())
        if not hit.all():
            missing.append({"pair": k, "missed_hz": truth[~hit].round(2).tolist()})
    return {"modes_present": present, "modes_found": found, "files": len(meta["pairs"]), "missing": missing}


#: What each test of :data:`experiments.second_sim.beams.TEST_AS_RUN` is, for the table.
TESTS = {
    "al-cantilever-cf-6s-tipforce": "aluminium cantilever, 6 accelerometers off the quarter points, mobilities, the "
                                    "shaker at the tip (no sensor there)",
    "steel-pp-5s-drive-third": "steel pinned-pinned beam, 5 accelerometers, receptances, the force at L/3 (a node of "
                               "modes 3 and 6); the beam file names no drive point, the files' geometry does",
    "steel-cf-1acc-impact": "steel cantilever with a 0.1 kg mass, one accelerometer at the tip, the hammer at 0.15 L, "
                            "accelerances 10-1600 Hz in 0.4 Hz lines, no node geometry",
}


def markdown(rows: list[dict]) -> str:
    """The table: one row per beam and model."""
    pct = lambda x: "-" if x is None or not np.isfinite(x) else f"{x:.0%}".replace("%", " %")  # noqa: E731
    lines = []
    for t in rows:
        n, v, b = t["network"], t["verdict"], t["best_classical"] or {}
        ident = t["identification"] or {}
        found = "".join(f"{ident[k]['modes_found']} of {ident[k]['modes_present']}" for k in ("this",) if k in ident)
        if "before" in ident:
            found += f" ({ident['before']['modes_found']} of {ident['before']['modes_present']})"
        lines.append([TESTS.get(t["beam"], t["beam"]), t["model"], ", ".join(map(str, t["modes"])),
                      f"{t['network_answered']} of {t['pairs']}", f"{pct(n['zone_accuracy'])} / "
                      f"{pct(v['zone_accuracy'])} / {pct(b.get('zone_accuracy'))} ({b.get('method', '-')})",
                      f"{pct(n['detection'])} / {pct(v['detection'])}",
                      f"{n['false_alarms']} / {v['false_alarms']} of {v['intact_pairs']}", found or "-"])
    return table(["test", "model trained on", "modes", "network answers",
                  "zone acc. network / verdict / best classical", "detection network / verdict",
                  "false alarms network / verdict", "modes found (before)"], lines)


def _row(cb, label: str, r: list[dict], info: dict, ident: dict | None) -> dict:
    net = next(x for x in r if x["method"] == "network")
    ver = next(x for x in r if x["method"] == "verdict")
    best = next((x for x in r if x["method"] == net["best_classical"]), None)
    return {"beam": cb.name, "model": label, "modes": info["modes"], "network_answered": net["answered"],
            "pairs": net["pairs"], "network": net, "verdict": ver, "best_classical": best, "identification": ident}


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="any-beam.md", json=True, out="out/test-as-run", seed=0, workers=2)
    ap.add_argument("--n-pairs", type=int, default=36)
    ap.add_argument("--train-n", type=int, default=10000)
    ap.add_argument("--only", default=None)
    ap.add_argument("--before", default=None, metavar="DIR",
                    help="another checkout (e.g. main) whose 'identify' is scored beside this one's")
    a = ap.parse_args(argv)

    out = Path(a.out)
    rows = []
    for cb in TEST_AS_RUN:
        if a.only not in (None, cb.name):
            continue
        r, info = run_beam(cb, out, a.n_pairs, a.train_n, a.seed, a.workers)
        pairs = out / cb.name / f"pairs-n{a.n_pairs}-s{a.seed}"
        meta = json.loads((pairs / "truth.json").read_text())
        excited = excited_modes(cb, 0.02)
        ident = {"this": modes_found(pairs, meta, excited)}
        if a.before:
            ident["before"] = modes_found(pairs, meta, excited, source_tree=a.before)
        rows.append(_row(cb, "the beam file" if cb.file_drive else "the beam file as written (a force at the first "
                          "sensor)", r, info, ident))
        if not cb.file_drive:  # the README's loop: discrepancy writes the files' drive point into the beam file
            cal = out / cb.name / "calibrated"
            if not (cal / "beam.toml").is_file():
                cli_json(["discrepancy", "--beam", str(pairs / "beam.toml"), "--measured",
                          str(pairs / "pair-000_baseline.uff"), "--out", str(cal)])
            r, info = run_beam(cb, out, a.n_pairs, a.train_n, a.seed, a.workers, beam_file=cal / "beam.toml",
                               model_tag="calibrated")
            rows.append(_row(cb, "discrepancy's beam file (the files' drive point)", r, info, None))
            rows[-1]["beam"] = "the same"

    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "test-as-run.json", json.dumps({"seed": a.seed, "n_pairs": a.n_pairs,
                                                            "train_n": a.train_n, "beams": rows}, indent=1))
    if a.json:
        print(json.dumps(rows, indent=1))
        return 0
    md = markdown(rows)
    print(md)
    publish(a, "test-as-run", md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
