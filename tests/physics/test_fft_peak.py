"""The zero-padded FFT peak (:mod:`physics.identification.fft_peak`) against closed forms."""

import numpy as np
import pytest

from physics.errors import ConvergenceError, ShapeError
from physics.identification import METHODS, identify_records
from experiments.benches.impact_records import ImpactCase, impact_records
from physics.identification.fft_peak import fft_peaks, identify_fft_peaks, natural_from_peak
from physics.io.timedata import TimeRecords

FS = 1000.0


def damped(fn_hz, zeta, amp, duration_s, phase=0.0):
    """Sum of ``amp exp(-zeta w t) sin(w_d t + phase)`` over modes, shape (n_samples,)."""
    t = np.arange(int(duration_s * FS)) / FS
    fn, z, a = (np.atleast_1d(np.asarray(v, float))[:, None] for v in (fn_hz, zeta, amp))
    w = 2 * np.pi * fn
    return np.sum(a * np.exp(-z * w * t) * np.sin(w * np.sqrt(1 - z ** 2) * t + phase), axis=0)


def test_sinusoid_frequency_bias_far_below_the_resolution():
    # an undamped sinusoid between two lines of the record's resolution (1 / T = 0.25 Hz): Hann window (stationary)
    y = damped(37.113, 0.0, 1.0, 4.0, phase=0.3)[None]
    res = fft_peaks(y, FS, [37.0], 1.0)
    assert res.window == "hann" and res.resolution_hz == pytest.approx(0.25)
    assert abs(res.frequency_hz[0] - 37.113) < 0.01 * res.resolution_hz
    assert np.isnan(res.damping_ratios[0])                     # the window's width, not a mode's
    assert res.natural_frequencies_hz[0] == res.frequency_hz[0]


def test_damped_sinusoid_frequency_and_half_power_damping():
    # a free decay that dies out within the record: no window; peak at the damped frequency, half-width zeta f
    fn, zeta = 48.37, 0.01
    y = damped(fn, zeta, 1.0, 4.0)[None]
    res = fft_peaks(y, FS, [48.0], 2.0)
    assert res.window == "none"
    assert abs(res.natural_frequencies_hz[0] - fn) < 0.01 * res.resolution_hz
    assert res.damping_ratios[0] == pytest.approx(zeta, rel=0.05)


def test_two_channels_sum_their_power_and_give_the_shape():
    y1 = damped([20.2, 61.7], [0.01, 0.01], [1.0, 0.5], 4.0)
    y2 = damped([20.2, 61.7], [0.01, 0.01], [-0.5, 1.0], 4.0)
    res = fft_peaks(np.array([y1, y2]), FS, [20.0, 62.0], 1.0)
    np.testing.assert_allclose(res.natural_frequencies_hz, [20.2, 61.7], atol=0.003)
    ratio = res.values[1] / res.values[0]                      # modal amplitude ratio at each peak, real
    np.testing.assert_allclose(ratio.real, [-0.5, 2.0], rtol=0.03)
    assert np.all(np.abs(ratio.imag) < 0.05 * np.abs(ratio.real))


def test_no_peak_within_the_tolerance_is_nan():
    y = damped(30.0, 0.01, 1.0, 4.0)[None]
    res = fft_peaks(y, FS, [30.0, 100.0], [0.5, 0.01])     # side-lobe maxima ~0.25 Hz apart, none in +-0.01
    assert np.isfinite(res.frequency_hz[0]) and np.isnan(res.frequency_hz[1]) and np.isnan(res.values[0, 1])


def test_registered_method_finds_the_clear_peaks_of_a_noisy_decay():
    rng = np.random.default_rng(3)
    truth = np.array([12.0, 75.2, 210.6])
    y = damped(truth, [0.01, 0.005, 0.02], [1.0, 0.5, 0.25], 4.0) + 1e-3 * rng.standard_normal(4000)
    spec = METHODS["fftpeak"]
    assert spec.data == "records" and not spec.yields_uncertainty
    est, diagram = spec.fit(y[None], FS, None, None, "decay")
    assert diagram is None and est.method == "fftpeak"
    np.testing.assert_allclose(est.natural_frequencies_hz, truth, rtol=2e-3)
    np.testing.assert_allclose(np.abs(est.shapes), 1.0)
    rec = TimeRecords(1 / FS, y[None], ("1:+Y",), ("acceleration",), {"source": "decay"})
    ident = identify_records(rec, "fftpeak", n_modes=1)       # the clear peak highest above the floor:
    np.testing.assert_allclose(ident.estimate.natural_frequencies_hz, truth[1:2], rtol=1e-3)   # 0.5 %, narrowest


def test_refusals_are_one_line_project_errors():
    with pytest.raises(ShapeError):
        fft_peaks(np.zeros((1, 100)), FS, [10.0], 1.0)         # constant channel
    with pytest.raises(ShapeError, match="window"):
        fft_peaks(damped(30.0, 0.01, 1.0, 1.0)[None], FS, [30.0], 1.0, window="flattop")
    rng = np.random.default_rng(0)
    with pytest.raises(ConvergenceError, match="no peak"):
        identify_fft_peaks(rng.standard_normal((1, 4000)), FS)   # white noise: no clear peak


