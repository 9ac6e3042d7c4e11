"""Each mode's frequency by the more repeatable of the identification and the FFT peak over the baseline period
(learn/monitor/estimator_choice.py)."""

import dataclasses
import json

import numpy as np
import pytest

import learn.monitor.identification as identification
import learn.monitor.workers as workers
from experiments.cli import main as cli_main
from learn.monitor import IdentificationSettings, IdentifiedModes, SeriesInput, monitor_series, reference_modes
from learn.monitor.estimator_choice import (FFT_PEAK, GROSS, MIN_HALF, FrequencyChoice, choose_estimators,
                                           choose_frequencies, gross_readings)
from learn.monitor.tracking import narrow_bands_hz, track_modes
from physics.identification.fft_peak import fft_peaks
from physics.errors import ConfigError

FS_HZ, N_SAMPLES, ZETA = 1000.0, 4000, 0.002


def _mad_hz(f_hz, f_ref_hz):
    """1.4826 MAD of ``ln f`` times ``f_ref``, computed here by hand."""
    x = np.log(np.asarray(f_hz, float))
    return f_ref_hz * 1.4826 * np.median(np.abs(x - np.median(x)))


def _decay(f_hz, seed):
    """A free decay of the modes ``f_hz`` (damped frequencies) with white noise 1e-3 of the first amplitude."""
    t = np.arange(N_SAMPLES) / FS_HZ
    y = sum(np.exp(-ZETA * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * t) for f in f_hz)
    return (y + 1e-3 * np.random.default_rng(seed).standard_normal(N_SAMPLES))[None, :]


def _series(tmp_path, n=20, seed=0):
    """``n`` records of a 40-Hz mode (unchanged) and a 110-Hz mode scattering 0.05 Hz from test to test; the
    identification reads mode 1 within 0.4 micro-Hz (the FFT peak scatters 5 micro-Hz there with the records'
    noise) and mode 2 with 1 Hz of extra scatter."""
    rng = np.random.default_rng(seed)
    f2 = 110.0 + 0.05 * rng.standard_normal(n)
    ident1 = 40.0 * (1 + 1e-8 * rng.standard_normal(n))
    ident2 = f2 + 1.0 * rng.standard_normal(n)
    files, tests = [], []
    for i in range(n):
        path = tmp_path / f"test_{i:02d}.npz"
        np.savez(path, signals=_decay((40.0, f2[i]), seed + 1 + i), sampling_frequency_hz=np.array(FS_HZ),
                 dofs=np.array(["1:+Z"]))
        files.append(str(path))
        tests.append(IdentifiedModes("response records", "era", np.array([ident1[i], ident2[i]]), np.full(2, ZETA),
                                     None, ("1:+Z",), (), (0.0, FS_HZ / 2), FS_HZ / N_SAMPLES))
    return files, tests, f2, ident1, ident2


def test_the_fft_peak_is_chosen_for_the_mode_the_identification_scatters_and_not_for_the_other(tmp_path):
    """Mode 1, read by the identification 10 times steadier than by the FFT peak, keeps it; mode 2, read with 1 Hz
    of extra scatter, takes the FFT peak, whose scatter over the baseline is the records' own 0.05 Hz (the peak is
    read within 5 mHz of each record's frequency), 20 times smaller."""
    files, tests, f2, ident1, ident2 = _series(tmp_path)
    base = np.arange(14)
    ref = reference_modes([tests[i] for i in base])
    F, _, _, cols = track_modes(tests, ref)
    choice = choose_frequencies(tests, files, ref, F, cols, base)
    assert choice.default == "era" and choice.estimators == ("era", FFT_PEAK)
    np.testing.assert_allclose(choice.fft_hz[:, 1], f2, atol=5e-3)
    np.testing.assert_array_equal(choice.frequencies_hz[:, 0], ident1)
    np.testing.assert_array_equal(choice.frequencies_hz[:, 1], choice.fft_hz[:, 1])
    f_ref = ref.frequencies_hz
    assert choice.scatter_hz[0, 0] == pytest.approx(_mad_hz(ident1[base], f_ref[0]), rel=1e-12)
    assert 0.0 < choice.scatter_hz[0, 0] < 0.1 * choice.scatter_hz[0, 1]
    assert choice.scatter_hz[1, 0] == pytest.approx(_mad_hz(ident2[base], f_ref[1]), rel=1e-12)
    assert choice.scatter_hz[1, 1] == pytest.approx(_mad_hz(choice.fft_hz[base, 1], f_ref[1]), rel=1e-12)
    assert choice.scatter_hz[1, 1] == pytest.approx(_mad_hz(f2[base], f_ref[1]), rel=0.1)
    assert choice.scatter_hz[1, 0] > 10 * choice.scatter_hz[1, 1]
    np.testing.assert_allclose(choice.halves_hz[1, :, 1], [_mad_hz(choice.fft_hz[base[0::2], 1], f_ref[1]),
                                                           _mad_hz(choice.fft_hz[base[1::2], 1], f_ref[1])])
    assert choice.texts()[1].startswith("mode 2: FFT peak, scatter ") and "against era" in choice.texts()[1]
    assert choice.to_dict()["estimators"] == ["era", FFT_PEAK]
    # the two quantities' distance on the baseline, stated beside the chosen mode
    want = [np.median(choice.fft_hz[base, r] - F[base, r]) for r in range(2)]
    np.testing.assert_allclose(choice.offset_hz, want, rtol=1e-12)
    assert f"{want[1]:+.3g} Hz from era's pole frequency at the baseline median" in choice.texts()[1]
    assert "pole frequency" not in choice.texts()[0]
    assert choice.to_dict()["offset_hz"] == pytest.approx(want)


