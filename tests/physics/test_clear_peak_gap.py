"""A clear peak's tolerance is bounded by half the gap to its neighbouring clear peaks (fdd.clear_peaks)."""

import numpy as np

from physics.identification.fdd import SingularValueSpectrum, clear_peaks, unexplained_peaks


def _spectrum(peaks_hz, half_width_hz=2.0, df=1.0, top_hz=5000.0):
    """Lorentzian power peaks 40 dB over a unit floor, one line every ``df`` Hz."""
    f = np.arange(0.0, top_hz + df, df)
    s = 1.0 + sum(1e4 / (1 + ((f - p) / half_width_hz) ** 2) for p in peaks_hz)
    return SingularValueSpectrum(f, s[:, None], np.ones((f.size, 1), complex), np.ones(f.size), (0.0, top_hz),
                                 3 * df)


def test_close_peaks_tolerance_is_half_their_gap_and_one_does_not_explain_the_other():
    sv = _spectrum([2000.0, 4000.0, 4036.0])                 # 4000 and 4036 Hz: 0.9 % apart
    peaks = clear_peaks(sv)
    np.testing.assert_allclose(peaks.frequency_hz, [2000.0, 4000.0, 4036.0])
    # 2000 Hz: 1 % of f (20 Hz > 1.5 lines and the 2 Hz half-width); the pair: 1 % (40, 40.36 Hz) > 36 / 2 = 18 Hz
    np.testing.assert_allclose(peaks.tolerance_hz, [20.0, 18.0, 18.0])
    # a mode at 4000.2 Hz lies 35.8 Hz from 4036 Hz: within its 1 %, not within half the gap
    np.testing.assert_array_equal(unexplained_peaks(peaks, [4000.2]), [True, False, True])
    np.testing.assert_array_equal(unexplained_peaks(peaks, [4000.2, 4036.1]), [True, False, False])


def test_a_peak_a_line_above_the_lowest_reads_its_valley_below_it():
    """Lines 1 Hz apart, the lowest line a peak may sit on at 3 Hz (three lines): a mode at 4 Hz (1 Hz half-width)
    over a low-frequency rise, its valley at 1 Hz, below that line. Its prominence is read against that valley (7.8
    dB: a clear peak), not against the 3 Hz line on its own flank (3 dB, short of the 6 dB asked)."""
    f = np.arange(0.0, 101.0)
    s = 1.0 + 1e4 / (1 + (f - 4.0) ** 2) + 3e3 * np.exp(-1.5 * f)
    sv = SingularValueSpectrum(f, s[:, None], np.ones((f.size, 1), complex), np.ones(f.size), (0.0, 100.0), 3.0)
    np.testing.assert_allclose(clear_peaks(sv).frequency_hz, [4.0])
    db = 10 * np.log10(s)
    assert db[4] - db[3] < 6.0 < db[4] - db[1]
