"""The independent simulator's monitoring series against closed forms: the temperature's frequency shift (half the
EI change), the re-placed mass's shift (first-order Rayleigh quotient), the slit's day; and its files."""

import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from experiments.second_sim.fem import assemble, modes, point_row
from experiments.second_sim.series import (SLIT_SIZES, SeriesConfig, nominal_series_beam, simulate_series,
                                           slit_frequency_drop, write_series)

#: no handling between the tests: only what a test switches on changes (a 24-element mesh keeps the tests fast)
STILL = dict(remount=0.0, mass_shift_m=0.0, temperature_amplitude_c=0.0, temperature_daily_sd_c=0.0,
             damage_day=None, damping_scatter=0.0, min_elements=24)


def _frequencies(tests):
    return np.array([t.truth["frequencies_hz"] for t in tests])


def test_temperature_shifts_every_frequency_by_half_the_EI_change():
    # a rigid clamp: EI scales K alone, so f ~ sqrt(EI) exactly and d f / f = 0.5 d EI / EI to first order
    cfg = SeriesConfig(n_tests=6, **{**STILL, "temperature_daily_sd_c": 8.0}, root_k_L_over_EI=math.inf)
    tests = simulate_series(cfg)
    t = np.array([x.truth["temperature_c"] for x in tests])
    ei = np.array([x.truth["ei_factor"] for x in tests])
    np.testing.assert_allclose(ei, 1 + cfg.ei_per_c * (t - cfg.temperature_mean_c), rtol=1e-12)
    assert np.ptp(ei) > 0.005                                      # the draws span several tenths of a percent
    F = _frequencies(tests)
    np.testing.assert_allclose(F / F[0], np.sqrt(ei / ei[0])[:, None] * np.ones((1, 4)), rtol=1e-8)
    rel = F / F[0] - 1
    np.testing.assert_allclose(rel, 0.5 * (ei / ei[0] - 1)[:, None] * np.ones((1, 4)), atol=2e-5)


def test_a_replaced_mass_shifts_each_mode_as_the_rayleigh_quotient_says():
    cfg = SeriesConfig(n_tests=5, **{**STILL, "mass_shift_m": 0.04})
    tests = simulate_series(cfg)
    x = np.array([t.truth["mass_x_m"] for t in tests])
    assert np.ptp(x) > 0.02
    F = _frequencies(tests)
    nominal = nominal_series_beam(cfg)
    asm = assemble(nominal)
    md = modes(asm)
    keep = asm.dof_index >= 0

    def phi2(xm):                                                  # mass-normalised shape squared at xm, modes 1-4
        d, N = point_row(nominal, xm)
        full = np.zeros((keep.size, 4))
        full[keep] = md.phi[:, :4]
        return (N @ full[d]) ** 2

    x0 = cfg.mass_x_over_L * cfg.length_m
    for k in range(len(tests)):
        # first order: d(omega^2) / omega^2 = -m (phi(x)^2 - phi(x0)^2), so d f / f is half of it
        predicted = -0.5 * cfg.mass_kg * (phi2(x[k]) - phi2(x0))
        measured = F[k] / md.frequencies_hz[:4] - 1
        np.testing.assert_allclose(measured, predicted, atol=0.03 * np.abs(predicted).max() + 2e-6)
    # outward from 0.75 L the first mode's amplitude grows: the mass there lowers it more
    order = np.argsort(x)
    assert F[order[-1], 0] < F[order[0], 0]


@pytest.mark.parametrize("size", list(SLIT_SIZES))
def test_the_slit_appears_on_its_day_and_drops_the_frequencies_as_the_nominal_beam_says(size):
    cfg = SeriesConfig(n_tests=8, days=8.0, **{**STILL, "damage_day": 5.0}, slit_ei_loss=SLIT_SIZES[size])
    tests = simulate_series(cfg)
    damaged = [t.truth["damaged"] for t in tests]
    assert damaged == [False] * 5 + [True] * 3
    assert all(t.truth["slits"][0]["x_m"] == pytest.approx(0.15 * cfg.length_m) for t in tests[5:])
    F = _frequencies(tests)
    np.testing.assert_allclose(1 - F[5] / F[0], slit_frequency_drop(cfg), rtol=1e-6)
    assert 0.001 < slit_frequency_drop(cfg)[0] < 0.05