def test_a_mode_told_apart_by_shape_keeps_the_identification(tmp_path):
    """Mode 2's band widened past a neighbour told apart by shape (a tracking band twice its band by frequency):
    its FFT peak, which would be chosen (20 times steadier), cannot tell the pair apart; the identification's
    frequency is kept and the text says why. The FFT peaks are read within the bands by frequency alone."""
    files, tests, f2, ident1, ident2 = _series(tmp_path)
    base = np.arange(14)
    ref = reference_modes([tests[i] for i in base])
    widened = dataclasses.replace(ref, tolerance=ref.tolerance * np.array([1.0, 2.0]),
                                  frequency_tolerance=ref.tolerance)
    F, _, _, cols = track_modes(tests, ref)
    plain = choose_frequencies(tests, files, ref, F, cols, base)
    choice = choose_frequencies(tests, files, widened, F, cols, base)
    assert plain.estimators == ("era", FFT_PEAK) and plain.by_shape is None and "by_shape" not in plain.to_dict()
    assert choice.estimators == ("era", "era")
    np.testing.assert_array_equal(choice.by_shape, [False, True])
    np.testing.assert_array_equal(choice.frequencies_hz, F)
    np.testing.assert_array_equal(choice.fft_hz, plain.fft_hz)
    np.testing.assert_array_equal(choice.scatter_hz, plain.scatter_hz)
    assert choice.texts()[1].startswith("mode 2: era, told apart from a neighbour by its shape, which the FFT peak "
                                        "cannot")
    assert choice.texts()[0] == plain.texts()[0]
    assert choice.to_dict()["by_shape"] == [False, True]


def _spread(k, scale, phase=0.0):
    """``k`` deterministic values of robust scatter proportional to ``scale`` about 100 Hz."""
    return 100.0 * np.exp(scale * np.sin(np.arange(k) * 2.39996 + phase))


def test_the_identification_is_kept_only_where_it_is_the_steadier_over_the_baseline():
    """Over 12 baseline tests (each scatter the 1.4826 MAD by hand): the FFT peak 10 times steadier is chosen; where
    the halves split, the whole baseline decides: the identification steady on the odd tests only (smaller there,
    larger on the even ones and over all 12) gives way to the FFT peak, and the FFT peak steady on the odd tests only
    (larger over all 12) to the identification; the FFT peak steadier but missing one test the identification read
    is not chosen."""
    k = 12
    odd, even = np.arange(0, k, 2), np.arange(1, k, 2)
    F = np.empty((k, 4))
    G = np.empty((k, 4))
    F[:, 0], G[:, 0] = _spread(k, 1e-3), _spread(k, 1e-4, 1.0)                   # FFT 10 times steadier
    F[odd, 1], F[even, 1] = _spread(6, 1e-4), _spread(6, 1e-2, 0.5)              # steady on the odd tests only
    G[:, 1] = _spread(k, 3e-4, 1.0)
    F[:, 2], G[:, 2] = F[:, 0], G[:, 0]
    G[3, 2] = np.nan                                                             # the FFT misses one test
    F[:, 3] = _spread(k, 1e-3, 2.0)
    G[odd, 3], G[even, 3] = _spread(6, 1e-4, 1.5), _spread(6, 1e-2, 0.3)          # FFT steady on the odd tests only
    chosen, scatter, halves, n_tests, complete, gross = choose_estimators(F, G, np.arange(k), np.full(4, 100.0))
    np.testing.assert_array_equal(gross, [[0, 0], [4, 0], [0, 0], [0, 0]])       # the even tests gross
    np.testing.assert_array_equal(chosen, [True, True, False, False])
    for r in (0, 1, 3):
        np.testing.assert_allclose(scatter[r], [_mad_hz(F[:, r], 100.0), _mad_hz(G[:, r], 100.0)], rtol=1e-12)
        for h, half in enumerate((odd, even)):
            np.testing.assert_allclose(halves[r, h], [_mad_hz(F[half, r], 100.0), _mad_hz(G[half, r], 100.0)],
                                       rtol=1e-12)
    np.testing.assert_allclose(scatter[1], [0.0554, 0.0298], atol=1e-4)          # FFT smaller over all 12 ...
    np.testing.assert_allclose(halves[1], [[0.0090, 0.0290], [0.8187, 0.0298]], atol=1e-4)   # ... the halves split
    np.testing.assert_allclose(scatter[3], [0.1038, 0.2077], atol=1e-4)          # identification smaller over all
    np.testing.assert_allclose(halves[3], [[0.0346, 0.0083], [0.0871, 0.6559]], atol=1e-4)   # ... the halves split
    assert scatter[2, 1] < scatter[2, 0]                                         # steadier, but incomplete
    np.testing.assert_array_equal(complete, [True, True, False, True])
    np.testing.assert_array_equal(n_tests, [12, 12, 11, 12])
    few = choose_estimators(F[:2 * MIN_HALF - 1], G[:2 * MIN_HALF - 1], np.arange(2 * MIN_HALF - 1),
                            np.full(4, 100.0))[0]
    assert not few.any()                                                         # 5 tests: halves of 3 and 2


