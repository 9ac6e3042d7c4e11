"""Benchmark of the damage classifier against the classical methods, robustness, and the thesis's beam 5.

    python -m experiments.bench_learn [--data-dir out/learn/data] [--out out/learn/bench] [--epochs 40]

1. Datasets (generated with ``beam-damage generate`` configs below when missing): three noise tiers,
   each 8000 training pairs (4000 with ``n_slits = [0, 1]`` and 4000 with one slit: 25 % intact) and
   2000 test pairs of other seeds (6000 test specimens), plus robustness sets.
2. Trains the default model (``learn.workflow.train``; its time is the training time), a network on
   each other input route on the same pairs, and gradient boosting on the default route's features.
3. Scores network(s) and every baseline on the held-out test datasets with the training-range
   temperature/re-clamping changes, prints the table with the issue's targets and the breakdowns.
4. Robustness: noise above the training range, specimen variability and temperature/re-clamping
   beyond it, several slits.
5. Beam 5: classify the thesis's measured modal data and FRFs synthesised from its identified
   models; distance from the training distribution.
Writes CSV/JSON tables and figures to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

TIERS = {  # frequency, shape, FRF, damping noise
    "low": (0.0002, 0.001, 0.001, 0.01),
    "mid": (0.0005, 0.002, 0.01, 0.02),
    "high": (0.001, 0.005, 0.03, 0.05),
    "above": (0.002, 0.01, 0.06, 0.1),
}
DAMAGE = {"position_fraction": [0.0, 1.0], "width_m": [0.001, 0.01], "depth_m": [0.00004, 0.00046]}


def dataset_configs(n_train: int, n_test: int) -> dict:
    """name -> (config overrides, n, seed)."""
    out, seed = {}, 100
    for t in ("mid", "low", "high"):
        f, s, h, z = TIERS[t]
        meas = {"frequency_noise": f, "shape_noise": s, "frf_noise": h, "damping_noise": z}
        for ab, slits in (("a", [0, 1]), ("b", [1, 1])):
            seed += 1
            out[f"train-{t}-{ab}"] = ({"damage": {**DAMAGE, "n_slits": slits}, "measurement": meas}, n_train, seed)
            seed += 1
            out[f"test-{t}-{ab}"] = ({"damage": {**DAMAGE, "n_slits": slits}, "measurement": meas}, n_test, seed + 1000)
    f, s, h, z = TIERS["above"]
    out["rob-noise"] = ({"damage": {**DAMAGE, "n_slits": [0, 1]},
                         "measurement": {"frequency_noise": f, "shape_noise": s, "frf_noise": h, "damping_noise": z}},
                        2 * n_test, 501)
    f, s, h, z = TIERS["mid"]
    mid = {"frequency_noise": f, "shape_noise": s, "frf_noise": h, "damping_noise": z}
    out["rob-variability"] = ({"damage": {**DAMAGE, "n_slits": [0, 1]}, "measurement": mid,
                               "specimen": {"ei_band": 0.15, "mass_band": 0.08, "damping_band": 0.4,
                                            "root_spring_relative": [100.0, 10000.0]}}, 2 * n_test, 502)
    out["rob-multi"] = ({"damage": {**DAMAGE, "n_slits": [2, 3]}, "measurement": mid}, n_test, 503)
    return out


def ensure_datasets(data_dir: Path, n_train: int, n_test: int) -> None:
    from datagen.config import merge
    from datagen.parallel import generate

    for name, (over, n, seed) in dataset_configs(n_train, n_test).items():
        if not (data_dir / name / "samples.parquet").exists():
            print(f"generating {name} ({n} pairs)", flush=True)
            generate(data_dir / name, merge(over), n=n, seed=seed, progress=True)


def fmt(v, nd=4):
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{v:.{nd}f}"


COLS = ("roc_auc", "accuracy", "false_alarm_rate", "element_accuracy", "within_one_element",
        "median_location_error_mm", "median_size_error", "ece")
TARGETS = {"roc_auc": (">=", 0.99), "element_accuracy": (">=", 0.95), "median_location_error_mm": ("<=", 0.02 * 609.5),
           "median_size_error": ("<=", 0.15), "ece": ("<=", 0.03), "false_alarm_rate": ("<=", 0.02)}


def print_table(rows, title, subset="all"):
    print(f"\n{title}")
    print(f"{'method':<26}{'n':>7}" + "".join(f"{c[:13]:>14}" for c in COLS))
    for r in rows:
        if r["subset"] == subset:
            print(f"{r['method']:<26}{r['n_pairs']:>7}" + "".join(f"{fmt(r[c]):>14}" for c in COLS))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data-dir", default="out/learn/data")
    ap.add_argument("--out", default="out/learn/bench")
    ap.add_argument("--epochs", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-train", type=int, default=4000, help="pairs per training dataset (6 datasets)")
    ap.add_argument("--n-test", type=int, default=1000, help="pairs per test dataset (6 datasets)")
    ap.add_argument("--threads", type=int, default=1, help="torch CPU threads (1 is fastest on a shared machine)")
    ap.add_argument("--skip-routes", action="store_true", help="do not train the networks of the other routes")
    args = ap.parse_args(argv)

    import torch

    from learn.baselines import BoostedBaseline, run_classical
    from learn.evaluate import figures, metrics, table_rows
    from learn.features import StateChanges, apply_state_changes, features, load_pairs
    from learn.estimator import DamageClassifier
    from learn.workflow import (DEFAULT_ROUTE, TRAINING_CHANGES, frf_arrays, load_model, network_output,
                                sensitivity_of, targets, train)

    torch.set_num_threads(args.threads)
    data_dir, out = Path(args.data_dir), Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ensure_datasets(data_dir, args.n_train, args.n_test)
    names = dataset_configs(args.n_train, args.n_test)
    train_dirs = [data_dir / n for n in names if n.startswith("train-")]
    test_dirs = [data_dir / n for n in names if n.startswith("test-")]

    # ---------------------------------------------------------------- default model
    t0 = time.perf_counter()
    summary = train(train_dirs, out / "model", epochs=args.epochs, seed=args.seed, progress=True)
    wall = time.perf_counter() - t0
    model = load_model(out / "model")
    route = model.route
    print(f"\ndefault model: route {route}, {summary['train_pairs']} training pairs (incl. validation); network fit "
          f"{summary['train_seconds'][route]:.0f} s (+ modal companion {summary['train_seconds'].get('modal', 0):.0f} s),"
          f" data loading {summary['load_seconds']:.0f} s, whole 'train' {wall:.0f} s wall, torch threads "
          f"{torch.get_num_threads()}")

    all_routes = ["modal", "updated", "measured"]
    need = all_routes if not args.skip_routes else list(model.networks)
    tr_pairs = apply_state_changes(load_pairs(train_dirs, frfs=frf_arrays(need)), TRAINING_CHANGES, seed=args.seed)
    te_pairs = apply_state_changes(load_pairs(test_dirs, frfs=frf_arrays(need)), TRAINING_CHANGES, seed=args.seed + 1)
    y_tr, truth_tr = targets(tr_pairs)
    _, truth = targets(te_pairs)
    sens = sensitivity_of(model.beam, model.config["root_spring_relative"])
    networks = dict(model.networks)
    for r in need:
        if r not in networks:
            t = time.perf_counter()
            networks[r] = DamageClassifier(epochs=args.epochs, random_state=args.seed).fit(
                features(tr_pairs, r), y_tr, tr_pairs.groups)
            print(f"network on route {r}: {time.perf_counter() - t:.0f} s", flush=True)
    net_outs = {r: network_output(networks[r], features(te_pairs, r), sens, f"network ({r})")[0] for r in need}

    t = time.perf_counter()
    boost = BoostedBaseline(random_state=args.seed).fit(features(tr_pairs, route), y_tr)
    boost_out = boost.predict(features(te_pairs, route))
    print(f"gradient boosting on the {route} features: {time.perf_counter() - t:.0f} s", flush=True)
    thresholds = model.config["baseline_thresholds"]
    classical, _ = run_classical(te_pairs.eigenvalues, te_pairs.eigenvectors, sens, thresholds)
    outputs = [net_outs[route]] + [net_outs[r] for r in need if r != route] + classical + [boost_out]
    rows = table_rows(outputs, truth, te_pairs.table, te_pairs.beam.length_m)
    pd.DataFrame(rows).to_csv(out / "benchmark.csv", index=False)
    figures(outputs, truth, out / "figures", te_pairs.beam.length_m)

    print(f"\n== Held-out test: {len(te_pairs)} specimens ({int(truth['damaged'].sum())} damaged, "
          f"{int((~truth['damaged']).sum())} intact), training-range noise and state changes ==")
    print("AUC: detectable slits (largest frequency drop > 0.2 %) vs intact; element/location/size over detectable slits")
    print_table(rows, "all test pairs")
    r0 = next(r for r in rows if r["method"] == outputs[0].name and r["subset"] == "all")
    print("\ntargets (network, default route):")
    for k, (op, v) in TARGETS.items():
        ok = r0[k] is not None and np.isfinite(r0[k]) and (r0[k] >= v if op == ">=" else r0[k] <= v)
        print(f"  {k:<28} {fmt(r0[k]):>10}  target {op} {v:g}  {'met' if ok else 'NOT met'}")
    hon = net_outs[route]
    small = truth["damaged"] & (truth["max_drop"] <= 0.002)
    big = truth["damaged"] & (truth["max_drop"] > 0.002)
    print(f"  'not detectable here': flagged on {np.mean(~hon.detectable[small]):.1%} of slits whose largest drop "
          f"is <= 0.2 %, on {np.mean(~hon.detectable[big]):.1%} of the detectable ones")
    for sub in ("noise f=0.0002", "noise f=0.0005", "noise f=0.001", "size small", "size medium", "size large",
                "element 1", "element 2", "element 3", "element 4 (x/L<0.85)", "tip zone x/L>=0.85"):
        print_table(rows, f"breakdown: {sub}", sub)

    # ---------------------------------------------------------------- robustness
    print("\n== Robustness (network on the default route vs baselines; training ranges in brackets) ==")
    rob = []
    sets = {
        "in range (test)": (test_dirs, TRAINING_CHANGES),
        "noise x2 above (f 0.2 %, FRF 6 %)": ([data_dir / "rob-noise"], TRAINING_CHANGES),
        "variability x3 (EI 15 %, spring 100-1e4)": ([data_dir / "rob-variability"], TRAINING_CHANGES),
        "temperature +-1 %, re-clamp +-20 %": (test_dirs, StateChanges(0.01, 0.2)),
        "several slits (2-3)": ([data_dir / "rob-multi"], TRAINING_CHANGES),
    }
    for name, (dirs, ch) in sets.items():
        P = apply_state_changes(load_pairs(dirs, frfs=frf_arrays([route])), ch, seed=args.seed + 2)
        _, tr = targets(P)
        outs = [network_output(networks[route], features(P, route), sens, f"network ({route})")[0]]
        outs += run_classical(P.eigenvalues, P.eigenvectors, sens, thresholds)[0]
        outs.append(boost.predict(features(P, route)))
        for o in outs:
            m = metrics(o, tr, None, name, P.beam.length_m).row()
            if name.startswith("several"):
                m["detection_rate_all_damaged"] = float(np.mean(o.damaged[tr["damaged"]]))
            rob.append(m)
    pd.DataFrame(rob).to_csv(out / "robustness.csv", index=False)
    cols = ("roc_auc", "accuracy", "false_alarm_rate", "detection_rate", "element_accuracy",
            "median_location_error_mm", "median_size_error", "ece")
    print(f"{'set':<42}{'method':<24}" + "".join(f"{c[:13]:>14}" for c in cols))
    for r in rob:
        print(f"{r['subset']:<42}{r['method']:<24}" + "".join(f"{fmt(r[c]):>14}" for c in cols))
    print("Timoshenko truth: not run (no shear-deformable truth model on this branch yet).")

    # ---------------------------------------------------------------- beam 5
    res5 = beam5(model, out / "beam5")
    (out / "beam5.json").write_text(json.dumps(res5, indent=1, default=float))
    print("\n== Beam 5 (thesis Tables 4.5/4.6) ==")
    for k, v in res5.items():
        print(f"{k}: {json.dumps(v, default=float)}")
    (out / "summary.json").write_text(json.dumps({"train": summary, "train_wall_s": wall, "rows_all": [
        r for r in rows if r["subset"] == "all"], "robustness": rob}, indent=1, default=float))


def beam5(model, out_dir) -> dict:
    """Classify the thesis's beam 5 from its measured modal data and from FRFs of its identified models."""
    from importlib.resources import files

    from learn.features import modal_features
    from learn.sensitivity import beam_sensitivity
    from learn.workflow import classify
    from physics.frf import receptance
    from physics.io import MeasuredFRF, modal_data_from_dict

    data = json.loads((files("experiments") / "data/thesis/beams.json").read_text())["beams"]["5"]
    dofs = ["2:y", "3:y", "4:y", "5:y"]
    md = {s: modal_data_from_dict({**data[s], "dofs": dofs}, f"beams.json beam 5 {s}") for s in ("undamaged", "damaged")}
    res = classify(model, md["undamaged"], md["damaged"])
    ex = res.pop("_extra")
    f0, f1 = md["undamaged"].natural_frequencies_hz, md["damaged"].natural_frequencies_hz
    out = {"measured_frequency_shift_percent": list(100 * (f1 / f0 - 1)),
           "modal_data_verdict": {**res, "mahalanobis_distance": ex["mahalanobis_distance"],
                                  "training_percentile": ex["training_percentile"], "best_baseline": ex["baseline"]}}
    # FRFs synthesised from the identified (reduced-mass) models of Chapter Six, on the thesis grid
    w = np.linspace(1.0, 5000.0, 25000)
    frfs = []
    for s in ("undamaged", "damaged"):
        m = data["identified_models"][s]["reduced_mass"]
        M = np.array(data["identified_models"]["undamaged"]["reduced_mass"]["M"])   # printed once, for both states
        H = receptance(M, np.array(m["C"]), np.array(m["K"]), w, [0, 1, 2, 3], [0])
        frfs.append(MeasuredFRF(w / (2 * np.pi), H, ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",)))
    r2 = classify(model, frfs[0], frfs[1])
    ex2 = r2.pop("_extra")
    out["identified_model_frf_verdict"] = {**r2, "mahalanobis_distance": ex2["mahalanobis_distance"],
                                           "training_percentile": ex2["training_percentile"]}
    # what the FE model predicts for the thesis's statement under both readings of "length"
    sens = beam_sensitivity(model.beam.name, model.config["root_spring_relative"])
    pattern = {}
    for label, x in (("quarter of the 0.6095 m cantilever (x = 0.152 m)", 0.25),
                     ("quarter of the 1.219 m specimen from the clamp (x = 0.305 m)", 0.5)):
        col = sens.frequency[:, sens.element_of(x)]
        pattern[label] = list(100 * col / abs(col[0]) * abs(out["measured_frequency_shift_percent"][0]) / 100)
    out["fe_shift_pattern_percent_scaled_to_mode1"] = pattern
    X = modal_features(np.stack([md["undamaged"].eigenvalues, md["damaged"].eigenvalues])[None],
                       np.stack([md["undamaged"].eigenvectors, md["damaged"].eigenvectors])[None])
    est = model.networks["modal"]
    Z = (X - est.mean_) / est.scale_
    out["largest_standardised_features"] = {int(i): float(Z[0, i]) for i in np.argsort(-np.abs(Z[0]))[:5]}
    return out


if __name__ == "__main__":
    main()
