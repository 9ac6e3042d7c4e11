"""era on a shock-like record whose two upper modes share one band of the refinement (the DS5 board's layout):
each at its Cramér-Rao bound, where the FFT peak is biased by the neighbours' tails."""

import numpy as np
import pytest
from impact_records import crb_frequency_std_hz, fft_peak_hz, poles

from physics.identification.free_decay import identify_era

FS, N, NOISE = 50000.0, 5000, 2e-3
FN, ZETA, AMP = np.array([804.0, 3909.0, 4768.0]), np.array([0.005, 0.012, 0.012]), np.array([1.0, 0.3, 0.3])


def _record(seed):
    t = np.arange(N) / FS
    lam = poles(FN, ZETA)
    y = AMP @ (np.exp(np.outer(-lam.real, -t)) * np.sin(np.outer(lam.imag, t)))
    return y + NOISE * np.random.default_rng(seed).standard_normal(N)


@pytest.mark.parametrize("seed", [0, 1])
def test_era_reads_both_modes_of_a_shared_band_at_the_bound(seed):
    y = _record(seed)
    crb = crb_frequency_std_hz(FS, N, FN, ZETA, AMP * np.exp(-0.5j * np.pi), NOISE)
    est = identify_era(y[None], FS, (500.0, 5500.0))
    f = est.estimate.natural_frequencies_hz
    got = f[np.argmin(np.abs(f[None, :] - FN[1:, None]), axis=1)]
    assert np.all(np.abs(got - FN[1:]) < 4 * crb[1:])                     # 0.1-0.13 Hz bounds
    j = np.argmin(np.abs(est.bands.natural_frequencies_hz[None, :] - FN[1:, None]), axis=1)
    assert est.bands.group[j[0]] == est.bands.group[j[1]] >= 0                # fitted in one band
    peak = fft_peak_hz(y, FS, FN[1:])
    assert np.all(np.abs(peak - FN[1:]) > 4 * crb[1:])                    # the peak's bias: the neighbours' tails
