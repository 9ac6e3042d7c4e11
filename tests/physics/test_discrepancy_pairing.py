"""The discrepancy workflow's pairing (classify's rule, learn.pairs.measured.pair_modes_by_frequency), its stop before
any fit, the stop on a failed noise check, and one sensor (shapes optional) on the one-accelerometer cantilever of
experiments/second_sim/one_sensor.py (nominal modes 22.21, 138.8, 386.3, 757.9, 1261 Hz, the accelerometer's 5 g in the
beam file)."""

import re
from types import SimpleNamespace

import numpy as np
import pytest

import experiments.second_sim.one_sensor as osc
from experiments.cli.cmd_discrepancy import CLASSIFY_PAIRING
from learn.pairs.measured import pair_modes_by_frequency
from physics import discrepancy as dsc
from physics.beam import load_beam
from physics.errors import ShapeError
from physics.discrepancy.selection import _separating_measurement


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    p = tmp_path_factory.mktemp("one") / "beam.toml"
    p.write_text(osc.beam_toml((30.0, 1600.0)))
    return load_beam(p)


def _pairing(beam, f_hz, rule=pair_modes_by_frequency):
    meas = dsc.Measurement(np.asarray(f_hz, float))
    return dsc.pair_measured(meas, dsc.predict(beam, meas, 40), rule, beam.band_hz)


def test_a_test_without_the_first_mode_pairs_138_hz_with_mode_2(beam):
    """The four modes above 22 Hz: the median-ratio rule pairs 138.8 Hz with model mode 1 (-84 %), classify's rule
    with mode 2 (within 0.05 %), and names mode 1 as below the band 30-1600 Hz."""
    f = [138.8, 386.3, 757.9, 1261.2]
    old = _pairing(beam, f, None)
    assert old.model_index.tolist() == [0, 1, 2, 3]
    assert 100 * (old.model_hz[0] / 138.8 - 1) == pytest.approx(-84.0, abs=0.1)
    p = _pairing(beam, f)
    assert p.model_index.tolist() == [1, 2, 3, 4] and p.plausible
    assert max(abs(r["error_pct"]) for r in p.to_list()) < 0.05
    assert p.skipped == ("model mode 1 (22.21 Hz) lies below the band 30-1600 Hz",)


def test_a_spurious_pole_and_a_missed_mode(beam):
    """A pole at 1150 Hz next to mode 5 (1261 Hz) pairs with nothing and stops; a test without mode 4 pairs the
    others and names mode 4 as missed."""
    p = _pairing(beam, [22.2, 138.8, 386.3, 757.9, 1150.0, 1261.2])
    assert p.model_index.tolist() == [0, 1, 2, 3, -1, 4] and not p.plausible
    assert p.unpaired[0].startswith("measured mode at 1150 Hz pairs with no model mode (nearest: model mode 5 at "
                                    "1261 Hz, +9.7 %, is the measured mode at 1261 Hz")
    err = dsc.pairing.implausible_pairing(p)
    assert "a spurious pole" in str(err) and err.result["pairing"][4]["model_mode"] is None
    q = _pairing(beam, [22.2, 138.8, 386.3, 1261.2])
    assert q.model_index.tolist() == [0, 1, 2, 4] and q.plausible
    assert q.skipped[0].startswith("model mode 4 (757.9 Hz) has no measured mode: missed")


def test_an_implausible_pairing_stops_before_any_fit(beam):
    """analyse raises before its first fit (no progress message) with the cause in one line."""
    said = []
    with pytest.raises(dsc.ImplausibleTest, match=r"measured mode at 60 Hz pairs with no model mode") as exc:
        dsc.analyse(beam, dsc.Measurement(np.array([60.0, 138.8, 386.3])), pairing=pair_modes_by_frequency,
                    band_hz=beam.band_hz, progress=said.append)
    assert said == [] and "\n" not in str(exc.value)
    assert "model mode 1 (22.21 Hz) lies below the band" in str(exc.value)


