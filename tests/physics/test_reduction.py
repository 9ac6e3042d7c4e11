import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import fem, modal, reduction
from physics.errors import BeamDamageError, ConvergenceError


def test_iirs_reproduces_table_4_1(beam5_data, beam5_model, beam5_masters):
    ref = beam5_data["iirs_reduced"]
    model, masters = beam5_model, beam5_masters
    red = reduction.iirs(model.M, model.K, masters)
    assert red.converged and 5 < red.iterations < 100
    for key, mat in (("M", red.M), ("K", red.K)):
        rel = np.linalg.norm(mat - np.array(ref[key])) / np.linalg.norm(ref[key])
        assert rel < 1e-3, key


def test_guyan_is_the_exact_static_condensation(beam5_model, beam5_masters):
    model, masters = beam5_model, beam5_masters
    g = reduction.guyan(model.M, model.K, masters)
    f = np.array([0.3, -1.0, 0.2, 1.5])  # forces on the masters only
    full = np.zeros(model.K.shape[0])
    full[masters] = f
    x = np.linalg.solve(model.K, full)
    np.testing.assert_allclose(np.linalg.solve(g.K, f), x[masters], rtol=1e-12)
    np.testing.assert_allclose(g.T @ np.linalg.solve(g.K, f), x, rtol=1e-10, atol=1e-14)


def test_iirs_eigenvalues_are_exact_for_the_lowest_modes_when_converged(beam5_model, beam5_masters):
    # Friswell et al. 1998: converged IIRS reproduces the lowest m eigenvalues exactly.
    model, masters = beam5_model, beam5_masters
    red = reduction.iirs(model.M, model.K, masters, tol=1e-14)
    w_full, _ = modal.undamped_modes(model.M, model.K)
    w_red, _ = modal.undamped_modes(red.M, red.K)
    np.testing.assert_allclose(w_red, w_full[:4], rtol=1e-10)


@settings(max_examples=25, deadline=None)
@given(n_el=st.integers(3, 10), seed=st.integers(0, 10_000))
def test_iirs_beats_guyan_on_random_beams(n_el, seed):
    rng = np.random.default_rng(seed)
    model = fem.beam_model(n_el, 1.0, 10.0, 1.0, ei_factors=rng.uniform(0.3, 1.0, n_el),
                           mass_factors=rng.uniform(0.5, 1.5, n_el))
    masters = model.index(model.translations())
    w_full, _ = modal.undamped_modes(model.M, model.K)
    m = masters.size
    errs = {}
    for name, fn in (("guyan", reduction.guyan), ("irs", reduction.irs), ("iirs", reduction.iirs)):
        red = fn(model.M, model.K, masters)
        w, _ = modal.undamped_modes(red.M, red.K)
        errs[name] = np.max(np.abs(w - w_full[:m]) / w_full[:m])
    assert errs["iirs"] < errs["guyan"]
    assert errs["iirs"] < 1e-6


def test_batched_reduction_equals_single():
    rng = np.random.default_rng(1)
    f = rng.uniform(0.6, 1.0, (3, 6))
    batch = fem.beam_model(6, 0.6, 22.0, 0.13, ei_factors=f)
    masters = batch.index(batch.translations())
    red = reduction.iirs(batch.M, batch.K, masters)
    for i in range(3):
        one = reduction.iirs(batch.M[i], batch.K[i], masters)
        np.testing.assert_allclose(red.K[i], one.K, rtol=1e-9)
        np.testing.assert_allclose(red.M[i], one.M, rtol=1e-9)


def test_non_convergence_and_bad_masters_are_reported(beam5_model, beam5_masters):
    model, masters = beam5_model, beam5_masters
    with pytest.raises(ConvergenceError, match="did not converge") as err:
        reduction.iirs(model.M, model.K, masters, max_iter=2)
    assert err.value.iterations == 2
    red = reduction.iirs(model.M, model.K, masters, max_iter=2, raise_on_failure=False)
    assert not red.converged
    with pytest.raises(BeamDamageError, match="masters"):
        reduction.guyan(model.M, model.K, [0, 0])
    with pytest.raises(BeamDamageError, match="masters"):
        reduction.guyan(model.M, model.K, list(range(8)))
