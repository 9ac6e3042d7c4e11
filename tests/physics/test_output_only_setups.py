"""Multi-setup output-only identification: roving sensors merged on a fixed reference."""

import numpy as np
import pytest
from oma_records import chain_record

from physics.errors import ShapeError
from physics.identification import identify_records
from physics.identification.output_only import merge_setups
from physics.io.timedata import TimeRecords
from physics.modal import mac


def _setup(channels, seed):
    y, fs, fn, zeta, phi = chain_record(seconds=300, seed=seed)
    dofs = ("1:+Z", "2:+Z", "3:+Z")
    rec = TimeRecords(1 / fs, y[channels] * (1 + seed), tuple(dofs[c] for c in channels),
                      ("displacement",) * len(channels), {"source": f"setup {seed}"})
    return identify_records(rec, "ssi", band_hz=(1, 60), max_order=30), fn, phi


def test_two_setups_sharing_a_reference_give_the_full_shapes():
    a, fn, phi = _setup([2, 0], seed=1)          # reference 3:+Z and roving 1:+Z
    b, _, _ = _setup([1, 2], seed=2)             # roving 2:+Z and the same reference (another gain)
    m = merge_setups([a, b])
    assert m.references == ("3:+Z",) and m.dofs == ("3:+Z", "1:+Z", "2:+Z") and not m.partial.any()
    np.testing.assert_allclose(m.estimate.natural_frequencies_hz, fn, rtol=2e-3)
    rows = [int(d[0]) - 1 for d in m.dofs]
    assert np.all(np.diag(mac(phi[rows], m.estimate.shapes)) > 0.999)
    assert np.all(m.estimate.frequency_std_hz > 0)
    np.testing.assert_allclose(np.linalg.norm(m.estimate.shapes, axis=0), 1.0)


def test_setups_without_a_common_dof_are_refused():
    a, _, _ = _setup([0], seed=1)
    b, _, _ = _setup([1, 2], seed=2)
    with pytest.raises(ShapeError, match="no DOF is measured in every setup"):
        merge_setups([a, b])
