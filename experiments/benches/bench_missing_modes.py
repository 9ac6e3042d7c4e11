"""The network on the modes a test holds: accuracy with each mode missing, before and after.

Run::

    python -m experiments.benches.bench_missing_modes --model M --before M0 --data TEST_DIR [--before-tree DIR]
        [--sim-n 24] [--seed 400] [--beam al-beam-pp-6s --beam-pairs DIR --beam-model MB --beam-before MB0]
        [--out out/missing] [--docs]

``M`` is a model of this checkout (its network answers on any 2 or more modes), ``M0`` one trained on the same
data by a checkout whose network needs every mode (``--before-tree``: that checkout, run in a subprocess for the
CLI rows; without it the CLI rows have no "before" column). Three tables, each with one row per missing mode
(none, then mode k of the model's modes):

* **held-out pairs** (``TEST_DIR``: ``generate --config training`` with another seed): the modes of every pair
  with mode k removed from both tests, fed to the networks (``learn.network.features.with_missing_modes``) and to the
  model's best classical method on the remaining modes (what ``classify`` answers with when the network cannot):
  AUC, detection, false alarms and element accuracy as :func:`learn.network.evaluate.metrics` counts them, and the share
  of pairs inside the training data (Mahalanobis distance on the present features within the 99.9th percentile);
* **independent simulator, thesis beam** (``experiments.second_sim pairs --set eb``): through ``classify``: the
  simulator's modal data (``pair-K_*.json``, frequencies 0.03 %, shapes 0.5 % noise) with mode k left out of both
  tests, and its UFF files with the band cut (2-500 Hz: mode 4 missing; 40-800 Hz: mode 1 missing), identified by
  ``classify`` itself;
* **independent simulator, a catalogue beam** (``--beam``; ``python -m experiments.second_sim beams --only NAME``
  writes the pairs and ``beam.toml``, from which ``generate --beam .../beam.toml --config training`` and
  ``train`` make ``--beam-model``): each UFF identified by ``beam-damage identify --band`` (the beam file's band),
  mode k left out of both tests' ``modal.json``, then ``classify``; zone accuracy over the beam file's zones.

``--sweep TRAIN_DIR ...`` trains modal networks on those datasets with each ``--probabilities`` of a mode missing
and scores them on ``--data`` (element accuracy / false alarms per missing mode).

Writes ``missing_modes.json`` and ``missing_modes.md`` in ``--out``; ``--docs`` puts the tables into
``docs/classifier.md``: the held-out and simulator tables into block ``missing-modes``, the sweep's into block
``missing-modes-sweep`` (each only when this run measured it).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from experiments.benches.bench_foreign import score, set_dir, write_sets
from experiments.benches.study_beams import score_beam
from experiments.benches.harness import cli_json, parser, publish, table
from learn.explanations.classical import run_classical
from learn.network.estimator import DamageClassifier
from learn.network.evaluate import metrics
from learn.network.features import (feature_modes, features, load_pairs, modal_features, split_by_specimen,
                                    with_missing_modes)
from learn.pairs.measured import pair_modes_by_frequency
from learn.network.model_dir import load_model, sensitivity_of
from learn.network.training import _nominal_root_spring, targets
from learn.pairs.verdict import IN_DISTRIBUTION_PERCENTILE, network_output
from physics.io import atomic_write_text, read_modal_json, write_modal_json

__all__ = ["held_out", "main", "markdown", "without_mode"]


def _pct(v) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{100 * v:.0f}%"


def held_out(model, before, data) -> list[dict]:
    """Rows per missing mode of the networks and the best classical method on held-out dataset pairs."""
    pairs = load_pairs(data, frfs=())
    model.check_beam(pairs.beam, f"dataset {data}")
    beam, m = pairs.beam, pairs.beam.n_modes
    _, truth = targets(pairs)
    sens = model.sensitivity
    lam_all, vec_all = pairs.eigenvalues[..., :m], pairs.eigenvectors[..., :m]
    rows = []
    for k in [None, *range(m)]:
        keep = [j for j in range(m) if j != k]
        X = _masked_features(pairs, k)
        case = "none" if k is None else f"mode {beam.modes[k]}"
        outs = []
        est = model.networks["modal"]
        outs.append(("network (after)", network_output(est, X, sens, "network")[0],
                     float(np.mean(est.training_percentile(X)[1] <= IN_DISTRIBUTION_PERCENTILE))))
        if k is None:
            outs.append(("network (before)", network_output(before.networks["modal"], X, sens, "network")[0],
                         float("nan")))
        cl, _ = run_classical(lam_all[..., keep], vec_all[..., keep], sens if k is None else sens.modes(keep),
                              model.config["classical_thresholds"])
        best = next(o for o in cl if o.name == model.config["best_classical"])
        outs.append((f"{best.name} (before: the verdict)" if k is not None else best.name, best, float("nan")))
        for name, out, inside in outs:
            r = metrics(out, truth, None, "all", beam)
            rows.append({"case": case, "method": name, "pairs": r.n_pairs, "auc": r.roc_auc,
                         "detection": r.detection_rate, "false_alarms": r.false_alarm_rate,
                         "element_accuracy": r.element_accuracy, "in_distribution": inside})
    return rows


def _masked_features(pairs, k):
    """Modal features of ``pairs`` with mode ``k`` (0-based; None: none) missing in both tests (NaN columns)."""
    m = pairs.beam.n_modes
    keep = [j for j in range(m) if j != k]
    lam, vec = with_missing_modes(pairs.eigenvalues[..., keep], pairs.eigenvectors[..., keep], keep, m)
    X = modal_features(lam, vec, m, pairs.beam.test)
    held = np.isin(np.arange(X.shape[1]) % m, keep)
    return np.where(held & ~np.isfinite(X), 0.0, X)             # as features() reads a dataset


def sweep(train_dirs, test_dirs, probabilities, epochs: int = 60, seed: int = 0) -> list[dict]:
    """Modal networks trained as ``train`` trains them (same split and seed) with each probability of a mode
    missing, scored on held-out pairs per missing mode: element accuracy, detection, false alarms, AUC."""
    pairs, test = load_pairs(train_dirs, frfs=()), load_pairs(test_dirs, frfs=())
    y, _ = targets(pairs)
    _, truth = targets(test)
    tr, _, _ = split_by_specimen(pairs.groups, (0.85, 0.0, 0.15), seed=seed)
    sens = sensitivity_of(pairs.beam, _nominal_root_spring(pairs.source), pairs.source[0].get("truth_beam"),
                          pairs.source[0].get("config"))
    X = features(pairs, "modal")
    rows = []
    m = pairs.beam.n_modes
    for p in probabilities:
        params = dict(epochs=epochs, random_state=seed, feature_modes=feature_modes(X.shape[1], m),
                      missing_mode_probability=p)
        if pairs.beam.test is not None:
            params["zone_edges"] = [float(v) for v in pairs.beam.zone_edges_m / pairs.beam.length_m]
        est = DamageClassifier(**params).fit(X[tr], y[tr], pairs.groups[tr])
        for k in [None, *range(m)]:
            r = metrics(network_output(est, _masked_features(test, k), sens)[0], truth, None, "all", test.beam)
            rows.append({"p": p, "case": "none" if k is None else f"mode {test.beam.modes[k]}", "auc": r.roc_auc,
                         "detection": r.detection_rate, "false_alarms": r.false_alarm_rate,
                         "element_accuracy": r.element_accuracy})
    return rows


def without_mode(src: Path, dst: Path, mode_index: int | None, nominal_hz) -> Path:
    """Write the modal data of ``src`` to ``dst`` without the mode paired with the nominal mode ``mode_index``
    (0-based; :func:`learn.pairs.measured.pair_modes_by_frequency`; all modes when None or none pairs with it)."""
    md = read_modal_json(src)
    which = pair_modes_by_frequency(np.abs(md.eigenvalues) / (2 * np.pi), nominal_hz)
    keep = np.flatnonzero(which != (-2 if mode_index is None else mode_index))
    dst.parent.mkdir(parents=True, exist_ok=True)
    write_modal_json(dst, replace(md, eigenvalues=md.eigenvalues[keep],
                                  eigenvectors=None if md.eigenvectors is None else md.eigenvectors[:, keep]))
    return dst


def _verdicts(model, base_files, cur_files, tree=None) -> list[dict]:
    def path(p):
        return str(Path(p).resolve())

    return [cli_json(["classify", "--model", path(model), "--baseline", path(b), path(c)], tree)
            for b, c in zip(base_files, cur_files)]


def _classical_verdicts(verdicts: list[dict]) -> list[dict]:
    """The verdicts a checkout whose network needs every mode gives pairs with a mode missing: the classical
    method's answer as the verdict, no network (``classify`` computes that answer the same way in both)."""
    return [{**v, **{k: v["classical"][k] for k in ("damaged", "location_element", "location_zone",
                                                      "location_x_m", "size")},
             "size_std": None, "location_std_m": None, "detectable": None, "network": None,
             "verdict_from": "classical", "in_distribution": False, "training_percentile": None} for v in verdicts]


