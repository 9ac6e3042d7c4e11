"""An FFT-peak-read mode whose peak walks beyond its band: read as the mode moved, as a pole there is
(learn/monitor/fft_beyond.py, learn/monitor/tracking.py: beyond_bands)."""

import numpy as np
import pytest

import learn.monitor.tracking as tracking
import learn.monitor.workers as workers
from learn.monitor import IdentificationSettings, IdentifiedModes, SeriesInput, monitor_series
from learn.monitor.estimator_choice import FFT_PEAK
from learn.monitor.fft_beyond import beyond_windows_hz
from learn.monitor.identification import FFT_FORMAT, cached_fft_peaks, file_key
from learn.monitor.tracking import MODE_MOVED, TOLERANCE_SIGMAS, narrow_bands_hz, reach_bands_hz

FS_HZ, N_SAMPLES, ZETA = 1000.0, 4000, 0.01
N_BASELINE = 14


def _decay(modes):
    """A free decay of ``modes`` ((damped frequency Hz, amplitude), ...), closed form; 4 s at 1 % damping: it has
    decayed to 1e-11 by the record's end, so its FFT power is the smooth sum of the modes' peaks, no ripple."""
    t = np.arange(N_SAMPLES) / FS_HZ
    return sum(a * np.exp(-ZETA * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * t) for f, a in modes)[None, :]


def _dtft_peak_hz(modes, lo_hz, hi_hz):
    """Where the power of the record's transform peaks in ``lo_hz``-``hi_hz`` (on a 0.1 mHz grid), from the closed
    form of a sampled decay's transform: ``sum_n r^n sin(w_d n dt) e^(-i w n dt)`` of each mode, the two geometric
    series of ``sin = (e^(i x) - e^(-i x)) / 2i`` (the record ends at 1e-11 of its start: the infinite sums)."""
    f = np.arange(lo_hz, hi_hz, 1e-4)
    dt = 1 / FS_HZ
    X = np.zeros(f.size, complex)
    for fd, a in modes:
        r = np.exp(-ZETA * 2 * np.pi * fd * dt)
        w, wd = 2 * np.pi * f * dt, 2 * np.pi * fd * dt
        X += a / 2j * (1 / (1 - r * np.exp(1j * (wd - w))) - 1 / (1 - r * np.exp(-1j * (wd + w))))
    return float(f[np.argmax(np.abs(X))])


def _series(tmp_path):
    """14 baseline tests of a 100-Hz mode (0.05 Hz from test to test, identified with 0.5 Hz of extra scatter: its
    FFT peak is chosen) and a 150-Hz mode ten times stronger (identified within 1e-8); then mode 1 at 84 Hz (3 tests),
    at 118 Hz (3 tests), at 100 Hz (1 test), gone (1 test). The identification reads mode 1 within its band (at
    97 and 103 Hz) where it walked, and not at all where it is gone."""
    rng = np.random.default_rng(0)
    f1 = np.r_[100.0 + 0.05 * rng.standard_normal(N_BASELINE), [84.0] * 3, [118.0] * 3, 100.0, np.nan]
    ident1 = np.r_[f1[:N_BASELINE] + 0.5 * rng.standard_normal(N_BASELINE), [97.0] * 3, [103.0] * 3, 100.2, np.nan]
    files, tests = [], []
    for i, (f, g) in enumerate(zip(f1, ident1)):
        path = tmp_path / f"test_{i:02d}.npz"
        modes = ([(f, 1.0)] if np.isfinite(f) else []) + [(150.0, 10.0)]
        np.savez(path, signals=_decay(modes), sampling_frequency_hz=np.array(FS_HZ), dofs=np.array(["1:+Z"]))
        files.append(str(path))
        f2 = 150.0 * (1 + 1e-8 * rng.standard_normal())
        poles = np.array([g, f2] if np.isfinite(g) else [f2])
        tests.append(IdentifiedModes("response records", "era", poles, np.full(poles.size, ZETA), None, ("1:+Z",),
                                     (), (0.0, FS_HZ / 2), FS_HZ / N_SAMPLES))
    return files, tests, f1


def _identified_as(tests, files, monkeypatch):
    """Each file identified as ``tests`` gives it; the narrow-band re-identification finds nothing."""
    by_file = dict(zip(files, tests))
    monkeypatch.setattr(workers, "cached_identification", lambda path, *a, **k: (by_file[str(path)], None, False))
    monkeypatch.setattr(tracking, "cached_identification", lambda *a, **k: (None, "nothing in the band", False))


