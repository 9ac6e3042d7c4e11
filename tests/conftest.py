"""Shared fixtures: the thesis's printed data and beam 5's 4-element model."""

import pytest
from hypothesis import settings

from physics import fem, properties, thesis

# Property tests draw the same examples on every run and machine: a failure in CI is reproducible, and the suite
# never turns red on a draw nobody has seen.
settings.register_profile("project", derandomize=True)
settings.load_profile("project")


@pytest.fixture
def thesis_beams():
    """``beams.json`` (a fresh copy: tests may modify it)."""
    return thesis.load("beams")


@pytest.fixture
def beam5_data(thesis_beams):
    """Beam 5's entry of ``beams.json``: measured modes, IIRS matrices, identified models."""
    return thesis_beams["beams"]["5"]


@pytest.fixture(scope="session")
def beam5():
    """The beam-5 preset (Table 4.1)."""
    return properties.beam_preset("beam5")


@pytest.fixture(scope="session")
def beam5_model(beam5):
    """Beam 5's 4-element clamped-free FE model (eqs. 3.8, 3.9), as in the thesis."""
    return fem.beam_model(beam5.n_elements, beam5.length_m, beam5.EI_Nm2, beam5.mass_per_length_kg_m)


@pytest.fixture(scope="session")
def beam5_masters(beam5, beam5_model):
    """Indices of the measured DOFs (translations of nodes 2..5) in ``beam5_model``."""
    return beam5_model.index(beam5.masters)
