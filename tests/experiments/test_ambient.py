"""The independent simulator's ambient records: their truth against their own spectra."""

import numpy as np
from scipy import signal

from experiments.benches.bench_oma import score
from experiments.second_sim.ambient import ambient_record
from experiments.second_sim.fem import Beam
from experiments.second_sim.pairs import EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M


def test_ambient_record_spectrum_peaks_at_the_true_modes_and_noise_is_the_fraction_asked():
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    x = LENGTH_M * np.array([0.5, 1.0])
    rec = ambient_record(beam, x, duration_s=60, sampling_frequency_hz=2000, damping=0.01, noise=0.0, seed=3)
    f, p = signal.welch(rec.signals[1], fs=2000, nperseg=2 ** 14)
    for fn in rec.frequencies_hz:       # each mode is the PSD's maximum near it, within half its half-power band
        near = np.abs(f - fn) < 20
        assert abs(f[near][np.argmax(p[near])] - fn) <= max(2 * f[1], 0.01 * fn)
    np.testing.assert_allclose(rec.frequencies_hz[0], 21.706, rtol=1e-4)   # 16 elements: 3.516/(2 pi) sqrt(EI/mL^4)
    noisy = ambient_record(beam, x, duration_s=60, sampling_frequency_hz=2000, damping=0.01, noise=0.03, seed=3)
    resid = noisy.signals - rec.signals
    np.testing.assert_allclose(resid.std(axis=1) / rec.signals.std(axis=1), 0.03, rtol=0.05)


def test_score_counts_matched_modes_and_their_errors():
    phi = np.eye(3)
    s = score((np.array([10.0, 20, 30]), np.array([0.01, 0.01, 0.01]), phi),
              np.array([10.01, 29.0]), np.array([0.011, 0.01]), phi[:, [0, 2]])
    assert s["found"] == 2 and abs(s["max_freq_err_pct"] - 100 / 30) < 1e-9
    assert abs(s["max_damping_err_pct"] - 10) < 1e-9
    assert s["min_mac"] == 1.0
