"""Free decays as real impact tests record them: heavily oversampled (the sampling rate 200 times the first mode),
many modes above the band of interest, a short decay beside a long one, dense modes whose peaks stand less than
10 dB above a running median of the spectrum. Frequencies against the closed form of :mod:`impact_records`."""

import re
import warnings

import numpy as np
import pytest
from impact_records import impact_record

from physics.errors import ConvergenceError, ShapeError
from physics.identification.decay_peaks import noise_line_db
from physics.identification.fdd import clear_peaks
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.decays import decay_spectrum, find_decays
from physics.identification.free_decay import identify_era
from physics.identification.record_checks import check_records

#: Three accelerometers at 2400 Hz, 200 times the first mode (12 Hz); modes 12, 17, 25 Hz in the band of interest.
FS = 2400.0
LOW_HZ = np.array([12.0, 17.0, 25.0])
BAND_HZ = (5.0, 40.0)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def _many_modes_record(seed, noise=1e-4):
    """8 s, one hit at 1 s, the three low modes and 20 more from 60 to 900 Hz (more poles than the hit detector's
    linear predictor holds): its one-step prediction error stays far above the noise while the decay is loud."""
    rng = np.random.default_rng(5)
    fn = np.concatenate([LOW_HZ, np.geomspace(60.0, 900.0, 20)])
    phi = rng.uniform(-1.0, 1.0, (3, fn.size))
    phi[:, 3:] *= 0.7
    return impact_record(FS, int(8 * FS), fn, np.full(fn.size, 0.01), phi, [1.0], noise, seed)[0]


