"""The validate, model, update and demo commands, through ``cli.main`` as a user calls them."""

import json
from pathlib import Path

import numpy as np
import pytest

from experiments import cli
from experiments.studies import validate
from physics import thesis


def _run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_validate_passes_and_prints_the_documented_json(capsys):
    code, out, _ = _run(capsys, "validate", "--json")
    res = json.loads(out)
    assert code == 0 and res["passed"] is True
    assert len(res["checks"]) == 38
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    assert f"(`beam-damage validate`: {len(res['checks'])} checks)" in readme      # the README's count is this run's
    for c in res["checks"]:
        assert {"name", "thesis", "reproduced", "rel_error", "tolerance", "passed"} <= set(c)
        assert c["passed"] and c["rel_error"] <= c["tolerance"]
    names = " ".join(c["name"] for c in res["checks"])
    for must in ("C16", "C20", "Table 4.1", "Table 4.2", "Table 6.1", "Table 6.2", "u3", "Program A/B"):
        assert must in names
    misprint = next(c for c in res["checks"] if c["name"] == "Example 2: damping iterate C10")
    assert "C10[2,4] printed 0.0749" in misprint["note"]
    finding = next(c for c in res["checks"] if "printed eigenvectors" in c["name"])
    assert "modes 3, 4 do not" in finding["name"] and "exponent off by +2" in finding["note"]


def test_validate_fails_when_a_thesis_value_is_perturbed(monkeypatch):
    real = thesis.load

    def perturbed(name):
        data = real(name)
        if name == "example1_two_dof":
            data["C_iterates"]["5"][0][0] += 0.001
        return data

    monkeypatch.setattr(thesis, "load", perturbed)
    checks = validate.run_checks()
    failed = [c.name for c in checks if not c.passed]
    assert failed == ["Example 1: damping iterate C5"]


def test_validate_text_table(capsys):
    code, out, _ = _run(capsys, "validate")
    assert code == 0 and "checks passed" in out and "rel_error" in out


def test_model_json_keys_and_iirs(capsys):
    code, out, _ = _run(capsys, "model", "--beam", "beam5", "--reduction", "iirs", "--json")
    res = json.loads(out)
    assert code == 0
    assert set(res) >= {"M", "K", "dofs", "natural_frequencies_hz", "closed_form_frequencies_hz", "iterations"}
    assert res["dofs"] == ["2:y", "3:y", "4:y", "5:y"] and res["iterations"] > 0
    assert np.array(res["M"]).shape == (4, 4)
    # IIRS keeps the 4 lowest FE frequencies, close to the closed form
    np.testing.assert_allclose(res["natural_frequencies_hz"][:2], res["closed_form_frequencies_hz"][:2], rtol=2e-3)


@pytest.mark.parametrize("bc, first_hz", [("free-free", 126.81), ("pinned-pinned", 55.94),
                                          ("clamped-clamped", 126.81)])
def test_model_of_each_support_against_its_closed_form_without_rigid_body_modes(capsys, bc, first_hz):
    """Beam 5 on 20 elements: the first bending mode first (a free beam's bounce and pitch left out), the four
    lowest within 0.03 % of the uniform beam's closed form on the same supports (the mesh's error)."""
    code, out, _ = _run(capsys, "model", "--beam", "beam5", "--elements", "20", "--bc", bc, "--json")
    res = json.loads(out)
    assert code == 0 and res["natural_frequencies_hz"][0] == pytest.approx(first_hz, rel=1e-4)
    np.testing.assert_allclose(res["natural_frequencies_hz"][:4], res["closed_form_frequencies_hz"][:4], rtol=3e-4)


def test_model_lumped_uses_eq_4_6(capsys):
    code, out, _ = _run(capsys, "model", "--mass", "lumped", "--reduction", "guyan", "--json")
    M = np.array(json.loads(out)["M"])
    assert code == 0 and M[0, 2] == 0 and M[3, 3] == pytest.approx(M[0, 0] / 2)


