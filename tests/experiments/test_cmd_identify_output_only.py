"""``beam-damage identify`` on response records without a force (output-only), and ``update`` refusing them."""

import json
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run_cli
from oma_records import chain_record
from systems import write_time_uff

from physics.modal import mac

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def chain():
    return chain_record(seconds=300, seed=5)


def _npz(path, y, fs, **extra):
    np.savez(path, signals=y, sampling_frequency_hz=np.array(fs), dofs=np.array(["1:+Z", "2:+Z", "3:+Z"]),
             quantity=np.array("displacement"), **extra)
    return path


def test_identify_picks_ssi_for_a_universal_file_of_responses_and_writes_unscaled_modal_json(capsys, chain,
                                                                                               tmp_path):
    pytest.importorskip("pyuff")
    y, fs, fn, zeta, phi = chain
    path = write_time_uff(tmp_path / "ambient.uff", np.arange(y.shape[1]) / fs,
                          [(k + 1, y[k], 8, "m") for k in range(3)])
    code, out, err = run_cli(capsys, ["identify", str(path), "--band", "1", "60", "--max-order", "30",
                                      "--out", str(tmp_path / "id"), "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["method"] == "ssi" and res["output_only"] and res["method_choice"].startswith("picked ssi")
    assert res["scaling"].startswith("unscaled") and res["dofs"] == ["1:+Z", "2:+Z", "3:+Z"]
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    np.testing.assert_allclose(f, fn, rtol=2e-3)
    np.testing.assert_allclose([m["damping_ratio"] for m in res["modes"]], zeta, rtol=0.15)
    assert all(np.isfinite(m["frequency_std_hz"]) and m["frequency_std_hz"] > 0 for m in res["modes"])
    saved = json.loads((tmp_path / "id" / "modal.json").read_text())
    assert saved["scaling"].startswith("unscaled") and len(saved["frequency_std_hz"]) == 3
    shapes = np.array([[complex(z) for z in row] for row in saved["eigenvectors"]])
    assert np.all(np.diag(mac(phi, shapes)) > 0.999)
    np.testing.assert_allclose(np.linalg.norm(shapes, axis=0), 1.0)
    # update refuses the unscaled shapes in one line, and the records themselves too
    code, out, err = run_cli(capsys, ["update", "--beam", "beam5", "--modal", str(tmp_path / "id" / "modal.json")])
    assert code == 2 and "unscaled" in err and "mass-normalise" in err and err.count("\n") == 1
    code, out, err = run_cli(capsys, ["update", "--beam", "beam5", "--modal", str(path)])
    assert code == 2 and "output-only shapes are unscaled" in err and err.count("\n") == 1


def test_identify_npz_and_csv_time_series_by_a_named_method(capsys, chain, tmp_path):
    y, fs, fn, *_ = chain
    code, out, err = run_cli(capsys, ["identify", str(_npz(tmp_path / "a.npz", y, fs)), "--method", "efdd",
                                      "--band", "1", "60", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["method"] == "efdd" and "named by --method" in res["method_choice"]
    np.testing.assert_allclose([m["frequency_hz"] for m in res["modes"]], fn, rtol=2e-3)
    n = y.shape[1]
    rows = "\n".join(",".join(f"{v:.9g}" for v in (k / fs, *y[:, k])) for k in range(n))
    (tmp_path / "a.csv").write_text("# quantity: displacement\ntime_s,1:+Z,2:+Z,3:+Z\n" + rows + "\n")
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "a.csv"), "--band", "1", "60", "--max-order", "30"])
    assert code == 0, err
    assert out.startswith("picked ssi") and "3 modes by ssi" in out


def test_identify_the_real_four_channel_acceleration_file_output_only(capsys):
    pytest.importorskip("pyuff")
    code, out, err = run_cli(capsys, ["identify", str(DATA / "MPSTD_Set001_2024_10_08_10_27_07.uff"), "--band", "100",
                                      "400", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["method"] == "ssi" and res["sampling_frequency_hz"] == 3200 and res["kind"] == "acceleration"
    assert res["duration_s"] == pytest.approx(222400 / 3200)
    assert any(abs(m["frequency_hz"] - 141) < 2 for m in res["modes"])   # the 141 Hz mode of its FDD and SSI
    code, out, err = run_cli(capsys, ["identify", str(DATA / "MPSTD_Set001_2024_10_08_10_27_07.uff"), "--json"])
    assert code == 0, err                        # with the defaults: the 182.3 Hz mode the docs name
    assert any(abs(m["frequency_hz"] - 182.3) < 0.5 for m in json.loads(out)["modes"])


@pytest.mark.parametrize("method", ["ssi", "fdd", "efdd"])
@pytest.mark.parametrize("case, message", [
    ("nan", "NaN"), ("inf", "inf"), ("constant", "constant"), ("clip", "clipped"), ("nyquist", "Nyquist"),
    ("no_rate", "sampling_frequency_hz"), ("short", "ten periods"), ("frf_file", "holds FRFs")])
def test_bad_records_get_one_line_and_exit_2_from_every_output_only_method(capsys, chain, tmp_path, case, message,
                                                                          method):
    """One set of checks (physics.identification.record_checks) for every output-only method."""
    y, fs, *_ = (a.copy() if isinstance(a, np.ndarray) else a for a in chain)
    argv_extra = ["--band", "1", "60"]
    if case == "nan":
        y[0, 100] = np.nan
    elif case == "inf":
        y[2, 7] = -np.inf
    elif case == "constant":
        y[1] = 0.25
    elif case == "clip":
        y[1] = np.minimum(y[1], 0.5 * y[1].max())
    elif case == "nyquist":
        argv_extra = ["--band", "1", "150"]
    elif case == "short":
        y, argv_extra = y[:, :240], ["--band", "5", "60", "--max-order", "12"]
    path = _npz(tmp_path / "r.npz", y, fs)
    if case == "no_rate":
        np.savez(path, signals=y)
    if case == "frf_file":
        from physics.io import MeasuredFRF, write_frf_npz

        f = np.linspace(1, 50, 100)
        write_frf_npz(path, MeasuredFRF(f, np.ones((1, 1, 100), complex) / (1 + f * 1j), ("1:+Z",), ("1:+Z",)))
    code, out, err = run_cli(capsys, ["identify", str(path), "--method", method, *argv_extra])
    assert code == 2 and message in err and err.count("\n") == 1, err


@pytest.mark.slow
def test_output_only_modes_feed_discrepancy_like_the_true_modes(capsys, tmp_path):
    """Records of the thesis beam-5 model -> identify (SSI) -> discrepancy: the gap it reports equals the gap of the
    simulation's true frequencies within the identification error."""
    from scipy import linalg, signal

    from physics.thesis import BEAM5_DOFS, beam5_reduced_model

    M, _, K = beam5_reduced_model("thesis")
    w2, phi = linalg.eigh(K, M)
    wn, fs, rng = np.sqrt(w2), 2000.0, np.random.default_rng(0)
    force, y = rng.standard_normal(int(300 * fs)), 0.0
    for r in range(4):
        b, a, _ = signal.cont2discrete(([1.0, 0, 0], [1, 2 * 0.005 * wn[r], wn[r] ** 2]), 1 / fs, "zoh")
        y = y + np.outer(phi[:, r], signal.lfilter(b.ravel(), a, phi[3, r] * force))
    y = y + 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    np.savez(tmp_path / "b5.npz", signals=y, sampling_frequency_hz=np.array(fs), dofs=np.array(BEAM5_DOFS))
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "b5.npz"), "--band", "5", "800", "--out",
                                      str(tmp_path / "id")])
    assert code == 0, err
    (tmp_path / "true.json").write_text(json.dumps({"natural_frequencies_hz": (wn / (2 * np.pi)).tolist()}))
    gaps = []
    for name in ("id/modal.json", "true.json"):
        code, out, err = run_cli(capsys, ["discrepancy", "--beam", "beam5", "--measured", str(tmp_path / name),
                                          "--json"])
        assert code == 0, err
        gaps.append(json.loads(out)["gap_before"]["max_abs_frequency_error_pct"])
    assert gaps[0] == pytest.approx(gaps[1], abs=0.1)