def test_an_fft_peak_beyond_its_band_is_the_mode_moved_and_never_its_neighbours_peak(tmp_path, monkeypatch):
    """Mode 1 (band 95.6-104.4 Hz: 10 robust standard deviations of its identified baseline frequencies; an FFT
    peak's reach 81.6-122.5 Hz: half the log gap to 150 Hz either side, the open side below mirroring it; a pole's
    reaches down to 50 Hz, the factor 2) read by its FFT peak: at 84 Hz its peak lies below its band, at 118 Hz above
    it, with no local maximum of the FFT power in the band; each reads ``mode moved`` at the
    peak as the band's readings are read (the vertex, the FFT peak of the same record over a window around the peak;
    within 0.1 Hz of the closed-form transform's peak, the 150-Hz mode's flank skewing it), its change against the
    reference frequency, flagged at chance 0 (the FFT peak read the mode in every baseline test). Where mode 1 is
    gone, the band and the windows beyond it hold only the flank of the 150-Hz mode, rising to its edge: no reading
    takes the neighbour's peak or the flank's value at the reach's edge; the mode is lost (unflagged after 14 baseline
    tests). The intact test reads nothing beyond the bands, nor does any baseline test."""
    files, tests, f1 = _series(tmp_path)
    _identified_as(tests, files, monkeypatch)
    res = monitor_series(SeriesInput.from_files(files), N_BASELINE, IdentificationSettings(), None, progress=False,
                         chart="none")
    assert res.frequency_choice.estimators == (FFT_PEAK, "era")
    ref = res.reference
    f_ref = ref.frequencies_hz[0]
    tol = ref.tolerance[0]
    assert tol == pytest.approx(TOLERANCE_SIGMAS * ref.log_std[0]) and 0.03 < tol < np.log(1.05)
    np.testing.assert_allclose(narrow_bands_hz(ref)[0], f_ref * np.exp([-tol, tol]))
    half = 0.5 * np.log(150.0 / f_ref)
    np.testing.assert_allclose(reach_bands_hz(ref)[0], f_ref * np.array([0.5, np.exp(half)]))   # a pole's
    np.testing.assert_allclose(reach_bands_hz(ref, open_factor=False)[0], f_ref * np.exp([-half, half]))
    np.testing.assert_allclose(beyond_windows_hz(ref)[0], [[f_ref * np.exp(-half), f_ref * np.exp(-tol)],
                                                           [f_ref * np.exp(tol), f_ref * np.exp(half)]])
    for i in range(N_BASELINE + 6):
        row = res.rows[i]
        if i < N_BASELINE:
            assert row["beyond_band"] == [] and row["status"] == "no alarm"
            continue
        assert row["frequencies_hz"][0] is None                   # no FFT peak in the band: mode 1 missing
        (d,) = row["beyond_band"]
        assert d["mode"] == 1 and d["reading"] == "moved" and d["flagged"] and d["chance"] == 0.0
        peak = _dtft_peak_hz([(f1[i], 1.0), (150.0, 10.0)], f1[i] - 2, f1[i] + 2)
        assert abs(peak - f1[i]) > 0.05 and d["frequency_hz"] == pytest.approx(peak, abs=0.1)
        vertex = cached_fft_peaks(files[i], np.array([[f1[i] - 2, f1[i] + 2]]))[0]
        assert d["frequency_hz"] == pytest.approx(vertex, rel=1e-12)
        assert d["change_pct"] == pytest.approx(100 * (d["frequency_hz"] / f_ref - 1), rel=1e-12)
        assert d["change_pct"] == pytest.approx(100 * (peak / f_ref - 1), abs=100 * 0.1 / f_ref)
        assert row["status"] == MODE_MOVED
        assert res.beyond.by_fft[i, 0] and res.beyond.moved_col[i, 0] == -1
    assert res.rows[N_BASELINE]["beyond_band"][0]["change_pct"] == pytest.approx(-16.0, abs=0.5)
    assert res.rows[N_BASELINE + 3]["beyond_band"][0]["change_pct"] == pytest.approx(18.0, abs=0.5)
    lo, hi = narrow_bands_hz(ref)[0]
    assert res.rows[N_BASELINE]["beyond_band_text"] == (f"mode 1 moved -16.1 % (83.85 Hz, beyond its band {lo:.4g}-"
                                                        f"{hi:.4g} Hz)")
    intact, gone = res.rows[N_BASELINE + 6], res.rows[N_BASELINE + 7]
    assert intact["beyond_band"] == [] and intact["frequencies_hz"][0] == res.frequency_choice.fft_hz[N_BASELINE + 6, 0]
    assert intact["frequencies_hz"][0] == pytest.approx(100.0, abs=0.3)           # the vertex, in the band
    (d,) = gone["beyond_band"]
    assert d["mode"] == 1 and d["reading"] == "lost" and d["frequency_hz"] is None and not d["flagged"]
    assert np.isnan(res.beyond.moved_hz[N_BASELINE + 7]).all()
    assert gone["frequencies_hz"][1] == pytest.approx(150.0, abs=0.05)    # the neighbour's peak stays its own


def test_without_the_fft_choice_the_same_series_reads_the_identifications_poles_in_the_band(tmp_path, monkeypatch):
    """With every frequency the identification's, the walked mode's poles (97 and 103 Hz) lie in its band: nothing
    beyond it, the FFT peaks are not read."""
    files, tests, _ = _series(tmp_path)
    _identified_as(tests, files, monkeypatch)
    res = monitor_series(SeriesInput.from_files(files), N_BASELINE, IdentificationSettings(), None, progress=False,
                         chart="none", frequency_estimator="identification")
    assert all(r["beyond_band"] == [] for r in res.rows[:N_BASELINE + 7])
    assert res.beyond.by_fft is not None and not res.beyond.by_fft.any()


def test_the_fft_peaks_are_cached_under_their_rule(tmp_path):
    """``cached_fft_peaks``: the vertices ``fft_peaks`` gives (within 0.1 Hz of the peaks of the record's closed-form
    transform), kept under a key holding :data:`FFT_FORMAT`, read back unchanged; an entry under another rule's key
    is not read."""
    files, _, f1 = _series(tmp_path)
    bands = np.array([[95.0, 105.0], [145.0, 155.0]])
    vertex = cached_fft_peaks(files[0], bands, tmp_path / "cache")
    (entry,) = (tmp_path / "cache").glob("*.json")
    peaks = [_dtft_peak_hz([(f1[0], 1.0), (150.0, 10.0)], lo, hi) for lo, hi in bands]
    np.testing.assert_allclose(vertex, peaks, atol=0.1)
    np.testing.assert_array_equal(cached_fft_peaks(files[0], bands, tmp_path / "cache"), vertex)
    assert entry.name == f"{file_key(files[0], None, {'fftpeak_bands_hz': bands.tolist(), 'rule': FFT_FORMAT})}.json"
