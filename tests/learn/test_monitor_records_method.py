"""The output-only method of a series' response records (``monitor --records-method``, IdentificationSettings):
``auto`` picks per record, a named method identifies every record by itself; the cache keeps them apart."""

import json

import numpy as np
import pytest

from experiments.cli import main
from learn.monitor.identification import IdentificationSettings, cached_identification, file_key, identify_test
from physics.identification.output_only import RECORDS_METHODS

FS_HZ, N_SAMPLES = 1000.0, 4000


def _decay(path, seed):
    """A free decay of two modes (12 and 41 Hz, 1 % damped) after a hit at 0.2 s, 1 % noise (seeded): ``auto``
    reads it by era."""
    rng = np.random.default_rng(seed)
    t = np.arange(N_SAMPLES) / FS_HZ
    tau = np.maximum(t - 0.2, 0.0)
    y = sum(a * np.exp(-0.01 * 2 * np.pi * f * tau) * np.sin(2 * np.pi * f * tau) for f, a in ((12.0, 1.0),
                                                                                               (41.0, 0.5)))
    np.savez(path, signals=(y + 0.01 * rng.standard_normal(t.size))[None], sampling_frequency_hz=np.array(FS_HZ),
             dofs=np.array(["1:+Z"]))
    return path


@pytest.fixture(scope="module")
def decay(tmp_path_factory):
    return _decay(tmp_path_factory.mktemp("records") / "decay.npz", 3)


def test_a_named_method_identifies_every_record_and_auto_picks_per_record(decay, tmp_path):
    auto = identify_test(decay, IdentificationSettings((5.0, 60.0)))
    ssi = identify_test(decay, IdentificationSettings((5.0, 60.0), records_method="ssi"))
    assert auto.method == "era" and ssi.method == "ssi"
    for modes in (auto, ssi):
        np.testing.assert_allclose(modes.frequencies_hz, [12.0, 41.0], rtol=2e-3)
    assert RECORDS_METHODS[0] == "auto" and {"ssi", "era"} <= set(RECORDS_METHODS)


def test_the_cache_keys_the_named_method_and_keeps_autos_key(decay, tmp_path):
    """``auto`` leaves the settings' dict (and so every cache key made before the option) as it was; a named method
    is a key of its own, and a cached entry of one is not read for the other."""
    auto, ssi = IdentificationSettings((5.0, 60.0)), IdentificationSettings((5.0, 60.0), records_method="ssi")
    assert "records_method" not in auto.to_dict() and ssi.to_dict()["records_method"] == "ssi"
    assert file_key(decay, auto) != file_key(decay, ssi)
    pending = []
    first, _, _ = cached_identification(decay, auto, tmp_path, pending)
    second, _, _ = cached_identification(decay, ssi, tmp_path, pending)
    assert (first.method, second.method) == ("era", "ssi") and len(pending) == 2


def test_the_cli_refuses_an_unknown_method_with_exit_2(decay, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["monitor", "--baseline-tests", "7", "--records-method", "lscf", str(decay)])
    assert exc.value.code == 2 and "--records-method" in capsys.readouterr().err


def test_monitor_records_the_named_method_in_its_config(tmp_path, capsys):
    """Nine decays (noise seeded apart), eight of them the baseline: every test identified by the method named (a mode
    the estimator choice reads by its FFT peak names the pole's method too), and the config says which."""
    files = [str(_decay(tmp_path / f"t{k}.npz", k)) for k in range(9)]
    assert main(["monitor", "--baseline-tests", "8", "--band", "5", "60", "--records-method", "ssi", "--json",
                 *files]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["config"]["identification"]["records_method"] == "ssi"
    named = {m for row in out["tests"] for m in row["identified_by"] if m}    # a mode read by its FFT peak names
    assert named and all(m in ("ssi", "fftpeak (the pole tracked: ssi)") for m in named)   # the pole's method
