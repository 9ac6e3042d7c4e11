"""A full disk (ENOSPC, injected at the flush of a write) leaves the previous state intact and is one line."""

import errno
import os

from experiments.cli import main
from physics.io import write_uff58
from physics.thesis import simulated_beam5_test


def _snapshot(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _full_disk_after(monkeypatch, n_ok):
    real, calls = os.fsync, []

    def fsync(fd):
        calls.append(fd)
        if len(calls) > n_ok:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)


def test_identify_out_on_a_full_disk_keeps_the_previous_results(tmp_path, monkeypatch, capsys):
    frf, _ = simulated_beam5_test(noise=0.0, seed=0, damping="heavy", df_hz=2.0)
    write_uff58(tmp_path / "g.uff", frf)
    out = tmp_path / "id"
    assert main(["identify", str(tmp_path / "g.uff"), "--out", str(out)]) == 0
    before = _snapshot(out)
    capsys.readouterr()
    _full_disk_after(monkeypatch, 0)
    assert main(["identify", str(tmp_path / "g.uff"), "--out", str(out), "--modes", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no space left on device" in err.lower()
    assert _snapshot(out) == before                      # every earlier file intact, no temporary left