def test_an_fft_peak_with_gross_readings_is_not_chosen_over_an_identification_without():
    """A mode read by two neighbouring peaks (board 4.4's third mode, docs/monitoring.md Dataset-11): over 10
    baseline tests the FFT peak reads one peak within 1.5 Hz at 4784 Hz and the other, 12 and 17 Hz lower, in tests
    1 and 6; the identification scatters 7 Hz about 4764 Hz without a gross reading. The MAD ignores the two gross
    readings (1.55 against 7.05 Hz) and would take the FFT peak; they lie 7.5 and 10.8 of its scatters from its
    median, so the identification is kept. Without them the FFT peak is chosen."""
    f_era = np.array([4771.0, 4772.3, 4764.2, 4763.6, 4762.3, 4782.8, 4759.5, 4759.2, 4779.9, 4764.0])
    f_fft = np.array([4772.2, 4780.6, 4782.8, 4783.9, 4784.1, 4767.1, 4785.6, 4783.8, 4784.8, 4784.9])
    f_ref = 4764.24
    chosen, scatter, _, n_tests, complete, gross = choose_estimators(f_era[:, None], f_fft[:, None], np.arange(10),
                                                                     [f_ref])
    np.testing.assert_allclose(scatter[0], [_mad_hz(f_era, f_ref), _mad_hz(f_fft, f_ref)], rtol=1e-12)
    np.testing.assert_allclose(scatter[0], [7.05, 1.55], atol=0.01)              # the FFT peak the steadier by MAD
    x = np.log(f_fft)
    by_hand = np.abs(x - np.median(x)) / (_mad_hz(f_fft, f_ref) / f_ref)
    np.testing.assert_allclose(np.sort(by_hand)[-2:], [7.49, 10.78], atol=0.01)   # tests 1 and 6
    assert np.sort(by_hand)[-3] < GROSS
    np.testing.assert_array_equal(gross, [[0, 2]])
    assert gross_readings(f_fft) == 2 and gross_readings(f_era) == 0
    assert not chosen[0] and complete[0] and n_tests[0] == 10
    keep = np.setdiff1d(np.arange(10), [0, 5])
    assert choose_estimators(f_era[keep, None], f_fft[keep, None], np.arange(8), [f_ref])[0][0]
    choice = FrequencyChoice("era", ("era",), scatter, np.full((1, 2, 2), 1.0), n_tests, complete,
                             f_fft[:, None], f_era[:, None], gross)
    assert choice.texts() == ["mode 1: era, the FFT peak's scatter 1.55 Hz against 7.05 Hz over the 10 baseline "
                              "tests but 2 of its readings more than 5 scatters from its median (era: 0)"]
    assert choice.to_dict()["gross_readings"] == [{"era": 0, FFT_PEAK: 2}]
    assert gross_readings([100.0] * 9 + [100.1]) == 1 and gross_readings([np.nan]) == 0


