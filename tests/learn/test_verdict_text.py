"""The verdict's sentences speak of the model's damage kind: a mass change is a mass added or lost, not a slit."""

from learn.verdict import _classical_sentence, _damage_sentence


def _answer(damaged, size):
    return {"damaged": damaged, "probability_damaged": 0.97, "decision_threshold": 0.9, "location_x_m": 0.3,
            "location_std_m": 0.02, "location_x_over_L": 0.49, "location_zone": 2, "zone_edges_m": [0, 0.2, 0.6],
            "location_element": None, "hinge_flexibility": size, "hinge_flexibility_std": 0.01, "depth_m": None,
            "detectable": True}


def test_a_mass_change_model_speaks_of_masses_and_a_slit_model_of_slits():
    lost = _damage_sentence(_answer(True, -0.0125), "mass_change")
    assert lost.startswith("changed (probability 97.0%, at or above the 90.0% this model calls damage at)")
    assert "a mass lost at x = 0.300 m of 1.25% of the beam's mass" in lost and "slit" not in lost
    assert _damage_sentence(_answer(False, 0.0), "mass_change").startswith("no change detected")
    slit = _damage_sentence(_answer(True, 0.012), "slit")
    assert "slit at x = 0.300 m" in slit and "hinge flexibility" in slit
    cl = {"method": "DLAC", **_answer(True, 0.02)}
    assert _classical_sentence(cl, "mass_change") == ("DLAC: changed, a mass added at x = 0.300 m of 2.00% of the "
                                                      "beam's mass (zone 2 of 2, 0.2-0.6 m)")
