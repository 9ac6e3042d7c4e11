"""``monitor`` on awkward real records: exact zeros among the held-out statistics, a band too narrow for the
spectrum's lines, an exception inside one test's identification, a record too short for the model order asked."""

import warnings

import numpy as np
import pytest
from scipy import stats

from learn.monitor import identification as ident_mod
from learn.monitor.alarm_threshold import LAW_MIN, threshold
from learn.monitor.identification import IdentificationSettings, cached_identification, identify_test
from physics.errors import BeamDamageError, ConvergenceError, ShapeError
from physics.identification.fdd import clear_peaks, identify_fdd, singular_value_spectrum
from physics.identification.record_checks import check_records
from physics.identification.ssi import identify_ssi


def test_threshold_of_a_zero_inflated_sample_is_the_law_of_its_positive_part():
    """Half the held-out indices exactly 0, the others ``c F(1, 30)``: the threshold is ``c F.ppf(1 - rate / 0.5)``
    (the positive part carries all the false alarms), and a fresh sample of the same law exceeds it at ``rate``."""
    rng = np.random.default_rng(3)
    c, d2, rate, n = 2.0, 30, 0.01, 4000
    law = stats.f(1, d2)

    def sample(m):
        s = c * law.rvs(size=m, random_state=rng)
        s[rng.random(m) < 0.5] = 0.0
        return s

    s = sample(n)
    t = threshold(s, rate, 1, d2 + 1)
    assert t.zero_share == pytest.approx(np.mean(s == 0))
    assert t.scale == pytest.approx(c, rel=0.08)
    assert t.law_value == pytest.approx(c * law.ppf(1 - rate / (1 - t.zero_share)), rel=0.1)
    assert t.value == max(t.law_value, t.empirical_quantile)
    assert np.mean(sample(200_000) > t.value) == pytest.approx(rate, rel=0.25)


def test_threshold_with_seven_zeros_of_twelve_fits_the_five_others():
    """The DROPBEAR case (7 of 12 held-out one-degree-of-freedom indices exactly 0) gives a finite threshold: the
    law fitted to the 5 positive indices, read at ``rate / (5 / 12)``; its empirical part is ``np.quantile``."""
    s = np.r_[np.zeros(7), 0.3, 1.1, 0.05, 2.4, 0.7]
    t = threshold(s, 0.01, 1, 11)
    alone = threshold(s[s > 0], 0.01 * 12 / 5, 1, 11)
    assert np.isfinite(t.value) and t.value > s.max()
    assert t.scale == pytest.approx(alone.scale, rel=1e-9)
    assert t.law_value == pytest.approx(alone.law_value, rel=1e-9)
    assert t.empirical_quantile == pytest.approx(np.quantile(s, 0.99, method="weibull")) and t.empirical_quantile == 2.4
    assert t.zero_share == pytest.approx(7 / 12)


def test_threshold_with_too_few_positive_indices_is_the_empirical_quantile():
    s = np.r_[np.zeros(12 - (LAW_MIN - 1)), np.linspace(0.5, 1.5, LAW_MIN - 1)]
    t = threshold(s, 0.05, 1, 11)
    assert t.scale == 0.0 and t.law_value == 0.0
    assert t.value == pytest.approx(np.quantile(s, 0.95, method="weibull")) and t.value == s.max()
    zero = threshold(np.zeros(12), 0.05, 1, 11)                   # a statistic that never varied: any change alarms
    assert 0.0 < zero.value < 1e-300


