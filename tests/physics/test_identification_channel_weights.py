"""Channels weighted by their own noise floor before the output-only identification (channel_weights)."""

import warnings

import numpy as np
import pytest
from oma_records import modal_record

from physics.identification import identify_records
from physics.identification.channel_weights import (SPREAD_DB, noise_floor_weights, unweighted_estimate,
                                                    weighted_record)
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.record_checks import check_records
from physics.identification.ssi import MAX_TOEPLITZ_ROWS, MIN_BLOCK_ROWS, _pass_sizes
from physics.io.timedata import TimeRecords

FS_HZ, MODES_HZ, BAND_HZ = 40.0, np.array([4.0, 11.0]), (1.0, 16.0)
#: The loud channel's noise, times the quiet channel's RMS (a shock accelerometer beside a low-g one, unscaled).
LOUD = 100.0


def _records(y, source="two channels"):
    return TimeRecords(1 / FS_HZ, y, tuple(f"ch{k}" for k in range(y.shape[0])), ("acceleration",) * y.shape[0],
                       {"source": source})


def _quiet_and_loud(seed=0):
    """Channel 0: two modes under white noise, sensor noise 10 % of its RMS; channel 1: white noise only, LOUD times
    channel 0's RMS (no mode above it)."""
    quiet = modal_record(MODES_HZ, [0.02, 0.02], [[1.0, 1.0]], seconds=60.0, fs_hz=FS_HZ, noise=0.1, seed=seed)
    loud = LOUD * quiet.std() * np.random.default_rng(100 + seed).standard_normal(quiet.shape)
    return np.vstack([quiet, loud])