def test_identify_merges_setups_with_a_fixed_reference(capsys, tmp_path):
    y, fs, fn, zeta, phi = chain_record(seconds=300, seed=6)
    y2, *_ = chain_record(seconds=300, seed=7)
    np.savez(tmp_path / "s1.npz", signals=y[[2, 0]], sampling_frequency_hz=np.array(fs),
             dofs=np.array(["3:+Z", "1:+Z"]), quantity=np.array("displacement"))
    np.savez(tmp_path / "s2.npz", signals=3 * y2[[1, 2]], sampling_frequency_hz=np.array(fs),
             dofs=np.array(["2:+Z", "3:+Z"]), quantity=np.array("displacement"))
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "s1.npz"), "--setup", str(tmp_path / "s2.npz"),
                                      "--band", "1", "60", "--max-order", "30", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert res["dofs"] == ["3:+Z", "1:+Z", "2:+Z"] and res["setup_references"] == ["3:+Z"]
    shapes = np.array([[complex(z) for z in m["shape"]] for m in res["modes"]]).T
    assert np.all(np.diag(mac(phi[[2, 0, 1]], shapes)) > 0.999)
    code, out, err = run_cli(capsys, ["identify", str(tmp_path / "s1.npz"), "--setup", str(DATA / "nothing.npz")])
    assert code == 2 and err.count("\n") == 1


def test_era_tried_on_a_stationary_record_after_ssi_found_nothing_warns_as_when_named(capsys, tmp_path):
    """A stationary record where SSI-cov at the highest order given finds no stable mode: ERA is tried next, and its
    modes carry the warning ``--method era`` gives on a record that is not a free response."""
    y, fs, *_ = chain_record(seconds=120.0)
    path = _npz(tmp_path / "ambient.npz", y, fs)
    code, out, err = run_cli(capsys, ["identify", str(path), "--max-order", "2", "--json"])
    assert code == 0, err
    res = json.loads(out)
    assert "ssi found no mode" in json.dumps(res) and "so era" in json.dumps(res)
    assert any("era fits free decays" in w and "not a free response" in w for w in res["warnings"])
