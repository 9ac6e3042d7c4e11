"""The detection bench's per-seed false-alarm table (:func:`experiments.benches.bench_detection.false_alarm_table`)."""

from experiments.benches.bench_detection import false_alarm_table


def test_the_false_alarm_table_gives_the_share_within_the_baselines_environment():
    rows = [{"case": "daily", "model": "pca", "seed": s, "damage": "none", "extrapolated": e,
             "false_alarms": {m: v for m in ("combined", "combined, equal shares", "combined, Šidák", "chart",
                                              "chart, Šidák", "plain shift", "plain shift, both signs",
                                              "plain per mode")} | {"combined, not extrapolated": w}}
            for s, v, w, e in ((0, 0.0219, 0.0058, 0.0548), (1, 0.0137, 0.01, 0.02))]
    line = false_alarm_table(rows).splitlines()[-1]
    assert "| 0 1 | 2.19 / 1.37 (mean 1.78) | 0.58 / 1.00 (mean 0.79) |" in line
    assert line.endswith("| 5.48 / 2.00 (mean 3.74) |")
