import json
from importlib import resources

import numpy as np
import pytest

from physics import properties
from physics.errors import BeamDamageError


def _beams():
    return json.loads(resources.files("experiments").joinpath("data/thesis/beams.json").read_text())


def test_closed_form_frequencies_reproduce_table_4_2():
    p = properties.beam_preset("beam5")
    f = properties.cantilever_frequencies_hz(p.EI, p.m_per_length, p.length)
    np.testing.assert_allclose(f, _beams()["beams"]["5"]["theoretical_frequencies_hz"], rtol=1e-3)


def test_exact_beta_l_agrees_with_the_thesis_digits():
    np.testing.assert_allclose(properties.cantilever_beta_l(4), properties.THESIS_BETA_L, atol=6e-5)
    bl = properties.cantilever_beta_l(6)
    np.testing.assert_allclose(np.cos(bl) * np.cosh(bl), -1.0, atol=1e-9)


def test_static_test_recovers_ei_and_r_squared():
    EI, x, a = 22.674, 0.5, 0.6
    loads = np.linspace(0.5, 5.0, 10)
    defl = loads * x**2 * (3 * a - x) / (6 * EI)  # eq. 4.2
    res = properties.equivalent_ei(loads, defl, x, a)
    assert res.EI == pytest.approx(EI, rel=1e-12)
    assert res.r_squared == pytest.approx(1.0, abs=1e-12)
    noisy = properties.equivalent_ei(loads, defl * (1 + 0.02 * np.sin(np.arange(10))), x, a)
    assert 0.99 < noisy.r_squared < 1.0
    with pytest.raises(BeamDamageError):
        properties.equivalent_ei(loads, defl, 0.7, 0.6)


def test_layered_ei_homogeneous_and_sandwich():
    b, h, E = 0.05, 0.01, 70e9
    assert properties.layered_ei(b, [0, h / 2], [E]) == pytest.approx(E * b * h**3 / 12, rel=1e-13)
    # the general form equals eq. 4.1 for a symmetric sandwich ...
    sym = properties.layered_ei(b, [0, 0.003, 0.0035], [1e8, 60e9])
    gen = properties.section_ei(b, [0, 0.0005, 0.0065], [0.0005, 0.0065, 0.007], [60e9, 1e8, 60e9])
    assert gen == pytest.approx(sym, rel=1e-12)
    # ... and a thinner top face lowers EI
    cut = properties.section_ei(b, [0, 0.0005, 0.0065], [0.0005, 0.0065, 0.0068], [60e9, 1e8, 60e9])
    assert cut < 0.8 * gen


def test_unknown_preset():
    with pytest.raises(BeamDamageError, match="beam5"):
        properties.beam_preset("beam7")
