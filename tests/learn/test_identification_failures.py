"""One list of the exceptions that make a record "not identified" (physics.identification.failures), read by
``classify`` and ``monitor`` alike: a LinAlgError in either path is reported with its class; the project's own
errors (ValueErrors too) pass unchanged, so an input the user must correct keeps its class and flag."""

from types import SimpleNamespace

import numpy as np
import pytest

from learn.monitor import identification as ident_mod
from learn.monitor.identification import IdentificationSettings, cached_identification, identify_test
from learn.pairs import inputs as inputs_mod
from learn.pairs import measured as measured_mod
from learn.pairs.measured import identify_band
from physics.errors import BeamDamageError, ConfigError
from physics.identification.failures import PER_RECORD_ERRORS, identification_failure
from physics.io import MeasuredFRF, write_frf_npz

SVD = np.linalg.LinAlgError("SVD did not converge")


def _raise(exc):
    def broken(*args, **kwargs):
        raise exc
    return broken


def _frf():
    f = np.linspace(1.0, 200.0, 400)
    h = (1.0 / (50.0 ** 2 - f ** 2 + 1j * f))[None, None, :]
    return MeasuredFRF(f, h, ("2:+Y",), ("2:+Y",))


def test_a_numerical_failure_is_one_line_with_its_class_and_the_projects_errors_pass_unchanged():
    assert np.linalg.LinAlgError in PER_RECORD_ERRORS and ValueError in PER_RECORD_ERRORS
    with pytest.raises(BeamDamageError) as e, identification_failure("t.npz: ssi"):
        raise SVD
    assert type(e.value) is BeamDamageError and str(e.value) == "t.npz: ssi failed (LinAlgError: SVD did not converge)"
    bad = ConfigError("band_hz (5, 1): expected lo < hi", parameter="band_hz")     # a ValueError: not converted
    with pytest.raises(ConfigError) as e, identification_failure("t.npz: ssi"):
        raise bad
    assert e.value is bad and e.value.parameter == "band_hz"
    with pytest.raises(TypeError), identification_failure("t.npz: ssi"):          # a defect of the program
        raise TypeError("unexpected keyword")


def test_classify_reports_a_linalg_failure_of_the_identification_with_its_class(monkeypatch):
    monkeypatch.setattr(measured_mod, "identify_frf", _raise(SVD))
    text = "baseline: LSCF/LSFD identification failed (LinAlgError: SVD did not converge)"
    with pytest.raises(BeamDamageError, match=r"^" + text.replace("(", r"\(").replace(")", r"\)") + "$"):
        identify_band(_frf(), (5.0, 150.0), "baseline")
    # an FRF-route model classifies the FRFs alone and says why there is no classical answer
    model = SimpleNamespace(sensitivity=SimpleNamespace(frequencies_hz=np.array([10.0, 60.0, 170.0, 330.0])),
                            beam=SimpleNamespace(test=None), route="frf")
    res = inputs_mod._measured_pairs(model, [_frf()], [_frf()], ["baseline", "measured 1"])
    assert res.baseline is None and res.warnings == (f"{text}: no classical answer; the FRF-route network alone",)
    # a modal-route model needs the modes: the one line reaches the user (exit code 2)
    with pytest.raises(BeamDamageError, match="LinAlgError: SVD did not converge"):
        inputs_mod._measured_pairs(SimpleNamespace(**{**vars(model), "route": "modal"}), [_frf()], [_frf()],
                                   ["baseline", "measured 1"])


def test_classify_lets_an_input_error_inside_the_identification_reach_the_user_unchanged(monkeypatch):
    bad = ConfigError("band_hz (150, 5): expected lo < hi", parameter="band_hz")
    monkeypatch.setattr(measured_mod, "identify_frf", _raise(bad))
    with pytest.raises(ConfigError) as e:
        identify_band(_frf(), (5.0, 150.0), "baseline")
    assert e.value is bad and e.value.parameter == "band_hz"


def test_monitor_reports_a_linalg_failure_of_an_frf_files_identification_as_not_identified(tmp_path, monkeypatch):
    path = tmp_path / "test.npz"
    write_frf_npz(path, _frf())
    monkeypatch.setattr(measured_mod, "identify_frf", _raise(SVD))
    settings = IdentificationSettings((5.0, 150.0))
    with pytest.raises(BeamDamageError) as e:
        identify_test(path, settings)
    assert str(e.value) == f"{path}: LSCF/LSFD identification failed (LinAlgError: SVD did not converge)"
    assert cached_identification(path, settings, tmp_path / "cache") == (None, str(e.value), False)
    monkeypatch.setattr(ident_mod, "identify_records", _raise(SVD))        # records: the same list, the same report
    rec = tmp_path / "rec.npz"
    np.savez(rec, signals=np.sin(np.arange(2000) * 0.3)[None], sampling_frequency_hz=np.array(1000.0),
             dofs=np.array(["2:+Y"]))
    modes, error, _ = cached_identification(rec, settings, None)
    assert modes is None and error.startswith(f"{rec}: output-only identification")
    assert error.endswith("failed (LinAlgError: SVD did not converge)")
