"""Slit datasets of the default and ``training`` configs, as plain arrays (the pin of ``test_slit_pin.py``).

``PYTHONPATH=tests python -m slit_pin OUT.npz`` writes them (the committed fixture
``tests/data/slit_pin.npz``); ``--sha256`` prints one checksum per array instead,
for a bitwise comparison between two versions of the code.

Keys are ``{config}/table/{column}`` and ``{config}/array/{name}`` and
``{config}/label/{name}`` (:func:`learn.network.features.labels`). Column names are those of
the damage plug-ins (``n_damages``, ``damage{k}_*`` with ``k`` from 0).
"""

from __future__ import annotations

import hashlib
import sys
import tempfile
from pathlib import Path

import numpy as np

from datagen.config import load_config, merge
from datagen.dataset import Dataset
from datagen.generation import generate
from datagen.store import ARRAYS
from learn.network.features import labels

#: Configurations pinned: (name, overrides, n, seed).
CASES = (("default", None, 6, 11), ("training", "training", 8, 5))

#: The ``training`` config as pinned: without the repeatability of the tests and the support changes (drawn after
#: every pinned draw, so that the pinned arrays are reproduced with these keys at zero).
PINNED_TRAINING = {"measurement": {"damping_scatter": [0.0, 0.0], "shape_scatter": [0.0, 0.0],
                                   "gain_scatter": [0.0, 0.0]},
                   "specimen": {"support_change_fraction": 0.0}}


def pin_arrays() -> dict:
    """``{key: ndarray}`` of every stored array, table column and label of the pinned datasets."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, base, n, seed in CASES:
            cfg = merge({"output": {"shard_size": 5}, **(PINNED_TRAINING if base == "training" else {})},
                        base=load_config(base))
            root = Path(tmp) / name
            generate(root, cfg, n=n, seed=seed, progress=False)
            ds = Dataset(root)
            for col, v in ds.table().items():
                out[f"{name}/table/{col}"] = v.to_numpy()
            for a in ARRAYS:
                out[f"{name}/array/{a}"] = ds.array(a)
            for k, v in labels(ds.table(), ds.manifest["preset"]["length_m"]).items():
                out[f"{name}/label/{k}"] = np.asarray(v)
    return out


def main(argv) -> int:
    arrays = pin_arrays()
    if argv and argv[0] == "--sha256":
        for k, v in sorted(arrays.items()):
            v = v.astype(str) if v.dtype == object else v   # an object array's bytes are its pointers
            print(k, hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest())
        return 0
    np.savez_compressed(argv[0], **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
