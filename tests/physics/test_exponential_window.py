"""Removal of an exponential window's added decay from identified modes (physics.identification.exponential_window)."""

import warnings

import numpy as np
import pytest

from physics.errors import ConfigError
from physics.identification import identify_frf
from physics.identification.exponential_window import (remove_window_decay, remove_window_decay_modal,
                                                        tau_from_end_value)
from physics.io import MeasuredFRF
from physics.modal import eigenvalues_from_modal, modal_parameters

FN_HZ, ZETA = np.array([20.0, 55.0]), np.array([0.002, 0.004])
FS_HZ, N = 512.0, 4096                                # a record of T = 8 s, lines 0.125 Hz apart


def windowed_2dof_frf(end_value=0.01):
    """Receptance FRFs (DOFs 1 and 2 over a force at DOF 1) of a 2-DOF system of real, unit-modal-mass modes:
    the impulse responses sampled over ``T = N / FS_HZ``, multiplied by ``exp(-t / tau)`` falling to ``end_value``
    at ``T``, and Fourier transformed; lines 5-100 Hz. Returns ``(frf, tau_s)``."""
    lam = eigenvalues_from_modal(FN_HZ, ZETA)
    phi = np.array([[1.0, 1.0], [1.0, -0.8]])
    t = np.arange(N) / FS_HZ
    wd, sigma = lam.imag, -lam.real
    h = np.einsum("pr,r,rt->pt", phi, phi[0], np.exp(-np.outer(sigma, t)) * np.sin(np.outer(wd, t)) / wd[:, None])
    tau = tau_from_end_value(N / FS_HZ, end_value)
    H = np.fft.rfft(h * np.exp(-t / tau), axis=-1) / FS_HZ
    f = np.fft.rfftfreq(N, 1 / FS_HZ)
    keep = (f > 5) & (f < 100)
    return MeasuredFRF(f[keep], H[:, None, keep], ("1:+Z", "2:+Z"), ("1:+Z",), kind="receptance"), tau


def test_tau_of_a_window_falling_to_its_end_value():
    tau = tau_from_end_value(8.0, 0.01)
    assert tau == pytest.approx(8 / np.log(100), rel=1e-15)
    assert np.exp(-8.0 / tau) == pytest.approx(0.01, rel=1e-12)
    for bad in (0.0, 1.0, 1.5, -0.1):
        with pytest.raises(ConfigError, match="must be in \\(0, 1\\)"):
            tau_from_end_value(8.0, bad)


def test_windowed_fft_frf_identified_then_corrected_recovers_damping_and_frequency():
    frf, tau = windowed_2dof_frf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = identify_frf(frf, "lscf").estimate
    # the window's poles: lambda - 1/tau (omega_d kept), identified to ~1e-10
    shifted = eigenvalues_from_modal(FN_HZ, ZETA) - 1 / tau
    f_w, z_w = modal_parameters(shifted)
    np.testing.assert_allclose(est.damping_ratios, z_w, rtol=1e-6)
    np.testing.assert_allclose(est.natural_frequencies_hz, f_w, rtol=1e-9)
    assert np.all(est.damping_ratios > 1.4 * ZETA)        # uncorrected: 0.00658 and 0.00567 for 0.002 and 0.004
    fix = remove_window_decay(est.eigenvalues, tau, est.damping_std)
    assert fix.added_decay_rate_1_s == pytest.approx(np.log(100) / 8, rel=1e-15)
    np.testing.assert_allclose(fix.damping_ratios, ZETA, rtol=1e-6)
    np.testing.assert_allclose(fix.natural_frequencies_hz, FN_HZ, rtol=1e-9)
    assert not fix.at_zero.any()


def test_modal_pairs_and_either_conjugate_member_in_closed_form():
    fn, zeta, tau = np.array([3.0, 40.0, 700.0]), np.array([0.01, 0.001, 0.05]), 0.25
    lam_w = eigenvalues_from_modal(fn, zeta) - 1 / tau
    f_w, z_w = modal_parameters(lam_w)
    fix = remove_window_decay_modal(f_w, z_w, tau)
    np.testing.assert_allclose(fix.natural_frequencies_hz, fn, rtol=1e-12)
    np.testing.assert_allclose(fix.damping_ratios, zeta, rtol=1e-9)
    # omega_d is kept: omega_n falls by sqrt((sigma + 1/tau)^2 + wd^2) - sqrt(sigma^2 + wd^2)
    np.testing.assert_allclose(fix.eigenvalues.imag, lam_w.imag, rtol=1e-14)
    assert np.all(f_w > fn)
    lower = remove_window_decay(lam_w.conj(), tau)
    np.testing.assert_allclose(lower.eigenvalues, eigenvalues_from_modal(fn, zeta).conj(), rtol=1e-12)
    np.testing.assert_allclose(lower.damping_ratios, zeta, rtol=1e-9)


def test_a_correction_below_zero_beyond_noise_is_refused_naming_the_mode():
    # mode 2 decays at 0.2 1/s; a window of tau 2 s would remove 0.5 1/s
    lam = np.array([-3.0 + 100j, -0.2 + 300j])
    with pytest.raises(ConfigError, match=r"mode 2 \(47\.746 Hz\) decays at 0\.2 1/s .* corrected damping ratio "
                                          r"would be -0\.001, below zero by 0\.3 1/s, more than the noise \(0\.005"):
        remove_window_decay(lam, 2.0)


def test_a_correction_below_zero_within_noise_is_set_to_zero_damping():
    tau = 2.0                                                   # removes 0.5 1/s
    lam = np.array([-0.498 + 300j, -0.45 + 500j])
    fix = remove_window_decay(lam, tau, damping_std=[np.nan, 1e-4])   # mode 2: 3 sigma = 0.15 1/s of allowance
    assert fix.at_zero.tolist() == [True, True]
    np.testing.assert_array_equal(fix.damping_ratios, [0.0, 0.0])
    np.testing.assert_allclose(fix.natural_frequencies_hz, [300 / (2 * np.pi), 500 / (2 * np.pi)], rtol=1e-15)
    with pytest.raises(ConfigError, match="mode 2"):
        remove_window_decay(lam, tau)                           # without its std, 0.05 1/s is beyond 0.005


@pytest.mark.parametrize("tau", [0.0, -1.0, np.inf, np.nan])
def test_a_bad_tau_is_refused(tau):
    with pytest.raises(ConfigError, match="tau_s .* must be finite and > 0"):
        remove_window_decay(np.array([-1 + 10j]), tau)
