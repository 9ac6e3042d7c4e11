"""bench_foreign's scoring of verdicts against the independent simulator's truth."""

import numpy as np

from experiments.benches.bench_foreign import markdown, score


def _verdict(damaged, element=0, theta=0.0, std=0.0, detectable=True):
    net = {"damaged": damaged, "location_element": element, "size": theta,
           "size_std": std, "detectable": detectable}
    dlac = {"method": "DLAC", "damaged": damaged and detectable, "location_element": element,
            "size": theta}
    return {**net, "network": net, "classical_methods": [dlac], "in_distribution": True, "training_percentile": 50.0}


def test_score_counts_accuracy_size_cover_and_faint_false_alarms():
    truth = [{"damaged": True, "element": 2, "hinge_flexibility": 0.010},
             {"damaged": True, "element": 3, "hinge_flexibility": 0.020},
             {"damaged": False, "element": "", "hinge_flexibility": 0.0},
             {"damaged": False, "element": "", "hinge_flexibility": 0.0},
             {"damaged": False, "element": "", "hinge_flexibility": 0.0}]
    verdicts = [_verdict(True, 2, 0.011, 0.002), _verdict(True, 4, 0.016, 0.002),
                _verdict(True, 1, 0.001, 0.001, detectable=False), _verdict(True, 3, 0.01, 0.002),
                _verdict(False)]
    rows = {r["method"]: r for r in score(verdicts, truth)}
    net = rows["network"]
    assert net["element_accuracy"] == 0.5 and net["detection"] == 1.0
    assert net["false_alarms"] == 2 and net["false_alarms_not_detectable"] == 1 and net["intact_pairs"] == 3
    np.testing.assert_allclose(net["median_size_error"], np.median([0.1, 0.2]))
    assert net["size_one_sigma_cover"] == 0.5                   # 0.011 +- 0.002 holds 0.010; 0.016 +- 0.002 not 0.020
    assert rows["DLAC"]["false_alarms"] == 1 and rows["DLAC"]["false_alarms_not_detectable"] == 0
    table = markdown([{**r, "set": "eb", "model": "m"} for r in rows.values()])
    assert "| 2 of 3 (1 not detectable) |" in table and "| 1 of 3 |" in table
