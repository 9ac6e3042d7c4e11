"""The bias bench's own closed forms: its independent band fit and the peak of ``|A(f) P(f)|``."""

import numpy as np
import pytest

from experiments.benches.bench_bias import band_poles, record_peak_hz
from experiments.benches.impact_records import ImpactCase, frf_peak_hz


def test_band_poles_recover_two_close_noise_free_decays():
    fs, n = 25_600.0, 25_600
    t = np.arange(n) / fs
    y = (96 * np.exp(-37.0 * t) * np.cos(2 * np.pi * 5969.5 * t)
         - 10.5 * np.exp(-15.0 * t) * np.cos(2 * np.pi * 5983.5 * t + 0.3))
    poles, rms = band_poles(y, fs, (5940, 6010), ((5970.0, 30.0), (5984.0, 20.0)))
    np.testing.assert_allclose(poles[:, 0], [5969.5, 5983.5], atol=1e-6)
    np.testing.assert_allclose(poles[:, 1], [37.0, 15.0], rtol=1e-6)
    assert rms < 1e-6


def test_record_peak_of_a_flat_pulse_is_the_accelerance_peak():
    # a pulse of 10 us is flat to 1e-5 over the peak: |A P| peaks where one mode's accelerance does
    case = ImpactCase((900.0,), (0.02,), (1.0,), pulse_s=1e-5, noise_std=0.0)
    assert record_peak_hz(case)[0] == pytest.approx(frf_peak_hz(900.0, 0.02, "accelerance"), abs=1e-3)
    assert record_peak_hz(case)[0] - 900.0 == pytest.approx(0.36, abs=0.005)
