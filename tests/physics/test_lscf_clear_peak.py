"""LSCF on a one-accelerometer cantilever (experiments/second_sim/one_sensor.py, the independent simulator): the 22 Hz
mode, 2 % damped and 24 dB below the higher modes' peaks over a floor rising towards low frequency, is plainly
visible (10 times the floor around it) and is identified with the default band, 0.5-1600 Hz."""

import importlib
import warnings

import numpy as np
import pytest

import experiments.second_sim.one_sensor as osc

lscf = importlib.import_module("physics.identification.lscf")


@pytest.fixture(scope="module")
def tests():
    return [osc.one_sensor_test(seed, floor=0.2) for seed in range(3)]


def test_the_low_peak_is_a_clear_peak_and_no_flank_ripple_is(tests):
    """The clear peaks are the five modes' lines (the octave's median is the floor, not the 2 % mode's own skirt,
    whose median over +-15 % is a quarter of its peak); a ripple of the noise on the 1261 Hz mode's flank is none."""
    for f, a, fn in tests:
        peaks = lscf.octave_median_peaks(f, np.abs(a[0]))
        assert peaks.size == 5
        np.testing.assert_allclose(peaks, fn[:5], rtol=0.015)


def test_lscf_identifies_the_low_mode_with_the_default_band(tests):
    """The whole band's model leaves the 22 Hz mode out (its order goes to the four modes above); the refit
    around the clear peak returns it within 0.6 % of the truth's 22.21 Hz, its damping within 0.6 % of 2 %."""
    for f, a, fn in tests:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est = lscf.identify_lscf(f, a[:, None, :], kind="accelerance").estimate
        assert est.natural_frequencies_hz.size == 5
        np.testing.assert_allclose(est.natural_frequencies_hz, fn[:5], rtol=0.006)
        assert est.damping_ratios[0] == pytest.approx(0.02, abs=0.006)


def test_a_whole_band_without_a_stable_pole_leaves_the_clear_peaks_to_their_own_fits(tests, monkeypatch):
    """Where no pole of the whole band's model is stable over enough orders (unweighted and weighted as the
    measured kind; the pyFRF hits' force-windowed H1, modes damped 0.01-0.15 %), the sub-band and clear-peak fits
    still run: the five modes come out as with a stable whole band, not a refusal."""
    f, a, fn = tests[0]
    real, calls = lscf.select_poles, []

    def unstable_whole_band(diagram, **kw):
        calls.append(diagram.band_hz)
        if len(calls) <= 2:                             # the whole band, unweighted then weighted
            raise lscf.ConvergenceError(lscf.NO_STABLE_POLE)
        return real(diagram, **kw)

    monkeypatch.setattr(lscf, "select_poles", unstable_whole_band)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = lscf.identify_lscf(f, a[:, None, :], kind="accelerance").estimate
    assert len(calls) > 2 and calls[0] == calls[1] == (f[0], f[-1])
    assert est.natural_frequencies_hz.size == 5
    np.testing.assert_allclose(est.natural_frequencies_hz, fn[:5], rtol=0.006)
