"""The closed-form hammer hits of :mod:`experiments.benches.impact_records` against their own Fourier transforms and
the peak of one mode's FRF against its closed form."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from experiments.benches.impact_records import ImpactCase, accelerance, frf_peak_hz, impact_records, pulse_spectrum
from physics.errors import ShapeError


def test_record_transform_is_accelerance_times_the_pulse():
    # a record that has decayed by its end: its DFT / fs is the continuous transform A(f) P(f)
    case = ImpactCase((900.0, 2640.0), (0.01, 0.005), (80.0, -40.0), noise_std=0.0)
    force, acc = impact_records(case, 1, seed=0)
    fs = case.sampling_frequency_hz
    f = np.fft.rfftfreq(acc.shape[1], 1 / fs)
    band = (f > 100) & (f < 8000)
    want = accelerance(case, f[band]) * pulse_spectrum(case, f[band])
    got = np.fft.rfft(acc[0])[band] / fs
    assert np.max(np.abs(got - want)) < 5e-4 * np.max(np.abs(want))
    # each mode rings at its stated amplitude just after the pulse (t = 2 ms: mode 1 alone rings at about 80)
    assert np.max(np.abs(force[0])) == pytest.approx(case.force_peak, rel=0.02)


def test_records_are_seeded_and_the_noise_is_white_of_the_stated_level():
    case = ImpactCase((900.0,), (0.01,), (80.0,), noise_std=0.25)
    a1, a2 = impact_records(case, 3, seed=4)[1], impact_records(case, 3, seed=4)[1]
    assert np.array_equal(a1, a2)
    noise = a1 - impact_records(ImpactCase((900.0,), (0.01,), (80.0,), noise_std=0.0), 1, seed=0)[1]
    assert np.std(noise) == pytest.approx(0.25, rel=0.01)


@pytest.mark.parametrize("kind, k", [("receptance", 0), ("mobility", 1), ("accelerance", 2)])
def test_one_mode_frf_peak_closed_form(kind, k):
    # |(i w)^k / (w_n^2 - w^2 + 2 i zeta w_n w)| maximised numerically against f_n (1 - 2 zeta^2)^((1 - k) / 2)
    fn, zeta = 900.0, 0.03
    wn = 2 * np.pi * fn

    def neg(f):
        w = 2 * np.pi * f
        return -abs((1j * w) ** k / (wn ** 2 - w ** 2 + 2j * zeta * wn * w))

    peak = minimize_scalar(neg, bounds=(0.9 * fn, 1.1 * fn), method="bounded", options={"xatol": 1e-9}).x
    assert peak == pytest.approx(frf_peak_hz(fn, zeta, kind), abs=1e-4)      # the search's resolution on a flat top
    assert peak - fn == pytest.approx({0: -0.81, 1: 0.0, 2: +0.81}[k], abs=0.01)   # f_n zeta^2 = 0.81 Hz


def test_refusals():
    with pytest.raises(ShapeError):
        frf_peak_hz(900.0, 0.01, "strain")
    with pytest.raises(ShapeError):
        impact_records(ImpactCase((900.0, 950.0), (0.01,), (1.0, 1.0)), 1, seed=0)
