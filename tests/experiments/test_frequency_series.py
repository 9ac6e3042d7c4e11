"""A published table of identified frequencies as the modal-data test files ``monitor`` reads."""

import json

import numpy as np
import pytest
import scipy.io

from experiments.studies.frequency_series import main, read_frequency_table
from physics.io.modal_json import read_modal_json


def test_a_mat_table_becomes_one_modal_file_per_test_and_their_times(tmp_path):
    F = np.array([[0.37, 0.36, np.nan, 0.30], [0.55, 0.54, 0.55, 0.49], [0.94, 0.93, 0.94, 0.82]])  # modes x tests
    scipy.io.savemat(tmp_path / "f.mat", {"freq_fdd": F})
    assert main([str(tmp_path / "f.mat"), "--key", "freq_fdd", "--tests-per-day", "24", "--out",
                 str(tmp_path / "s")]) == 0
    rows = (tmp_path / "s" / "conditions.csv").read_text().split()
    assert rows == ["file,time", "test-000.json,0", "test-001.json,1", "test-003.json,3"]   # test 2 left out
    md = read_modal_json(tmp_path / "s" / "test-003.json")
    np.testing.assert_allclose(md.natural_frequencies_hz, [0.30, 0.49, 0.82])
    assert json.loads((tmp_path / "s" / "test-000.json").read_text()) == {"natural_frequencies_hz": [0.37, 0.55, 0.94]}


def test_a_csv_table_with_a_header_and_a_missing_matrix_named(tmp_path, capsys):
    (tmp_path / "f.csv").write_text("f1,f2\n10.0,60.0\n10.1,60.2\n9.9,59.8\n")
    np.testing.assert_allclose(read_frequency_table(tmp_path / "f.csv"), [[10.0, 60.0], [10.1, 60.2], [9.9, 59.8]])
    scipy.io.savemat(tmp_path / "g.mat", {"a": np.ones((2, 3)), "b": np.ones((2, 3))})
    assert main([str(tmp_path / "g.mat"), "--key", "freq", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no matrix 'freq'" in err and "a, b" in err


@pytest.mark.parametrize("per_day", ["0", "-3"])
def test_tests_per_day_must_be_positive(tmp_path, per_day):
    (tmp_path / "f.csv").write_text("10.0,60.0\n")
    assert main([str(tmp_path / "f.csv"), "--tests-per-day", per_day, "--out", str(tmp_path / "o")]) == 2
