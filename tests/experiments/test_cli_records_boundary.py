"""The command line at the boundary on response-record files and monitoring series as users give them: each refusal
one line naming the file and what was expected (exit code 2, nothing on stdout), the pick of the output-only method
named when it fails, channels sharing a DOF warned of, and the monitor's chart, threshold and help saying what they
show."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run_cli

from experiments.cli import build_parser
from experiments.cli.cmd_monitor import chart_axis, threshold_label, threshold_text
from monitor_series import write_modal_series
from physics.identification import identify_frf
from physics.identification.poles import NO_STABLE_POLE
from physics.io import MeasuredFRF, write_frf_npz

DATA = Path(__file__).resolve().parents[1] / "data"
FS_HZ = 1000.0


def _npz(path, y, **extra):
    np.savez(path, signals=y, sampling_frequency_hz=np.array(FS_HZ), **extra)
    return path


def test_a_record_of_no_samples_is_refused_as_such_not_as_transposed(capsys, tmp_path):
    path = _npz(tmp_path / "empty.npz", np.zeros((1, 0)))
    code, out, err = run_cli(capsys, ["identify", str(path), "--json"])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: field 'signals' must be a real (n_channels, n_samples) "
                   "array of at least 2 samples, got float64 of shape (1, 0)\n")


@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 cut short", b"not a zip\n"])
def test_an_unreadable_npz_names_both_forms_identify_reads(capsys, tmp_path, content):
    path = tmp_path / "broken.npz"
    path.write_bytes(content)
    code, out, err = run_cli(capsys, ["identify", str(path), "--out", str(tmp_path / "id")])
    assert (code, out) == (2, "")
    assert err.count("\n") == 1 and err.startswith(f"beam-damage identify: error: {path}: " + (
        "file is empty; " if not content else "not a readable .npz ("))
    assert err.endswith("expected an .npz of FRFs (frequency_hz, frf, response_dofs, reference_dofs) or of response "
                        "time series (signals, sampling_frequency_hz)\n")
    assert not (tmp_path / "id").exists()


def test_when_the_picked_method_and_the_other_find_no_mode_the_refusal_names_both(capsys, tmp_path):
    """White noise: SSI-cov (picked: no hit, no decay) finds no stable pole, and ERA is not tried (no decay)."""
    path = _npz(tmp_path / "noise.npz", np.random.default_rng(0).standard_normal((2, 2000)))
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err.count("\n") == 1 and err.startswith(f"beam-damage identify: error: {path}: no pole is stable")
    assert err.endswith("(picked ssi: response records without a force channel, not a free response: no hit, no "
                        "decay (identified as a stationary response); era not tried: the record holds no decay)\n")


def test_channels_sharing_a_dof_label_are_warned_of_on_stderr(capsys, tmp_path):
    """MPSTD_Set001 (a real measurement system's export) labels its channels 1 and 4 both 1:+Z."""
    code, out, err = run_cli(capsys, ["identify", str(DATA / "MPSTD_Set001_2024_10_08_10_27_07.uff")])
    assert code == 0 and "MPSTD_Set001_2024_10_08_10_27_07.uff: 4 modes by ssi" in out and "warning" not in out
    assert ("MPSTD_Set001_2024_10_08_10_27_07.uff: channels share a DOF label: 1:+Z (channels 1, 4); modal.json "
            "keeps each channel's row") in err


def test_time_records_without_frfs_name_both_ways_forward(capsys):
    path = DATA / "MPSTD_Set001_2024_10_08_10_27_07.uff"
    code, out, err = run_cli(capsys, ["discrepancy", "--measured", str(path), "--json"])
    assert (code, out) == (2, "")
    assert err.count("\n") == 1 and err.endswith(
        "1 (time response) x4; time records need a force channel to give FRFs ('beam-damage estimate FILE --out "
        "FRF.uff'); without one, identify the responses output-only ('beam-damage identify FILE --out DIR') and give "
        "DIR/modal.json\n")


def test_a_folder_given_as_a_test_is_refused_naming_it(capsys, tmp_path):
    folder = tmp_path / "series"
    folder.mkdir()
    _npz(folder / "t01.npz", np.ones((1, 100)))
    code, out, err = run_cli(capsys, ["monitor", str(folder), "--baseline-tests", "12", "--out",
                                      str(tmp_path / "mon")])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage monitor: error: TEST {folder}: is a directory; give its test files in time order "
                   f"({folder / '*'}) or list them in --conditions CSV\n")
    assert not (tmp_path / "mon").exists()


def test_the_chart_counts_tests_from_one_and_names_the_time_unit():
    t, label = chart_axis([None] * 3, np.arange(3.0))
    assert t.tolist() == [1.0, 2.0, 3.0] and label == "test (1 = the first)"
    t, label = chart_axis(["2026-01-01", "2026-01-03"], np.array([0.0, 2.0]))
    assert t.tolist() == [0.0, 2.0] and label == "time (days since the first test)"
    assert chart_axis(["5", "7.5"], np.array([5.0, 7.5]))[1] == "time (the time column of --conditions, its unit)"


def test_the_threshold_says_its_own_rate_and_the_family_wise_one():
    assert threshold_label(0.0031181215913, 0.01, 4) == "threshold (0.312 % false alarms; 1 % over the 4 statistics)"
    assert threshold_label(0.01, 0.01, 1) == "threshold (1 % false alarms)"
    out = {"threshold": {"value": 581.39293, "false_alarm_rate": 0.0031181215913}, "false_alarm_rate": 0.01,
           "detector": {"statistics": ["residual", "environment", "shift", "mode"]}}
    assert threshold_text(out) == ("threshold 581.4 of the residual statistic at 0.312 % false alarms (1 % over the "
                                   "4 statistics)")