@pytest.mark.parametrize("quantity, k", [("displacement", 0), ("velocity", 1), ("acceleration", 2)])
def test_natural_from_peak_inverts_one_mode_frf_peak(quantity, k):
    # the peak of |(i w)^k / (w_n^2 - w^2 + 2 i zeta w_n w)| (closed form: where d|H|^2/dw = 0), converted back
    fn, zeta = 210.6, 0.05
    r = (1 - 2 * zeta ** 2) ** 0.5
    peak = fn * {0: r, 1: 1.0, 2: 1 / r}[k]
    w = 2 * np.pi * np.array([peak - 1e-4, peak, peak + 1e-4])
    mag = np.abs((1j * w) ** k / ((2 * np.pi * fn) ** 2 - w ** 2 + 2j * zeta * 2 * np.pi * fn * w))
    assert mag[1] > mag[0] and mag[1] > mag[2]                 # it is the peak
    assert natural_from_peak([peak], [zeta], quantity)[0] == pytest.approx(fn, rel=1e-12)
    assert natural_from_peak([peak], [np.nan], quantity)[0] == peak     # no damping ratio: the peak itself


def test_acceleration_record_natural_frequency_by_its_quantity():
    # a hammer hit's acceleration (closed form) peaks at f_n / sqrt(1 - 2 zeta^2), 0.04 Hz above f_n here; read as
    # the analytic decay's damped frequency it is put 0.06 Hz above f_n, read as an acceleration within 0.01 Hz
    case = ImpactCase((100.0,), (0.02,), (1.0,), sampling_frequency_hz=10_000.0, n_samples=40_000,
                      pretrigger_s=1e-3, pulse_s=3e-4, noise_std=0.0)
    acc = impact_records(case, 1, seed=0)[1]
    acc_peaks = fft_peaks(acc, case.sampling_frequency_hz, [100.0], 5.0, quantity="acceleration")
    plain = fft_peaks(acc, case.sampling_frequency_hz, [100.0], 5.0)
    assert acc_peaks.frequency_hz[0] - 100.0 == pytest.approx(0.04, abs=0.01)
    assert abs(acc_peaks.natural_frequencies_hz[0] - 100.0) < 0.01
    assert plain.natural_frequencies_hz[0] - 100.0 > 0.05
    with pytest.raises(ShapeError):
        fft_peaks(acc, case.sampling_frequency_hz, [100.0], 5.0, quantity="strain")


def test_identify_records_passes_the_channels_quantity():
    case = ImpactCase((100.0,), (0.02,), (1.0,), sampling_frequency_hz=10_000.0, n_samples=40_000,
                      pretrigger_s=1e-3, pulse_s=3e-4, noise_std=1e-4)
    acc = impact_records(case, 1, seed=1)[1]
    got = {}
    for q in ("acceleration", "displacement"):
        rec = TimeRecords(1 / case.sampling_frequency_hz, acc, ("1:+Y",), (q,), {"source": "hit"})
        got[q] = identify_records(rec, "fftpeak").estimate.natural_frequencies_hz[0]
    assert abs(got["acceleration"] - 100.0) < 0.01
    assert got["displacement"] / got["acceleration"] == pytest.approx(1 / (1 - 2 * 0.02 ** 2), rel=2e-5)


def test_the_window_holds_the_vertex_returned_not_the_highest_line():
    """A wide peak of two close modes (4160 and 4240 Hz, 1.5 % damped, equal amplitudes, 0.16 s at 51.2 kHz: its
    half-power half-width about 110 Hz) peaks on the padded grid near 4162 Hz while its top's parabola, fitted over
    half its half-width, has its vertex near 4176 Hz. A window centred on the vertex and too narrow to hold the line
    reads that vertex, as a wide window does; a window centred on the line and too narrow to hold the vertex has no
    peak (NaN), never a frequency outside itself."""
    fs_hz, n = 51200.0, 8192
    t = np.arange(n) / fs_hz
    y = sum(np.exp(-0.015 * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * t) for f in (4160.0, 4240.0))[None]
    wide = fft_peaks(y, fs_hz, [4200.0], [150.0])
    vertex, line = wide.frequency_hz[0], wide.line_hz[0]
    assert 10.0 < vertex - line < 20.0 and 4150.0 < line < 4170.0
    half = 0.5 * (vertex - line)
    at_vertex = fft_peaks(y, fs_hz, [vertex], [half])
    assert at_vertex.frequency_hz[0] == vertex and at_vertex.line_hz[0] == line
    at_line = fft_peaks(y, fs_hz, [line], [half])
    assert np.isnan(at_line.frequency_hz[0]) and np.isnan(at_line.line_hz[0]) and np.isnan(at_line.damping_ratios[0])
