"""physics.io.prepare_measured: positive senses, the DOF map and the one reciprocity rule."""

import numpy as np
import pytest

from learn.network.features import BeamSpec
from learn.pairs.measured import on_model_dofs
from physics.io import MeasuredFRF, ModalData, prepare_measured, reads_by_reciprocity

QUARTERS = ("2:+Y", "3:+Y", "4:+Y", "5:+Y")


def _frf(responses, references, seed=0):
    rng = np.random.default_rng(seed)
    H = rng.normal(size=(len(responses), len(references), 6)) + 1j * rng.normal(size=(len(responses),
                                                                                         len(references), 6))
    return MeasuredFRF(np.linspace(10.0, 60.0, 6), H, tuple(responses), tuple(references))


@pytest.mark.parametrize("responses, references, wanted, swap", [
    (("2:+Y",), QUARTERS, None, True),                        # roving hammer, one accelerometer
    (QUARTERS, ("2:+Y",), None, False),                       # SIMO: one drive, responses everywhere
    (QUARTERS, QUARTERS, None, False),                        # full matrix
    (QUARTERS, QUARTERS + ("6:+Y",), QUARTERS, False),        # MIMO whose responses cover the wanted DOFs
    (QUARTERS, QUARTERS + ("6:+Y",), None, True),             # ... whose references cover every DOF it names
    (("2:+Y", "3:+Y"), ("4:+Y", "5:+Y", "6:+Y"), None, False),  # neither covers: read as it is
])
def test_the_reciprocity_rule(responses, references, wanted, swap):
    assert reads_by_reciprocity(responses, references, wanted) is swap
    f = _frf(responses, references)
    p = prepare_measured(f, wanted=wanted)
    assert p.reciprocal is swap
    if swap:
        np.testing.assert_array_equal(p.data.frf, np.swapaxes(f.frf, 0, 1))
        assert (p.data.response_dofs, p.data.reference_dofs) == (f.reference_dofs, f.response_dofs)
    else:
        assert p.data is f


def test_negative_senses_are_turned_before_the_rule():
    """A hammer struck towards -Y at node 3 and an upside-down accelerometer at node 2: H(+2, +3) = H(-2, -3)
    and H(+2, +2) = -H(-2, +2); the labels covering the wanted DOFs only once positive."""
    f = _frf(("2:-Y",), ("2:+Y", "3:-Y", "4:+Y", "5:+Y"), seed=1)
    p = prepare_measured(f)
    assert p.reciprocal and p.data.response_dofs == QUARTERS and p.data.reference_dofs == ("2:+Y",)
    np.testing.assert_array_equal(p.data.frf[0, 0], -f.frf[0, 0])
    np.testing.assert_array_equal(p.data.frf[1, 0], f.frf[0, 1])
    np.testing.assert_array_equal(p.data.frf[2, 0], -f.frf[0, 2])
    shapes = np.arange(8.0).reshape(4, 2) + 0j
    m = prepare_measured(ModalData(np.array([-1 + 100j, -2 + 600j]), shapes, ("2:+Y", "3:-Y", "4:+Y", "5:+Y")))
    np.testing.assert_array_equal(m.data.eigenvectors, shapes * np.array([1, -1, 1, 1])[:, None])


def test_a_mimo_file_whose_responses_cover_the_model_is_read_as_it_is():
    """Responses at the quarter points, references at them and at a fifth point between two: more references
    than responses, yet the responses already cover the model's DOFs, so classify reads the file as it is."""
    beam = BeamSpec("beam5", 0.6095, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    f = _frf(QUARTERS, QUARTERS + ("6:+Y",), seed=2)
    data, dof_map = on_model_dofs(f, beam)
    np.testing.assert_array_equal(data.frf, f.frf)
    assert data.response_dofs == beam.dofs and "reciprocity" not in dof_map.detail
    hammer = _frf(("2:+Y",), QUARTERS, seed=3)                  # the roving hammer is read by reciprocity
    data, dof_map = on_model_dofs(hammer, beam)
    np.testing.assert_array_equal(data.frf[:, 0], hammer.frf[0])
    assert "reciprocity" in dof_map.detail