def _before(after: list[dict], run, measured: dict) -> list[dict]:
    """The "before" verdicts of a case: measured (``run()``, the before checkout's ``classify``) for the first case
    with a mode missing of a set and for complete pairs, else derived from ``after`` (:func:`_classical_verdicts`);
    where both exist they are compared and the agreement recorded in ``measured``."""
    if measured.get("done"):
        return _classical_verdicts(after)
    got = run()
    if any(v["network"] is None for v in got):
        derived = _classical_verdicts(after)
        keys = ("damaged", "location_zone", "location_x_m")
        measured["done"] = True
        measured["agree"] = sum(all(a[k] == b[k] for k in keys) for a, b in zip(got, derived) if a["network"] is None)
        measured["of"] = sum(a["network"] is None for a in got)
    return got


def _cli_rows(case: str, score, verdicts: dict) -> list[dict]:
    """Rows of one case: the verdict and the network, after and before (``verdicts``: label -> list)."""
    rows = []
    for label, vs in verdicts.items():
        answered = sum(v.get("network") is not None for v in vs)
        inside = sum(v.get("verdict_from") == "network" for v in vs)
        for r in score(vs):
            if r["method"] in ("verdict", "network"):
                rows.append({"case": case, "model": label, "method": r["method"], "pairs": r["pairs"],
                             "network_answers": answered, "network_verdicts": inside,
                             "accuracy": r.get("element_accuracy", r.get("zone_accuracy")),
                             "detection": r["detection"], "false_alarms": r["false_alarms"],
                             "intact_pairs": r["intact_pairs"], "damaged_pairs": r["damaged_pairs"]})
    return rows


