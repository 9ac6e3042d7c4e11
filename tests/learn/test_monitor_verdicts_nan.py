"""``event_verdicts`` on an event whose alarms all lack a mode: the representative alarm without a numpy warning."""

import warnings
from types import SimpleNamespace

import numpy as np

from learn.monitor.verdicts import event_verdicts


def test_an_event_whose_alarms_all_lack_a_mode_picks_its_representative_without_a_warning():
    z = [[np.nan, 4.0], [np.nan, 5.0], [np.nan, 9.0]]
    rows = [{"status": "alarm", "file": f"t{k}", "mode_z_scores": zk, "damping_ratios": [0.01, 0.01]}
            for k, zk in enumerate(z)]
    f = np.array([[np.nan, 200.0], [np.nan, 201.0], [np.nan, 205.0]])
    result = SimpleNamespace(rows=rows, frequencies_hz=f, expected_hz=np.full_like(f, 200.0),
                             reference=SimpleNamespace(frequencies_hz=np.array([100.0, 200.0])))
    event = SimpleNamespace(members=[0, 1, 2], before=())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (verdict,) = event_verdicts(result, [event], None)
    assert verdict["representative"] == "t1"          # z = 5 lies nearest the alarms' mean z of mode 2 (6)
