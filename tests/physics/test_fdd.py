"""FDD/EFDD output-only identification against the closed-form 3-DOF chain of test_ssi."""

import numpy as np
import pytest
from oma_records import chain_record
from scipy import signal

from physics.errors import BeamDamageError
from physics.identification.fdd import cross_spectra, identify_fdd
from physics.modal import mac


def test_cross_spectra_in_chunks_equal_scipy_welch():
    rng = np.random.default_rng(0)
    y = rng.standard_normal((2, 9000))
    f, G = cross_spectra(y, 100.0, 256, frames_per_chunk=5)
    y0 = y - y.mean(axis=1, keepdims=True)              # one mean over the record, not per frame
    f_ref, P01 = signal.csd(y0[0], y0[1], fs=100.0, nperseg=256, detrend=False)
    np.testing.assert_allclose(f, f_ref)
    np.testing.assert_allclose(G[:, 0, 1], np.conj(P01), rtol=1e-10, atol=1e-14)   # scipy: conj(X) Y
    _, P00 = signal.welch(y0[0], fs=100.0, nperseg=256, detrend=False)
    np.testing.assert_allclose(G[:, 0, 0].real, P00, rtol=1e-10)


def test_efdd_finds_the_chain_modes_with_their_damping_and_shapes():
    y, fs, fn, zeta, phi = chain_record()
    res = identify_fdd(y, fs, band_hz=(1, 60))
    e = res.estimate
    np.testing.assert_allclose(e.natural_frequencies_hz, fn, rtol=1e-3)
    np.testing.assert_allclose(e.damping_ratios, zeta, rtol=0.15)
    assert np.all(np.diag(mac(phi, e.shapes)) > 0.999)
    assert e.method == "efdd" and not e.scaled


def test_fdd_gives_the_peak_lines_and_no_damping():
    y, fs, fn, *_ = chain_record(seconds=300, seed=4)
    res = identify_fdd(y, fs, band_hz=(1, 60), n_modes=3, enhanced=False)
    df = res.frequency_hz[1]
    assert np.all(np.abs(res.estimate.natural_frequencies_hz - fn) <= 2 * df)     # noisy peak: within two lines
    assert np.all(np.isnan(res.estimate.damping_ratios))


@pytest.mark.parametrize("case, message", [("nan", "NaN"), ("nyquist", "Nyquist"), ("short", "ten periods|two frames")])
def test_bad_records_are_refused(case, message):
    y, fs, *_ = chain_record(seconds=120, seed=3)
    band, res = (1, 60), None
    if case == "nan":
        y[0, 7] = np.nan
    elif case == "nyquist":
        band = (1, 101)
    elif case == "short":
        y, res = y[:, :240], 1.0
    with pytest.raises(BeamDamageError, match=message):
        identify_fdd(y, fs, band_hz=band, resolution_hz=res)