@pytest.mark.parametrize("seed", [0, 1])
def test_a_decay_starts_where_the_response_to_the_hit_stops_growing(seed):
    """The predictor's errors stay above its threshold for ~0.2 s after the hit (40 dB of decay above the noise);
    the decay starts at the response's first crest (a quarter period of 12 Hz, 50 samples), not at the end of that
    run, and era identifies the low modes in the band to 1e-4."""
    y = _many_modes_record(seed)
    d = find_decays(check_records(y, FS), lowest_hz=LOW_HZ[0])
    hit = int(FS)
    assert d.starts.size == 1 and d.stops[0] == y.shape[1]
    assert hit < d.starts[0] <= hit + FS / (4 * LOW_HZ[0]) + 24         # a quarter period + the predictor's order
    res = _quiet(identify_era, y, FS, BAND_HZ)
    f = res.estimate.natural_frequencies_hz
    np.testing.assert_allclose(f[np.argmin(np.abs(f[:, None] - LOW_HZ), axis=0)], LOW_HZ, rtol=1e-4)
    assert res.decimation == int(FS // (2.5 * BAND_HZ[1]))


@pytest.mark.parametrize("gap_s", [0.1, 0.3])
def test_a_short_decay_beside_a_long_one_does_not_shrink_the_model(gap_s):
    """A second hit 0.1-0.3 s after the first: the first decay holds 4-12 decimated samples. The Hankel's rows
    come from the longest decay (the short one left out), so the model keeps its orders and every low mode."""
    fn = np.array([12.0, 17.0, 25.0, 160.0])
    phi = np.array([[1.0, 0.6, -0.5, 0.8], [0.7, -0.9, 0.6, -0.6], [0.4, 0.8, 1.0, 0.5]])
    y = impact_record(FS, int(8 * FS), fn, [0.012, 0.01, 0.008, 0.015], phi, [1.0, 1.0 + gap_s], 1e-3, 0,
                      hit_gains=[1.0, -3.0])[0]
    res = _quiet(identify_era, y, FS, BAND_HZ)
    assert res.decays.starts.size == 2 and res.block_rows == 160 // 3
    f = res.estimate.natural_frequencies_hz
    np.testing.assert_allclose(f[np.argmin(np.abs(f[:, None] - LOW_HZ), axis=0)], LOW_HZ, rtol=1e-4)


def test_a_decay_too_short_is_refused_with_its_own_length_and_the_need():
    """A hit 0.08 s before the record ends: the one decay holds ~190 samples, the band's decimation by 24 needs
    (2 x 3 block rows + the filter's margin of 4) x 24 = 240; the message quotes both, the first below the second."""
    y = impact_record(FS, int(3 * FS), LOW_HZ, [0.01, 0.01, 0.01], np.ones((1, 3)), [2.92], 1e-3, 0)[0]
    with pytest.raises(ShapeError) as err:
        _quiet(identify_era, y, FS, BAND_HZ)
    holds, need = map(int, re.search(r"holds (\d+) samples .* at least (\d+) samples", str(err.value)).groups())
    d = find_decays(check_records(y, FS, BAND_HZ), lowest_hz=BAND_HZ[0])
    assert holds == int(np.max(d.stops - d.starts)) < need == 240


def test_dense_modes_less_than_10_db_above_the_running_median_are_clear_peaks():
    """Ten modes 1.2 Hz apart (30-40.8 Hz, 0.5 % damping), every other one 8 dB weaker: within +-15 % of each mode
    lie eight others, so the running median rides on their flanks and the five strong peaks stand less than 10 dB
    above it (the plain rule keeps at most one), though 10 dB above their valleys. fftpeak finds all five."""
    fn = np.arange(30.0, 42.0, 1.2)
    y = impact_record(500.0, 4000, fn, np.full(fn.size, 0.005), np.array([[1.0, 0.4] * 5]), [0.0], 1e-3, 0)[0]
    checked = check_records(y, 500.0)
    plain = clear_peaks(decay_spectrum(checked))
    assert plain.frequency_hz.size <= 1
    got = identify_fft_peaks(y, 500.0)[0].natural_frequencies_hz
    strong = fn[::2]
    assert got.size == strong.size
    np.testing.assert_allclose(got, strong, atol=0.05)                 # the neighbours' flanks move each by < 0.04 Hz


def test_the_noise_line_level_is_passed_by_the_stated_share_of_noise_lines():
    """Mean of three exponential line powers (white noise, three lines averaged): the share of 2e6 draws above
    ``noise_line_db(10)`` over their median is 0.01 / 10 (binomial one sigma ~2 %)."""
    rng = np.random.default_rng(0)
    p = rng.exponential(size=(2_000_000, 3)).mean(axis=1)
    share = np.mean(10 * np.log10(p / np.median(p)) > noise_line_db(10))
    assert share == pytest.approx(1e-3, rel=0.1)


def test_a_decay_without_a_clear_peak_is_refused_naming_both_rules():
    """Decaying white noise (a free decay by its envelope, no mode; 3 s time constant in 8 s): fftpeak refuses it,
    naming the 10 dB over the floor and the prominent-peak level of its 1590 lines, above white noise's 8.05 dB
    (the envelope correlates neighbouring lines, fewer independent ones in each average) and below 12.4 dB (one)."""
    rng = np.random.default_rng(1)
    t = np.arange(4000) / 500.0
    y = (rng.standard_normal(4000) * np.exp(-t / 3.0))[None, :]
    with pytest.raises(ConvergenceError) as err:
        identify_fft_peaks(y, 500.0)
    level = float(re.search(r"nor 10 dB above its valleys and ([\d.]+) dB above its floor, in 0-200 Hz",
                            str(err.value)).group(1))
    assert noise_line_db(1590) + 0.3 < level < noise_line_db(1590, dof=1.0)


def _tip_record(f0_hz, width, hits, seed):
    """5 kHz, two modes (``f0_hz``, 3.1 ``f0_hz``), each hit ``(sample, gain)`` a half-sine force over ``width``
    samples (a hammer tip), noise 1e-3 of the peak."""
    fs, n = 5000.0, 8000
    t = np.arange(n) / fs
    h = sum(a * np.exp(-z * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * np.sqrt(1 - z * z) * t)
            for f, z, a in [(f0_hz, 0.01, 1.0), (3.1 * f0_hz, 0.02, 0.5)])
    force = np.zeros(n)
    for at, gain in hits:
        force[at:at + width] += gain * np.sin(np.pi * (np.arange(width) + 0.5) / width)
    x = np.convolve(force, h)[:n]
    return check_records((x / np.abs(x).max() + 1e-3 * np.random.default_rng(seed).standard_normal(n))[None, :], fs)


@pytest.mark.parametrize("f0_hz", [40.0, 120.0, 400.0])
@pytest.mark.parametrize("width", [5, 8, 16])
def test_a_hit_whose_force_lasts_many_samples_is_one_hit_with_its_onset(f0_hz, width):
    """The response to a tip's force grows for its duration, and the energy's rise is seen in bursts: one hit, its
    decay's onset within a few samples of the force's first (the samples from there hold the whole response)."""
    d = find_decays(_tip_record(f0_hz, width, [(100, 1.0)], 0))
    assert d.hits.size == 1 and d.starts.size == 1, d
    assert 100 <= d.onsets[0] <= 106


@pytest.mark.parametrize("f0_hz", [40.0, 120.0, 400.0])
@pytest.mark.parametrize("width", [1, 8])
def test_a_second_hit_after_the_response_peaked_is_a_hit_of_its_own(f0_hz, width):
    """A hit twice as strong 400 samples after the first: two hits, the second's onset at its force."""
    d = find_decays(_tip_record(f0_hz, width, [(100, 1.0), (500, 2.0)], 1))
    assert d.hits.size == 2, d
    assert 500 <= d.onsets[-1] <= 506
