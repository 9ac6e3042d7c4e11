"""Beam file: presets, TOML round trip, validation of every key, FE model with effects."""

import numpy as np
import pytest

from physics import fem, modal, properties
from physics.beam import Beam, beam_from_dict, load_beam, preset_beam, write_beam
from physics.errors import ConfigError


def test_preset_matches_table_4_1():
    b = load_beam("beam5")
    assert b.EI_Nm2 == 22.674
    assert b.mass_per_length_kg_m == pytest.approx(0.15792 / 1.219)
    assert b.length_m == 0.6095 and b.n_elements == 4
    assert b.measured_x_m == pytest.approx((0.152375, 0.30475, 0.457125, 0.6095))
    assert b.masters == ("2:y", "3:y", "4:y", "5:y")


def test_fe_model_without_effects_is_the_euler_bernoulli_model():
    b = load_beam("beam6")
    ref = fem.beam_model(4, b.length_m, b.EI_Nm2 * 1.1, b.mass_per_length_kg_m * 0.9)
    m = b.fe_model(EI_scale=1.1, mass_scale=0.9)
    np.testing.assert_allclose(m.K, ref.K, rtol=1e-13)
    np.testing.assert_allclose(m.M, ref.M, rtol=1e-13)
    assert m.dofs == ref.dofs


def test_fe_model_converges_to_eq_4_5():
    b = load_beam("beam5")
    m = b.fe_model(60)
    w, _ = modal.undamped_modes(m.M, m.K)
    exact = properties.cantilever_frequencies_hz(b.EI_Nm2, b.mass_per_length_kg_m, b.length_m,
                                                 properties.cantilever_beta_l(4))
    np.testing.assert_allclose(w[:4] / (2 * np.pi), exact, rtol=1e-6)


def test_round_trip_with_effects(tmp_path):
    b = preset_beam("beam5").with_effects({
        "shear_deformation": {"kGA_N": 2.0e4},
        "root_flexibility": {"k_theta_Nm_rad": 5e3, "k_y_N_m": 1e7},
        "added_mass": {"mass_kg": 0.004, "x_m": 0.5},
        "local_damping": {"c_Ns_m": 0.05},
    }, name="calibrated")
    p = tmp_path / "b.toml"
    write_beam(p, b, comment="written by a test\nseed 0")
    back = load_beam(p)
    assert back == b
    np.testing.assert_allclose(back.fe_model(8).K, b.fe_model(8).K)
    assert "1:y" in back.fe_model().dofs  # translational root spring keeps the root translation


def test_preset_key_and_alternative_inputs(tmp_path):
    p = tmp_path / "b.toml"
    p.write_text('preset = "beam5"\nmass_kg = 0.2\nn_elements = 8\n[effects.added_mass]\nmass_kg = 0.01\n',
                 encoding="utf-8")
    b = load_beam(p)
    assert b.mass_per_length_kg_m == pytest.approx(0.2 / 1.219)
    assert b.n_elements == 8 and b.effects["added_mass"]["mass_kg"] == 0.01
    # eq. 4.1 from the layers: faces 0.5 mm of E_f on a core of E_c
    d = {"length_m": 0.6, "width_m": 0.05, "thickness_m": 0.008, "face_thickness_m": 0.0005,
         "core_modulus_pa": 1e8, "face_modulus_pa": 5e10, "mass_per_length_kg_m": 0.1}
    ei = 2 * 0.05 / 3 * (1e8 * 0.0035**3 + 5e10 * (0.004**3 - 0.0035**3))
    assert beam_from_dict(d).EI_Nm2 == pytest.approx(ei)


@pytest.mark.parametrize("text, fragment", [
    ('preset = "beam5"\nfoo = 1\n', "unknown key 'foo'"),
    ('preset = "beam9"\n', "'preset'"),
    ('preset = "beam5"\nEI_Nm2 = -3\n', "'EI_Nm2'"),
    ('preset = "beam5"\nEI_Nm2 = "big"\n', "'EI_Nm2'"),
    ('preset = "beam5"\nbc = "welded"\n', "'bc'"),
    ('preset = "beam5"\nn_elements = 2.5\n', "'n_elements'"),
    ('preset = "beam5"\nmeasured_x_m = [0.1, 9.0]\n', "'measured_x_m'"),
    ('preset = "beam5"\n[effects.magic]\nx = 1\n', "effects.magic"),
    ('preset = "beam5"\n[effects.shear_deformation]\nrho_I_kg_m = 1e-6\n', "kGA_N"),
    ('preset = "beam5"\n[effects.root_flexibility]\nk_theta_Nm_rad = 0\n', "k_theta_Nm_rad"),
    ('preset = "beam5"\n[effects.added_mass]\nmass_kg = 0.1\nx_m = 2.0\n', "x_m"),
    ('preset = "beam5"\n[effects.local_damping]\nc_Ns_m = 1e9\n', "effects.local_damping make 2 mode(s) of the "
                                                                   "model overdamped"),
    ('preset = "beam5"\n[effects.added_mass]\nmass_kg = 1e12\n', "effects.added_mass leave no positive definite"),
    ('preset = "beam5"\n[effects.root_flexibility]\nk_theta_Nm_rad = 1e-12\n', "leave no positive definite"),
    ('length_m = 0.6\nwidth_m = 0.05\nthickness_m = 0.008\nmass_kg = 0.1\n', "EI_Nm2"),
    ('preset = "beam5"\nEI_Nm2 = 20\nface_modulus_pa = 5e10\n', "not both"),
    ("preset = 'beam5\n", "not valid TOML"),
])
def test_bad_beam_files_are_refused_with_the_key(tmp_path, text, fragment):
    p = tmp_path / "bad.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_beam(p)
    msg = str(err.value)
    assert fragment in msg and "\n" not in msg and str(p) in msg


def test_non_utf8_and_missing_files(tmp_path):
    p = tmp_path / "latin.toml"
    p.write_bytes('name = "Träger"\n'.encode("latin-1"))
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_beam(p)
    with pytest.raises(ConfigError, match="neither a beam preset"):
        load_beam(tmp_path / "nope.toml")


def test_beam_is_frozen():
    b = load_beam("beam8")
    with pytest.raises(AttributeError):
        b.EI_Nm2 = 1.0
    with pytest.raises(TypeError):
        b.effects["added_mass"] = {"mass_kg": 1.0}
    assert isinstance(b, Beam)
