"""A narrow component on a mode's flank that no pole holds (:mod:`physics.identification.band_neighbours`), against
closed-form decays."""

import numpy as np
import pytest

from physics.identification.band_neighbours import band_neighbour, refine_with_neighbours
from physics.identification.band_refine import refine_in_bands

FS, N = 25_600.0, 25_600


def decay(modes, noise, seed):
    """``sum a exp(-zeta w t) cos(w_d t + phase)`` over ``modes`` (f_n Hz, zeta, a, phase) plus white noise."""
    t = np.arange(N) / FS
    y = np.zeros(N)
    for fn, z, a, ph in modes:
        w = 2 * np.pi * fn
        y += a * np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z ** 2) * t + ph)
    return (y + noise * np.random.default_rng(seed).standard_normal(N))[None]


def pole(fn, zeta):
    w = 2 * np.pi * fn
    return complex(-zeta * w, w * np.sqrt(1 - zeta ** 2))


# the pyFRF hits' 5969-Hz mode and the component 14 Hz above it (amplitude 0.11 of the mode's, opposite phase)
MODE, SHOULDER = (5969.5, 0.00099, 96.0, 0.0), (5983.5, 0.0004, 10.5, np.pi)


def test_a_shoulder_in_the_band_is_kept_and_the_mode_read_without_it():
    y = decay([MODE, SHOULDER], 0.25, seed=1)
    alone = refine_in_bands([y], FS, [pole(5970.0, 0.001)])
    assert alone.natural_frequencies_hz[0] - 5969.5 > 0.3        # the one-pole band fit is pulled towards it
    test = band_neighbour([y], FS, alone.eigenvalues[0], alone.bands_hz[0])
    assert test.kept and test.residual_drop > 0.9
    assert abs(test.eigenvalue) / (2 * np.pi) == pytest.approx(5983.5, abs=0.05)
    refit = refine_with_neighbours([y], FS, alone, np.array([True]))
    fn = abs(refit.eigenvalues[0]) / (2 * np.pi)
    assert abs(fn - 5969.5) < 3 * refit.frequency_std_hz[0] and refit.frequency_std_hz[0] < 0.05
    assert refit.neighbours_hz[0] == pytest.approx(5983.5, abs=0.05)


@pytest.mark.parametrize("seed", [2, 3])
def test_a_lone_mode_in_white_noise_keeps_no_neighbour(seed):
    y = decay([MODE], 0.25, seed=seed)
    alone = refine_in_bands([y], FS, [pole(5969.6, 0.001)])
    refit = refine_with_neighbours([y], FS, alone, np.array([True]))
    assert np.isnan(refit.neighbours_hz[0])
    assert refit.eigenvalues[0] == alone.eigenvalues[0]                  # as given, to the bit
    assert not band_neighbour([y], FS, alone.eigenvalues[0], alone.bands_hz[0]).kept


def test_a_mode_of_the_model_is_subtracted_not_taken_for_a_neighbour():
    # the component is a mode of the model here: fixed, it is no neighbour of the first
    y = decay([MODE, (5983.5, 0.0004, 40.0, np.pi)], 0.25, seed=4)
    both = refine_in_bands([y], FS, [pole(5969.6, 0.001), pole(5983.4, 0.0005)])
    refit = refine_with_neighbours([y], FS, both, np.array([True, True]))
    assert np.all(np.isnan(refit.neighbours_hz))
    np.testing.assert_array_equal(refit.eigenvalues, both.eigenvalues)
