"""Narrow-band output-error refinement of FRF poles (physics.identification.frf_band_refine), against closed-form
modal sums with known poles."""

import warnings

import numpy as np
import pytest

from physics.errors import ShapeError
from physics.identification.frf_band_refine import refine_frf_poles
from physics.identification.lscf import identify_lscf

#: A strong light mode and a weak mode 1 % below it (the pyFRF hits' 4164/4128 Hz pair, its roles swapped: here the
#: lighter mode is the stronger), and a far mode whose skirt crosses the band.
F_HZ = np.array([1000.0, 4123.0, 4164.0])
SIGMA = np.array([6.0, 12.0, 3.0])               # decay rates (1/s)
RESIDUE = np.array([2.0e3, 3.0e2, 1.0e3]) * 1j   # receptance residues; accelerance = (i w)^2 x receptance
LAM = -SIGMA + 2j * np.pi * F_HZ


def _accelerance(f_hz, lam, residue):
    iw = 2j * np.pi * f_hz[:, None]
    return (((residue / (iw - lam)) + np.conj(residue) / (iw - np.conj(lam))).sum(axis=1) * iw[:, 0] ** 2)


def _frf(seed, noise=0.01, decay_shift=0.0):
    """Accelerance on 1 Hz lines 500-5000 Hz with complex noise ``noise`` times the largest value of each line's
    neighbourhood (white, seeded); ``decay_shift`` (1/s) added to every decay rate (an exponential window)."""
    rng = np.random.default_rng(seed)
    f = np.arange(500.0, 5000.5, 1.0)
    h = _accelerance(f, LAM - decay_shift, RESIDUE)
    scale = noise * np.abs(_accelerance(np.array([4123.0]), LAM[1:2] - decay_shift, RESIDUE[1:2]))[0]
    h = h + scale * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2)
    return f, h[None, None]


def test_weak_mode_beside_a_strong_one_refined_from_a_biased_start():
    """The weak mode's start off by one half-power bandwidth (4 Hz, as LSCF's on the pyFRF hits) and its damping
    by 40 %: the refit lands within 0.05 Hz and 5 % on every seed; the start's errors stay 4 Hz and 40 %."""
    start = LAM.copy()
    start[1] = -0.6 * SIGMA[1] + 2j * np.pi * (F_HZ[1] - 4.0)
    start[2] = -1.5 * SIGMA[2] + 2j * np.pi * (F_HZ[2] + 0.3)
    for seed in range(2):
        f, h = _frf(seed)
        fit = refine_frf_poles(f, h, start, kind="accelerance")
        assert fit.converged.all() and fit.moved[1:].all()
        f_err = fit.natural_frequencies_hz - np.abs(LAM) / (2 * np.pi)
        z_err = fit.damping_ratios / (SIGMA / np.abs(LAM)) - 1
        assert np.all(np.abs(f_err[1:]) < 0.05), f_err
        assert np.all(np.abs(z_err[1:]) < 0.05), z_err
        assert np.all(np.abs(f_err[1:]) < 4 * fit.frequency_std_hz[1:])     # the one sigma is honest
    assert abs(np.abs(start[1]) / (2 * np.pi) - np.abs(LAM[1]) / (2 * np.pi)) > 3.9


def test_a_start_that_agrees_with_its_band_is_kept():
    """Starting at the true poles, each refined pole lies within its confidence region of the start: the start is
    kept exactly (the whole band's fit is the more precise where its model holds)."""
    f, h = _frf(7)
    fit = refine_frf_poles(f, h, LAM, kind="accelerance")
    assert fit.converged.all() and not fit.moved.any()
    np.testing.assert_array_equal(fit.eigenvalues, LAM)


def test_window_damping_kept_above_the_windows():
    """An exponential window adds 4.6 1/s to every decay rate; a start whose weak light mode decays slower than the
    window alone (3.5 1/s: its damping below zero once the window is removed) is refined to the windowed pole
    (3 + 4.6 1/s, within 5 %), so the damping left after removing the window is the mode's, not zero."""
    shift = 4.6
    f, h = _frf(3, decay_shift=shift)
    start = LAM - shift
    start[2] = -3.5 + 2j * np.pi * (F_HZ[2] - 0.2)
    fit = refine_frf_poles(f, h, start, kind="accelerance")
    sigma = -fit.eigenvalues.real
    assert fit.moved[2]
    assert sigma[2] - shift == pytest.approx(SIGMA[2], rel=0.05)


def test_a_pole_does_not_move_to_another_peak():
    """A pole started between the 4123 and 4164 Hz modes (27 and 14 Hz from them), neither in the model: a refit
    that carries it to either peak leaves its band (+-11.5 Hz) and its reach (3 bandwidths of 3.8 Hz) and is
    refused; the start is kept as given."""
    f, h = _frf(1)
    start = np.array([LAM[0], -12.0 + 2j * np.pi * 4150.0])
    fit = refine_frf_poles(f, h, start, kind="accelerance")
    assert not fit.converged[1] and not fit.moved[1]
    assert fit.eigenvalues[1] == start[1]


def test_wide_band_of_a_heavily_damped_mode_is_left_alone():
    """A mode damped 5 % has a band of +-30 % (6 half-widths): wider than a tenth of its frequency, it is not
    refined (its pole returned as given, not converged)."""
    f = np.arange(5.0, 400.0, 0.5)
    lam = np.array([-0.05 * 2 * np.pi * 100.0 + 2j * np.pi * 100.0 * np.sqrt(1 - 0.05 ** 2)])
    h = _accelerance(f, lam, np.array([1j]))[None, None]
    start = lam * (1 + 1e-3)
    fit = refine_frf_poles(f, h, start, kind="accelerance")
    assert not fit.converged[0] and not fit.moved[0]
    np.testing.assert_array_equal(fit.eigenvalues, start)


def test_identify_lscf_on_the_close_pair():
    """End to end: LSCF poles refined in their bands, then LSFD; both modes of the pair within 0.05 Hz and 5 % of
    their damping on every seed."""
    for seed in range(2):
        f, h = _frf(seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est = identify_lscf(f, h, kind="accelerance").estimate
        for lam in LAM:
            fn = abs(lam) / (2 * np.pi)
            j = int(np.argmin(np.abs(est.natural_frequencies_hz - fn)))
            assert est.natural_frequencies_hz[j] == pytest.approx(fn, abs=0.05)
            assert est.damping_ratios[j] == pytest.approx(-lam.real / abs(lam), rel=0.05)


def test_bad_input_is_refused():
    f, h = _frf(0)
    with pytest.raises(ShapeError, match="one flag per pole"):
        refine_frf_poles(f, h, LAM, refine=[True], kind="accelerance")
    with pytest.raises(ShapeError, match="must decay"):
        refine_frf_poles(f, h, -LAM.conj(), kind="accelerance")