def thesis_beam_sim(model, before, tree, out: Path, n: int, seed: int, checks: dict) -> list[dict]:
    """Rows per missing mode on the independent simulator's ``eb`` set through ``classify`` (``checks``: the
    agreement of measured and derived "before" verdicts, :func:`_before`)."""
    nominal = load_model(model).sensitivity.frequencies_hz
    truth = write_sets(out, ["eb"], n, seed)["eb"]
    d = set_dir(out, "eb")
    check, check_uff = {}, {}
    rows = []
    m = nominal.size
    for k in [None, *range(m)]:
        case = "none" if k is None else f"mode {k + 1}"
        cut = out / "cut-modes" / f"eb-no{0 if k is None else k + 1}"
        files = [[without_mode(d / f"pair-{int(t['pair']):03d}_{day}.json", cut / f"{int(t['pair']):03d}_{day}.json",
                               k, nominal) for day in ("baseline", "current")] for t in truth]
        vs = {"after": _verdicts(model, [f[0] for f in files], [f[1] for f in files])}
        if tree:
            vs["before"] = _before(vs["after"], lambda: _verdicts(before, [f[0] for f in files], [f[1] for f in files],
                                                                  tree), check)
        rows += _cli_rows(f"{case} (modal data)", lambda v: score(v, truth), vs)
    for band, missing in (((2.0, 500.0), 4), ((40.0, 800.0), 1)):
        tb = write_sets(out, ["eb"], n, seed, band)["eb"]
        db = set_dir(out, "eb", band)
        base = [db / f"pair-{int(t['pair']):03d}_baseline.uff" for t in tb]
        cur = [db / f"pair-{int(t['pair']):03d}_current.uff" for t in tb]
        vs = {"after": _verdicts(model, base, cur)}
        if tree:
            vs["before"] = _before(vs["after"], lambda: _verdicts(before, base, cur, tree), check_uff)
        rows += _cli_rows(f"mode {missing} (UFF, band {band[0]:g}-{band[1]:g} Hz)", lambda v, tb=tb: score(v, tb), vs)
    checks.update(eb_modal=check, eb_uff=check_uff)
    return rows


