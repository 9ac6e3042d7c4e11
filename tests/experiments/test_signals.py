"""Interrupted `generate` runs: one stderr line and 130/143 on SIGINT/SIGTERM, stale temporaries and a truncated
manifest repaired, every case resumed byte-identical (the full matrix: experiments/benches/bench_interrupts.py)."""

import os
from pathlib import Path

import pytest

from experiments.benches.bench_interrupts import CASES, run_matrix

ROOT = str(Path(__file__).resolve().parents[2])


@pytest.fixture(autouse=True)
def _pythonpath(monkeypatch):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (ROOT, os.environ.get("PYTHONPATH")) if p))


def _check(rows):
    for r in rows:
        assert r["rc"] == r["expected_rc"], r
        assert r["resume_rc"] == 0 and r["identical"] and r["differing_files"] == [], r
        assert r["ok"], r


def test_sigint_and_a_kill_inside_the_manifest_write_resume_byte_identical(tmp_path):
    rows = run_matrix(("sigint", "kill-manifest"), work=tmp_path)
    assert rows[0]["stderr"] == "beam-damage generate: interrupted (SIGINT)" and rows[0]["stderr_lines"] == 1
    _check(rows)


@pytest.mark.slow
def test_the_whole_interrupt_matrix_resumes_byte_identical(tmp_path):
    rows = run_matrix(CASES, work=tmp_path)
    assert [r["case"] for r in rows] == list(CASES)
    assert [r["stderr"] for r in rows if r["case"] == "sigterm"] == ["beam-damage generate: terminated (SIGTERM)"]
    _check(rows)


@pytest.mark.parametrize(("sig", "code", "line"), [("SIGINT", 130, "interrupted (SIGINT)"),
                                                    ("SIGTERM", 143, "terminated (SIGTERM)")])
def test_any_command_ends_with_one_line_on_a_signal(monkeypatch, capsys, tmp_path, sig, code, line):
    import signal

    import experiments.cli.cmd_inspect
    from experiments.cli import main

    def run(args):
        os.kill(os.getpid(), getattr(signal, sig))
        raise AssertionError("the signal did not stop the command")

    # Python's Ctrl-C handler, also when the suite runs with SIGINT ignored (a background job of a plain shell)
    previous_sigint = signal.signal(signal.SIGINT, signal.default_int_handler)
    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(experiments.cli.cmd_inspect, "inspect_dataset", lambda *a: run(a))
    try:
        assert main(["inspect", str(tmp_path)]) == code
    finally:
        signal.signal(signal.SIGINT, previous_sigint)
    assert capsys.readouterr().err == f"beam-damage inspect: {line}\n"
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is the command's only
