"""The output-only modal noise: synthesised records identified by SSI-cov scatter as the closed form of a single
mode says, shape errors measured as a dataset draws them, the std model, a calibration recorded and reused on
resume, and the one-line warning when the modes were identified otherwise than the training data assumes."""

import json

import numpy as np
import pytest

from learn.network.model_dir import TrainedModel
from learn.pairs.noise_calibration import mode_errors, robust_std


def ssi_scatter(record_length_s, records=16, f_hz=20.0, zeta=0.01, fs_hz=128.0, noise=0.01):
    """Relative frequency and damping errors of SSI-cov on ``records`` two-channel records of one mode (NaN where
    no pole was stable)."""
    from learn.pairs.output_only_calibration import response_records
    from physics.errors import ConvergenceError
    from physics.identification import identify_records
    from physics.io.timedata import TimeRecords
    from physics.modal import eigenvalues_from_modal

    lam = eigenvalues_from_modal(np.array([f_hz]), np.array([zeta]))
    psi = np.array([[1.0], [0.6]]) + 0j
    fe, ze = [], []
    for i in range(records):
        y = response_records(lam, psi, 0, fs_hz, int(record_length_s * fs_hz), noise,
                             np.random.default_rng([3, int(record_length_s), i]))
        try:
            est = identify_records(TimeRecords(1 / fs_hz, y, ("1:+Y", "2:+Y"), ("acceleration",) * 2), "ssi",
                                   band_hz=(5.0, 50.0)).estimate
        except ConvergenceError:
            fe.append(np.nan), ze.append(np.nan)
            continue
        k = np.argmin(np.abs(est.natural_frequencies_hz - f_hz))
        fe.append(est.natural_frequencies_hz[k] / f_hz - 1)
        ze.append(est.damping_ratios[k] / zeta - 1)
    return np.array(fe), np.array(ze)


def test_ssi_scatter_of_one_mode_follows_the_closed_form_and_falls_with_record_length():
    # a lightly damped mode observed for T seconds: std(f)/f = sqrt(zeta / (2 pi f T)),
    # std(zeta)/zeta = sqrt(1 / (2 pi zeta f T)) (the asymptotic scatter of a single mode's estimates; SSI-cov
    # reaches it within a factor of 2)
    f_hz, zeta = 20.0, 0.01
    stds = {}
    for T in (100.0, 900.0):
        fe, ze = ssi_scatter(T, records=24, f_hz=f_hz, zeta=zeta)
        assert np.isfinite(fe).sum() >= 18
        fe, ze = fe[np.isfinite(fe)], ze[np.isfinite(ze)]
        closed = np.array([np.sqrt(zeta / (2 * np.pi * f_hz * T)), np.sqrt(1 / (2 * np.pi * zeta * f_hz * T))])
        assert np.all(np.abs([np.median(fe), np.median(ze)]) < closed)            # no bias beyond the scatter
        stds[T] = np.array([robust_std(fe), robust_std(ze)])
        assert np.all((stds[T] / closed > 0.5) & (stds[T] / closed < 2.0)), (T, stds[T] / closed)
    assert np.all(stds[100.0] / stds[900.0] > 2)                                  # sqrt(9) = 3 expected


def test_unscaled_shape_errors_measure_the_std_of_circular_errors():
    rng = np.random.default_rng(0)
    n, S, m, sigma = 4000, 4, 2, 0.01
    psi_t = rng.standard_normal((n, S, m)) + 0j
    lam = np.full((n, m), -0.1 + 100j)
    noise = sigma * (rng.standard_normal((n, S, m)) + 1j * rng.standard_normal((n, S, m))) / np.sqrt(2)
    psi_e = (psi_t + noise * np.max(np.abs(psi_t), axis=-2, keepdims=True))
    psi_e = psi_e * np.exp(1j * rng.uniform(0, 6, (n, 1, m))) / np.linalg.norm(psi_e, axis=-2, keepdims=True)
    _, _, e = mode_errors(lam, psi_e, lam, psi_t, unscaled=True)
    got = robust_std(e[..., 0].ravel())
    assert got == pytest.approx(sigma, rel=0.05)
    _, _, e0 = mode_errors(lam, psi_t * (0.3 - 2j), lam, psi_t, unscaled=True)
    assert np.abs(e0).max() < 1e-12                               # any complex scale: no error


