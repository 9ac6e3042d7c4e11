"""Slit datasets are the ones written before the damage plug-ins: every stored array, column and label.

The fixture ``tests/data/slit_pin.npz`` was written by ``tests/slit_pin.py``
before :mod:`datagen.damage` became a registry, with the column names of then
(``n_slits``, ``slit{k}_*`` from k = 1); :func:`old_name` maps today's names onto them.
Equality is bitwise on the machine that wrote the fixture; elsewhere LAPACK builds may
differ in the last digits, hence the relative tolerance of 1e-9 on computed values (the
drawn inputs are compared exactly).
"""

import re

import numpy as np
import pytest

from slit_pin import pin_arrays

FIXTURE = "tests/data/slit_pin.npz"

#: Columns and labels that are pure draws (no linear algebra): compared exactly.
DRAWN = re.compile(r"/(table|label)/(sample_id|shard|damaged|n_slits|n_damages|noise_seed|noise_level|noise_floor|"
                   r"slit\d+_x_m|slit\d+_width_m|slit\d+_depth_m|slit\d+_damping_s|slit\d+_element4|"
                   r"x_over_L|element)$")


def old_name(key: str) -> str:
    """Today's key -> the key the fixture was written with (``damage{k}_*`` was ``slit{k+1}_*``)."""
    key = re.sub(r"/(table|label)/n_damages$", r"/\1/n_slits", key)
    return re.sub(r"/table/damage(\d+)_", lambda m: f"/table/slit{int(m[1]) + 1}_", key)


@pytest.fixture(scope="module")
def pinned():
    with np.load(FIXTURE) as f:
        old = {k: f[k] for k in f.files}
    return old, {old_name(k): v for k, v in pin_arrays().items()}


def test_every_pinned_slit_array_column_and_label_is_reproduced(pinned):
    old, new = pinned
    assert set(old) <= set(new), sorted(set(old) - set(new))
    for k, v in old.items():
        if DRAWN.search(k) or v.dtype.kind not in "fc":
            np.testing.assert_array_equal(new[k], v, err_msg=k)
        else:
            np.testing.assert_allclose(new[k], v, rtol=1e-9, atol=0, err_msg=k)


def test_a_dataset_written_before_the_damage_kinds_is_refused_in_one_line(tmp_path, capsys):
    """Its manifest's config has no damage.kind (and its table slit{k}_* columns): readers and commands refuse it
    naming manifest.json and the new column names, exit 2, no traceback."""
    import json

    from datagen.config import merge
    from datagen.dataset import Dataset
    from datagen.generation import generate
    from experiments.cli import main
    from physics.errors import FileFormatError

    root = tmp_path / "old"
    generate(root, merge({"measurement": {"lines": 16}}), n=2, seed=0, progress=False)
    m = json.loads((root / "manifest.json").read_text())
    del m["config"]["damage"]["kind"]
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(FileFormatError, match=r"manifest.json: written before the damage kinds \(columns n_slits, "
                                              r"slit\{k\}_\*; now n_damages, damage\{k\}_\*"):
        Dataset(root)
    for argv in (["inspect", str(root)], ["train", "--data", str(root), "--out", str(tmp_path / "m")]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "regenerate it with `beam-damage generate`" in err
