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
    assert err.count("\n") == 1 and "No space left on device" in err and "files from before are as they were" in err
    assert _snapshot(out) == before                      # every earlier file intact, no temporary left


def test_generate_on_a_full_disk_leaves_its_complete_shards_and_resumes_identical(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "small.toml"
    cfg.write_text("[output]\nshard_size = 10\n")
    args = ["generate", "--n", "30", "--config", str(cfg), "--seed", "4"]
    assert main([*args, "--out", str(tmp_path / "full")]) == 0
    capsys.readouterr()
    with monkeypatch.context() as m:
        _full_disk_after(m, 14)                          # the first shard's files and the manifest, then full
        assert main([*args, "--out", str(tmp_path / "ds")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err
    shards = tmp_path / "ds" / "shards"
    assert not [p.name for p in shards.iterdir() if p.name.startswith(".tmp")]
    assert main([*args, "--out", str(tmp_path / "ds")]) == 0
    want = _snapshot(tmp_path / "full")
    got = _snapshot(tmp_path / "ds")
    assert set(got) == set(want)
    for name in want:
        if name.name != "manifest.json":
            assert got[name] == want[name], name
