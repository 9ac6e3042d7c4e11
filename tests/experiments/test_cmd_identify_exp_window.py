"""``identify --exp-window-tau / --exp-window-end``: an exponential window's decay removed from impact FRFs' modes;
the window ``estimate`` applied carried to ``identify`` through ``.npz``; dataset 1858 windows reported."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run_cli
from systems import write_time_uff

from physics.io import read_modal_json, write_uff58
from physics.modal import eigenvalues_from_modal, modal_parameters

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "physics"))
from test_exponential_window import FN_HZ, ZETA, windowed_2dof_frf  # noqa: E402
from test_time_records import _impact_test  # noqa: E402

#: A dataset 1858 record (qualifiers of the next dataset 58 record): window type 6 (impact and exponential),
#: exponential window damping factor 0.0527 (the field pyuff's sample 1858.uff sets).
QUALIFIERS_1858 = ("    -1\n  1858\n           1           0           1           0           0           0\n"
                   "     0     6     0     0     0     0     0     0     0     0     0     0\n"
                   + "  0.0000000E+00" * 5 + "\n" + "  0.0000000E+00" * 4 + "  5.2706007E-02\n"
                   + "  0.0000000E+00" * 5 + "\nZ+    Z+\nNONE\n    -1\n")


@pytest.fixture(scope="module")
def windowed(tmp_path_factory):
    d = tmp_path_factory.mktemp("w")
    frf, tau = windowed_2dof_frf()
    write_uff58(d / "w.uff", frf)
    (d / "w1858.uff").write_text(QUALIFIERS_1858 + (d / "w.uff").read_text())
    return d, tau


@pytest.mark.parametrize("option", [["--exp-window-end", "0.01"], ["--exp-window-tau", "TAU"]])
def test_identify_removes_the_window_decay(capsys, windowed, option):
    d, tau = windowed
    option = [o.replace("TAU", repr(float(tau))) for o in option]
    code, out, err = run_cli(capsys, ["identify", str(d / "w.uff"), "--json", *option])
    assert code == 0, err
    res = json.loads(out)
    win = res["exponential_window"]
    assert win["tau_s"] == pytest.approx(8 / np.log(100), rel=1e-12)
    assert win["added_decay_rate_1_s"] == pytest.approx(np.log(100) / 8, rel=1e-12)
    assert win["source"].startswith(option[0]) and win["at_zero"] == []
    np.testing.assert_allclose([m["damping_ratio"] for m in res["modes"]], ZETA, rtol=1e-6)
    np.testing.assert_allclose([m["frequency_hz"] for m in res["modes"]], FN_HZ, rtol=1e-9)
    # what the fit of the windowed FRFs gave: the poles lambda - 1/tau
    f_w, z_w = modal_parameters(eigenvalues_from_modal(FN_HZ, ZETA) - 1 / tau)
    np.testing.assert_allclose([m["damping_ratio"] for m in win["identified"]], z_w, rtol=1e-6)
    np.testing.assert_allclose([m["frequency_hz"] for m in win["identified"]], f_w, rtol=1e-9)


@pytest.mark.slow
def test_identify_out_writes_the_corrected_modes_for_update(capsys, windowed, tmp_path):
    d, _ = windowed
    code, out, err = run_cli(capsys, ["identify", str(d / "w.uff"), "--out", str(tmp_path), "--exp-window-end", "0.01"])
    assert code == 0, err
    modal = read_modal_json(tmp_path / "modal.json")
    np.testing.assert_allclose(modal.damping_ratios, ZETA, rtol=1e-6)
    np.testing.assert_allclose(modal.natural_frequencies_hz, FN_HZ, rtol=1e-9)


def test_identify_text_says_what_window_it_removed(capsys, windowed):
    d, _ = windowed
    code, out, err = run_cli(capsys, ["identify", str(d / "w.uff"), "--exp-window-end", "0.01"])
    assert code == 0, err
    assert ("exponential window removed: tau 1.737 s (--exp-window-end 0.01 over the record length 1/df = 8 s): "
            "0.5756 1/s off every mode's decay rate") in out


@pytest.mark.parametrize("argv, message", [
    (["--exp-window-tau", "-1"], "--exp-window-tau -1: the window's time constant must be finite and > 0 (s)"),
    (["--exp-window-tau", "inf"], "--exp-window-tau inf: the window's time constant must be finite and > 0 (s)"),
    (["--exp-window-end", "1.5"], "--exp-window-end 1.5: the window's value at the record end must be in (0, 1)"),
    (["--exp-window-end", "0.01", "--exp-window-tau", "1"], "--exp-window-tau and --exp-window-end name the same "
                                                            "window: give one"),
    (["--exp-window-tau", "0.5"], "exponential window tau_s 0.5 s adds 2 1/s to every decay rate, but mode 1 "
                                  "(20 Hz, the farthest of 2 such modes) decays at 0.827 1/s"),
])
def test_identify_bad_window_exit_2_one_line(capsys, windowed, argv, message):
    d, _ = windowed
    code, out, err = run_cli(capsys, ["identify", str(d / "w.uff"), *argv])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and message in err, err


def test_identify_reports_a_1858_exponential_window_without_removing_it(capsys, windowed):
    d, _ = windowed
    code, out, err = run_cli(capsys, ["identify", str(d / "w1858.uff"), "--json"])
    assert code == 0, err
    res = json.loads(out)
    win = res["exponential_window"]
    assert win["tau_s"] is None and win["file_windows"] == [
        {"window_type": 6, "window": "impact and exponential", "exponential_window_damping_factor": 0.052706007,
         "records": 1}]
    assert any("dataset 1858 records name an exponential window" in w for w in res["warnings"])
    assert not any("skipped" in w for w in res["warnings"])
    assert res["modes"][0]["damping_ratio"] == pytest.approx(0.00658, rel=1e-3)      # the window's, as fitted
    code, out, err = run_cli(capsys, ["identify", str(d / "w1858.uff"), "--json", "--exp-window-end", "0.01"])
    assert code == 0, err
    res = json.loads(out)
    assert res["exponential_window"]["file_windows"][0]["window_type"] == 6
    np.testing.assert_allclose([m["damping_ratio"] for m in res["modes"]], ZETA, rtol=1e-6)


def test_estimate_impact_npz_carries_tau_and_identify_removes_it(capsys, tmp_path):
    rec, (m, c, k), _ = _impact_test()
    path = tmp_path / "impact.uff"
    write_time_uff(path, np.arange(rec.signals[0].size) * rec.time_step_s,
                   [("1", rec.signals[0], 13, "N"), ("2", rec.signals[1], 8, "m")])
    code, out, err = run_cli(capsys, ["estimate", str(path), "--excitation", "impact", "--averages", "6",
                                      "--decay", "0.01", "--out", str(tmp_path / "frf.npz"), "--json"])
    assert code == 0, err
    tau = json.loads(out)["exp_window_tau_s"]
    assert tau == pytest.approx((2048 - 1) / 2048 / np.log(100), rel=1e-5)      # 1 s blocks, to 1 % at the last
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "frf.npz"), "--band", "20", "200", "--json"])
    assert code == 0, err
    res = json.loads(out)
    win = res["exponential_window"]
    assert win["tau_s"] == pytest.approx(tau, rel=1e-12) and "stored by 'beam-damage estimate'" in win["source"]
    zeta_true = c / (2 * np.sqrt(k * m))                                         # 0.01 at 50 Hz
    assert win["identified"][0]["damping_ratio"] == pytest.approx(zeta_true + 1 / (tau * 2 * np.pi * 50), rel=0.01)
    assert res["modes"][0]["damping_ratio"] == pytest.approx(zeta_true, rel=0.01)
    assert res["modes"][0]["frequency_hz"] == pytest.approx(50.0, rel=1e-4)
    code, out, err = run_cli(capsys, ["estimate", str(path), "--excitation", "impact", "--averages", "6",
                                      "--decay", "0.01", "--out", str(tmp_path / "frf.uff")])
    assert code == 0, err
    assert f"'beam-damage identify --exp-window-tau {tau:.6g}' removes its decay" in out
    code, out, err = run_cli(capsys, ["identify", str(path), "--band", "20", "200", "--exp-window-tau", "0.2"])
    # the time records are estimated as the impact test they are, with their own window (to 19 % over 1-s blocks,
    # tau 0.61 s): a shorter tau would take more decay off the modes than the window added, refused in one line
    assert code == 2 and err.count("\n") == 1 and "the window's tau is shorter than the one applied" in err, err


def test_identify_refuses_a_window_on_output_only_records(capsys, tmp_path):
    rec, _, _ = _impact_test()
    path = tmp_path / "resp.uff"
    write_time_uff(path, np.arange(rec.signals[0].size) * rec.time_step_s, [("2", rec.signals[1], 8, "m")])
    code, out, err = run_cli(capsys, ["identify", str(path), "--exp-window-tau", "1"])
    assert code == 2 and err.count("\n") == 1 and "response records identified output-only" in err, err


def test_identify_unreadable_1858_record_exit_2_one_line(capsys, windowed, tmp_path):
    d, _ = windowed
    path = tmp_path / "bad.uff"
    path.write_text(QUALIFIERS_1858.replace("     0     6     0", "     0    xx     0") + (d / "w.uff").read_text())
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert code == 2 and err.count("\n") == 1
    assert f"{path}: cannot read the dataset 1858 (dataset 58 qualifiers) records" in err, err
