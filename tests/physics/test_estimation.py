"""Tests of H1/H2/Hv estimation and coherence on simulated random-excitation tests."""

import numpy as np
import pytest

from physics.errors import ShapeError
from physics.estimation import estimate_frf
from physics.frf import receptance

FS = 1024.0
NSEG = 1024


def two_dof():
    M = np.diag([1.0, 0.5])
    K = np.array([[3e5, -1e5], [-1e5, 1e5]])
    C = 1e-4 * K + np.array([[2.0, 0], [0, 0.0]])  # non-proportional
    return M, C, K


def blockwise_response(force, H_bins):
    """Filter each NSEG block of random force through H exactly (circular steady state per block)."""
    n_i, n = force.shape
    F = np.fft.rfft(force.reshape(n_i, -1, NSEG), axis=-1)  # (n_i, blocks, bins)
    X = np.einsum("oik,ibk->obk", H_bins, F)
    return np.fft.irfft(X, n=NSEG, axis=-1).reshape(H_bins.shape[0], n)


def exact_bins(reference):
    M, C, K = two_dof()
    f = np.fft.rfftfreq(NSEG, 1 / FS)
    H = receptance(M, C, K, 2 * np.pi * f, reference=reference)
    return f, H


@pytest.mark.parametrize("reference", [[1], [0, 1]])
def test_boxcar_blocks_give_exact_frf_and_unit_coherence(reference):
    f, H = exact_bins(reference)
    rng = np.random.default_rng(0)
    force = rng.normal(size=(len(reference), 8 * NSEG))
    x = blockwise_response(force, H)
    est = estimate_frf(force, x, FS, NSEG, noverlap=0, window="boxcar")
    k = slice(1, NSEG // 2)  # drop DC and Nyquist bins
    np.testing.assert_allclose(est.frequency_hz, f)
    np.testing.assert_allclose(est.h1[..., k], H[..., k], rtol=1e-9)
    np.testing.assert_allclose(est.hv[..., k], H[..., k], rtol=1e-7)
    np.testing.assert_allclose(est.multiple_coherence[:, k], 1.0, atol=1e-9)
    if len(reference) == 1:
        np.testing.assert_allclose(est.h2[..., k], H[..., k], rtol=1e-9)
        np.testing.assert_allclose(est.coherence[..., k], 1.0, atol=1e-9)
    else:
        assert est.h2 is None
        assert np.all(est.coherence[..., k] < 1.0 + 1e-12)
    assert est.n_averages == 8


def test_noise_bias_h1_h2_closed_forms():
    """Force noise of variance s^2 biases H1 by 1/(1+s^2) and leaves H2 unbiased; Hv lies between."""
    f, H = exact_bins([1])
    rng = np.random.default_rng(1)
    force = rng.normal(size=(1, 400 * NSEG))
    x = blockwise_response(force, H)
    s2 = 0.25
    measured_force = force + np.sqrt(s2) * rng.normal(size=force.shape)
    est = estimate_frf(measured_force, x, FS, NSEG, noverlap=0, window="boxcar")
    k = slice(5, NSEG // 2 - 5)
    r1 = np.abs(est.h1[..., k] / H[..., k])
    r2 = np.abs(est.h2[..., k] / H[..., k])
    rv = np.abs(est.hv[..., k] / H[..., k])
    assert np.median(r1) == pytest.approx(1 / (1 + s2), rel=0.02)
    assert np.median(r2) == pytest.approx(1.0, rel=0.02)
    assert np.all(np.median(r1) < np.median(rv)) and np.median(rv) < np.median(r2) + 0.01
    # coherence = 1/(1+s^2) for force noise on white input
    assert np.median(est.coherence[..., k]) == pytest.approx(1 / (1 + s2), rel=0.03)


def test_hann_welch_recovers_frf_of_white_noise_through_model_within_bias():
    """Continuous white-noise excitation (no block alignment): Hann, 50 % overlap, resolution bias only."""
    M, C, K = two_dof()
    n = 200 * NSEG
    rng = np.random.default_rng(2)
    force = rng.normal(size=n)
    # steady periodic response of the whole record, computed by FFT filtering
    f_all = np.fft.rfftfreq(n, 1 / FS)
    H_all = receptance(M, C, K, 2 * np.pi * f_all, response=[0, 1], reference=[1])[:, 0, :]
    x = np.fft.irfft(H_all * np.fft.rfft(force), n=n)
    est = estimate_frf(force, x, FS, NSEG)
    _, H = exact_bins([1])
    k = (est.frequency_hz > 5) & (est.frequency_hz < 500)
    err = np.abs(est.h1[:, 0, k] - H[:, 0, k]) / np.abs(H[:, 0, k])
    assert np.median(err) < 0.01 and np.max(err) > 0.1  # resolution bias at the lightly damped peaks
    # expected bias: H smoothed by the window's power spectral kernel |W|^2 (white input)
    ratio = n // NSEG
    w = np.zeros(n)
    w[:NSEG] = np.hanning(NSEG + 1)[:-1]
    W2 = np.abs(np.fft.fft(w)) ** 2
    m = np.arange(-10 * ratio, 10 * ratio + 1)
    kernel = W2[m] / W2.sum()
    bins = np.nonzero(k)[0]
    H_bias = np.array([[np.sum(H_all[o, b * ratio + m] * kernel) for b in bins] for o in range(2)])
    err_bias = np.abs(est.h1[:, 0, k] - H_bias) / np.abs(H_bias)
    assert np.max(err_bias) < 0.05 and np.max(err_bias) < 0.2 * np.max(err)  # 3 % vs 24 %
    assert np.median(est.coherence[:, 0, k]) > 0.99


def test_bad_inputs():
    with pytest.raises(ShapeError):
        estimate_frf(np.ones(100), np.ones(99), FS, 32)
    with pytest.raises(ShapeError):
        estimate_frf(np.ones(100), np.ones(100), FS, 1000)
