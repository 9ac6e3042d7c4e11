"""``beam-damage identify`` on response-record files of the wrong form or with a method that does not fit them: one
line naming the file and what to do, exit code 2."""

import json

import numpy as np
import pytest
from cli_runs import run_cli

from systems import write_time_uff

from physics.errors import FileFormatError
from physics.io.npz import read_frf_npz

FS_HZ = 1000.0


def _npz(path, y):
    np.savez(path, signals=y, sampling_frequency_hz=np.array(FS_HZ))
    return path


@pytest.mark.parametrize("method", ["lscf", "circle", "peak"])
def test_an_frf_method_on_response_records_names_the_output_only_methods(capsys, tmp_path, method):
    y = np.random.default_rng(0).standard_normal((2, 4000))
    path = _npz(tmp_path / "r.npz", y)
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", method])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: --method {method}: fits FRFs, but {path} holds response records "
                   "without a force channel; identify them output-only: --method ssi, era, fdd, efdd, fftpeak, or no "
                   "--method\n")


def test_transposed_signals_are_refused_naming_the_shape(capsys, tmp_path):
    y = np.random.default_rng(1).standard_normal((4000, 3))
    path = _npz(tmp_path / "t.npz", y)
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: field 'signals' of shape (4000, 3) holds more channels than "
                   "samples; expected (n_channels, n_samples), one row per channel (transposed?)\n")


def test_a_one_dimensional_signals_field_is_refused_with_its_shape(capsys, tmp_path):
    path = _npz(tmp_path / "v.npz", np.arange(100.0))
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: field 'signals' must be a real (n_channels, n_samples) "
                   "array of at least 2 samples, got float64 of shape (100,)\n")


def test_a_multichannel_record_too_short_for_the_channel_floors_names_the_file(capsys, tmp_path):
    """The channel-weighting step's spectra (two frames of 16 samples) refuse 20 samples naming the file."""
    path = _npz(tmp_path / "s.npz", np.random.default_rng(2).standard_normal((3, 20)))
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", "ssi"])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage identify: error: {path}: 20 samples are fewer than two frames of 16 (a 62.5 Hz "
                   "resolution): too short a record for this resolution\n")


def test_an_npz_of_neither_form_names_both_forms(capsys, tmp_path):
    path = tmp_path / "x.npz"
    np.savez(path, records=np.zeros((2, 3, 100)), fs=np.array(FS_HZ))
    code, out, err = run_cli(capsys, ["identify", str(path)])
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


def _hits(seed=4):
    """Two channels: three hits 2.5 s apart exciting 25 and 60 Hz decays (damping ratio 0.01), little noise."""
    t = np.arange(int(8 * FS_HZ)) / FS_HZ
    y = np.zeros((2, t.size))
    for t0 in (0.5, 3.0, 5.5):
        tau = np.clip(t - t0, 0, None)
        on = t >= t0
        for f, phi in ((25.0, (1.0, 0.6)), (60.0, (0.5, -0.8))):
            w = 2 * np.pi * f
            y += np.outer(phi, on * np.exp(-0.01 * w * tau) * np.sin(w * np.sqrt(1 - 1e-4) * tau))
    return y + 1e-3 * np.random.default_rng(seed).standard_normal(y.shape)


@pytest.mark.parametrize("method", ["fdd", "efdd", "ssi"])
def test_a_stationary_method_named_for_a_free_response_is_warned_of(capsys, tmp_path, method):
    path = _npz(tmp_path / "hits.npz", _hits())
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", method, "--band", "10", "100"])
    assert code == 0
    warned = [line for line in err.splitlines() if "assumes a stationary response" in line]
    assert len(warned) == 1 and warned[0].startswith(f"beam-damage identify: warning: {path}: a free response: 3 hits")
    effect = ("modes may be missed (the poles it keeps are refined in their bands of the decays, as era's are)"
              if method == "ssi" else "modes may be missed and damping overestimated")
    assert warned[0].endswith(f"; {method} assumes a stationary response: its spectra or correlations averaged over "
                              f"the whole record dilute the decays, so {effect}; --method era or fftpeak read free "
                              "decays")
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", "era", "--band", "10", "100"])
    assert code == 0 and "assumes a stationary response" not in err
    stationary = _npz(tmp_path / "ambient.npz", np.random.default_rng(5).standard_normal((2, 8000)))
    code, out, err = run_cli(capsys, ["identify", str(stationary), "--method", method])
    assert "assumes a stationary response" not in err