def test_series_files_are_what_the_truth_says_and_identical_before_the_damage(tmp_path):
    from physics.beam import load_beam
    from physics.io.formats import read_frf
    from physics.io.timeseries import read_time_npz

    cfg = SeriesConfig(n_tests=4, days=4.0, damage_day=2.0, min_elements=24)
    out = write_series(cfg, simulate_series(cfg), tmp_path / "a")
    other = replace(cfg, slit_ei_loss=SLIT_SIZES["large"])
    out_b = write_series(other, simulate_series(other), tmp_path / "b")
    truth = json.loads((out / "truth.json").read_text())
    assert [t["damaged"] for t in truth["tests"]] == [False, False, True, True]
    assert truth["first_damaged_test"] == 2 and truth["first_damaged_day"] == 2.0
    for k in range(4):
        same = (out / f"test-00{k}.uff").read_bytes() == (out_b / f"test-00{k}.uff").read_bytes()
        assert same == (k < 2)
    rows = list(csv.DictReader((out / "conditions.csv").open()))
    assert [r["file"] for r in rows] == [t["file"] for t in truth["tests"]]
    np.testing.assert_allclose([float(r["temperature_c"]) for r in rows],
                               [t["measured_temperature_c"] for t in truth["tests"]], atol=0.006)
    beam = load_beam(out / "beam.toml")
    np.testing.assert_allclose(beam.measured_x_m, [0.8 / 3, 1.6 / 3, 0.8], rtol=1e-9)
    frf = read_frf(out / "test-000.uff")
    assert frf.frf.shape[0] == 3 and frf.frequency_hz.size == cfg.freq_hz.size
    oo = replace(cfg, kind="output-only", n_tests=2, duration_s=2.0, damage_day=None)
    rec = read_time_npz(write_series(oo, simulate_series(oo), tmp_path / "oo") / "test-000.npz")
    assert rec.signals.shape == (3, 2000)


def test_bad_series_configurations_are_refused():
    with pytest.raises(ValueError, match="kind"):
        SeriesConfig(kind="strain")
    with pytest.raises(ValueError, match="n_tests"):
        SeriesConfig(n_tests=1)


def test_a_frequency_series_is_the_fem_at_each_test_and_its_steps_are_exact():
    from experiments.second_sim.series import FrequencySeriesConfig, frequency_series, uniform_stiffness_pattern

    beam = SeriesConfig(n_tests=2, damage_day=None, min_elements=24)
    cfg = FrequencySeriesConfig(beam=beam, days=14, tests_per_day=4, seed=3, frequency_noise=0.0)
    fs = frequency_series(cfg)
    assert fs.frequencies_hz.shape == (56, 4) and not fs.damaged.any()
    assert np.unique(fs.root_spring_factor[fs.day < 7]).size == 1            # re-mounted weekly
    assert np.unique(fs.root_spring_factor).size == 2
    nominal = nominal_series_beam(beam)
    for i in (0, 17, 55):                                                    # the surrogate against the FEM
        b = replace(nominal, EI_Nm2=beam.EI_Nm2 * fs.ei_factor[i],
                    root_k_theta_Nm_rad=nominal.root_k_theta_Nm_rad * fs.root_spring_factor[i],
                    masses=(replace(nominal.masses[0], x_m=fs.mass_x_m[i]),))
        np.testing.assert_allclose(fs.true_hz[i], modes(assemble(b), n_refine=4).frequencies_hz[:4], rtol=1e-4)
    one = frequency_series(replace(cfg, step_day=10.0, step_fraction=0.01, step_modes=(1,)))
    ratio = one.frequencies_hz / fs.frequencies_hz
    np.testing.assert_allclose(ratio[one.damaged], [[0.99, 1, 1, 1]] * int(one.damaged.sum()))
    np.testing.assert_allclose(ratio[~one.damaged], 1.0)
    assert one.damaged.sum() == 16
    # a rigid clamp: f ~ sqrt(EI) for every mode, so a uniform EI loss drops every mode alike
    np.testing.assert_allclose(uniform_stiffness_pattern(replace(beam, root_k_L_over_EI=math.inf)), 1.0, atol=1e-6)


def test_a_mass_loss_raises_the_modes_as_the_rayleigh_quotient_says():
    from experiments.second_sim.series import mass_loss_pattern

    cfg = SeriesConfig(n_tests=2, **STILL)
    nominal = nominal_series_beam(cfg)
    asm = assemble(nominal)
    md = modes(asm, n_refine=4)
    keep = asm.dof_index >= 0
    full = np.zeros((keep.size, 4))
    full[keep] = md.phi[:, :4]
    d, N = point_row(nominal, cfg.mass_x_over_L * cfg.length_m)
    phi2 = (N @ full[d]) ** 2                                   # mass-normalised shapes squared at the mass
    # first order: losing dm raises ln f by dm phi(x)^2 / 2; the pattern is that over its mean
    pattern = mass_loss_pattern(cfg, loss=0.02)
    np.testing.assert_allclose(pattern, phi2 / phi2.mean(), rtol=0.03)


def test_drop_pattern_reads_the_kind_named():
    """``drop_pattern``: a tuple drops the modes named alone, ``stiffness`` and ``mass`` are the closed patterns
    (the mass negated: the modes rise)."""
    from experiments.second_sim.series import SeriesConfig, drop_pattern, mass_loss_pattern, uniform_stiffness_pattern

    beam = SeriesConfig(n_modes=4)
    np.testing.assert_array_equal(drop_pattern(beam, (1, 3)), [1.0, 0.0, 1.0, 0.0])
    np.testing.assert_array_equal(drop_pattern(beam, "stiffness"), uniform_stiffness_pattern(beam))
    np.testing.assert_array_equal(drop_pattern(beam, "mass"), -mass_loss_pattern(beam))
