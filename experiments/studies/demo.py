"""``beam-damage demo``: the mission end to end, the job behind ``make demo``.

1. ``validate``: the thesis reproduction table.
2. The thesis study (Tables 4.1/4.2, the identified models, Tables 6.1/6.2, FRFs in the
   style of Figures 6.1-6.3) and a simulated beam-5 test through UFF58 -> LSCF/LSFD -> Pilkey.
3. The discrepancy workflow on beam 5's measured frequencies (Table 4.3): the named effect,
   the gap before and after, and the calibrated beam file.
4. A training dataset (``--config training``) with the calibrated beam as truth, a held-out
   test dataset of other specimens, training, and the evaluation against the classical methods.
5. ``classify`` of the thesis's beam 5, damaged against undamaged (Tables 4.5/4.6).
6. ``report.html`` (self-contained) and ``report.md`` with every table and figure.

Each step keeps its result in ``OUT/.steps/NAME.json``; a second run reuses what is there
unless ``--force`` (or a different ``--quick``/``--samples`` choice) asks for it again.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import time
from pathlib import Path

from datagen.config import load_config, merge
from datagen.generation import generate
from datagen.truth_beam import beam_mapping
from experiments.studies import study_discrepancy, study_thesis, validate
from experiments.studies.doc_tables import DOCS, write_table
from experiments.studies.report import Section, Table, figure, write_report
from learn.pairs.classify import classify_many
from learn.network.model_dir import MODEL_FORMAT, load_model
from learn.pairs.verdict import explained_text, explanation_label, noise_text
from physics import discrepancy, modal, properties, thesis, updating
from physics.beam import load_beam
from physics.errors import BeamDamageError
from physics.identification import identify_frf
from physics.io import (atomic_write_text, modal_data_from_dict, read_frf, read_modal_json, to_jsonable,
                        write_modal_json, write_uff58)

__all__ = ["add_parser", "run"]


#: (training pairs, test pairs, epochs) of the full and the quick demo.
SIZES = {"full": (20000, 5000, 40), "quick": (3000, 1000, 10)}


def _step(out: Path, name: str, force: bool, key: dict, fn):
    """Run ``fn()`` unless ``OUT/.steps/NAME.json`` holds a result computed with the same ``key``."""
    path = out / ".steps" / f"{name}.json"
    if not force and path.exists():
        saved = json.loads(path.read_text())
        if saved.get("key") == key:
            print(f"[demo] {name}: reusing {path} (--force recomputes)", file=sys.stderr, flush=True)
            return saved["result"]
    print(f"[demo] {name} ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    result = to_jsonable(fn())
    result["seconds"] = time.perf_counter() - t0
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps({"key": key, "result": result}, indent=1) + "\n")
    return result


def measured_data_step(out: Path) -> dict:
    """Simulated beam-5 test -> UFF58 -> LSCF/LSFD identification -> Pilkey updating."""
    from experiments.studies.plots_identify import write_outputs  # matplotlib: the identification's figures

    frf, exact = thesis.simulated_beam5_test(noise=0.01, damping="thesis")
    out.mkdir(parents=True, exist_ok=True)
    uff = out / "beam5_simulated.uff"
    write_uff58(uff, frf, binary=True)
    ident = identify_frf(read_frf(uff), n_modes=4)
    write_outputs(ident, out)
    data = read_modal_json(out / "modal.json")
    b5 = properties.beam_preset("beam5")
    M = updating.analyst_mass(b5.mass_per_length_kg_m, b5.length_m, "iirs", b5.n_elements)
    upd = updating.pilkey(M, data.eigenvalues, data.eigenvectors)
    return {"exact_frequencies_hz": exact.natural_frequencies_hz, "exact_damping_ratios": exact.damping_ratios,
            "identified_frequencies_hz": ident.estimate.natural_frequencies_hz,
            "identified_damping_ratios": ident.estimate.damping_ratios,
            "updated_model_frequencies_hz": modal.complex_modes(M, upd.C, upd.K).natural_frequencies_hz,
            "figures": [str(out / "overlay.png"), str(out / "stabilisation.png")]}


def dataset_step(out: Path, beam_file: str, n: int, seed: int, workers: int) -> dict:
    """A ``training``-config dataset with the calibrated beam as truth."""
    if out.exists():   # a dataset of another size or beam: start again (resume only continues the same run)
        shutil.rmtree(out)
    cfg = merge({"beam": beam_mapping(load_beam(beam_file))}, base=load_config("training"))
    m = generate(out, cfg, n=n, seed=seed, workers=workers, progress=True)
    return {"path": str(out), "samples": m["counts"]["samples"], "not_converged": m["counts"]["not_converged"],
            "seed": seed}


def classify_step(out: Path, model_dir: Path) -> dict:
    """Beam 5 (Tables 4.5/4.6 as modal JSON) through the trained model."""
    out.mkdir(parents=True, exist_ok=True)
    b5 = thesis.load("beams")["beams"]["5"]
    data, paths = {}, {}
    for state in ("undamaged", "damaged"):   # Tables 4.5/4.6: rows are the translations of nodes 2..5
        data[state] = modal_data_from_dict({**b5[state], "dofs": ["2:y", "3:y", "4:y", "5:y"]},
                                           f"beams.json beam 5 {state}")
        paths[state] = out / f"beam5_{state}.json"
        write_modal_json(paths[state], data[state])
    model = load_model(model_dir)
    res = classify_many(model, data["undamaged"], [data["damaged"]])[0]
    res["verdict_text"] = model.verdict_text(res)
    res["inputs"] = {k: str(v) for k, v in paths.items()}
    atomic_write_text(out / "verdict.json", json.dumps(to_jsonable(res), indent=1) + "\n")
    return res


def _verdict_text(v: dict, length_m: float) -> str:
    """The verdict's own text (:meth:`learn.network.model_dir.TrainedModel.verdict_text`) and where the thesis cut its
    slit."""
    return (f"{v['verdict_text']}\nThe thesis cut its slit a quarter of the length from the fixed end: "
            f"x = {length_m / 4:.3f} m on the {length_m:g} m cantilever (the element 1/2 boundary).")


def _answers(v: dict) -> list[dict]:
    """One row per method of a classify verdict (the network, then every classical method), the one taken marked."""
    taken = "network" if v["verdict_from"] == "network" else (v.get("classical") or {}).get("method")
    methods = [("network", v["network"])] + [(a["method"], a)
                                              for a in (v.get("classical_methods") or [v.get("classical")]) if a]
    return [{"method": name if name == "network" else f"classical: {name}",
             "verdict taken": "yes" if name == taken else "",
             "damaged": a["damaged"], "probability of damage": a.get("probability_damaged"),
             "x_m": round(a["location_x_m"], 4), "element": a["location_element"],
             "size": float(f"{a['size']:.3g}")} for name, a in methods if a]


#: Metrics of the classifier in the summary: key, header, True when larger is better.
SUMMARY_METRICS = (("roc_auc", "ROC AUC", True), ("element_accuracy", "element accuracy", True),
                   ("within_one_element", "within one element", True),
                   ("median_location_error_mm", "median location error (mm)", False),
                   ("median_size_error", "median size error", False),
                   ("false_alarm_rate", "false-alarm rate", False), ("accuracy", "accuracy", True))


def _rounded(row: dict) -> dict:
    """A metrics row with its numbers to 3 significant digits (estimates from about a thousand test pairs)."""
    return {k: float(f"{v:.3g}") if isinstance(v, float) else v for k, v in row.items()}


def _best_classical(rows: list[dict]) -> dict | None:
    """The classical method with the highest element accuracy (then ROC AUC)."""
    classical = [r for r in rows if not r["method"].startswith("network")]

    def key(r):
        return tuple(-1.0 if r.get(k) is None else r[k] for k in ("element_accuracy", "roc_auc"))

    return max(classical, key=key) if classical else None


def _summary_section(checks, disc: dict, evaluated: dict, verdict: dict, length_m: float) -> Section:
    """What was found, in one screen: thesis checks, the model's gap, beam 5's verdict, the classifier."""
    n_pass = sum(c.passed for c in checks)
    worst = max(checks, key=lambda c: c.rel_error)
    failed = [c.name for c in checks if not c.passed]
    thesis_text = (f"**Thesis reproduced:** {n_pass} of {len(checks)} checks against the thesis's printed numbers "
                   f"pass; the largest relative error is {100 * worst.rel_error:.2g} % ({worst.name}; tolerance "
                   f"{100 * worst.tolerance:.2g} %)." if not failed else
                   f"**Thesis reproduction incomplete:** {n_pass} of {len(checks)} checks pass; failing: "
                   f"{'; '.join(failed)}.")
    gb, ga = disc["gap_before"], disc["gap_after"]
    effects = " then ".join(e.replace("_", " ") for e in disc["effects"])
    gap_text = (f"**What beam 5's model lacks:** {effects or 'no effect named'}. "
                f"Against the measured frequencies (Table 4.3) the largest frequency error falls from "
                f"{gb['max_abs_frequency_error_pct']:.2f} % to {ga['max_abs_frequency_error_pct']:.2f} % "
                f"(mean {gb['mean_abs_frequency_error_pct']:.2f} % -> {ga['mean_abs_frequency_error_pct']:.2f} %); "
                "the calibrated beam is the truth model of the training data.")

    net, cl = verdict["network"], verdict.get("classical") or {}
    answer = (f"damaged, element {verdict['location_element']} of 4, x = {verdict['location_x_m']:.3f} m"
              if verdict["damaged"] else "undamaged")
    net_answer = (f"damaged with probability {net['probability_damaged']:.3f}, element {net['location_element']}, "
                  f"x = {net['location_x_m']:.3f} m" if net["damaged"]
                  else f"undamaged (probability of damage {net['probability_damaged']:.3f})")
    cl_answer = (f"damaged, element {cl['location_element']}, x = {cl['location_x_m']:.3f} m" if cl.get("damaged")
                 else "undamaged")
    if verdict["verdict_from"] == "network":
        support = ("" if net.get("probability_support_change") is None else
                   f"; supports changed beyond re-clamping: probability {net['probability_support_change']:.2g}")
        source = (f"from the network (probability of damage {net['probability_damaged']:.3f}{support}), the pair "
                  f"lying inside the training data (Mahalanobis distance {verdict['mahalanobis_distance']:.3g}; "
                  f"{verdict['training_percentile']:.0f} % of the training pairs lie nearer); the classical method "
                  f"{cl.get('method', '–')} says {cl_answer}")
    else:
        source = (f"from the classical method {cl.get('method', '–')}: the pair lies outside the training data "
                  f"(Mahalanobis distance {verdict['mahalanobis_distance']:.3g}, beyond "
                  f"{verdict['training_percentile']:.1f} % of training pairs), so the network's answer ({net_answer}) "
                  "is not used")
    slit_m = length_m / 4
    caveat = (f"Caveat: the thesis cut its slit at x = {slit_m:.3f} m, on the boundary of elements 1 and 2"
              + (f"; this answer lies {1000 * abs(verdict['location_x_m'] - slit_m):.0f} mm from it."
                 if verdict["damaged"] else "; this answer misses it."))

    explained = (f" Explanations of the {explained_text(verdict)} ({noise_text(verdict)}, equal priors): "
                 f"{verdict['hypotheses_summary']}." if verdict.get("hypotheses") else "")
    verdict_text = (f"**Beam 5, damaged against undamaged (Tables 4.5/4.6): {answer}.** Verdict {source}. {caveat}"
                    f"{explained}")

    rows = evaluated["rows"]
    best = _best_classical(rows)
    nets = [r for r in rows if r["method"].startswith("network")]
    side = nets + ([best] if best else [])
    table_rows = [_rounded({"method": r["method"] + (" (best classical)" if r is best else ""),
                            **{h: r.get(k) for k, h, _ in SUMMARY_METRICS}}) for r in side]
    clf_text = f"**Classifier against the classical methods** ({evaluated.get('pairs', '–')} held-out test pairs)"
    if nets and best:
        ahead = [h for k, h, up in SUMMARY_METRICS if nets[0].get(k) is not None and best.get(k) is not None
                 and (nets[0][k] > best[k] if up else nets[0][k] < best[k])]
        clf_text += (f": the network is ahead of the best classical method, {best['method']} (highest element "
                     f"accuracy), on {len(ahead)} of {len(SUMMARY_METRICS)} metrics"
                     + (f" ({', '.join(ahead)})." if ahead else "."))
    else:
        clf_text += "."
    return Section("Summary", (thesis_text, gap_text, verdict_text, clf_text),
                   (Table.from_records("The network beside the best classical method on the same test pairs",
                                       table_rows),))


def _metric(row: dict | None, key: str, fmt: str, scale: float = 1.0) -> str:
    v = None if row is None else row.get(key)
    return "-" if v is None else format(scale * v, fmt)


def doc_blocks(result: dict) -> dict:
    """The demo's numbers as README.md and docs/demo.md show them: ``{(page, block name): markdown}``
    (:func:`experiments.studies.doc_tables.write_table` writes them with ``--docs``).

    The ``demo-numbers`` blocks hold what the run computes (deterministic for a seed); ``demo-timings`` the
    seconds of the machine that ran it, dated.
    """
    disc, verdict, rows = result["discrepancy"], result["classify"], result["evaluate"]
    net = next((r for r in rows if r["method"].startswith("network")), None)
    best = _best_classical(rows)
    gb, ga = disc["gap_before"], disc["gap_after"]
    effects = " then ".join(e.replace("_", " ") for e in disc["effects"]) or "no effect"
    called = (f"called damaged, {verdict['location_x_m']:.3f} m from the clamp (element "
              f"{verdict['location_element']}), by the {verdict['verdict_from']}" if verdict["damaged"]
              else f"called undamaged by the {verdict['verdict_from']}")
    hyp = verdict.get("hypotheses") or []
    explained = ("; its explanations: " + ", ".join(f"{explanation_label(h['name'])} {h['probability']:.2f}"
                                                     for h in hyp[:3]) if hyp else "")
    numbers = (f"{result['validate_passed_count']} of {result['checks']} thesis checks pass; {effects} named, largest "
               f"frequency error {gb['max_abs_frequency_error_pct']:.2f} % -> "
               f"{ga['max_abs_frequency_error_pct']:.2f} %; "
               f"on the {result['test_pairs']} held-out specimens of the calibrated beam the network reaches ROC AUC "
               f"{_metric(net, 'roc_auc', '.3f')}, element accuracy {_metric(net, 'element_accuracy', '.1f', 100)} %, "
               f"median location error {_metric(net, 'median_location_error_mm', '.1f')} mm, median size error "
               f"{_metric(net, 'median_size_error', '.0f', 100)} %, "
               f"{_metric(net, 'false_alarm_rate', '.1f', 100)} % false alarms"
               + (f" ({best['method']}, the best classical method: ROC AUC {_metric(best, 'roc_auc', '.3f')}, element "
                  f"accuracy {_metric(best, 'element_accuracy', '.1f', 100)} %, "
                  f"{_metric(best, 'false_alarm_rate', '.1f', 100)} % false alarms)" if best else "")
               + f"; beam 5 is {called}{explained}.")
    t = result["step_seconds"]
    timings = (f"On {result['machine']} ({time.strftime('%Y-%m-%d', time.gmtime())}) the steps took: identification "
               f"{t['identify']:.1f} s, discrepancy {t['discrepancy']:.1f} s, datasets {t['dataset']:.1f} s, training "
               f"{t['train']:.0f} s (one torch thread), evaluation {t['evaluate']:.1f} s; the whole run "
               f"{result['seconds']:.0f} s after the install.")
    return {("demo.md", "demo-numbers"): numbers, ("demo.md", "demo-timings"): timings,
            (str(DOCS.parent / "README.md"), "demo-numbers"): numbers}


def run(args) -> dict:
    if args.samples is not None and args.samples < 200:
        raise BeamDamageError(f"samples must be >= 200 (training pairs), got {args.samples}", parameter="samples")
    if args.workers < 1:
        raise BeamDamageError(f"workers must be >= 1, got {args.workers}", parameter="workers")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    n_train, n_test, epochs = SIZES["quick" if args.quick else "full"]
    if args.samples is not None:   # a chosen size: the test set scales with it
        n_train, n_test = args.samples, max(200, args.samples // 4)
    t_start = time.perf_counter()
    force = args.force

    # 1-2: the thesis
    checks = validate.run_checks()
    vsum = validate.summary(checks)
    atomic_write_text(out / "validate.json", json.dumps(to_jsonable(vsum), indent=1) + "\n")
    atomic_write_text(out / "validate.txt", validate.format_table(checks) + "\n")
    thesis_summary, thesis_sections = study_thesis.run(out / "thesis")
    measured = _step(out, "identify", force, {}, lambda: measured_data_step(out / "identify"))

    # 3: discrepancy -> calibrated beam file
    disc = _step(out, "discrepancy", force, {}, lambda: {
        k: v for k, v in discrepancy.analyse_file("beam5", discrepancy.EXAMPLE, out / "discrepancy").items()
        if k != "_result"})
    beam_file = disc["beam_file"]

    # 4: data, training, evaluation
    config = hashlib.sha256(json.dumps(load_config("training"), sort_keys=True).encode()).hexdigest()[:16]
    key = {"beam": beam_file, "n_train": n_train, "n_test": n_test, "training_config": config}
    data = _step(out, "dataset", force, key, lambda: {
        "train": dataset_step(out / "dataset", beam_file, n_train, 0, args.workers),
        "test": dataset_step(out / "testset", beam_file, n_test, 1, args.workers)})
    force_model = force or not (out / "model").exists()
    key = {**key, "epochs": epochs, "model_format": MODEL_FORMAT}   # a model of another format is retrained

    def train_model():
        from learn.network.training import train  # torch: the network
        return train(out / "dataset", out / "model", epochs=epochs, seed=0, progress=True)

    trained = _step(out, "train", force_model, key, train_model)

    def evaluate_model():
        from learn.network.training import evaluate  # torch: the network
        res = evaluate(load_model(out / "model"), out / "testset", out / "evaluate", progress=True)
        return {"rows": [r for r in res["rows"] if r["subset"] == "all"], "figures": res["figures"],
                "pairs": res["pairs"]}

    evaluated = _step(out, "evaluate", force_model, key, evaluate_model)

    # 5: classify beam 5
    verdict = _step(out, "classify", force_model, {**key, "verdict": "text"},
                    lambda: classify_step(out / "classify", out / "model"))

    # 6: report
    elapsed = time.perf_counter() - t_start
    sections = _report_sections(checks, thesis_sections, measured, disc, data, trained, evaluated, verdict, out)
    paths = write_report(out, "beam-damage: from the thesis to a damage classifier for beam 5", sections,
                         summary=_summary_section(checks, disc, evaluated, verdict, 0.6095))
    result = {
        "validate_passed": vsum["passed"], "validate_passed_count": sum(c.passed for c in checks),
        "checks": len(checks),
        "thesis": thesis_summary, "measured_data": measured,
        "discrepancy": {k: disc[k] for k in ("named_effect", "effects", "gap_before", "gap_after", "beam_file")},
        "dataset": data, "train": {k: trained.get(k) for k in ("route", "train_pairs", "test_pairs", "train_seconds")},
        "evaluate": evaluated["rows"], "test_pairs": evaluated.get("pairs"), "classify": verdict, "report": paths,
        "seconds": elapsed, "machine": f"{os.cpu_count()} cores",
        "step_seconds": {k: v.get("seconds", float("nan")) for k, v in
                         (("identify", measured), ("discrepancy", disc), ("dataset", data), ("train", trained),
                          ("evaluate", evaluated))},
    }
    if args.docs:
        for (page, name), text in doc_blocks(result).items():
            write_table(page, name, text)
    if not args.json:
        gb, ga = disc["gap_before"], disc["gap_after"]
        print(f"\nvalidate: {sum(c.passed for c in checks)} of {len(checks)} thesis checks pass")
        print(f"discrepancy: named {', '.join(disc['effects']) or 'none'}; max frequency error "
              f"{gb['max_abs_frequency_error_pct']:.2f} % -> {ga['max_abs_frequency_error_pct']:.2f} %; "
              f"calibrated beam {beam_file}")
        print(f"dataset: {data['train']['samples']} training + {data['test']['samples']} test specimens")
        for r in evaluated["rows"][:4]:
            print(f"  {r['method']:<36s} AUC {r.get('roc_auc', float('nan')):.3f}  element accuracy "
                  f"{r.get('element_accuracy', float('nan')):.3f}")
        print(_verdict_text(verdict, 0.6095))
        print(f"\nReport: {paths['html']} (and {paths['markdown']}); {elapsed:.0f} s")
    atomic_write_text(out / "demo.json", json.dumps(to_jsonable(result), indent=1) + "\n")   # what --json prints
    result["exit_code"] = 0 if vsum["passed"] else 1
    return result


def _report_sections(checks, thesis_sections, measured, disc, data, trained, evaluated, verdict, out):
    """The detail sections after the summary, in the order of the steps."""
    rows = [{"check": c.name, "group": c.group, "relative error": c.rel_error, "tolerance": c.tolerance,
             "share of tolerance": c.rel_error / c.tolerance if c.tolerance else None, "passed": c.passed}
            for c in checks]
    closest = sorted(rows, key=lambda r: -(r["share of tolerance"] or 0.0))[:5]
    s_validate = Section("Thesis reproduction (`beam-damage validate`)",
                         (f"{sum(c.passed for c in checks)} of {len(checks)} checks pass.",),
                         (Table.from_records("The five checks closest to their tolerance", closest),
                          Table.from_records("Every check against the thesis's printed numbers", rows,
                                             collapsed=True)))
    s_ident = Section("Measured-data path: simulated beam-5 test -> UFF58 -> LSCF/LSFD -> Pilkey",
                      ("Beam 5's IIRS model with the thesis's identified damping, 1 % complex noise, 0.5 Hz lines, "
                       "written as binary UFF58 and identified.",),
                      (Table("Frequencies (Hz) and damping ratios", ("quantity", "mode 1", "mode 2", "mode 3",
                                                                      "mode 4"),
                             (("exact f (Hz)", *measured["exact_frequencies_hz"]),
                              ("identified f (Hz)", *measured["identified_frequencies_hz"]),
                              ("updated model f (Hz)", *measured["updated_model_frequencies_hz"]),
                              ("exact zeta", *measured["exact_damping_ratios"]),
                              ("identified zeta", *measured["identified_damping_ratios"]))),),
                      tuple(figure(p) for p in measured["figures"] if Path(p).exists()))
    s_disc = study_discrepancy.beam5_section(disc, out / "discrepancy",
                                             "Discrepancy workflow: what the Euler-Bernoulli model of beam 5 lacks")
    s_disc = Section(s_disc.title, s_disc.paragraphs + (f"Calibrated beam file: `{disc['beam_file']}`; it is the "
                                                        "truth model of the dataset below.",),
                     s_disc.tables, s_disc.figures)
    metric_cols = {"method": "method", **{k: h for k, h, _ in SUMMARY_METRICS}, "ece": "ECE"}
    s_learn = Section(
        "Damage classifier on the calibrated beam",
        (f"Training data: {data['train']['samples']} specimens from `generate --config training` with the "
         f"calibrated beam as truth (slits 5-90 % local EI loss, 1-10 mm wide, anywhere; 25 % intact; noise "
         f"0.1-3 %; temperature and re-clamping between the two test days). Test: {data['test']['samples']} other "
         f"specimens (seed 1). Input route of the network: {trained.get('route')}; training "
         f"{sum((trained.get('train_seconds') or {}).values()):.0f} s.",),
        (Table.from_records("Network against the classical methods on the same test pairs",
                            [_rounded(r) for r in evaluated["rows"]], metric_cols),),
        tuple(figure(f) for f in evaluated["figures"] if Path(f).exists()))
    s_class = Section("Beam 5 classified (Tables 4.5/4.6, damaged against undamaged)",
                      tuple(_verdict_text(verdict, 0.6095).splitlines()),
                      (Table.from_records("The network's and every classical method's answers", _answers(verdict)),))
    return [s_validate, *thesis_sections, s_ident, s_disc, s_learn, s_class]


def add_parser(sub):
    p = sub.add_parser("demo",
                       description="The mission end to end on embedded defaults: reproduce the thesis, name what "
                                   "beam 5's model lacks and calibrate it, generate data from the calibrated beam, "
                                   "train and evaluate the classifier against the classical methods, classify the "
                                   "thesis's beam 5, and write report.html and report.md.")
    p.add_argument("--out", default="out/demo", help="report directory (default out/demo)")
    p.add_argument("--quick", action="store_true", help="small dataset and short training (about a minute)")
    p.add_argument("--force", action="store_true", help="recompute every step instead of reusing earlier results")
    p.add_argument("--samples", type=int, default=None,
                   help=f"training specimens (default {SIZES['full'][0]}, {SIZES['quick'][0]} with --quick)")
    p.add_argument("--workers", type=int, default=2, help="processes for the datasets (default 2)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.add_argument("--docs", action="store_true",
                   help="write the run's numbers and timings into README.md and docs/demo.md (their demo-* blocks)")
    p.set_defaults(func=run, flags={"samples": "--samples", "workers": "--workers"})
