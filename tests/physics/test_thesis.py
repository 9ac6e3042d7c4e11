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


def test_simulated_beam5_test_is_the_reduced_model_plus_the_stated_noise():
    from physics import frf as frf_mod

    clean, modes = thesis.simulated_beam5_test(noise=0.0, df_hz=1.0, fmax_hz=400.0)
    M, C, K = thesis.beam5_reduced_model("thesis")
    assert clean.frf.shape == (4, 1, 400) and clean.reference_dofs == ("5:+Y",)
    # independent route: modal superposition of the exact modes
    H = frf_mod.receptance_modal(modes.eigenvalues, modes.eigenvectors, 2 * np.pi * clean.frequency_hz, reference=[3])
    np.testing.assert_allclose(clean.frf, H, rtol=1e-9, atol=1e-12 * np.abs(H).max())
    noisy, _ = thesis.simulated_beam5_test(noise=0.01, df_hz=1.0, fmax_hz=400.0, seed=3)
    rel = np.abs(noisy.frf - clean.frf) / np.abs(clean.frf)
    assert 0.008 < np.sqrt(np.mean(rel**2)) < 0.012
    z = modal.complex_modes(*thesis.beam5_reduced_model("heavy")).damping_ratios
    assert 0.01 < z.min() and z.max() < 0.09
