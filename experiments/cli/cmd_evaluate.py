"""``beam-damage evaluate``: the classifier and the classical methods on a dataset."""

from __future__ import annotations

from learn.network.model_dir import load_model

__all__ = ["add_parser", "run"]


def add_parser(sub):
    p = sub.add_parser("evaluate",
                       description="Detection ROC AUC and accuracy, false alarms on intact pairs, element accuracy "
                                   "(thesis 4-element grid), within-one-element, location error (mm), size error, "
                                   "expected calibration error; broken down by noise level, size and position (tip "
                                   "zone separately) for the network and each classical method. With --out: "
                                   "metrics.csv/json and roc.png, confusion.png, location_error.png, reliability.png.")
    p.add_argument("--model", required=True, metavar="MODEL_DIR")
    p.add_argument("--data", required=True, nargs="+", metavar="DIR", help="dataset directories of the model's beam")
    p.add_argument("--out", metavar="DIR", help="write the table and figures here")
    p.add_argument("--json", action="store_true", help="print all rows as JSON")
    p.set_defaults(func=run)


def run(args) -> dict:
    from learn.network.training import evaluate  # torch: the network

    res = evaluate(load_model(args.model), args.data, args.out, progress=True)
    if not args.json:
        cols = {"roc_auc": "ROC AUC", "accuracy": "accuracy", "false_alarm_rate": "false alarms",
                "detection_rate": "detection", "element_accuracy": "zone acc.", "within_one_element": "within 1 zone",
                "median_location_error_mm": "loc. err. (mm)", "median_size_error": "size err.", "ece": "ECE"}
        print(f"{'method':<24}" + "".join(f"{c:>15}" for c in cols.values()))
        for r in res["rows"]:
            if r["subset"] == "all":
                print(f"{r['method']:<24}" + "".join(f"{r[c]:>15.4f}" if r[c] is not None and r[c] == r[c]
                                                     else f"{'-':>15}" for c in cols))      # None or NaN: a dash
        if args.out:
            print(f"table and figures in {args.out}")
    return res
