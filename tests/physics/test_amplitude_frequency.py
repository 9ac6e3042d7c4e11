"""A mode's frequency at a stated amplitude (physics/identification/amplitude_frequency.py) on closed-form decays:
a stiffening decay with a weaker component beside its band, found by the model-order test and its backbone read at
a reference amplitude; a linear decay, where no neighbour is kept, the shift is not significant and the estimate is
the backbone fitted alone in the mode's own band."""

import numpy as np
import pytest

from physics.errors import ConfigError
from physics.identification.amplitude_frequency import backbone_with_neighbours, frequency_at_amplitude, \
    read_at_amplitude
from physics.identification.backbone import fit_backbone
from physics.identification.band_refine import mode_bands, refine_in_bands

FS, N, F0, ZETA = 1000.0, 4000, 50.0, 0.005
SIGMA = 2 * np.pi * F0 * ZETA
#: Frequency per unit envelope (Hz): instantaneous frequency ``F0 + K A(t)``, and the hit's amplitude.
K_HZ, AMPLITUDE = 0.05, 2.0
#: The neighbour: 3 Hz above the mode (outside its own band of +-2 Hz, inside the band grown by 2), 0.2 of its
#: amplitude, twice its damping.
F_NB, A_NB, SIGMA_NB = F0 + 3.0, 0.2 * AMPLITUDE, 2 * SIGMA
LAM = -SIGMA + 2j * np.pi * F0


def _decay(k_hz, neighbour=True, noise=0.0, seed=0):
    t = np.arange(N) / FS
    c = k_hz * AMPLITUDE
    x = AMPLITUDE * np.exp(-SIGMA * t) * np.cos(2 * np.pi * F0 * t + 2 * np.pi * c * (1 - np.exp(-SIGMA * t)) / SIGMA
                                                + 0.3)
    if neighbour:
        x = x + A_NB * np.exp(-SIGMA_NB * t) * np.cos(2 * np.pi * F_NB * t + 1.0)
    return x + noise * np.random.default_rng(seed).standard_normal(N)


def _truth_hz(a_ref):
    """The undamped natural frequency of the decay's backbone at envelope ``a_ref``."""
    return np.hypot(F0 + K_HZ * a_ref, SIGMA / (2 * np.pi))


def test_the_neighbour_beside_the_band_is_found_and_the_backbone_read_at_the_reference_amplitude():
    band = mode_bands([LAM], N / FS, FS / 2)[0][0]
    assert band[1] < F_NB < F0 + 2 * (band[1] - F0)                  # outside the own band, inside the grown one
    x = _decay(K_HZ)
    f_lin = refine_in_bands([x[None]], FS, [LAM]).natural_frequencies_hz[0]
    assert f_lin - _truth_hz(0.0) > 0.3 * K_HZ * AMPLITUDE          # a linear fit follows the hit's amplitude
    b = backbone_with_neighbours(x, FS, LAM)
    assert b.neighbours.size == 1
    np.testing.assert_allclose(b.neighbours[0], -SIGMA_NB + 2j * np.pi * F_NB, rtol=1e-6)
    for a_ref in (0.0, 1.0):
        est = read_at_amplitude(b, a_ref)
        assert abs(est.natural_frequency_hz - _truth_hz(a_ref)) < 1e-3 * K_HZ * AMPLITUDE   # noise-free
        assert est.reference_amplitude == a_ref
    noisy = frequency_at_amplitude(_decay(K_HZ, noise=0.01, seed=4), FS, LAM, reference_amplitude=0.0)
    assert noisy.backbone.neighbours.size == 1 and noisy.backbone.significant
    for a_ref in (0.0, 1.0):
        est = read_at_amplitude(noisy.backbone, a_ref)
        assert abs(est.natural_frequency_hz - _truth_hz(a_ref)) < 3 * est.frequency_std_hz
    # read nearer the decay's amplitudes, the estimate extrapolates less: its one sigma is smaller
    assert read_at_amplitude(noisy.backbone, 1.0).frequency_std_hz < noisy.frequency_std_hz


def test_the_neighbour_unfitted_pulls_the_zero_amplitude_frequency():
    x = _decay(K_HZ)
    alone = backbone_with_neighbours(x, FS, LAM, max_neighbours=0)
    assert alone.neighbours.size == 0
    assert abs(alone.natural_frequency_hz - _truth_hz(0.0)) > 10 * 1e-3 * K_HZ * AMPLITUDE


@pytest.mark.parametrize("seed", [1, 2])
def test_a_linear_decay_keeps_no_neighbour_no_shift_and_the_own_band_fit(seed):
    x = _decay(0.0, neighbour=False, noise=0.01, seed=seed)
    b = backbone_with_neighbours(x, FS, LAM)
    assert b.neighbours.size == 0 and not b.significant
    own = fit_backbone(x, FS, LAM)
    assert b.frequency_hz == own.frequency_hz and b.shift_hz == own.shift_hz    # the own-band fit, unchanged
    np.testing.assert_array_equal(b.band_hz, own.band_hz)
    fit = refine_in_bands([x[None]], FS, [LAM])
    f_lin, f_lin_std = fit.natural_frequencies_hz[0], fit.frequency_std_hz[0]
    est = read_at_amplitude(b, 0.0)
    assert est.natural_frequency_hz == b.natural_frequency_hz
    assert abs(est.natural_frequency_hz - f_lin) < 3 * np.sqrt(est.frequency_std_hz ** 2 - f_lin_std ** 2)


def test_bad_options_are_refused_in_one_line():
    x = _decay(0.0, neighbour=False)
    with pytest.raises(ConfigError, match="reference_amplitude"):
        frequency_at_amplitude(x, FS, LAM, reference_amplitude=-1.0)
    with pytest.raises(ConfigError, match="reference_amplitude"):
        read_at_amplitude(fit_backbone(x, FS, LAM), reference_amplitude=np.nan)
    with pytest.raises(ConfigError, match="max_neighbours"):
        backbone_with_neighbours(x, FS, LAM, max_neighbours=-1)
