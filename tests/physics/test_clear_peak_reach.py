"""A pole explains a clear peak of the FRFs within a few of the peak's own half-power bandwidths (or lines), never
farther than 2 %: two modes damped 0.1 %, 1 % apart, are two peaks to explain."""

import importlib

import numpy as np
import pytest

from physics.identification.half_power import half_power_bandwidth_hz
from physics.identification.measured import peaks_left_out
from physics.identification.poles import select_poles
from physics.io import MeasuredFRF

lscf = importlib.import_module("physics.identification.lscf")

F1_HZ, F2_HZ, ZETA = 1000.0, 1010.0, 0.001
F_HZ = np.arange(900.0, 1120.0, 0.25)


def _receptance(f_hz, fn_hz, zeta):
    w, wn = 2 * np.pi * f_hz, 2 * np.pi * fn_hz
    return 1.0 / (wn**2 - w**2 + 2j * zeta * wn * w)


def _two_modes():
    """Receptance (1, 1, n_lines) of two modes 1 % apart, each damped 0.1 % (half-power bandwidths 2.0, 2.02 Hz)."""
    return (_receptance(F_HZ, F1_HZ, ZETA) + _receptance(F_HZ, F2_HZ, ZETA))[None, None, :]


def test_the_half_power_bandwidth_of_a_lone_mode_is_two_zeta_f():
    """|H| of one mode at 1000 Hz: 2 zeta f_n = 2 Hz for zeta 0.1 %, 20 Hz for 1 % (0.25 Hz lines, interpolated);
    its reach is 3 bandwidths (6 Hz) when damped 0.1 %, the 2 % cap (20 Hz) when damped 1 %."""
    for zeta in (0.001, 0.01):
        mag = np.abs(_receptance(F_HZ, F1_HZ, zeta))
        peak = [int(np.argmax(mag))]
        assert half_power_bandwidth_hz(F_HZ, mag, peak)[0] == pytest.approx(2 * zeta * F1_HZ, rel=0.01)
    assert lscf.clear_peak_reach_hz(F_HZ, np.abs(_receptance(F_HZ, F1_HZ, 0.001)), peak)[0] \
        == pytest.approx(3 * 2 * 0.001 * F1_HZ, rel=0.01)
    assert lscf.clear_peak_reach_hz(F_HZ, np.abs(_receptance(F_HZ, F1_HZ, 0.01)), peak)[0] \
        == pytest.approx(0.02 * F1_HZ)


def test_a_peak_with_one_side_cut_off_is_doubled_or_nan():
    """The 1000 Hz mode damped 1 % (bandwidth 20 Hz) with the band cut at 1005 Hz: its power |H|^2 falls to half
    on the left only (about 10 Hz below), so ``one_side="double"`` gives twice that distance (read off the rising
    flank by ``np.interp``) and ``"nan"`` NaN; over the whole band the power (ratio 2) gives the bandwidth the
    magnitude (ratio sqrt 2) does. A line above the peak before its crossing is no crossing: on lines 0..5 Hz,
    0.5 1 2 1.8 3 0.5 read from line 2, the left side crosses 2 / sqrt 2 at 2 - (2 - sqrt 2) Hz, the right side
    meets 3 first."""
    power = np.abs(_receptance(F_HZ, F1_HZ, 0.01)) ** 2
    peak = [int(np.argmax(power))]
    cut = F_HZ <= 1005.0
    left_hz = F_HZ[peak[0]] - np.interp(power[peak[0]] / 2, power[:peak[0] + 1], F_HZ[:peak[0] + 1])
    assert left_hz == pytest.approx(10.0, rel=0.03)
    assert half_power_bandwidth_hz(F_HZ[cut], power[cut], peak, ratio=2.0)[0] == pytest.approx(2 * left_hz, rel=1e-12)
    assert np.isnan(half_power_bandwidth_hz(F_HZ[cut], power[cut], peak, ratio=2.0, one_side="nan")[0])
    both = half_power_bandwidth_hz(F_HZ, power, peak, ratio=2.0, one_side="nan")[0]
    assert both == pytest.approx(half_power_bandwidth_hz(F_HZ, np.sqrt(power), peak)[0], rel=1e-3)
    lines, values = np.arange(6.0), np.array([0.5, 1.0, 2.0, 1.8, 3.0, 0.5])
    assert half_power_bandwidth_hz(lines, values, [2])[0] == pytest.approx(2 * (2 - np.sqrt(2.0)), rel=1e-12)
    assert np.isnan(half_power_bandwidth_hz(lines, values, [2], one_side="nan")[0])


def test_a_mode_one_percent_from_a_fitted_one_is_named():
    """Both modes are clear peaks, each reaching 3 half-power bandwidths (6.0 and 6.06 Hz, under the 2 % cap of
    20 Hz). With only the 1000 Hz mode identified the 1010 Hz peak is named (10 Hz, 1 % off: the relative 2 % rule
    took it as explained), and the other way round; identified modes 1 Hz (half a bandwidth) off each peak explain
    both."""
    frf = MeasuredFRF(F_HZ, _two_modes(), ("1:+Z",), ("1:+Z",), kind="receptance")
    peaks, reach = lscf.octave_median_peaks_and_reach(F_HZ, np.abs(frf.frf[0, 0]))
    np.testing.assert_allclose(peaks, [F1_HZ, F2_HZ], atol=0.25)
    np.testing.assert_allclose(reach, [6 * ZETA * F1_HZ, 6 * ZETA * F2_HZ], rtol=0.03)
    np.testing.assert_allclose(peaks_left_out(frf, [F1_HZ]), [F2_HZ], atol=0.25)
    np.testing.assert_allclose(peaks_left_out(frf, [F2_HZ]), [F1_HZ], atol=0.25)
    assert peaks_left_out(frf, [F1_HZ + 1.0, F2_HZ - 1.0]).size == 0
    assert peaks_left_out(frf, [F1_HZ, F2_HZ]).size == 0


def test_the_peak_a_fit_passed_over_is_fitted_again():
    """Poles lacking the 1010 Hz mode: the refit around its clear peak adds its pole (0.01 % off, damping 0.1 % to
    1 %); with both poles, nothing is added."""
    h = _two_modes()
    poles = select_poles(lscf.lscf(F_HZ, h, max_order=12))
    fn = poles.natural_frequencies_hz
    assert np.min(np.abs(fn - F1_HZ)) < 0.1 and np.min(np.abs(fn - F2_HZ)) < 0.1
    lacking = lscf._take(poles, np.flatnonzero(np.abs(fn - F2_HZ) > 1.0))
    merged = lscf._with_peak_poles(F_HZ, h, h, lacking, 12, 0.0, None, {})
    assert merged.natural_frequencies_hz.size == lacking.natural_frequencies_hz.size + 1
    k = int(np.argmin(np.abs(merged.natural_frequencies_hz - F2_HZ)))
    assert merged.natural_frequencies_hz[k] == pytest.approx(F2_HZ, rel=1e-4)
    assert merged.damping_ratios[k] == pytest.approx(ZETA, rel=0.01)
    assert lscf._with_peak_poles(F_HZ, h, h, poles, 12, 0.0, None, {}) is poles
