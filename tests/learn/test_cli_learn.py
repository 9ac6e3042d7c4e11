"""train / evaluate / classify end to end on a tiny generated dataset (real files, real CLI)."""

import json

import numpy as np
import pytest

from datagen.config import merge
from datagen.parallel import generate
from experiments.cli import main
from experiments.cmd_classify import KEYS
from physics.io import MeasuredFRF, ModalData, write_frf_npz, write_modal_json


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("learn")
    cfg = merge({"damage": {"n_slits": [0, 1], "position_fraction": [0.0, 0.8], "depth_m": [0.0002, 0.00045]},
                 "measurement": {"lines": 256}, "output": {"shard_size": 100}})
    generate(root / "data", cfg, n=200, seed=5, progress=False)
    assert main(["train", "--data", str(root / "data"), "--out", str(root / "model"), "--epochs", "3",
                 "--route", "measured", "--json"]) == 0
    return root


def test_train_writes_a_complete_model_directory(tiny):
    cfg = json.loads((tiny / "model" / "config.json").read_text())
    assert cfg["route"] == "measured" and set(cfg["networks"]) == {"measured", "modal"}
    assert cfg["beam"] == {"name": "beam5", "length_m": 0.6095, "dofs": ["2:y", "3:y", "4:y", "5:y"],
                           "mass_model": "iirs"}
    assert len(cfg["training_data"][0]["manifest_checksum"]) == 64
    assert cfg["split"]["by"] == "specimen"


def test_evaluate_writes_table_and_figures(tiny, capsys):
    assert main(["evaluate", "--model", str(tiny / "model"), "--data", str(tiny / "data"),
                 "--out", str(tiny / "eval"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    methods = {r["method"] for r in res["rows"]}
    assert {"network (measured)", "DLAC", "MDLAC", "Cawley-Adams", "sensitivity updating"} <= methods
    for f in ("metrics.csv", "roc.png", "confusion.png", "location_error.png", "reliability.png"):
        assert (tiny / "eval" / f).stat().st_size > 0


def _modal_files(tmp, drop):
    """Baseline and damaged modal JSON of an independent FE beam (slit = element loss)."""
    from physics.fem import beam_model
    from physics.modal import undamped_modes
    from physics.properties import beam_preset

    p = beam_preset("beam5")
    f = np.ones((2, 40))
    f[1, 8] -= drop
    m = beam_model(40, p.length, p.EI, p.m_per_length, ei_factors=f, root_spring=948.7 * p.EI / p.length)
    w, phi = undamped_modes(m.M, m.K)
    idx = m.index(["11:y", "21:y", "31:y", "41:y"])
    paths = []
    for s, name in ((0, "base.json"), (1, "cur.json")):
        lam = -0.002 * w[s, :4] + 1j * w[s, :4]
        write_modal_json(tmp / name, ModalData(lam, phi[s][idx, :4].astype(complex), ("2:y", "3:y", "4:y", "5:y")))
        paths.append(str(tmp / name))
    return paths


def test_classify_modal_json_prints_exactly_the_keys(tiny, capsys):
    base, cur = _modal_files(tiny, 0.5)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert tuple(res) == KEYS
    assert res["input_route"] == "modal" and 1 <= res["location_element"] <= 4
    assert sum(res["element_probabilities"]) == pytest.approx(1.0, abs=1e-4)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--out", str(tiny / "cl")]) == 0
    assert "Best classical baseline" in capsys.readouterr().out
    assert (tiny / "cl" / "classify.png").stat().st_size > 0


def test_classify_frf_on_another_grid_is_accepted(tiny, capsys):
    from datagen.store import Dataset

    ds = Dataset(tiny / "data")
    H = ds.array("frf_measured")[:1]
    w = ds.omega_rad_s
    lines = np.linspace(w[0], w[-1], 700) / (2 * np.pi)     # a different frequency grid
    paths = []
    for s in (0, 1):
        h = np.stack([np.interp(lines * 2 * np.pi, w, H[0, s, k].real) + 1j * np.interp(lines * 2 * np.pi, w,
                      H[0, s, k].imag) for k in range(4)])[:, None, :]
        frf = MeasuredFRF(lines, h, ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",))
        paths.append(str(tiny / f"frf{s}.npz"))
        write_frf_npz(paths[-1], frf)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", paths[0], paths[1], "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["input_route"] == "measured"


def test_refusals_and_bad_input_exit_2(tiny, capsys):
    base, cur = _modal_files(tiny, 0.5)
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, cur, "--mass", "lumped"]) == 2
    assert "mass model 'lumped' instead of 'iirs'" in capsys.readouterr().err
    obj = json.loads(open(cur).read())
    obj["dofs"] = ["2:y", "3:y", "4:y", "6:y"]
    (tiny / "other.json").write_text(json.dumps(obj))
    assert main(["classify", "--model", str(tiny / "model"), "--baseline", base, str(tiny / "other.json")]) == 2
    assert "DOF set" in capsys.readouterr().err
    assert main(["evaluate", "--model", str(tiny / "nowhere"), "--data", str(tiny / "data")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a model directory" in err
