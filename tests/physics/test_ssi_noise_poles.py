"""A pole whose band fit holds no more energy than noise is no mode: SSI-cov's extra poles of a free response (its
correlations' error has the modes' spectrum, and a model above the modes' order holds poles beside them) are
dropped after their band refinement (``era`` drops its own after its time-domain fit, ``MIN_MODE_SNR``), against
closed-form decays of :mod:`impact_records`."""

import warnings

import numpy as np
import pytest
from scipy import stats
from impact_records import crb_frequency_std_hz, impact_record, poles

from physics.identification.band_refine import refine_in_bands
from physics.identification.ssi_free_response import NOISE_POLE_PROBABILITY, noise_poles
from physics.identification.free_decay import identify_era
from physics.identification.ssi import identify_ssi

#: One accelerometer, 4 s at 1 kHz, a hit at 0.2 s: 21, 67 and 143 Hz (the last weak: a tenth of the first's shape
#: entry, 0.02 of its amplitude after the 1 / omega of an impulse response).
FS, N, HIT_S = 1000.0, 4000, 0.2
FN, ZETA, SHAPE = np.array([21.0, 67.0, 143.0]), np.array([0.01, 0.01, 0.005]), np.array([1.0, 0.8, 0.1])


def _bound(shape, noise_std):
    """The Cramer-Rao bound (Hz) of each mode's frequency of the decay after the hit."""
    lam = poles(FN, ZETA)
    return crb_frequency_std_hz(FS, N - int(HIT_S * FS), FN, ZETA, shape / np.abs(lam.imag), noise_std)


@pytest.mark.parametrize("noise", [1e-3, 1e-2])
def test_ssi_and_era_keep_the_three_modes_within_four_cramer_rao_bounds_and_no_other(noise):
    """Seeds 1 and 2 at 1e-3 are where SSI-cov's default model orders hold extra stable poles (79.8 Hz, damping
    0.05 %; 100.4 and 125.4 Hz, 2.4 and 3.6 %), seed 1 at 1e-2 too (84.4 Hz), whose amplitudes' chi-squares in
    their band fits are 7-21 (two degrees of freedom; the modes' 10^3-10^9): dropped, and the three modes read as
    ``era`` reads them."""
    for seed in range(3):
        y, _, noise_std = impact_record(FS, N, FN, ZETA, SHAPE[None], [HIT_S], noise, seed)
        bound = _bound(SHAPE, noise_std)
        for identify in (identify_ssi, identify_era):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                f = identify(y, FS).estimate.natural_frequencies_hz
            assert f.size == 3, (identify.__name__, seed, f)
            assert np.all(np.abs(f - FN) < 4 * bound), (identify.__name__, seed, f - FN, bound)


def test_a_weak_mode_far_above_the_noise_is_kept_beside_the_dropped_noise_poles():
    """The 143-Hz mode at a fifth of the shape above (0.004 of the first mode's amplitude, its amplitude's
    chi-square 4-8 x 10^3): kept within four Cramer-Rao bounds where SSI-cov's model also holds noise poles (78.4
    and 99.9 Hz on seeds 1 and 2, chi-square 4 and 9)."""
    _ssi_reads_the_three_modes(SHAPE * np.array([1.0, 1.0, 0.2]), 1e-3, (1, 2))


def test_a_pole_on_noise_beside_a_decay_holds_an_amplitude_chi_square_below_the_threshold_and_the_decay_far_above():
    """One 67-Hz decay in white noise, refined with a second pole started at 90 Hz where the record holds noise
    alone: the decay's amplitude chi-square (one decay and channel: two degrees of freedom) is 0.3-1 times its
    energy over the noise variance (its band's lines alone, a background fitted with it), at every amplitude; the
    pole on noise holds a chi-square of noise's few units, below the threshold ``noise_poles`` sets (30 at two
    degrees of freedom), on every seed, and is told from the decay."""
    lam = poles([67.0], [0.01])[0]
    n, s = 3000, 2e-6
    t = np.arange(n) / FS
    unit = np.real(np.exp(0.7j) * np.exp(lam * t))
    energy = 0.5 * np.sum(np.exp(2 * lam.real * t)) / s ** 2              # per unit amplitude squared
    assert stats.chi2.isf(NOISE_POLE_PROBABILITY, 2) == pytest.approx(30.0)
    for amplitude in (1e-3, 1e-5):
        for seed in range(12):
            y = amplitude * unit + s * np.random.default_rng(seed).standard_normal(n)
            bands = refine_in_bands([y[None]], FS, [lam * 1.001, poles([90.0], [0.01])[0]])
            chi2 = bands.amplitude_chi2
            np.testing.assert_array_equal(bands.amplitude_dof, [2, 2])
            assert 0.3 < chi2[0] / (amplitude ** 2 * energy) < 1.0, (chi2, amplitude ** 2 * energy)
            assert chi2[1] < 20, chi2
            np.testing.assert_array_equal(noise_poles(bands), [False, True])


def test_a_group_whose_band_fit_fails_is_refitted_without_its_weakest_pole():
    """Noise 1e-4, seeds 4, 7 and 9: SSI-cov's model holds a pole beside a mode (21.28, 65.69, 19.85 and 68.56 Hz)
    that its group's band fit draws out of the band or to no damping, so the group's fit fails and its raw poles
    are no band fit's to judge. Refitted without its weakest pole (the least energy with the poles held): the three
    modes within four Cramer-Rao bounds and no other (with the group's raw poles: four or five modes, the 21-Hz
    mode 0.006 Hz and 20 % damping off on seed 4)."""
    _ssi_reads_the_three_modes(SHAPE, 1e-4, (4, 7, 9))


def _ssi_reads_the_three_modes(shape, noise, seeds):
    """SSI on the closed-form decay of ``shape`` at ``noise``: exactly three modes, each within four Cramer-Rao
    bounds of the truth, on every seed."""
    for seed in seeds:
        y, _, noise_std = impact_record(FS, N, FN, ZETA, shape[None], [HIT_S], noise, seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            f = identify_ssi(y, FS).estimate.natural_frequencies_hz
        assert f.size == 3, (seed, f)
        assert np.all(np.abs(f - FN) < 4 * _bound(shape, noise_std)), (seed, f - FN)
