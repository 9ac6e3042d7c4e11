import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import frf, modal
from physics.errors import BeamDamageError
from systems import random_system


def test_sdof_receptance_is_eq_3_11():
    m, c, k = 1.5, 0.4, 900.0
    w = np.linspace(1, 60, 500)
    h = frf.receptance([[m]], [[c]], [[k]], w)[0, 0]
    np.testing.assert_allclose(h, 1 / ((k - m * w**2) + 1j * c * w), rtol=1e-13)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(2, 10), seed=st.integers(0, 2**31))
def test_direct_modal_and_state_space_routes_agree(n, seed):
    M, C, K = random_system(n, seed)
    cm = modal.complex_modes(M, C, K)
    w = np.linspace(0.1, 1.5, 300) * np.abs(cm.eigenvalues).max()
    out, inp = [0, n - 1], [n // 2]
    a = frf.receptance(M, C, K, w, out, inp)
    b = frf.receptance_modal(cm.eigenvalues, cm.eigenvectors, w, out, inp)
    c = frf.receptance_state_space(M, C, K, w, out, inp)
    assert a.shape == (2, 1, 300)
    scale = np.abs(a).max()
    assert np.abs(a - b).max() < 1e-8 * scale
    assert np.abs(a - c).max() < 1e-8 * scale


def test_batched_frf_and_reciprocity():
    systems = [random_system(3, seed=s) for s in range(4)]
    M, C, K = (np.stack(x) for x in zip(*systems))
    w = np.linspace(1, 30, 50)
    h = frf.receptance(M, C, K, w)
    assert h.shape == (4, 3, 3, 50)
    np.testing.assert_allclose(h, np.swapaxes(h, 1, 2), rtol=1e-10)  # H_sr = H_rs
    np.testing.assert_allclose(h[2], frf.receptance(*systems[2], w), rtol=1e-12)


def test_kind_conversion_and_db():
    w = np.array([2.0, 10.0])
    h = np.array([1e-3 + 1e-3j, -2e-4j])
    mob = frf.convert_frf(h, w, "receptance", "mobility")
    np.testing.assert_allclose(mob, 1j * w * h)
    np.testing.assert_allclose(frf.convert_frf(mob, w, "mobility", "accelerance"), -(w**2) * h)
    np.testing.assert_allclose(frf.convert_frf(-(w**2) * h, w, "accelerance", "receptance"), h)
    assert frf.magnitude_db(np.array([10.0]))[0] == pytest.approx(20.0)
    assert frf.phase_deg(np.array([1j]))[0] == pytest.approx(90.0)
    with pytest.raises(BeamDamageError, match="FRF kind"):
        frf.convert_frf(h, w, "receptance", "inertance")