def _decay(fs_hz, n, f_hz=(40.0, 110.0), seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs_hz
    y = sum(np.exp(-0.01 * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * t) for f in f_hz)
    return (y + 1e-3 * rng.standard_normal(n))[None, :]


def test_a_band_narrower_than_the_spectral_lines_is_identified_without_peaks():
    """A 0.5-s record at 1 kHz has Welch lines 31.25 Hz apart (frames of 32 samples, a power of 2 below n / 8): the
    band 101-119 Hz holds none. The spectrum has no floor and no clear peak there; SSI still runs in the band (its
    steadiest pole the 110-Hz mode), FDD answers in one line."""
    checked = check_records(_decay(1000.0, 500), 1000.0, (101.0, 119.0))
    sv = singular_value_spectrum(checked)
    assert sv.resolution_hz == pytest.approx(31.25) and np.isnan(sv.floor).all()
    assert clear_peaks(sv).lines.size == 0
    with pytest.raises(ConvergenceError, match=r"steadiest poles \(frequency and shape\): 110 Hz") as e, \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        identify_ssi(_decay(1000.0, 500), 1000.0, (101.0, 119.0))
    assert "\n" not in str(e.value)
    with pytest.raises(ConvergenceError, match="no peak of the first singular value"):
        identify_fdd(_decay(1000.0, 500), 1000.0, (101.0, 119.0))
    wide = singular_value_spectrum(check_records(_decay(1000.0, 500), 1000.0, (20.0, 200.0)))
    inband = (wide.frequency_hz >= 20.0) & (wide.frequency_hz <= 200.0)
    assert inband.sum() == 6 and np.isfinite(wide.floor[inband]).all()     # 31.25 ... 187.5 Hz


def test_ssi_caps_the_model_order_at_what_the_record_allows():
    """0.57 s at 5 kHz, one channel, band up to 300 Hz: decimated by 6 to 475 samples, 59 block rows; max_order 80
    runs at orders up to 58 (with a warning) and finds both modes."""
    fs, n = 5000.0, 2850
    with pytest.warns(UserWarning, match="model orders up to 58, not max_order 80: 59 block rows x 1 channel"):
        res = identify_ssi(_decay(fs, n), fs, (20.0, 300.0), max_order=80)
    assert res.block_rows == 59 and res.passes[0].orders[-1] == 58
    f = np.sort(res.estimate.natural_frequencies_hz)
    assert np.abs(f[:, None] - np.array([40.0, 110.0])).min(axis=0) == pytest.approx([0, 0], abs=0.5)
    with pytest.raises(ShapeError, match="max_order 80 exceeds block_rows x channels = 40"):
        identify_ssi(_decay(fs, n), fs, (20.0, 300.0), max_order=80, block_rows=40)


def _records_file(tmp_path):
    path = tmp_path / "test.npz"
    np.savez(path, signals=_decay(1000.0, 4000), sampling_frequency_hz=np.array(1000.0), dofs=np.array(["2:+Y"]))
    return path


@pytest.mark.parametrize("exc", [IndexError("index 12 is out of bounds for axis 0 with size 12"),
                                 OverflowError("math range error"), FloatingPointError("overflow"),
                                 np.linalg.LinAlgError("SVD did not converge")])
def test_a_numerical_failure_in_one_test_is_that_test_not_identified(tmp_path, monkeypatch, exc):
    def broken(*args, **kwargs):
        raise exc

    monkeypatch.setattr(ident_mod, "identify_records", broken)
    path = _records_file(tmp_path)
    settings = IdentificationSettings((5.0, 300.0))
    with pytest.raises(BeamDamageError) as e:
        identify_test(path, settings)
    text = str(e.value)
    assert text.startswith(f"{path}: output-only identification") and "\n" not in text
    assert f"({type(exc).__name__}: {exc})" in text
    modes, error, cached = cached_identification(path, settings, tmp_path / "cache")
    assert modes is None and error == text and not cached
    assert cached_identification(path, settings, tmp_path / "cache") == (None, text, True)


def test_a_programming_error_in_the_identification_is_not_hidden(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise TypeError("identify_records() got an unexpected keyword argument")

    monkeypatch.setattr(ident_mod, "identify_records", broken)
    with pytest.raises(TypeError), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        identify_test(_records_file(tmp_path), IdentificationSettings((5.0, 300.0)))
