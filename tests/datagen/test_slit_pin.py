"""Slit datasets stay as pinned: every stored array, column and label.

The fixture ``tests/data/slit_pin.npz`` is written by ``tests/slit_pin.py`` with the column names of the first
slit datasets (``n_slits``, ``slit{k}_*`` from k = 1); :func:`old_name` maps today's names onto them. LAPACK
builds differ in the last digits, hence the relative tolerance of 1e-9 on computed values (the drawn inputs are
compared exactly; a change between the two tests to 1e-9 of its column's largest; mode shapes up to each mode's
sign, which the generator fixes itself: :func:`datagen.solvers.ritz_modes`).
"""

import re

import numpy as np
import pytest

from slit_pin import pin_arrays

FIXTURE = "tests/data/slit_pin.npz"

#: Columns and labels that are pure draws (no linear algebra): compared exactly. A slit's depth is not one: a
#: config that draws the rigidity loss inverts it into a depth (``depth_for_ei_loss``: the section's rigidity over a
#: table, interpolated), reproduced to rounding.
DRAWN = re.compile(r"/(table|label)/(sample_id|shard|damaged|n_slits|n_damages|noise_seed|noise_level|noise_floor|"
                   r"slit\d+_x_m|slit\d+_width_m|slit\d+_damping_s|slit\d+_element4|"
                   r"x_over_L|element)$")


#: Mode shapes (dofs, modes) in the last two axes: compared up to each mode's sign.
SHAPES = re.compile(r"/array/(truth_shapes|eigenvectors_measured)$")
#: The updating's converged residuals: rounding, compared to 1e-9 absolute.
RESIDUAL = re.compile(r"/table/residual_(base|cur)$")


def old_name(key: str) -> str:
    """Today's key -> the key the fixture was written with (``damage{k}_*`` was ``slit{k+1}_*``, the label ``size``
    of a slit ``hinge_flexibility``)."""
    key = re.sub(r"/(table|label)/n_damages$", r"/\1/n_slits", key)
    key = re.sub(r"/label/size$", "/label/hinge_flexibility", key)
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
            # changes between the two tests (df, dzeta) are differences of values reproduced to 1e-9: each entry
            # to 1e-9 of its column's largest; the updating's residuals are rounding once converged (< 1e-9)
            atol = 1e-9 if RESIDUAL.search(k) else 1e-9 * float(np.max(np.abs(v[np.isfinite(v)]), initial=0.0))
            np.testing.assert_allclose(_sign_of(new[k], v) if SHAPES.search(k) else new[k], v, rtol=1e-9, atol=atol,
                                       err_msg=k)


def _sign_of(shapes, reference):
    """``shapes`` (..., dofs, modes) with each mode's sign following ``reference``'s: an eigenvector's sign is the
    LAPACK build's choice."""
    sign = np.sign(np.sum(np.conj(reference) * shapes, axis=-2, keepdims=True).real)
    return shapes * np.where(sign == 0, 1.0, sign)


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