def catalogue_beam(name: str, pairs_dir: Path, model, before, tree, out: Path, checks: dict) -> list[dict]:
    """Rows per missing mode on a catalogue beam of the independent simulator: each UFF identified by
    ``identify --band`` (the beam's band), mode k left out of both tests, then ``classify``."""
    meta = json.loads((pairs_dir / "truth.json").read_text())
    nominal = np.asarray(meta["nominal_frequencies_hz"], float)
    lo, hi = meta["band_hz"]
    ident = out / "identified" / name
    for t in meta["pairs"]:
        for day in ("baseline", "current"):
            stem = f"pair-{int(t['pair']):03d}_{day}"
            if not (ident / stem / "modal.json").is_file():
                cli_json(["identify", str(pairs_dir / f"{stem}.uff"), "--band", f"{lo}", f"{hi}",
                          "--out", str(ident / stem)])
    check = {}
    rows = []
    for k in [None, *range(nominal.size)]:
        case = "none" if k is None else f"mode {k + 1}"
        cut = out / "cut-modes" / f"{name}-no{0 if k is None else k + 1}"
        files = [[without_mode(ident / f"pair-{int(t['pair']):03d}_{day}" / "modal.json",
                               cut / f"{int(t['pair']):03d}_{day}.json", k, nominal) for day in ("baseline", "current")]
                 for t in meta["pairs"]]
        vs = {"after": _verdicts(model, [f[0] for f in files], [f[1] for f in files])}
        if tree:
            vs["before"] = _before(vs["after"], lambda: _verdicts(before, [f[0] for f in files], [f[1] for f in files],
                                                                  tree), check)
        rows += _cli_rows(f"{case} (identified modal data)", lambda v: score_beam(v, meta), vs)
    checks[name] = check
    return rows


def sweep_markdown(rows: list[dict]) -> str:
    cases = list(dict.fromkeys(r["case"] for r in rows))
    by = {(r["p"], r["case"]): r for r in rows}
    return ("Probability of a mode missing in training (held-out pairs, network element accuracy / false alarms):\n\n"
            + table(["p", *(f"{c} missing" for c in cases)],
                    [[f"{p:g}", *(f"{_pct(by[p, c]['element_accuracy'])} / {100 * by[p, c]['false_alarms']:.1f}%"
                                  for c in cases)] for p in dict.fromkeys(r["p"] for r in rows)]) + "\n")