def _identify(y, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify_records(_records(y), "auto", BAND_HZ, **kw)


def _found(freqs_hz, tol=0.01):
    """Whether each of MODES_HZ has an identified frequency within ``tol`` (relative)."""
    f = np.asarray(freqs_hz, float)
    return np.array([np.any(np.abs(f - m) <= tol * m) for m in MODES_HZ])


def test_a_loud_noise_channel_hides_the_modes_of_the_quiet_one_unless_each_is_weighted_by_its_noise():
    y = _quiet_and_loud()
    try:
        raw = _identify(y, weigh_channels=False).estimate.natural_frequencies_hz
    except Exception:                          # no stable pole at all: the modes hidden too
        raw = np.zeros(0)
    assert not _found(raw).all()               # the cause: the loud channel's noise fills the leading subspace
    alone = _identify(y[:1]).estimate.natural_frequencies_hz
    assert _found(alone).all()                 # the quiet channel alone holds both modes
    weighted = _identify(y)
    assert _found(weighted.estimate.natural_frequencies_hz).all()
    assert weighted.estimate.shapes.shape == (2, weighted.estimate.natural_frequencies_hz.size)
    np.testing.assert_allclose(np.linalg.norm(weighted.estimate.shapes, axis=0), 1.0, rtol=1e-12)
    # each weight is 1 / sqrt(the channel's floor): the loud channel's white-noise density 2 sigma^2 / fs
    w = weighted.weights
    sigma_loud = LOUD * y[0].std()
    assert w.floor[1] == pytest.approx(2 * sigma_loud ** 2 / FS_HZ, rel=0.15)
    assert w.weights[0] / w.weights[1] == pytest.approx(np.sqrt(w.floor[1] / w.floor[0]), rel=1e-12)
    assert np.prod(w.weights) == pytest.approx(1.0, rel=1e-12)
    assert w.spread_db > 30                    # the loud channel's floor lies 40 dB above the quiet one's


def test_the_weighted_identification_does_not_depend_on_a_channels_units():
    y = _quiet_and_loud(seed=2)
    a = _identify(y).estimate
    scaled = y * np.array([[1.0], [4.0]])      # channel 1 in other units: the weighted record only doubles
    b = _identify(scaled).estimate
    np.testing.assert_allclose(b.natural_frequencies_hz, a.natural_frequencies_hz, rtol=1e-9)
    np.testing.assert_allclose(b.damping_ratios, a.damping_ratios, rtol=1e-6)
    # the shapes are on the recorded channels: channel 1's entry four times larger before normalising
    expect = a.shapes * np.array([[1.0], [4.0]])
    expect /= np.linalg.norm(expect, axis=0)
    np.testing.assert_allclose(np.abs(b.shapes), np.abs(expect), rtol=1e-6, atol=1e-9)


def test_one_channel_is_identified_as_recorded():
    y = _quiet_and_loud()[:1]
    a, b = _identify(y), _identify(y, weigh_channels=False)
    assert a.weights is None
    np.testing.assert_array_equal(a.estimate.natural_frequencies_hz, b.estimate.natural_frequencies_hz)
    w = noise_floor_weights(check_records(y, FS_HZ, BAND_HZ))
    np.testing.assert_array_equal(w.weights, [1.0])
    assert w.spread_db == 0.0


def test_weighting_and_unweighting_are_exact_inverses_on_the_shapes():
    y = _quiet_and_loud()
    checked = check_records(y, FS_HZ, BAND_HZ)
    w = noise_floor_weights(checked)
    wc = weighted_record(checked, w)
    np.testing.assert_allclose(np.asarray(wc.signals), y * w.weights[:, None], rtol=1e-15)
    np.testing.assert_allclose(wc.signals[:, 10:20], y[:, 10:20] * w.weights[:, None], rtol=1e-15)
    np.testing.assert_allclose(wc.signals[1, 5:9], y[1, 5:9] * w.weights[1], rtol=1e-15)
    np.testing.assert_allclose(wc.mean, checked.mean * w.weights, rtol=1e-15)
    # a shape measured on the weighted record is W phi: unweighted, it is phi (unit norm, largest entry real > 0)
    phi = np.array([[0.6 + 0.1j, -0.2], [0.8, 0.98j]])
    phi_w = w.weights[:, None] * phi
    est = ModalEstimate(np.array([4.0, 11.0]), np.full(2, 0.02), np.zeros(2, complex), phi_w,
                        np.zeros((2, 0, 2), complex), np.zeros(2), np.zeros(2), modal_phase_collinearity(phi_w),
                        "ssi", False)
    back = unweighted_estimate(est, w).shapes
    ref = phi / np.linalg.norm(phi, axis=0)
    k = np.argmax(np.abs(ref), axis=0)
    ref = ref * (np.abs(ref[k, [0, 1]]) / ref[k, [0, 1]])
    np.testing.assert_allclose(back, ref, atol=1e-12)
    np.testing.assert_allclose(unweighted_estimate(est, w).mpc, modal_phase_collinearity(ref), atol=1e-12)


@pytest.mark.parametrize("n_ch, rows", [(1, 81), (2, 80), (4, 40), (8, 30)])
def test_a_channel_added_does_not_shorten_the_lags_the_model_order_is_fitted_on(n_ch, rows):
    # max_order 80 with automatic block rows: one channel's rank needs 81 rows; more channels keep the 80 lags the
    # order spans up to the Toeplitz bound of MAX_TOEPLITZ_ROWS rows (160 / n_ch block rows), never below the
    # rank's 80 / n_ch + 1 nor MIN_BLOCK_ROWS
    i, p = _pass_sizes(1000.0, 100_000, None, 0, n_ch, n_ch, 80, None)
    assert i == max(min(80, MAX_TOEPLITZ_ROWS // n_ch), 80 // n_ch + 1, MIN_BLOCK_ROWS) == rows
    assert p == min(80, 2 * (rows * n_ch // 2))


def test_channels_whose_floors_lie_within_a_clear_peaks_height_are_identified_as_recorded():
    quiet = _quiet_and_loud()[:1]
    rng = np.random.default_rng(5)
    # a second channel seeing the modes at half the amplitude, its white noise 3 times the first's: floors about
    # 20 log10(3) = 9.5 dB apart at most (the modes' tails raise the first channel's floor)
    noise = 0.1 * quiet.std()
    y = np.vstack([quiet, 0.5 * quiet + 3 * noise * rng.standard_normal(quiet.shape)])
    w = noise_floor_weights(check_records(y, FS_HZ, BAND_HZ))
    assert 0 < w.spread_db <= SPREAD_DB
    np.testing.assert_array_equal(w.weights, [1.0, 1.0])
    a, b = _identify(y), _identify(y, weigh_channels=False)
    np.testing.assert_array_equal(a.estimate.natural_frequencies_hz, b.estimate.natural_frequencies_hz)
    np.testing.assert_array_equal(a.estimate.shapes, b.estimate.shapes)
