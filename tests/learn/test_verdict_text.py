"""The verdict's sentences speak of the model's damage kind in its own words (its ``describe``): a mass change is
a mass added or lost, a slit a slit of a hinge flexibility."""

from learn.verdict import DamageWords, _classical_sentence, _damage_sentence


def _answer(damaged, size):
    return {"damaged": damaged, "probability_damaged": 0.97, "decision_threshold": 0.9, "location_x_m": 0.3,
            "location_std_m": 0.02, "location_x_over_L": 0.49, "location_zone": 2, "zone_edges_m": [0, 0.2, 0.6],
            "location_element": None, "size": size, "size_std": 0.01, "detectable": True}


def test_a_mass_change_model_speaks_of_masses_and_a_slit_model_of_slits():
    lost = _damage_sentence(_answer(True, -0.0125), DamageWords("mass_change"))
    assert lost.startswith("damaged (probability 97.0%, at or above the 90.0% this model calls damage at)")
    assert "a mass lost at x = 0.300 m of 1.25% of the beam's mass" in lost and "slit" not in lost
    assert "mass ratio +- 0.01" in lost
    assert _damage_sentence(_answer(False, 0.0), DamageWords("mass_change")).startswith("no damage detected")
    slit = _damage_sentence(_answer(True, 0.012), DamageWords("slit"))
    assert "a slit at x = 0.300 m of hinge flexibility EI/(k L) = 0.012" in slit and "hinge flexibility +- 0.01" in slit
    assert "mm deep" not in slit                     # no section given: no depth example
    cl = {"method": "DLAC", **_answer(True, 0.02)}
    assert _classical_sentence(cl, DamageWords("mass_change")) == ("DLAC: damaged, a mass added at x = 0.300 m of "
                                                                   "2.00% of the beam's mass (zone 2 of 2, 0.2-0.6 m)")


def test_a_slit_model_gives_the_depth_example_of_its_section():
    """With the model's truth beam and section, the slit's prose names a depth of that hinge flexibility."""
    from datagen.config import DEFAULTS

    words = DamageWords("slit", "beam5", DEFAULTS["section"])
    text = _damage_sentence(_answer(True, 0.0098), words)
    assert "(e.g. 0." in text and "mm deep over 5.5 mm)" in text
