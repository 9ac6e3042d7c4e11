"""Verdicts of ``classify`` on fixed pairs by a small model trained on a fixed slit dataset (a before/after pin).

``PYTHONPATH=tests python -m verdict_pin DIR`` generates the ``training`` dataset of
``tests/learn/test_cli_learn.py`` (200 samples, seed 5), trains a 3-epoch model on
the measured route and prints the ``classify --json`` answers on independent FE
pairs like that test's (modal JSON of a 40-element beam on a root spring, element 9
losing 50 % and 20 % of its EI), one JSON line each.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
from pathlib import Path

import numpy as np

from datagen.config import load_config, merge
from datagen.generation import generate
from experiments.cli import main
from physics.fem import beam_model
from physics.io import ModalData, write_modal_json
from physics.modal import undamped_modes
from physics.properties import beam_preset


def _modal_files(tmp: Path, drop: float) -> list[str]:
    """Baseline and damaged modal JSON of an independent FE beam (element 9 of 40 loses ``drop`` of its EI)."""
    p = beam_preset("beam5")
    f = np.ones((2, 40))
    f[1, 8] -= drop
    m = beam_model(40, p.length_m, p.EI_Nm2, p.mass_per_length_kg_m, ei_factors=f,
                   root_spring=948.7 * p.EI_Nm2 / p.length_m)
    w, phi = undamped_modes(m.M, m.K)
    idx = m.index(["11:y", "21:y", "31:y", "41:y"])
    paths = []
    for s, name in ((0, "base.json"), (1, "cur.json")):
        lam = -0.002 * w[s, :4] + 1j * w[s, :4]
        write_modal_json(tmp / name, ModalData(lam, phi[s][idx, :4].astype(complex), ("2:y", "3:y", "4:y", "5:y")))
        paths.append(str(tmp / name))
    return paths


def main_pin(root: Path) -> int:
    cfg = merge({"measurement": {"lines": 256}, "output": {"shard_size": 100}}, base=load_config("training"))
    generate(root / "data", cfg, n=200, seed=5, progress=False)
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["train", "--data", str(root / "data"), "--out", str(root / "model"), "--epochs", "3",
                     "--route", "measured", "--json"]) == 0
    for drop in (0.5, 0.2):
        pair = root / f"pair{drop}"
        pair.mkdir()
        base, cur = _modal_files(pair, drop)
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            assert main(["classify", "--model", str(root / "model"), "--baseline", base, cur, "--json"]) == 0
        print(json.dumps(json.loads(buf.getvalue()), sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main_pin(Path(sys.argv[1])))
