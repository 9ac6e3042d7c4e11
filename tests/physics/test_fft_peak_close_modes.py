"""fftpeak on two free-decay modes closer than 1 % of their frequency (the clear peaks' tolerance): each keeps its own
FFT peak, the weaker one not taken by its stronger neighbour's top."""

import numpy as np

from physics.identification.fft_peak import identify_fft_peaks

FS_HZ = 2000.0


def test_two_modes_closer_than_the_tolerance_are_both_found():
    t = np.arange(int(2 * FS_HZ)) / FS_HZ
    tau, on = np.clip(t - 0.1, 0, None), t >= 0.1
    y = np.zeros((1, t.size))
    for f, a in ((400.0, 1.0), (403.5, 0.3)):                    # 3.5 Hz apart; 1 % of 403.5 Hz is 4.035 Hz
        w = 2 * np.pi * f
        y[0] += a * on * np.exp(-0.0005 * w * tau) * np.sin(w * tau)
    y += 1e-4 * np.random.default_rng(0).standard_normal(y.shape)
    est, _ = identify_fft_peaks(y, FS_HZ, (300, 500))
    np.testing.assert_allclose(est.natural_frequencies_hz, [400.0, 403.5], atol=0.1)