def test_update_reproduces_chapter_six(tmp_path, capsys):
    b5 = thesis.load("beams")["beams"]["5"]
    f = tmp_path / "modal.json"
    f.write_text(json.dumps(b5["undamaged"]))
    code, out, _ = _run(capsys, "update", "--beam", "beam5", "--modal", str(f), "--json")
    res = json.loads(out)
    assert code == 0 and res["converged"] is True
    assert set(res) >= {"M", "C", "K", "iterations", "natural_frequencies_hz", "damping_ratios"}
    K = np.array(b5["identified_models"]["undamaged"]["reduced_mass"]["K"])
    # our M is the unrounded IIRS mass, so K agrees to the printed M's rounding (<1%)
    assert np.linalg.norm(np.array(res["K"]) - K) / np.linalg.norm(K) < 1e-2


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "file not found"),
        ("{not json", "not valid JSON"),
        ('{"eigenvalues": ["1+2j", "x"]}', "field 'eigenvalues'"),
        ('{"damping_ratios": [0.1]}', "missing key 'eigenvalues'"),
        ('{"eigenvalues": ["-1+20j"], "eigenvectors": [["1"], ["2"]]}', "complete set of 4 modes"),
        ('{"eigenvalues": ["-1+20j", "-1+30j", "-1+40j", "-1+50j"]}', "'eigenvectors' is required"),
    ],
)
def test_update_bad_files_give_one_line_and_exit_2(tmp_path, capsys, content, message):
    f = tmp_path / "m.json"
    if content is not None:
        f.write_text(content)
    code, out, err = _run(capsys, "update", "--modal", str(f))
    assert code == 2 and out == ""
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_library_errors_name_the_parameter_and_the_cli_adds_the_flag(capsys):
    code, out, err = _run(capsys, "model", "--elements", "0")
    assert code == 2 and out == ""
    assert err == "beam-damage model: error: --elements: n_elements must be >= 1, got 0\n"


def test_update_accepts_the_old_mass_spelling(tmp_path, capsys):
    f = tmp_path / "modal.json"
    f.write_text(json.dumps(thesis.beam_state("undamaged")))
    runs = [json.loads(_run(capsys, "update", "--modal", str(f), "--mass", m, "--json")[1])
            for m in ("reduced", "iirs")]
    assert runs[0]["mass"] == runs[1]["mass"] == "iirs"
    np.testing.assert_array_equal(runs[0]["K"], runs[1]["K"])


def test_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["model", "--beam", "beam9"])
    assert e.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_demo_writes_its_report(tmp_path, capsys):
    """A tiny demo run renders the report: every figure referenced exists, every table holds numbers."""
    from experiments.studies.report import check_report

    d = tmp_path / "d"
    code, out, _ = _run(capsys, "demo", "--out", str(d), "--quick", "--samples", "200", "--workers", "1", "--json")
    res = json.loads(out)
    assert code == 0 and res["validate_passed"] and res["checks"] == 38
    assert json.loads((d / "demo.json").read_text()) == res          # the run's demo.json is its --json
    m = res["measured_data"]
    np.testing.assert_allclose(m["identified_frequencies_hz"], m["exact_frequencies_hz"], rtol=1e-3)
    # the discrepancy step names shear deformation on Table 4.3 and closes the 8 % gap (issue 9)
    disc = res["discrepancy"]
    assert disc["named_effect"] == "shear_deformation"
    assert disc["gap_before"]["max_abs_frequency_error_pct"] > 8 > 1 > disc["gap_after"]["max_abs_frequency_error_pct"]
    assert (d / "discrepancy" / "beam.toml").is_file()
    assert res["dataset"]["train"]["samples"] == 200 and res["dataset"]["test"]["samples"] == 200
    assert set(res["classify"]) >= {"damaged", "probability_damaged", "location_element", "detectable"}
    chk = check_report(d / "report.md")
    assert chk["problems"] == [] and chk["figures"] >= 5 and chk["tables"] >= 8
    html = (d / "report.html").read_text()
    assert "data:image/png;base64," in html and "src='http" not in html
    # a second run reuses every step
    code, _, err = _run(capsys, "demo", "--out", str(d), "--quick", "--samples", "200", "--workers", "1", "--json")
    assert code == 0