def markdown(held: list[dict], sim: list[dict], beam: list[dict], beam_name: str | None = None) -> str:
    lines = []
    if held:
        lines += ["Held-out pairs (`generate --config training`, another seed):", "",
                  table(["missing", "method", "AUC", "detection", "false alarms", "element acc.", "in distribution"],
                        [[r["case"], r["method"], f"{r['auc']:.3f}", _pct(r["detection"]),
                          f"{100 * r['false_alarms']:.1f}%", _pct(r["element_accuracy"]), _pct(r["in_distribution"])]
                         for r in held])]
    for title, rows, acc in ((("Independent simulator, thesis beam (`eb` set)"), sim, "element acc."),
                             (f"Independent simulator, {beam_name}", beam, "zone acc.")):
        if not rows:
            continue
        cells = []
        for case in dict.fromkeys(r["case"] for r in rows):
            for label in dict.fromkeys(r["model"] for r in rows if r["case"] == case):
                v = next(r for r in rows if (r["case"], r["model"], r["method"]) == (case, label, "verdict"))
                n = next((r for r in rows if (r["case"], r["model"], r["method"]) == (case, label, "network")), None)
                net = ([_pct(n["accuracy"]), _pct(n["detection"]), f"{n['false_alarms']} of {n['intact_pairs']}"]
                       if n and n["network_answers"] else ["-"] * 3)
                cells.append([case, label, f"{v['network_answers']} of {v['pairs']}", f"{v['network_verdicts']} of "
                              f"{v['pairs']}", _pct(v["accuracy"]), _pct(v["detection"]),
                              f"{v['false_alarms']} of {v['intact_pairs']}", *net])
        lines += ["", f"{title}, through `classify`:", "",
                  table(["missing", "model", "network answers", "network verdicts", f"verdict: {acc}", "detection",
                         "false alarms", f"network alone: {acc}", "detection", "false alarms"], cells)]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="classifier.md", json=True, out="out/missing", seed=400)
    ap.add_argument("--model", required=True, help="model directory of this checkout")
    ap.add_argument("--before", help="model directory of the checkout whose network needs every mode")
    ap.add_argument("--before-tree", help="that checkout (its classify runs in a subprocess)")
    ap.add_argument("--data", nargs="*", default=[], help="held-out dataset directories of the model's beam")
    ap.add_argument("--sim-n", type=int, default=24, help="pairs of the simulator's eb set (0: none)")
    ap.add_argument("--beam", help="a catalogue beam of experiments.second_sim (its pairs in --beam-pairs)")
    ap.add_argument("--beam-pairs", help="directory written by 'python -m experiments.second_sim beams --only NAME'")
    ap.add_argument("--beam-model", help="model trained on that beam's beam.toml (this checkout)")
    ap.add_argument("--beam-before", help="the same, trained by the --before-tree checkout")
    ap.add_argument("--sweep", nargs="*", default=[], metavar="TRAIN_DIR",
                    help="train modal networks on these datasets with each --probabilities and score them on --data")
    ap.add_argument("--probabilities", type=float, nargs="+", default=[0.0, 0.05, 0.15, 0.3])
    a = ap.parse_args(argv)

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    held = held_out(load_model(a.model), load_model(a.before), a.data) if a.data and a.before else []
    checks: dict = {}
    sim = thesis_beam_sim(a.model, a.before, a.before_tree, out, a.sim_n, a.seed, checks) if a.sim_n else []
    beam = (catalogue_beam(a.beam, Path(a.beam_pairs), a.beam_model, a.beam_before, a.before_tree, out, checks)
            if a.beam else [])

    swept = sweep(a.sweep, a.data, a.probabilities) if a.sweep else []
    text = markdown(held, sim, beam, a.beam)
    if any(c.get("of") for c in checks.values()):
        text += ("\n\"before\" with a mode missing: measured on the first such case of each set, derived from the "
                 "classical answer elsewhere; measured and derived agree on "
                 + ", ".join(f"{c['agree']} of {c['of']} ({k})" for k, c in checks.items() if c.get("of")) + ".\n")
    atomic_write_text(out / "missing_modes.json", json.dumps({"held_out": held, "simulator": sim, "beam": beam,
                                                              "sweep": swept, "before_checks": checks,
                                                              "args": vars(a)}, indent=1))
    swept_text = sweep_markdown(swept) if swept else ""
    atomic_write_text(out / "missing_modes.md", text + ("\n" + swept_text if swept_text else ""))
    print(json.dumps({"held_out": held, "simulator": sim, "beam": beam, "sweep": swept}, indent=1) if a.json
          else text + ("\n" + swept_text if swept_text else ""))
    if held or sim or beam:
        publish(a, "missing-modes", text.strip())
    if swept:
        publish(a, "missing-modes-sweep", swept_text.strip())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