def test_output_only_std_model_and_per_sample_draws():
    from datagen.config import calibrated_modal_std, load_config, merge, output_only_variables
    from datagen.batch_inputs import draw_batch
    from datagen.setup import get_setup

    coef = {"modal_noise": "output-only", "frequency_noise": [0.1, 0.2], "frequency_noise_per_floor": [0.002, 0.001],
            "frequency_noise_floor": [1e-5, 0.0], "damping_noise": [5.0], "damping_noise_per_floor": [0.5],
            "damping_noise_floor": [0.01], "shape_noise": [0.1], "shape_noise_per_floor": [0.003],
            "shape_noise_floor": [0.0], "sensor_noise": [0.005, 0.03], "record_length_s": [120.0, 900.0]}
    cfg = merge({"measurement": coef}, base=load_config("training"))
    assert cfg["measurement"]["identification"] == {"method": "ssi", "n_modes": 2}
    sd = calibrated_modal_std(cfg["measurement"], *output_only_variables(0.01, 400.0))["frequency"]
    np.testing.assert_allclose(sd, np.sqrt(((np.array([0.1, 0.2]) * 0.01) ** 2 + [0.002 ** 2, 0.001 ** 2]) / 400
                                           + [1e-10, 0.0]))
    inp = draw_batch(np.random.default_rng(1), 2000, get_setup(cfg))
    assert 0.005 <= inp.sensor_noise.min() and inp.sensor_noise.max() <= 0.03
    assert np.median(inp.record_length_s) == pytest.approx(np.sqrt(120 * 900), rel=0.1)        # log-uniform
    base = draw_batch(np.random.default_rng(1), 2000, get_setup(load_config("training")))
    assert base.sensor_noise is None and np.array_equal(base.noise_level, inp.noise_level)     # drawn last
    with pytest.raises(Exception, match="'measurement.frequency_noise': modal_noise 'output-only'"):
        merge({"measurement": {"modal_noise": "output-only", "frequency_noise": 0.1}})


COEF = {"modal_noise": "output-only", **{f"{q}{s}": [v] * 4 for q, v in (("frequency", 1e-3), ("damping", 0.05),
                                                                          ("shape", 1e-3))
                                          for s in ("_noise", "_noise_per_floor", "_noise_floor")}}


def test_generate_output_only_calibrates_once_and_reuses_it_on_resume(tmp_path, monkeypatch, capsys):
    import experiments.cli.cmd_generate as cg
    from datagen.dataset import Dataset
    from experiments.cli import main

    calls = []
    monkeypatch.setattr(cg, "calibrate_output_only", lambda cfg: calls.append(1) or dict(COEF))
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\nshard_size = 10\n[measurement]\nlines = 32\n')
    args = ["generate", "--n", "20", "--out", str(tmp_path / "ds"), "--config", str(cfg), "--modal-noise",
            "output-only", "--json"]
    assert main(args) == 0 and len(calls) == 1
    m = json.loads((tmp_path / "ds" / "manifest.json").read_text())
    shards = sorted((tmp_path / "ds" / "shards").glob("shard-*"))
    import shutil
    shutil.rmtree(shards[-1])                                       # an interrupted run: one shard to redo
    capsys.readouterr()
    assert main(args) == 0 and len(calls) == 1                      # resumed without recalibrating
    assert "reusing the modal-noise calibration" in capsys.readouterr().err
    assert json.loads((tmp_path / "ds" / "manifest.json").read_text())["config"] == m["config"]
    t = Dataset(tmp_path / "ds").table(["sensor_noise", "record_length_s"])
    assert len(t) == 20 and t["record_length_s"].between(120, 900).all()
    other = tmp_path / "c2.toml"
    other.write_text('[output]\nshard_size = 10\n[measurement]\nlines = 40\n')
    assert main([*args[:6], str(other), *args[7:]]) == 2            # another config: calibrated, then refused
    assert len(calls) == 2


def model_of(identification):
    return TrainedModel("m", {"generator_config": {"measurement": {"identification": identification}}})


def test_identification_warning_names_a_skew_in_one_line_and_is_silent_on_a_match():
    from learn.pairs.inputs import identification_warning
    from learn.pairs.measured import IDENTIFICATION

    frf, oma, fixed = model_of(dict(IDENTIFICATION)), model_of({"method": "ssi", "n_modes": 4}), model_of(None)
    assert identification_warning(oma, False, ["ssi", "ssi"]) is None
    assert identification_warning(frf, True, [None, None]) is None
    assert identification_warning(frf, False, [None, None]) is None           # modal data of unknown origin
    w = identification_warning(frf, False, ["ssi", "ssi"])
    assert "LSCF/LSFD" in w and "--modal-noise output-only" in w and "\n" not in w
    assert "fixed stds" in identification_warning(fixed, False, ["ssi", None])
    assert "describes the output-only identification" in identification_warning(oma, True, [None, None])


def test_classify_reads_the_method_of_an_output_only_modal_json(tmp_path):
    from experiments.cli.cmd_classify import identification_method
    from physics.io import ModalData, modal_data_to_dict

    md = ModalData(np.array([-0.1 + 100j]), np.array([[1.0 + 0j], [0.5 + 0j]]), ("2:+Y", "3:+Y"))
    (tmp_path / "oma.json").write_text(json.dumps({**modal_data_to_dict(md), "method": "ssi"}))
    (tmp_path / "plain.json").write_text(json.dumps(modal_data_to_dict(md)))
    assert identification_method(tmp_path / "oma.json") == "ssi"
    assert identification_method(tmp_path / "plain.json") is None


@pytest.mark.slow
def test_calibrated_output_only_noise_falls_with_record_length_on_the_thesis_test():
    from datagen.config import calibrated_modal_std, load_config, merge, output_only_variables
    from learn.pairs.output_only_calibration import calibrate_output_only

    cfg = load_config("training")
    meas = merge({"measurement": calibrate_output_only(cfg, specimens=4)}, base=cfg)["measurement"]
    short, long_ = (calibrated_modal_std(meas, *output_only_variables(0.01, t)) for t in (120.0, 900.0))
    for q in ("frequency", "damping"):
        assert np.all(long_[q] < short[q]), q
