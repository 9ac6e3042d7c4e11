"""CLI: generate (JSON summary, config errors naming the key) and inspect (curvature check)."""

import json

import pandas as pd

from experiments.cli import main


def test_generate_json_and_inspect(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 40\n[measurement]\nlines = 32\n')
    rc = main(["generate", "--n", "120", "--out", str(tmp_path / "ds"), "--config", str(cfg), "--seed", "4",
               "--json"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert s["complete"] and s["counts"]["samples"] == 120 and s["n_shards"] == 3 and s["seed"] == 4
    assert len(pd.read_parquet(tmp_path / "ds" / "samples.parquet")) == 120
    rc = main(["inspect", str(tmp_path / "ds"), "--out", str(tmp_path / "ins"), "--json"])
    assert rc == 0
    r = json.loads(capsys.readouterr().out)
    # single slits of 0.2-0.3 mm: the shift follows curvature^2 of each mode
    for m in ("mode1", "mode2", "mode3", "mode4"):
        assert r["curvature_check"][m]["r2"] > 0.95
        assert 0.9 < r["curvature_check"][m]["slope"] < 1.4
    assert (tmp_path / "ins" / "shift_vs_position.png").stat().st_size > 1000


def test_bad_config_names_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[damage]\nwidth_m = [0.01]\n')
    rc = main(["generate", "--n", "5", "--out", str(tmp_path / "ds"), "--config", str(cfg)])
    assert rc == 2
    assert "damage.width_m" in capsys.readouterr().err
    cfg.write_text('[measurment]\nlines = 3\n')
    assert main(["generate", "--n", "5", "--out", str(tmp_path / "ds"), "--config", str(cfg)]) == 2
    assert "measurment" in capsys.readouterr().err
