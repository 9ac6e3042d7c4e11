"""``beam-damage identify --method fftpeak`` on a file of response records: the baseline from the command line."""

import json

import numpy as np
import pytest

from experiments.cli import main


def test_identify_method_fftpeak_reads_a_free_decay_file(capsys, tmp_path):
    fs, truth, zeta = 1000.0, np.array([12.0, 75.2]), np.array([0.01, 0.005])
    t = np.arange(4000) / fs
    w = 2 * np.pi * truth[:, None]
    y = np.sum(np.exp(-zeta[:, None] * w * t) * np.sin(w * np.sqrt(1 - zeta[:, None] ** 2) * t), axis=0)
    y += 1e-3 * np.random.default_rng(0).standard_normal(y.size)
    path = tmp_path / "decay.npz"
    np.savez(path, signals=y[None], sampling_frequency_hz=np.array(fs))
    code = main(["identify", str(path), "--method", "fftpeak", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    res = json.loads(out)
    assert res["method"] == "fftpeak"
    got = np.array([m["frequency_hz"] for m in res["modes"]])
    np.testing.assert_allclose(got, truth, rtol=5e-4)
    zeta_got = np.array([m["damping_ratio"] for m in res["modes"]], dtype=float)
    assert np.isnan(zeta_got[0])               # 12 Hz: half-width 0.12 Hz, under twice the window's 0.11 Hz
    assert abs(zeta_got[1] / zeta[1] - 1) < 0.1


def test_a_stationary_records_fft_peaks_carry_no_damping(tmp_path):
    """The raw periodogram's half-power width is one random line's (0.0001 for 1 % damping): none is reported."""
    from scipy import signal

    from physics.identification.fft_peak import identify_fft_peaks

    fs, n = 2000.0, 60000
    wn, z = 2 * np.pi * 357.0, 0.01
    b, a, _ = signal.cont2discrete(([1.0, 0.0, 0.0], [1.0, 2 * z * wn, wn ** 2]), 1 / fs, "zoh")
    y = signal.lfilter(b.ravel(), a, np.random.default_rng(0).standard_normal(n + 20000))[20000:]
    est, peaks = identify_fft_peaks(np.vstack([y, 0.5 * y]), fs, (200.0, 500.0))
    assert peaks.window == "hann"
    assert est.natural_frequencies_hz == pytest.approx([357.0], abs=3.57)      # within the half-power half-width
    assert np.isnan(est.damping_ratios).all()
    np.testing.assert_array_equal(est.natural_frequencies_hz, peaks.frequency_hz)
