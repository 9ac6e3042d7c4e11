import numpy as np
import pytest

from physics import modal, thesis
from physics.errors import BeamDamageError
from physics.io import modal_data_from_dict


def test_fixtures_load_as_fresh_copies():
    a = thesis.load("example1_two_dof")
    a["M"][0][0] = -1.0
    assert thesis.load("example1_two_dof")["M"][0][0] != -1.0
    for name in thesis.FIXTURES:
        assert isinstance(thesis.load(name), dict)
    with pytest.raises(BeamDamageError, match="'beam9'"):
        thesis.load("beam9")


def test_identified_models_reproduce_their_printed_frequencies():
    # Tables 6.1/6.2 print the natural frequencies of the identified (M, C, K)
    b5 = thesis.load("beams")["beams"]["5"]["identified_models"]
    for state in ("undamaged", "damaged"):
        for mass, key in (("iirs", "reduced_mass"), ("lumped", "lumped_mass")):
            M, C, K = thesis.identified_model(state, mass)
            f = modal.complex_modes(M, C, K).natural_frequencies_hz
            table = np.array(b5[state][key]["model_frequencies_hz"])
            np.testing.assert_allclose(f[:table.size], table, rtol=1e-3)
    with pytest.raises(BeamDamageError, match="state"):
        thesis.identified_model("broken")


def test_beam_state_is_modal_data():
    data = modal_data_from_dict(thesis.beam_state("undamaged"))
    assert data.eigenvectors.shape == (4, 4)
    assert np.all(data.natural_frequencies_hz > 10)
