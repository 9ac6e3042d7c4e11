"""A free decay whose frequency moves with its amplitude (a mode that stiffens): what the narrow-band fit of one
damped exponential and the FFT peak read of it, against the closed-form weighted slopes of its phase.

To first order in the phase departure ``delta(t)`` from ``2 pi f0 t``, a least-squares fit of one damped
exponential reads the slope of ``delta`` weighted by the squared envelope ``A(t)^2``, the peak of the record's
transform the slope weighted by ``A(t)`` (the peak maximises ``|sum A exp(i (delta - dw t))|``, whose second-order
expansion is the ``A``-weighted variance of ``delta - dw t``). A loud start thus weighs more in the fit than in the
FFT peak: a decay that starts stiffer reads stiffer by the fit (the pyFRF hits' 900-Hz mode, docs/identification.md).
"""

import numpy as np
import pytest

from physics.identification import band_refine
from physics.identification.band_refine import refine_in_bands
from physics.identification.fft_peak import fft_peaks

FS, N, F0, ZETA = 1000.0, 4000, 50.0, 0.005
SIGMA = 2 * np.pi * F0 * ZETA
DEFAULT_LINES = band_refine.BAND_LINES


def _stiffening(c_hz):
    """``A(t) cos(2 pi f0 t + delta(t))``, ``A = exp(-sigma t)``, instantaneous frequency ``f0 + c A(t)``; the
    record (1, N), ``t`` and ``delta``."""
    t = np.arange(N) / FS
    a = np.exp(-SIGMA * t)
    delta = 2 * np.pi * c_hz * (1 - a) / SIGMA
    return (a * np.cos(2 * np.pi * F0 * t + delta))[None], t, delta


def _weighted_slope_hz(t, delta, w):
    """The ``w``-weighted least-squares slope of ``delta(t)`` over ``2 pi`` (Hz)."""
    tm = np.sum(w * t) / np.sum(w)
    return np.sum(w * (t - tm) * delta) / np.sum(w * (t - tm) ** 2) / (2 * np.pi)


def _band_hz(y, monkeypatch, lines):
    monkeypatch.setattr(band_refine, "BAND_LINES", lines)
    return refine_in_bands([y], FS, [-SIGMA + 2j * np.pi * F0]).eigenvalues[0].imag / (2 * np.pi)


@pytest.mark.parametrize("c_hz", [0.02, 0.05])
def test_a_stiffening_decay_reads_higher_by_the_band_fit_than_by_the_fft_peak(monkeypatch, c_hz):
    y, t, delta = _stiffening(c_hz)
    a = np.exp(-SIGMA * t)
    by_a, by_a2 = _weighted_slope_hz(t, delta, a), _weighted_slope_hz(t, delta, a ** 2)
    assert by_a2 > 1.6 * by_a                                   # the squared envelope weighs the start more
    wide = _band_hz(y, monkeypatch, 400) - F0                   # a band of +-100 Hz: the full least squares
    np.testing.assert_allclose(wide, by_a2, rtol=0.02)
    y0 = _stiffening(0.0)[0]                                    # the peak's own bias (the negative-frequency image)
    peak = fft_peaks(y, FS, [F0], 1.0, window="none", pad=64).frequency_hz[0] \
        - fft_peaks(y0, FS, [F0], 1.0, window="none", pad=64).frequency_hz[0]
    np.testing.assert_allclose(peak, by_a, rtol=0.1)                # first order: 7 % at 0.05 Hz
    default = _band_hz(y, monkeypatch, DEFAULT_LINES) - F0
    assert peak < default < wide                                 # era's band: between, above the FFT peak
