"""Modes crowding within the running floor's window (+-15 %): each is a clear peak by its prominence over the
Welch average's noise, and no ripple between them is one."""

import dataclasses
import warnings

import numpy as np
import pytest
from scipy import signal

from physics.identification.fdd import (FALSE_RIPPLES, SingularValueSpectrum, clear_peaks, identify_fdd, ripple_db,
                                        running_floor)
from physics.identification.ssi import identify_ssi

CROWD_HZ = np.array([1.10, 1.24, 1.40])


def _sdof_psd(f, fn, zeta):
    """``|H(f)|^2`` of a unit SDOF oscillator (displacement over force), closed form."""
    r = f / fn
    return 1.0 / ((2 * np.pi * fn) ** 4 * ((1 - r ** 2) ** 2 + (2 * zeta * r) ** 2))


def _spectrum(averages, seed, df=0.01, top_hz=8.0):
    """A Welch-averaged PSD of three crowded modes and one apart (3.86 Hz), equal modal forces, 1 % damping, and
    white noise 40 dB below the crowd's peaks: the exact density times ``Gamma(averages) / averages`` per line."""
    f = np.arange(int(top_hz / df) + 1) * df
    exact = sum(_sdof_psd(f, fn, 0.01) for fn in (*CROWD_HZ, 3.86))
    exact += 1e-4 * exact.max()
    rng = np.random.default_rng(seed)
    s = exact * rng.gamma(averages, 1.0 / averages, f.size)
    floor = np.full(f.size, np.nan)
    floor[1:] = running_floor(f[1:], s[1:], df)
    return SingularValueSpectrum(f, s[:, None], np.ones((f.size, 1), complex), floor, (0.0, top_hz), 3 * df,
                                 float(averages))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_three_crowded_modes_are_each_a_clear_peak_and_nothing_between(seed):
    sv = _spectrum(30, seed)
    peaks = clear_peaks(sv).frequency_hz
    # the resonant peak of |H|^2 lies at fn sqrt(1 - 2 zeta^2), within a line of fn at 1 % damping
    crowd = peaks[(peaks > 0.9) & (peaks < 1.6)]
    assert crowd.size == 3
    np.testing.assert_allclose(crowd, CROWD_HZ, atol=0.015)
    assert np.any(np.abs(peaks - 3.86) <= 0.015)
    assert peaks.size == 4                                      # no ripple of the noise anywhere in the band


def test_the_running_floor_alone_misses_the_crowd():
    sv = _spectrum(30, 0)
    floor_only = clear_peaks(dataclasses.replace(sv, averages=0.0)).frequency_hz
    assert np.sum((floor_only > 0.9) & (floor_only < 1.6)) < 3     # the floor rides on the crowd's flanks
    assert np.any(np.abs(floor_only - 3.86) <= 0.015)


def test_ripple_bound_holds_on_simulated_noise_spectra():
    """The prominence bound of :func:`ripple_db` against 2000 simulated white-noise averages of 400 lines: the
    share of spectra holding a ripple above it is at most :data:`FALSE_RIPPLES` (a bound: the upper and lower
    quantiles at once), and the largest ripple of a typical spectrum is within a factor 2.5 of it (not vacuous)."""
    k, n = 24, 400
    rng = np.random.default_rng(7)
    db = 10 * np.log10(rng.gamma(k, 1.0 / k, (2000, n)))
    top = np.array([signal.find_peaks(x, prominence=0)[1]["prominences"].max() for x in db])
    bound = ripple_db(k, n)
    assert np.mean(top >= bound) <= FALSE_RIPPLES
    assert np.median(top) >= bound / 2.5
    assert ripple_db(1e7, n) < 0.1                              # a long average: no ripple


def _record(fn, zeta, fs, duration_s, n_channels, seed, noise=0.05):
    """Ambient response: each mode an SDOF filter (impulse-invariant) of its own white force, random shapes."""
    rng = np.random.default_rng(seed)
    n, warm = int(duration_s * fs), int(5 * fs / (2 * np.pi * zeta.min() * fn.min()))
    q = np.empty((fn.size, n + warm))
    for m, (f, z) in enumerate(zip(fn, zeta)):
        w = 2 * np.pi * f
        b, a = signal.cont2discrete(([1.0], [1, 2 * z * w, w * w]), 1 / fs, method="impulse")[:2]
        q[m] = signal.lfilter(np.ravel(b), a, rng.standard_normal(n + warm))
    y = rng.standard_normal((n_channels, fn.size)) @ q[:, warm:]
    return y + noise * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_fdd_finds_three_crowded_modes_of_an_ambient_record(seed):
    """1.0, 1.2 and 1.4 Hz (+-17 %), 1 % damping, six channels, 328 s at 40 Hz (the Welch lines 0.039 Hz apart):
    each mode is the line nearest it or the next, and no other peak lies among them."""
    crowd_hz = np.array([1.0, 1.2, 1.4])
    y = _record(np.array([*crowd_hz, 3.86]), np.full(4, 0.01), 40.0, 328.0, 6, seed)
    got = identify_fdd(y, 40.0, enhanced=False)
    f = got.estimate.natural_frequencies_hz
    crowd = f[(f > 0.8) & (f < 1.7)]
    assert crowd.size == 3                                      # each found, no spurious pick between them
    np.testing.assert_allclose(crowd, crowd_hz, atol=got.spectrum.resolution_hz)
    assert np.sum(np.abs(f - 3.86) <= got.spectrum.resolution_hz) == 1


@pytest.mark.slow
def test_ssi_keeps_two_modes_of_one_unresolved_peak():
    """1.227 and 1.285 Hz (1.5 spectral lines apart: one peak) beside 1.453 Hz: a sub-band pass whose model
    separates the two keeps both, each in place of the whole band's estimate nearest it."""
    fn = np.array([1.227, 1.285, 1.453, 3.856])
    y = _record(fn, np.array([0.015, 0.015, 0.012, 0.01]), 40.0, 328.0, 6, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = identify_ssi(y, 40.0).estimate.natural_frequencies_hz
    near = np.abs(f[:, None] - fn[None, :]).min(axis=0)
    assert np.all(near <= 0.01 * fn)
