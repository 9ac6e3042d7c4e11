"""The clear peaks of a free decay's spectrum that no mode `era` returns explains are named in a warning, as SSI
names its own (:func:`physics.identification.peak_warning.warn_unexplained_peaks`), against closed-form decays of
:mod:`impact_records`."""

import re
import warnings

import numpy as np
from impact_records import impact_record

from physics.identification.free_decay import identify_era

#: One accelerometer, 4 s at 1 kHz (lines 0.25 Hz apart), a hit at 0.2 s: three modes of 1 % damping.
FS, N, FN, ZETA = 1000.0, 4000, np.array([21.0, 67.0, 143.0]), np.full(3, 0.01)
WARNING = re.compile(r"test\.npz: clear spectral peak\(s\) without an identified mode: (.*) above the floor")


def _decay(seed):
    return impact_record(FS, N, FN, ZETA, np.array([[0.6, 1.0, 0.8]]), [0.2], 1e-3, seed)[0]


def _era(y, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify_era(y, FS, where="test.npz", **kwargs)
    named = [m.group(1) for w in caught if (m := WARNING.match(str(w.message)))]
    return res, named


def test_a_mode_the_selection_drops_is_named_at_its_peak_with_its_height():
    """Two modes asked of three: the one left out stands as a clear peak of the decay's spectrum and is named,
    within a line (0.25 Hz) of its damped frequency, with its height above the floor; the result carries it."""
    res, named = _era(_decay(0), n_modes=2)
    got = res.estimate.natural_frequencies_hz
    kept = np.abs(got[:, None] - FN[None, :]).argmin(axis=1)
    np.testing.assert_allclose(got, FN[kept], rtol=1e-3)
    dropped = np.setdiff1d(np.arange(FN.size), kept)
    assert dropped.size == 1 and len(named) == 1, named
    f_d = FN[dropped[0]] * np.sqrt(1 - ZETA[dropped[0]] ** 2)
    assert res.unexplained_hz.size == 1 and abs(res.unexplained_hz[0] - f_d) <= 1 / (N / FS), res.unexplained_hz
    hz, db = re.fullmatch(r"([\d.]+) Hz \((\d+) dB\)", named[0]).groups()
    assert abs(float(hz) - f_d) <= 1 / (N / FS) and int(db) >= 10, named


def test_a_clean_three_mode_decay_and_one_of_too_low_an_order_warn_of_no_peak():
    """All three modes found: no peak left unexplained. A model of order 2 holds one mode; the two others are
    refined from their clear peaks (:mod:`~physics.identification.peak_seeds`), so no peak is left either."""
    y = _decay(1)
    for kwargs in ({}, {"max_order": 2}):
        res, named = _era(y, **kwargs)
        np.testing.assert_allclose(res.estimate.natural_frequencies_hz, FN, rtol=1e-3)
        assert named == [] and res.unexplained_hz.size == 0, (kwargs, named)


def test_a_sinusoid_that_does_not_decay_is_named():
    """A 50-Hz line lasting the record beside the three decaying modes: a clear peak `era` returns no mode at (its
    fit shows no decay), named in the warning."""
    y = _decay(2) + 0.05 * np.abs(_decay(2)).max() * np.sin(2 * np.pi * 50.0 * np.arange(N) / FS)
    res, named = _era(y)
    np.testing.assert_allclose(res.estimate.natural_frequencies_hz, FN, rtol=1e-3)
    assert res.unexplained_hz.size == 1 and abs(res.unexplained_hz[0] - 50.0) <= 1 / (N / FS), res.unexplained_hz
    assert len(named) == 1 and abs(float(named[0].split(" Hz")[0]) - 50.0) <= 1 / (N / FS), named
