"""SSI-cov on a free response starts a mode at each clear peak of its decays' spectrum that no refined pole holds,
as ``era`` does (:func:`~physics.identification.peak_seeds.seed_unheld_peaks`), against closed-form decays of
:mod:`impact_records`."""

import warnings

import numpy as np
from impact_records import crb_frequency_std_hz, fft_peak_hz, impact_record, poles

from physics.identification.ssi import identify_ssi

#: One accelerometer, 4 s at 1 kHz, a hit at 0.2 s: a strong 21-Hz mode, 67 Hz, and a weak 143-Hz mode (a tenth of
#: the first's shape entry, 0.02 of its amplitude after the 1 / omega of an impulse response).
FS, N, HIT_S = 1000.0, 4000, 0.2
FN, ZETA, SHAPE = np.array([21.0, 67.0, 143.0]), np.array([0.01, 0.01, 0.005]), np.array([1.0, 0.8, 0.1])
NOISE = 1e-3


def test_the_clear_peaks_a_low_order_model_leaves_without_a_stable_pole_are_each_refined_at_their_peak():
    """Model orders up to 6 keep only the 21-Hz pole stable (SSI-cov alone names 66.4 and 144.5 Hz as clear peaks
    without a mode); the 67- and 143-Hz modes start at their peaks and are refined in their bands: each within 4
    of its Cramer-Rao bound of the truth, its one sigma (the band fit's: its lines alone, a background fitted
    with it) 0.8-2 times that bound, flagged weakly stable, no peak left."""
    n = N - int(HIT_S * FS)
    lam = poles(FN, ZETA)
    crb = crb_frequency_std_hz(FS, n, FN, ZETA, SHAPE / np.abs(lam.imag), 1.0)     # per unit noise
    for seed in range(3):
        y, _, noise_std = impact_record(FS, N, FN, ZETA, SHAPE[None], [HIT_S], NOISE, seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = identify_ssi(y, FS, max_order=6)
        est = res.estimate
        assert est.natural_frequencies_hz.size == 3, est.natural_frequencies_hz
        bound = crb * noise_std
        assert np.all(np.abs(est.natural_frequencies_hz - FN) < 4 * bound), (est.natural_frequencies_hz, bound)
        assert np.all((est.frequency_std_hz[1:] > 0.8 * bound[1:]) & (est.frequency_std_hz[1:] < 2 * bound[1:])), \
            (est.frequency_std_hz, bound)
        np.testing.assert_array_equal(est.weakly_stable, [False, True, True])
        np.testing.assert_allclose(res.seeded.peak_hz, fft_peak_hz(y[0], FS, FN[1:]), atol=FS / n)
        assert res.unexplained_hz.size == 0, res.unexplained_hz


def test_n_modes_keeps_the_highest_seeded_peak_and_the_unrefined_fallback_seeds_none():
    """``n_modes=2``: the stable 21-Hz mode and the higher of the two seeded peaks (67 Hz). ``refine_decays=False``
    (``identify_records``' fallback) keeps SSI-cov's poles alone: the 21-Hz mode, the two peaks left unexplained."""
    y = impact_record(FS, N, FN, ZETA, SHAPE[None], [HIT_S], NOISE, 0)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        two = identify_ssi(y, FS, max_order=6, n_modes=2)
        bare = identify_ssi(y, FS, max_order=6, refine_decays=False)
    np.testing.assert_allclose(two.estimate.natural_frequencies_hz, FN[:2], rtol=1e-4)
    np.testing.assert_allclose(two.unexplained_hz, [FN[2]], atol=2.0)
    assert bare.seeded is None and bare.bands is None
    np.testing.assert_allclose(bare.estimate.natural_frequencies_hz, FN[:1], rtol=1e-4)
    assert bare.unexplained_hz.size == 2, bare.unexplained_hz
