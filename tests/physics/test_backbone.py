"""The backbone fit (physics/identification/backbone.py) on closed-form decays: a stiffening decay's zero-amplitude
frequency whatever the hit's amplitude (where the linear band fit follows the amplitude), and a linear decay's
frequency equal to the linear band fit's with no significant shift."""

import numpy as np
import pytest

from physics.errors import ConfigError, ShapeError
from physics.identification.backbone import fit_backbone
from physics.identification.band_refine import refine_in_bands

FS, N, F0, ZETA = 1000.0, 4000, 50.0, 0.005
SIGMA = 2 * np.pi * F0 * ZETA
#: Frequency shift per unit amplitude (Hz): instantaneous frequency ``F0 + K A(t)``.
K_HZ = 0.05


def _decay(amplitude, k_hz, noise=0.0, seed=0):
    """``A e^(-sigma t) cos(2 pi F0 t + 2 pi c (1 - e^(-sigma t)) / sigma + 0.3)``, ``c = k_hz A``, plus white noise."""
    t = np.arange(N) / FS
    c = k_hz * amplitude
    x = amplitude * np.exp(-SIGMA * t) * np.cos(2 * np.pi * F0 * t + 2 * np.pi * c * (1 - np.exp(-SIGMA * t)) / SIGMA
                                                 + 0.3)
    return x + noise * np.random.default_rng(seed).standard_normal(N)


def _linear(x):
    """The linear band fit's pole (the backbone fit's start) and its frequency of oscillation (Hz) and sigma."""
    fit = refine_in_bands([x[None]], FS, [-SIGMA + 2j * np.pi * F0])
    lam = fit.eigenvalues[0]
    return lam, lam.imag / (2 * np.pi), fit.frequency_std_hz[0]


@pytest.mark.parametrize("amplitude", [1.0, 2.0])
def test_a_stiffening_decay_gives_its_zero_amplitude_frequency_whatever_its_amplitude(amplitude):
    x = _decay(amplitude, K_HZ)
    lam, f_lin, _ = _linear(x)
    assert f_lin - F0 > 0.3 * K_HZ * amplitude                   # the linear fit follows the hit's amplitude
    b = fit_backbone(x, FS, lam)
    assert abs(b.frequency_hz - F0) < 2e-4 * K_HZ * amplitude      # noise-free: the model is the decay's
    np.testing.assert_allclose(b.shift_hz, K_HZ * amplitude, rtol=2e-3)
    np.testing.assert_allclose(b.decay_rate, SIGMA, rtol=1e-4)
    np.testing.assert_allclose(abs(b.amplitude), amplitude, rtol=1e-3)
    np.testing.assert_allclose(b.natural_frequency_hz, np.hypot(b.frequency_hz, b.decay_rate / (2 * np.pi)))
    noisy = fit_backbone(_decay(amplitude, K_HZ, noise=0.01, seed=3), FS, lam)
    assert noisy.significant
    assert abs(noisy.frequency_hz - F0) < 2 * noisy.frequency_std_hz
    assert abs(noisy.shift_hz - K_HZ * amplitude) < 2 * noisy.shift_std_hz


def test_a_linear_decay_has_no_significant_shift_and_the_linear_fits_frequency():
    lam, f_lin, _ = _linear(_decay(1.0, 0.0))
    b = fit_backbone(_decay(1.0, 0.0), FS, lam)
    assert abs(b.shift_hz) < 1e-6
    assert abs(b.frequency_hz - f_lin) < 1e-7
    for seed in (1, 2, 3):
        x = _decay(1.0, 0.0, noise=0.01, seed=seed)
        lam, f_lin, f_lin_std = _linear(x)
        b = fit_backbone(x, FS, lam)
        assert not b.significant
        # f0 - f_lin is the part of f0's error the shift adds: its variance is f0's less the linear fit's
        assert abs(b.frequency_hz - f_lin) < 3 * np.sqrt(b.frequency_std_hz ** 2 - f_lin_std ** 2)
        assert b.frequency_std_hz > f_lin_std


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ShapeError, match="decay"):
        fit_backbone(np.zeros((2, 100)), FS, -SIGMA + 2j * np.pi * F0)
    with pytest.raises(ConfigError, match="eigenvalue"):
        fit_backbone(_decay(1.0, 0.0), FS, SIGMA + 2j * np.pi * F0)


def test_a_neighbour_in_the_band_fitted_beside_the_mode_leaves_its_zero_amplitude_frequency():
    t = np.arange(N) / FS
    f_nb, sigma_nb = F0 + 1.5, 1.2 * SIGMA                  # 20 dB down, inside the mode's band
    x = _decay(2.0, K_HZ) + 0.2 * np.exp(-sigma_nb * t) * np.cos(2 * np.pi * f_nb * t + 1.0)
    lam, _, _ = _linear(_decay(2.0, K_HZ))
    alone = fit_backbone(x, FS, lam)
    assert abs(alone.frequency_hz - F0) > 100 * 2e-4 * K_HZ              # the neighbour pulls the fit of one mode
    b = fit_backbone(x, FS, lam, neighbours=[-SIGMA + 2j * np.pi * (f_nb + 0.3)])
    assert abs(b.frequency_hz - F0) < 2e-4 * K_HZ * 2.0
    np.testing.assert_allclose(b.shift_hz, 2 * K_HZ, rtol=2e-3)
    np.testing.assert_allclose(b.neighbours[0], -sigma_nb + 2j * np.pi * f_nb, rtol=1e-7)
