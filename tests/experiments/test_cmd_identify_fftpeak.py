"""``beam-damage identify --method fftpeak`` on a file of response records: the baseline from the command line."""

import json

import numpy as np

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