def _help_keys(text: str) -> set:
    return set(text.split("{", 1)[1].rsplit("}", 1)[0].replace('"', "").replace("[...]", "").replace(":", "")
               .replace(" ", "").split(","))


def test_the_monitor_help_lists_every_key_of_its_json_and_the_report_captions_its_chart(capsys, tmp_path):
    csv_path, files, _ = write_modal_series(tmp_path / "series", 14, seed=3)
    out_dir = tmp_path / "mon"
    code, out, err = run_cli(capsys, ["monitor", "--conditions", str(csv_path), "--baseline-tests", "12",
                                      "--out", str(out_dir), "--json"])
    assert code == 0, err
    result = json.loads(out)
    parser = build_parser(["monitor"])
    sub = next(a for a in parser._actions if a.dest == "command").choices["monitor"]
    helped = _help_keys(next(a.help for a in sub._actions if a.dest == "json"))
    assert helped == set(result) - {"outputs"}
    assert result["threshold"]["false_alarm_rate"] < result["false_alarm_rate"]       # a share of the family's
    report = (out_dir / "report.md").read_text()
    assert "novelty index (residual statistic) against its threshold" in report
    assert "of the residual statistic at" in report
    shutil.rmtree(out_dir)


def test_the_stabilisation_diagram_labels_its_curve_in_the_frfs_units(monkeypatch, tmp_path):
    """An accelerance's mode indicator is in m/s^2/N, not the receptance's m/N."""
    import experiments.studies.plots_identify as plots

    f = np.arange(20.0, 200.0, 0.25)
    w, wn = 2 * np.pi * f, 2 * np.pi * np.array([60.0, 140.0])
    receptance = (1 / (wn[None] ** 2 - w[:, None] ** 2 + 2j * 0.01 * wn[None] * w[:, None])).sum(axis=1)
    frf = MeasuredFRF(f, -w ** 2 * receptance, ("2:+Z",), ("2:+Z",), kind="accelerance")
    ident = identify_frf(frf, method="lscf")
    figures = []
    monkeypatch.setattr(plots, "figure_png", lambda fig: figures.append(fig) or b"")
    plots.write_outputs(ident, tmp_path / "id")
    labels = [ax.get_ylabel() for fig in figures for ax in fig.axes]
    assert "sqrt(sum |H|^2) (m/s^2/N)" in labels and not any("(m/N)" in label for label in labels)


def test_an_frf_file_without_a_stable_pole_is_named_by_discrepancy(capsys, tmp_path):
    """Noise alone: LSCF finds no stable pole, and the refusal says in which file."""
    rng = np.random.default_rng(0)
    f = np.arange(1.0, 1200.0, 0.5)
    path = tmp_path / "noise.npz"
    write_frf_npz(path, MeasuredFRF(f, 1e-6 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)),
                                    ("2:+Y",), ("2:+Y",), kind="receptance"))
    code, out, err = run_cli(capsys, ["discrepancy", "--measured", str(path), "--out", str(tmp_path / "d")])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage discrepancy: error: {path}: no pole is stable over enough model orders: raise the "
                   "highest model order or widen the band (beam-damage identify --max-order N --band FMIN FMAX)\n")
    assert not (tmp_path / "d").exists()


def test_the_no_stable_pole_refusal_names_options_identify_accepts():
    """The command the refusal names (:data:`physics.identification.poles.NO_STABLE_POLE`), its placeholders filled,
    parses: ``identify`` sets the highest model order and the band from those options."""
    command = NO_STABLE_POLE.split("(beam-damage ")[1].rstrip(")").split()
    values = {"N": "60", "FMIN": "10", "FMAX": "500"}
    argv = [values.get(w, w) for w in command] + ["test.npz"]
    assert argv[:2] == ["identify", "--max-order"] and "--band" in argv
    args = build_parser(argv).parse_args(argv)
    assert (args.max_order, list(args.band)) == (60, [10.0, 500.0])


@pytest.mark.parametrize("option, value, expected", [
    ("--beam", "nosuch", "--beam nosuch: neither a beam preset (beam5, beam6, beam8) nor an existing beam file"),
    ("--model", "no/such/dir", "--model no/such/dir: not a model directory (no config.json); create one with "
                               "'beam-damage train'"),
])
def test_monitor_names_the_option_of_a_bad_beam_or_model_before_identifying(capsys, tmp_path, option, value,
                                                                            expected):
    tests = [str(_npz(tmp_path / f"t{k:02d}.npz", np.ones((1, 100)))) for k in range(12)]
    code, out, err = run_cli(capsys, ["monitor", *tests, "--baseline-tests", "11", option, value, "--out",
                                      str(tmp_path / "mon")])
    assert (code, out) == (2, "")
    assert err == f"beam-damage monitor: error: {expected}\n"
    assert not (tmp_path / "mon").exists()


def test_one_mode_of_one_channel_is_said_in_the_singular(capsys, tmp_path):
    """A 50-Hz decay (decay rate 1 /s) of one channel, 2 s at 1 kHz: '1 mode ... from 1 channel', not '1 modes'."""
    t = np.arange(2000) / FS_HZ
    path = _npz(tmp_path / "decay.npz", (np.sin(2 * np.pi * 50 * t) * np.exp(-t))[None])
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert code == 0, err
    assert f"{path}: 1 mode by era in 0-400 Hz from 1 channel x 2 s" in out


@pytest.mark.parametrize("name", ["empty.json", "empty.csv", "empty.uff"])
def test_an_empty_file_is_named_empty_whatever_its_extension(capsys, tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"")
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert err.startswith(f"beam-damage identify: error: {path}: file is empty; expected ")
