"""``beam-damage identify`` on response-record files of the wrong form or with a method that does not fit them: one
line naming the file and what to do, exit code 2."""

import numpy as np
import pytest

from experiments.cli import main
from physics.errors import FileFormatError
from physics.io.npz import read_frf_npz

FS_HZ = 1000.0


def _run(capsys, argv):
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _npz(path, y):
    np.savez(path, signals=y, sampling_frequency_hz=np.array(FS_HZ))
    return path


@pytest.mark.parametrize("method", ["lscf", "circle", "peak"])
def test_an_frf_method_on_response_records_names_the_output_only_methods(capsys, tmp_path, method):
    y = np.random.default_rng(0).standard_normal((2, 4000))
    path = _npz(tmp_path / "r.npz", y)
    code, out, err = _run(capsys, ["identify", str(path), "--method", method])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: --method {method}: fits FRFs, but {path} holds response records "
                   "without a force channel; identify them output-only: --method ssi, era, fdd, efdd, fftpeak, or no "
                   "--method\n")


def test_transposed_signals_are_refused_naming_the_shape(capsys, tmp_path):
    y = np.random.default_rng(1).standard_normal((4000, 3))
    path = _npz(tmp_path / "t.npz", y)
    code, out, err = _run(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: field 'signals' of shape (4000, 3) holds more channels than "
                   "samples; expected (n_channels, n_samples), one row per channel (transposed?)\n")


def test_a_one_dimensional_signals_field_is_refused_with_its_shape(capsys, tmp_path):
    path = _npz(tmp_path / "v.npz", np.arange(100.0))
    code, out, err = _run(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: field 'signals' must be a real (n_channels, n_samples) "
                   "array, got float64 of shape (100,)\n")


def test_a_multichannel_record_too_short_for_the_channel_floors_names_the_file(capsys, tmp_path):
    """The channel-weighting step's spectra (two frames of 16 samples) refuse 20 samples naming the file."""
    path = _npz(tmp_path / "s.npz", np.random.default_rng(2).standard_normal((3, 20)))
    code, out, err = _run(capsys, ["identify", str(path), "--method", "ssi"])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: 20 samples are fewer than two frames of 16 (a 62.5 Hz "
                   "resolution): too short a record for this resolution\n")


def test_an_npz_of_neither_form_names_both_forms(capsys, tmp_path):
    path = tmp_path / "x.npz"
    np.savez(path, records=np.zeros((2, 3, 100)), fs=np.array(FS_HZ))
    code, out, err = _run(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: missing array(s) frequency_hz, frf, response_dofs, "
                   "reference_dofs; expected frequency_hz, frf, response_dofs, reference_dofs, kind, units, "
                   "metadata_json; or, for response time series, signals and sampling_frequency_hz\n")


def test_the_frf_reader_refuses_response_time_series_naming_the_way_to_modal_data(tmp_path):
    path = _npz(tmp_path / "r.npz", np.random.default_rng(3).standard_normal((2, 400)))
    with pytest.raises(FileFormatError) as exc:
        read_frf_npz(path)
    assert str(exc.value) == (f"{path}: holds response time series (array 'signals'), not FRFs (arrays "
                              "frequency_hz, frf, response_dofs, reference_dofs); identify its modes first "
                              "(beam-damage identify FILE --out DIR) and give DIR/modal.json")