def test_a_noise_check_failed_by_orders_of_magnitude_names_the_worst_mode():
    """chi2/dof 131 (FRF block 260) stops and names the FRF band of the worst mode; 50 does not stop."""
    r = SimpleNamespace(measured_hz=np.array([22.2, 138.8]), frequency_error_pct=np.array([0.05, -0.1]),
                        frf_band_error_db=np.array([28.7, 2.9]), mac=None)
    chk = SimpleNamespace(chi2_per_dof=131.0, blocks={"frequencies": {"chi2_per_dof": 1.66},
                                                      "FRF": {"chi2_per_dof": 260.0}})
    pairing = SimpleNamespace(skipped=("model mode 1 (22.21 Hz) lies below the band 30-1600 Hz",))
    stop = dsc.failed_noise_check(chk, r, pairing)
    assert stop["stopped"].startswith("the calibrated model fails its own noise check by orders of magnitude "
                                      "(chi2/dof 131 > 100), no beam file written; likely cause: model mode 1")
    assert stop["causes"][1].startswith("the FRF's level around measured mode 1 (22.2 Hz) differs from the model's "
                                        "by 28.7 dB rms")
    assert dsc.failed_noise_check(SimpleNamespace(chi2_per_dof=50.0, blocks={}), r, pairing) is None
    freq = SimpleNamespace(chi2_per_dof=400.0, blocks={"frequencies": {"chi2_per_dof": 400.0}})
    assert "measured mode 2 (138.8 Hz) stays -0.10 % off" in dsc.failed_noise_check(freq, r, None)["stopped"]


def test_a_block_failed_by_orders_of_magnitude_stops_however_well_the_others_fit():
    """A tension no candidate models: the frequencies block's chi2/dof 306, the shapes' 0.108 bring the whole to 64
    (under 100); the frequencies' failure stops, naming the block and the mode that stays off."""
    r = SimpleNamespace(measured_hz=np.array([22.6, 118.9]), frequency_error_pct=np.array([-9.44, 0.3]),
                        frf_band_error_db=None, mac=np.array([0.999, 0.998]))
    chk = SimpleNamespace(chi2_per_dof=64.4, blocks={"frequencies": {"chi2_per_dof": 306.0},
                                                     "mode shapes": {"chi2_per_dof": 0.108}})
    stop = dsc.failed_noise_check(chk, r, None)
    assert stop["stopped"].startswith("the calibrated model fails its own noise check by orders of magnitude (the "
                                      "frequencies block's chi2/dof 306 > 100, 64.4 over every residual), no beam "
                                      "file written; likely cause: measured mode 1 (22.6 Hz) stays -9.44 % off")
    chk.blocks["frequencies"]["chi2_per_dof"] = 90.0
    chk.chi2_per_dof = 20.0
    assert dsc.failed_noise_check(chk, r, None) is None


def test_a_mode_within_the_ratio_band_but_of_another_shape_is_named_by_its_mac(beam):
    """Two sensors (0.2 and 0.4 m) whose shapes of mode 5 are the nominal mode 4's (MAC with the nominal mode 5
    below 0.5): the frequency is 3 % off mode 5, and the stop names the MAC rule, not the 35 % band."""
    f = np.array([22.2, 138.8, 386.3, 757.9, 1300.0])
    nominal = dsc.predict(beam, dsc.Measurement(f, shapes=np.ones((2, 5)), shape_x_m=(0.2, 0.4)), 40)
    shapes = np.array(nominal.shapes[:, :5])
    shapes[:, 4] = shapes[:, 3]
    meas = dsc.Measurement(f, shapes=shapes, shape_x_m=(0.2, 0.4))
    p = dsc.pair_measured(meas, dsc.predict(beam, meas, 40), CLASSIFY_PAIRING, beam.band_hz)
    assert p.model_index[4] == -1
    assert re.search(r"measured mode at 1300 Hz pairs with no model mode \(nearest: model mode 5 at 1261 Hz, -3.0 %, "
                     r"but the shapes' MAC [0-9.]+ is below the pairing rule's 0.5\)", p.unpaired[0]), p.unpaired[0]


def test_one_sensor_separating_measurement_and_simulation(beam):
    """One measured position compares no shape: a one-row shape is held as none, the measurement that separates two
    models compares shapes at the quarter points, and a one-sensor simulation gives frequencies (shapes refused in
    one line)."""
    meas = dsc.Measurement(np.array([22.2, 138.8, 386.3]))
    a = SimpleNamespace(beam=beam)
    b = SimpleNamespace(beam=beam.with_effects({**beam.effects_dict(), "root_flexibility": {"k_theta_Nm_rad": 2e3}}))
    assert _separating_measurement(a, b, meas, dsc.Noise(), 24) == ("natural frequency of mode 4 (8.8 % apart: "
                                                                    "757.9 vs 696.4 Hz)")
    precise = _separating_measurement(a, b, meas, dsc.Noise(0.003, 0.1, 0.001), 24)
    assert precise == ("mode shapes at the quarter points (more sensors than the one measured) (largest normalised "
                       "difference 0.14)")
    one = dsc.Measurement(np.array([22.2, 138.8]), shapes=np.ones((1, 2)), shape_x_m=(0.1,))
    assert one.shapes is None and one.shape_x_m == ()
    with pytest.raises(ShapeError, match=r"measured shapes must be \(n_points, n_modes = 2\)"):
        dsc.Measurement(np.array([22.2, 138.8]), shapes=np.ones((2, 2)), shape_x_m=(0.1,))
    sim = dsc.simulate_measurement(beam, 3, damping=False)
    assert sim.shapes is None and sim.frequencies_hz[0] == pytest.approx(22.21, rel=0.01)
    with pytest.raises(ShapeError, match="at least 2 measured positions, the beam has 1"):
        dsc.simulate_measurement(beam, 3, damping=False, shapes=True)