def test_monitor_takes_the_chosen_frequencies_and_reports_the_choice(tmp_path, monkeypatch):
    """``monitor_series`` on records (their identification given): mode 2's frequency in every row is its FFT peak,
    the choice in ``normal_variation``; with ``frequency_estimator="identification"`` the identification's."""
    files, tests, f2, ident1, ident2 = _series(tmp_path)
    by_file = dict(zip(files, tests))
    monkeypatch.setattr(workers, "cached_identification", lambda path, *a, **k: (by_file[str(path)], None, False))
    series = SeriesInput.from_files(files)
    res = monitor_series(series, 14, IdentificationSettings(), None, progress=False, chart="none")
    assert res.frequency_choice.estimators == ("era", FFT_PEAK)
    rows = np.array([r["frequencies_hz"] for r in res.rows], float)
    np.testing.assert_allclose(rows[:, 1], f2, atol=5e-3)
    assert res.normal_variation["frequency_estimators"]["estimators"] == ["era", FFT_PEAK]
    assert [r["identified_by"] for r in res.rows] == [["era", "fftpeak (the pole tracked: era)"]] * len(files)
    json.dumps(res.normal_variation["frequency_estimators"])
    one = monitor_series(series, 14, IdentificationSettings(), None, progress=False, chart="none",
                         frequency_estimator="identification")
    assert one.frequency_choice is None and one.normal_variation["frequency_estimators"] is None
    np.testing.assert_array_equal(np.array([r["frequencies_hz"] for r in one.rows], float)[:, 1], ident2)
    with pytest.raises(ConfigError, match="--frequency-estimator fft: expected one of choose, identification"):
        monitor_series(series, 14, IdentificationSettings(), None, progress=False, frequency_estimator="fft")


def test_modal_data_keep_their_frequencies(tmp_path):
    """A series of modal data (no record to read an FFT of) has no choice; its frequencies are as read."""
    rng = np.random.default_rng(3)
    files = []
    for i in range(12):
        path = tmp_path / f"m{i:02d}.json"
        path.write_text(json.dumps({"natural_frequencies_hz": [40.0 + 0.01 * rng.standard_normal(),
                                                               110.0 + 0.02 * rng.standard_normal()]}))
        files.append(str(path))
    res = monitor_series(SeriesInput.from_files(files), 10, IdentificationSettings(), None, progress=False,
                         chart="none")
    assert res.frequency_choice is None and res.normal_variation["frequency_estimators"] is None
    read = np.array([json.loads(open(f).read())["natural_frequencies_hz"] for f in files])
    np.testing.assert_allclose(np.array([r["frequencies_hz"] for r in res.rows], float), read, rtol=1e-12)


def test_the_cli_reports_the_choice_in_its_summary_and_json(tmp_path, monkeypatch):
    """``monitor --out DIR``: the summary of report.md names each mode's estimator with both scatters;
    ``monitor.json`` holds the choice and the request's ``--frequency-estimator``."""
    files, tests, *_ = _series(tmp_path)
    by_file = dict(zip(files, tests))
    monkeypatch.setattr(workers, "cached_identification", lambda path, *a, **k: (by_file[str(path)], None, False))
    out = tmp_path / "out"
    assert cli_main(["monitor", *files, "--baseline-tests", "14", "--chart", "none", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert "Frequency estimators over the baseline period: mode 1: era, scatter " in report
    assert "mode 2: FFT peak, scatter " in report
    saved = json.loads((out / "monitor.json").read_text())
    assert saved["config"]["frequency_estimator"] == "choose"
    assert saved["normal_variation"]["frequency_estimators"]["estimators"] == ["era", FFT_PEAK]


def test_the_fft_peaks_are_cached_beside_the_identifications(tmp_path, monkeypatch):
    """With a cache folder, each record's FFT peaks are computed once: a second choice reads them from the cache
    (no record read), equal to the bit, and equal to :func:`fft_peaks` of the record in the modes' bands."""
    files, tests, *_ = _series(tmp_path)
    base = np.arange(14)
    ref = reference_modes([tests[i] for i in base])
    F, _, _, cols = track_modes(tests, ref)
    first = choose_frequencies(tests, files, ref, F, cols, base, tmp_path / "cache")
    bands = narrow_bands_hz(ref)
    rec = np.load(files[3])
    direct = fft_peaks(rec["signals"], FS_HZ, bands.mean(axis=1), 0.5 * (bands[:, 1] - bands[:, 0])).frequency_hz
    np.testing.assert_array_equal(first.fft_hz[3], direct)
    assert len(list((tmp_path / "cache").glob("*.json"))) == len(files)

    def refuse(path):
        raise AssertionError(f"{path} read again")

    monkeypatch.setattr(identification, "read_response_records", refuse)
    again = choose_frequencies(tests, files, ref, F, cols, base, tmp_path / "cache")
    np.testing.assert_array_equal(again.fft_hz, first.fft_hz)
    assert again.estimators == first.estimators == ("era", FFT_PEAK)
