"""A full disk (injected ENOSPC) during a write: one line saying so, the previous state intact, resume completes."""

import errno
import os

import numpy as np
import pytest

import datagen.store
from experiments.cli import main
from physics.errors import DiskFullError
from physics.io import atomic_write_text

CONFIG = "[output]\nshard_size = 4\n[measurement]\nlines = 32\n"


def _tree(root):
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _full(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_atomic_writer_keeps_the_previous_file(tmp_path, monkeypatch):
    p = tmp_path / "metrics.json"
    p.write_text("previous")
    monkeypatch.setattr(os, "fsync", _full)
    with pytest.raises(DiskFullError, match=r"metrics.json: no space left on device; not written, its previous "
                                            r"version is intact"):
        atomic_write_text(p, "new" * 1000)
    assert p.read_text() == "previous" and sorted(x.name for x in tmp_path.iterdir()) == ["metrics.json"]


def test_generate_on_a_full_disk_keeps_its_shards_and_resumes(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    argv = ["generate", "--n", "12", "--config", str(cfg), "--seed", "2", "--json", "--out"]
    assert main([*argv, str(tmp_path / "ref")]) == 0
    root = tmp_path / "ds"
    from datagen.config import load_config
    from datagen.generation import generate
    generate(root, load_config(str(cfg)), n=12, seed=2, progress=False, max_new_shards=1)
    before = _tree(root)
    capsys.readouterr()
    real_save = np.save

    def save(file, *args, **kwargs):  # the disk fills while the second shard is written
        if ".tmp-shard-000001" in str(file) and str(file).endswith("K_updated.npy"):
            _full()
        return real_save(file, *args, **kwargs)

    monkeypatch.setattr(datagen.store.np, "save", save)
    assert main([*argv, str(root)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "shard-000001: no space left on device" in err and "intact" in err, err
    assert _tree(root) == before  # nothing of the failed shard, the lock released
    monkeypatch.setattr(datagen.store.np, "save", real_save)
    assert main([*argv, str(root)]) == 0
    assert _tree(root) == _tree(tmp_path / "ref")


def test_a_new_dataset_on_a_full_disk_leaves_nothing(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    monkeypatch.setattr(os, "fsync", _full)
    assert main(["generate", "--n", "8", "--config", str(cfg), "--out", str(tmp_path / "ds")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no space left on device" in err
    assert not (tmp_path / "ds").exists()


def test_export_on_a_full_disk_removes_what_it_wrote(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    assert main(["generate", "--n", "8", "--config", str(cfg), "--out", str(tmp_path / "ds"), "--json"]) == 0
    out = tmp_path / "x"
    out.mkdir()
    (out / "keep.txt").write_text("previous")
    real, calls = os.fsync, []

    def fsync(fd):  # the disk fills on the third file
        calls.append(fd)
        if len(calls) == 3:
            _full()
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    capsys.readouterr()
    rc = main(["export", str(tmp_path / "ds"), "--samples", "1,2", "--format", "npz", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "no space left on device" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"] and (out / "keep.txt").read_text() == "previous"