def test_a_command_builds_only_its_own_parser_and_lists_every_command_with_its_help_line():
    """``beam-damage classify`` builds classify's sub-parser from its module; every command is listed with the help
    line of its :data:`experiments.cli.COMMANDS` row (``--help`` imports no command module: tests/test_api.py)."""
    from experiments.cli import COMMANDS, build_parser

    sub = next(a for a in build_parser(["classify", "--help"])._actions if a.dest == "command")
    assert list(sub.choices) == list(COMMANDS)
    assert [a.help for a in sub._choices_actions] == [c.help for c in COMMANDS.values()]
    assert any(a.dest == "baseline" for a in sub.choices["classify"]._actions)
    assert [a.dest for a in sub.choices["train"]._actions] == ["help"]       # listed, not built


def test_every_commands_help_prints_its_percent_signs_once():
    """argparse %-formats help strings but not descriptions: a ``%%`` in a description prints doubled."""
    from experiments.cli import COMMANDS, build_parser

    for name in COMMANDS:
        sub = next(a for a in build_parser([name, "--help"])._actions if a.dest == "command")
        text = sub.choices[name].format_help()
        assert "%%" not in text, name


@pytest.mark.parametrize("argv, message", [
    (["estimate", "x.uff", "--out", "{d}"], "--out {d}: is a directory; expected a file name"),
    (["estimate", "x.uff", "--out", "{f}/frf.uff"], "--out {f}/frf.uff: {f} exists and is not a directory"),
    (["identify", "x.uff", "--out", "{f}/sub"], "--out {f}/sub: {f} exists and is not a directory"),
    (["generate", "--n", "5", "--out", "{f}"], "--out {f}: {f} exists and is not a directory")])
def test_an_out_that_cannot_be_written_is_refused_before_the_command_runs(capsys, tmp_path, monkeypatch, argv,
                                                                         message):
    """Checked against the parser's ``--out`` (metavar FILE: a file, else a directory) before the input is read:
    ``x.uff`` does not exist, and its error would come first."""
    d, f = tmp_path / "adir.uff", tmp_path / "afile"
    d.mkdir()
    f.write_text("")
    fill = {"d": str(d), "f": str(f)}
    code, out, err = _run(capsys, *[a.format(**fill) for a in argv])
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert err.endswith(message.format(**fill) + "\n")


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs /proc, where nothing can be created")
def test_an_out_the_system_refuses_is_named_by_its_flag(capsys, tmp_path):
    from physics.io import MeasuredFRF, write_frf_npz

    f = np.arange(1, 801) * 0.25
    w, wn = 2 * np.pi * f, 2 * np.pi * 50.0
    write_frf_npz(tmp_path / "sdof.npz", MeasuredFRF(f, (1.0 / (wn ** 2 - w ** 2 + 2j * 0.02 * wn * w))[None, None],
                                                     ("1:+Z",), ("1:+Z",)))
    code, out, err = _run(capsys, "identify", str(tmp_path / "sdof.npz"), "--out", "/proc/beam-damage-test/id")
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert err.endswith("(--out /proc/beam-damage-test/id: cannot be written there)\n")


def test_a_beam_whose_supports_hold_every_dof_is_one_line(capsys):
    code, out, err = _run(capsys, "model", "--elements", "1", "--bc", "clamped-clamped", "--json")
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert "n_elements 1 on a clamped-clamped beam: its supports hold every DOF; at least 2 elements" in err


@pytest.mark.parametrize("rate", ["0", "0.5", "1.5", "-0.1"])
def test_classify_refuses_a_false_alarm_rate_outside_its_range_before_reading(capsys, tmp_path, rate):
    code, out, err = _run(capsys, "classify", "--model", str(tmp_path / "none"), "--baseline", "b.json", "c.json",
                          "--false-alarm-rate", rate)
    assert (code, out) == (2, "") and err.endswith(f"--false-alarm-rate {float(rate):g}: expected a rate in (0, 0.5)\n")
