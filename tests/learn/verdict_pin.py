"""Verdicts of ``classify`` on fixed pairs by a small model trained on a fixed slit dataset (a before/after pin).

``python -m tests.learn.verdict_pin DIR`` generates the ``training`` dataset of
``tests/learn/test_cli_learn.py`` (200 samples, seed 5), trains a 3-epoch model on
the measured route and prints the ``classify --json`` answers on the independent
FE pairs of that test (modal JSON, 50 % and 20 % element loss), one JSON line each.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
from pathlib import Path

from datagen.config import load_config, merge
from datagen.generation import generate
from experiments.cli import main
from tests.learn.test_cli_learn import _modal_files


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