def test_one_sensor_frequencies_calibrate_ei_with_the_added_mass(beam):
    """Frequencies alone of a truth with EI 10 % above the beam file's (the independent simulator, the 5 g
    accelerometer on it), the beam file's added mass kept: the globals-only fit recovers EI 103.95 N m^2 within
    0.3 %; the modes pair 1-5."""
    f = np.sqrt(1.1) * osc.truth_frequencies_hz()[:5]
    res = dsc.analyse(beam, dsc.Measurement(f), candidates=(), n_elements=24, pairing=pair_modes_by_frequency,
                      band_hz=(10.0, 1600.0))
    assert res.pairing.model_index.tolist() == [0, 1, 2, 3, 4]
    assert res.final.parameters["EI_Nm2"] == pytest.approx(1.1 * osc.EI_NM2, rel=0.003)
    assert res.final.beam.effects["added_mass"]["mass_kg"] == pytest.approx(0.005)


def test_the_pole_off_the_other_modes_ratio_trend_is_named_the_likelier_spurious_one(beam):
    """A test 4.65 % above the beam file on every mode (mode 5 at 1.0465 x 1261 = 1320 Hz) with a pole at 1230 Hz:
    the nominal rule pairs 1230 Hz (-2.5 %) with mode 5 and leaves 1320 Hz unpaired; the stop names 1230 Hz the
    likelier spurious pole, the ratio trend of modes 2-4 putting mode 5 at 1.0465 x 1261 Hz. With a shear-like trend
    (ln(f / f_model) = 0.02 - 6e-5 f_model: mode 5 at 1193 Hz) a pole at 1240 Hz, nearer the median-scaled model
    (1257 Hz) than mode 5, is named too, at the line's own prediction; classify's rule pairs the pole the stop keeps."""
    f = 1.0465 * np.array([138.81, 386.28, 757.85, 1261.21])
    p = _pairing(beam, sorted([*f, 1230.0]))
    assert p.model_index.tolist() == [1, 2, 3, 4, -1] and not p.plausible
    said = re.search(r"; the ratios of modes 2, 3, 4 to the model put mode 5 at (\d+) Hz: 1230 Hz is the likelier "
                     r"spurious pole$", p.unpaired[0])
    assert said and float(said[1]) == pytest.approx(1.0465 * p.model_hz[4], abs=0.5)
    # the command's rule (classify's, with the ratio trend): 1320 Hz is mode 5, 1230 Hz the unpaired pole named
    p = _pairing(beam, sorted([*f, 1230.0]), CLASSIFY_PAIRING)
    assert p.model_index.tolist() == [1, 2, 3, -1, 4] and not p.plausible
    assert p.unpaired[0].startswith("measured mode at 1230 Hz pairs with no model mode")
    assert "likelier spurious pole" not in p.unpaired[0]
    model = p.model_hz[1:5]
    sheared = model * np.exp(0.02 - 6e-5 * model)
    p = _pairing(beam, [*sheared, 1240.0])
    assert p.model_index.tolist() == [1, 2, 3, -1, 4]
    said = re.search(r"put mode 5 at (\d+) Hz: 1240 Hz is the likelier spurious pole$", p.unpaired[0])
    assert said and float(said[1]) == pytest.approx(sheared[3], abs=0.5) and round(sheared[3]) == 1193
    assert _pairing(beam, [*sheared, 1240.0], CLASSIFY_PAIRING).model_index.tolist() == [1, 2, 3, 4, -1]
    # a pole off the trend itself gets no such sentence
    q = _pairing(beam, [22.2, 138.8, 386.3, 757.9, 1150.0, 1261.2])
    assert "likelier spurious pole" not in q.unpaired[0]
