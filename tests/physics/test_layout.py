"""The test a beam file describes (physics.layout): closed-form bending frequencies per support, the modes a
band holds and the sensors see, default zones, and the one-line refusals."""

import numpy as np
import pytest

from physics.beam import beam_from_dict, load_beam
from physics.errors import ConfigError
from physics.layout import DEFAULT_BAND_HZ, Layout, layout_of

EI, M, L = 210e9 * 0.04 * 0.01**3 / 12, 7850 * 0.04 * 0.01, 1.0
STEEL = dict(name="bar", length_m=L, width_m=0.04, thickness_m=0.01, EI_Nm2=EI, mass_per_length_kg_m=M,
             measured_x_m=[k / 7 for k in range(1, 7)])
SCALE = np.sqrt(EI / M) / (2 * np.pi * L**2)
BETA_L = {"clamped-free": [1.8751, 4.6941, 7.8548, 10.9955], "free-free": [4.7300, 7.8532, 10.9956, 14.1372],
          "clamped-clamped": [4.7300, 7.8532, 10.9956, 14.1372],
          "pinned-pinned": [np.pi * k for k in range(1, 5)]}


@pytest.mark.parametrize("bc", sorted(BETA_L))
def test_bending_frequencies_of_each_support_match_the_closed_form(bc):
    lay = layout_of(beam_from_dict({**STEEL, "bc": bc, "band_hz": [1.0, 2000.0]}))
    f = np.asarray(lay.frequencies_hz)[:4]
    np.testing.assert_allclose(f, np.square(BETA_L[bc]) * SCALE, rtol=2e-4)
    assert lay.modes[:4] == (1, 2, 3, 4)  # rigid-body modes of a free-free bar left out


def test_the_thesis_beams_keep_the_thesis_test():
    for name in ("beam5", "beam6", "beam8"):
        lay = layout_of(load_beam(name))
        assert lay.thesis and lay.modes == (1, 2, 3, 4) and lay.band_hz == DEFAULT_BAND_HZ
        np.testing.assert_allclose(lay.zones_x_m, np.linspace(0, lay.length_m, 5))
        assert lay.drive_sensor == 0 and lay.zone_of([0.0, 0.2, np.nan]).tolist() == [1, 2, 0]
    assert Layout.from_dict(lay.to_dict()) == lay


def test_a_midspan_sensor_of_a_pinned_beam_sees_the_odd_modes_only():
    lay = layout_of(beam_from_dict({**STEEL, "bc": "pinned-pinned", "measured_x_m": [0.5]}))
    assert lay.modes == (1, 3, 5) and lay.unseen == (2, 4)
    assert lay.zones_x_m == (0.0, 0.25, 0.5, 0.75, 1.0)  # one sensor: four equal zones
    assert not lay.thesis


def test_the_band_decides_the_modes_and_the_zones_follow_the_sensors():
    lay = layout_of(beam_from_dict({**STEEL, "bc": "free-free", "band_hz": [40.0, 300.0]}))
    assert lay.modes == (1, 2, 3)
    np.testing.assert_allclose(lay.zones_x_m, np.arange(8) / 7)
    lay = layout_of(beam_from_dict({**STEEL, "zones_x_m": [0.3, 0.6]}))
    assert lay.zones_x_m == (0.0, 0.3, 0.6, 1.0)


@pytest.mark.parametrize(("change", "message"), [
    ({"measured_x_m": [0.2, 0.2]}, "sensors 1 and 2 coincide at 0.2 m"),
    ({"measured_x_m": [0.2, 1.2]}, "'measured_x_m' positions must lie in [0, length_m = 1.0]"),
    ({"bc": "pinned-free"}, "'bc' = 'pinned-free' leaves the beam a mechanism"),
    ({"band_hz": [1.0, 2.0]}, "'band_hz' [1, 2] holds no bending mode of the beam"),
    ({"band_hz": [5.0]}, "'band_hz' must be [lo, hi] in Hz"),
    ({"bc": "clamped-free", "measured_x_m": [0.0, 0.5]}, "sensor 1 at 0 m lies at a node of every mode"),
    ({"bc": "pinned-pinned", "measured_x_m": [0.5], "drive_x_m": 1.0}, "'drive_x_m' = 1 m lies at a node"),
    ({"drive_x_m": 3.0}, "'drive_x_m' must be a position in [0, length_m = 1.0] m"),
    ({"zones_x_m": [0.5, 0.3]}, "'zones_x_m' must be increasing positions strictly inside (0, 1) m"),
])
def test_a_test_that_cannot_be_run_is_refused_in_one_line(change, message):
    with pytest.raises(ConfigError) as err:
        layout_of(beam_from_dict({**STEEL, "bc": "free-free", **change}, "bar.toml"), "bar.toml")
    text = str(err.value)
    assert message in text and text.startswith("bar.toml: ") and "\n" not in text