def test_era_named_for_a_stationary_response_is_warned_of(capsys, tmp_path):
    """era on a record that is no free response: the warning (or, where era finds no mode, the refusal) names the
    verdict and the stationary method; on the free response, none."""
    from scipy import signal

    rng = np.random.default_rng(5)
    y = np.zeros((2, 8000))
    for f, phi in ((25.0, (1.0, 0.6)), (60.0, (0.5, -0.8))):            # two modes driven by white noise
        p = np.exp(2 * np.pi * f / FS_HZ * (-0.01 + 1j))
        y += np.outer(phi, signal.lfilter([1.0], [1.0, -2 * p.real, abs(p) ** 2], rng.standard_normal(8000)))
    path = _npz(tmp_path / "ambient.npz", y)
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", "era", "--band", "10", "100"])
    warned = [line for line in err.splitlines() if "fits free decays" in line]
    assert len(warned) == 1 and warned[0].startswith(f"beam-damage identify: warning: {path}: not a free response")
    assert warned[0].endswith("; era fits free decays (the response after each hit): on a stationary response the "
                              "random ripple of its spectrum's peaks passes for modes; --method ssi reads a "
                              "stationary response")
    white = _npz(tmp_path / "white.npz", rng.standard_normal(y.shape))
    code, out, err = run_cli(capsys, ["identify", str(white), "--method", "era", "--band", "10", "100"])
    assert code == 2 and err.startswith(f"beam-damage identify: error: {white}: no free decay found")
    assert err.rstrip().endswith("; era fits free decays (the response after each hit): on a stationary response the "
                                 "random ripple of its spectrum's peaks passes for modes; --method ssi reads a "
                                 "stationary response)") and len(err.strip().splitlines()) == 1
    hits = _npz(tmp_path / "hits.npz", _hits())
    code, out, err = run_cli(capsys, ["identify", str(hits), "--method", "era", "--band", "10", "100"])
    assert code == 0 and "fits free decays" not in err


def _csv_rows(n=3000):
    y = _hits()[:, :n]
    return ["time_s,1:+Z,2:+Z"] + [f"{k / FS_HZ:.9g},{y[0, k]:.9g},{y[1, k]:.9g}" for k in range(n)]


def test_a_csv_time_series_with_a_byte_order_mark_reads_as_without(capsys, tmp_path):
    rows = _csv_rows()
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    plain.write_text("\n".join(rows) + "\n", encoding="utf-8")
    bom.write_text("\n".join(rows) + "\n", encoding="utf-8-sig")
    results = [run_cli(capsys, ["identify", str(p), "--method", "fftpeak", "--band", "10", "100", "--json"])
               for p in (plain, bom)]
    assert [r[0] for r in results] == [0, 0]
    freqs = [[m["frequency_hz"] for m in json.loads(r[1])["modes"]] for r in results]
    assert freqs[0] == freqs[1]
    np.testing.assert_allclose(freqs[0], [25.0, 60.0], rtol=5e-3)


@pytest.mark.parametrize("edit, message", [
    (lambda r: r[:200] + [r[200].rsplit(",", 1)[0]] + r[201:], "line 201: 2 fields, expected 3 like the header "
                                                               "(truncated file?)"),
    (lambda r: r[:100] + [r[100].split(",")[0] + ",nan," + r[100].split(",")[2]] + r[101:], "line 101: NaN or inf "
                                                                                             "value"),
    (lambda r: r[:100] + [r[100].split(",")[0] + ",," + r[100].split(",")[2]] + r[101:], "line 101: non-numeric "
                                                                                          "field; expected 3 numbers"),
    (lambda r: [x.replace(",", ";") for x in r], "line 1: header 'time_s;1:+Z;2:+Z' has no comma; columns must be "
                                                 "separated by commas, not ';'"),
    (lambda r: ["time_ms" + r[0][6:]] + r[1:], "line 1: a time series' first column must be 'time_s' (seconds), got "
                                               "'time_ms'"),
])
def test_a_bad_csv_time_series_names_its_line(capsys, tmp_path, edit, message):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(edit(_csv_rows(600))) + "\n")
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out, err) == (2, "", f"beam-damage identify: error: {path}: {message}\n")


def test_frfs_estimated_from_time_records_that_give_no_pole_name_the_file_and_the_impact_estimate(capsys, tmp_path):
    pytest.importorskip("pyuff")
    rng = np.random.default_rng(6)
    t = np.arange(4000) / FS_HZ
    path = write_time_uff(tmp_path / "run.uff", t, [(1, rng.standard_normal(t.size), 13, "N"),
                                                    (2, rng.standard_normal(t.size), 12, "m/s^2")])
    code, out, err = run_cli(capsys, ["identify", str(path)])
    assert (code, out) == (2, "")
    assert err.startswith(f"beam-damage identify: error: {path}: no pole is stable over enough model orders")
    assert err.endswith("; FRFs estimated as H1 of random excitation, hann window, 8 averages, 50% overlap, 1.126 Hz "
                        "lines: for a hammer test, 'beam-damage estimate --excitation impact' first\n")
    assert err.count("\n") == 1


def test_estimate_writes_the_format_its_out_extension_names(capsys, tmp_path):
    pytest.importorskip("pyuff")
    rng = np.random.default_rng(7)
    t = np.arange(4000) / FS_HZ
    force = rng.standard_normal(t.size)
    path = write_time_uff(tmp_path / "run.uff", t, [(1, force, 13, "N"), (2, 2.0 * force, 12, "m/s^2")])
    code, out, err = run_cli(capsys, ["estimate", str(path), "--out", str(tmp_path / "frf.npz")])
    assert code == 0, err
    frf = read_frf_npz(tmp_path / "frf.npz")
    np.testing.assert_allclose(frf.frf, 2.0, rtol=1e-9)          # H1 of a response twice the force
    code, out, err = run_cli(capsys, ["estimate", str(path), "--out", str(tmp_path / "frf.mat")])
    assert (code, out) == (2, "")
    assert err == (f"beam-damage estimate: error: --out {tmp_path / 'frf.mat'}: the extension names the format to "
                   "write, one of UFF (.uff/.unv/.uf/.58/.58b), NPZ (.npz) or CSV (.csv/.txt)\n")
    assert not (tmp_path / "frf.mat").exists()
