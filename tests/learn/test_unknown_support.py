"""An unknown support reaching learn (a model directory's test) is refused in one line, never taken for another."""

from dataclasses import replace

import pytest

from learn.explanations.hypotheses import support_curve
from learn.network.features import BeamSpec
from physics.beam import load_beam
from physics.errors import ConfigError
from physics.layout import layout_of


def _spec(bc: str) -> BeamSpec:
    beam = load_beam("beam5").with_effects({}, bc="free-free", measured_x_m=(0.0, 0.2, 0.4, 0.6))
    test = replace(layout_of(beam), bc=bc)
    return BeamSpec("beam5", beam.length_m, ("1:y", "2:y", "3:y", "4:y"), "consistent", test)


def test_the_support_change_of_an_unknown_support_is_refused():
    with pytest.raises(ConfigError) as e:
        support_curve(_spec("fixed-free"), 30.0, 1.0, None, [0.0, 1.0], [0, 1])
    assert str(e.value) == ("the model's test: 'bc' = 'fixed-free' unknown; expected one of ['clamped-free', "
                            "'free-free', 'pinned-pinned', 'clamped-clamped']")


def test_a_model_directory_s_test_with_an_unknown_support_is_refused():
    d = _spec("free-free").to_dict()
    assert BeamSpec.from_dict(d).test.support.rigid_body_modes == 2
    d["test"]["bc"] = "fixed-free"
    with pytest.raises(ConfigError, match=r"^layout: 'bc' = 'fixed-free' unknown; expected one of \["):
        BeamSpec.from_dict(d)
