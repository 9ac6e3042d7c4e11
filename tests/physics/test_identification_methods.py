"""Tests of the identification-method table :data:`physics.identification.METHODS`."""

import inspect

import numpy as np
import pytest

from physics.identification import METHODS, ModalEstimate, identify_frf
from physics.io import MeasuredFRF

#: Two modes of a proportionally damped 3-DOF system: natural frequencies (Hz), damping ratios and
#: mass-normalised shapes (columns, 1/sqrt(kg)).
FN_HZ = np.array([40.0, 110.0])
ZETA = np.array([0.01, 0.02])
PHI = np.array([[1.0, 0.8], [0.6, -0.5], [-0.4, 0.9]])


def two_mode_receptance(noise=1e-3, seed=0):
    """Receptances (m/N) to a force at DOF 1, 0.25 Hz lines 10-200 Hz, closed-form modal sum, seeded noise."""
    f = np.arange(10.0, 200.0 + 0.125, 0.25)
    w, wn = 2 * np.pi * f, 2 * np.pi * FN_HZ
    h = np.einsum("sj,j,jn->sn", PHI, PHI[0],
                  1 / (wn[:, None] ** 2 - w**2 + 2j * ZETA[:, None] * wn[:, None] * w))
    rng = np.random.default_rng(seed)
    h = h + noise * np.abs(h) * (rng.normal(size=h.shape) + 1j * rng.normal(size=h.shape)) / np.sqrt(2)
    dofs = ("1:+Y", "2:+Y", "3:+Y")
    return MeasuredFRF(f, h[:, None, :], dofs, (dofs[0],), metadata={"source": "two-mode test"})


@pytest.mark.parametrize("name", [n for n, spec in METHODS.items() if spec.data == "frf"])
def test_every_method_identifies_the_two_modes_of_a_closed_form_frf(name):
    spec = METHODS[name]
    frf = two_mode_receptance()
    ident = identify_frf(frf, name)
    est = ident.estimate
    assert est.method == name and est.scaled and ident.drive == "1:+Y"
    np.testing.assert_allclose(est.natural_frequencies_hz, FN_HZ, rtol=1e-3)
    np.testing.assert_allclose(est.damping_ratios, ZETA, rtol=0.06)  # peak picking: 4 %
    # unit modal A of a mass-normalised mode: psi psi^T = phi phi^T / (2 i w_d); signs relative to the drive
    wd = 2 * np.pi * FN_HZ * np.sqrt(1 - ZETA**2)
    np.testing.assert_allclose(np.abs(est.shapes) ** 2, PHI**2 / (2 * wd), rtol=0.05)
    np.testing.assert_array_equal(np.sign(np.real(est.shapes / est.shapes[0])), np.sign(PHI / PHI[0]))
    assert ident.synthesised.shape == frf.frf.shape
    assert np.linalg.norm(ident.synthesised - frf.frf) < 0.1 * np.linalg.norm(frf.frf)
    stds = np.r_[est.frequency_std_hz, est.damping_std]
    assert np.all(np.isfinite(stds)) if spec.yields_uncertainty else np.all(np.isnan(stds))


@pytest.mark.parametrize("name", list(METHODS))
def test_method_spec_names_real_fields_and_the_options_its_fit_takes(name):
    spec = METHODS[name]
    fields = set(ModalEstimate.__dataclass_fields__)
    for group, meaning in spec.uncertainty:
        assert meaning and {x.strip() for x in group.split(",")} <= fields
    assert spec.help and "\n" not in spec.help
    params = list(inspect.signature(spec.fit).parameters)
    first = ["frf", "drive", "n_modes"] if spec.data == "frf" else ["signals", "fs", "band_hz", "n_modes", "where"]
    assert params[:len(first)] == first and set(params[len(first):]) >= set(spec.options)
    assert set(spec.options) <= set(inspect.signature(identify_frf).parameters)


def test_stability_status_codes_against_the_previous_order():
    from physics.identification import STABILITY_CODES, stability_status

    order = np.array([1, 2, 2, 2, 2, 4])
    fn = np.array([10.0, 10.05, 10.5, 10.05, 10.05, 10.0])
    zeta = np.array([0.01, 0.0102, 0.01, 0.02, 0.0102, 0.01])
    v, w = np.array([1.0, 0.0]), np.array([0.6, 0.8])  # MAC(v, w) = 0.36
    mpf = np.array([v, v, v, v, w, v])
    status = stability_status(order, fn, zeta, mpf, freq_tol=0.01, damping_tol=0.05, mpf_tol=0.98)
    # first order: new; 0.5 % / 2 %: stable; 5 % in frequency: new; damping doubled: vector only;
    # other vector: damping only; order 4 has no order 3 before it: new
    assert [STABILITY_CODES[s] for s in status] == ["new", "stable", "new", "stable frequency and vector",
                                                    "stable frequency and damping", "new"]
    assert list(stability_status(order, fn, zeta, mpf[:, :1] / np.abs(mpf[:, :1]))) == [0, 4, 0, 3, 4, 0]
