"""The verdict's sentences speak of the model's damage kind in its own words (its ``describe``): a mass change is
a mass added or lost, a slit a slit of a hinge flexibility."""

import numpy as np

from learn.pairs.verdict import DamageWords, _classical_sentence, _damage_sentence


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


def _six_zone_beam():
    """A 1.2 m beam of six 0.2 m zones (only what the place rule reads of a test: its zone edges)."""
    from types import SimpleNamespace

    from learn.network.features import BeamSpec

    return BeamSpec("pp", 1.2, (), "", SimpleNamespace(zones_x_m=(0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2)))


def _network(p, x_over_L=0.48):
    return {**_answer(True, 0.01), "location_x_over_L": x_over_L, "location_x_m": 1.2 * x_over_L,
            "location_zone": int(np.argmax(p)) + 1, "zone_edges_m": [0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2],
            "zone_probabilities": list(p), "location_std_m": 0.382}


def test_a_flat_or_two_peaked_place_distribution_names_no_place():
    """Zone probabilities 0.25/0.14/0.14/0.14/0.12/0.22 (a pinned-pinned beam missing modes 3 and 6): the best zone
    and its neighbour hold 0.39 < PLACE_MASS and the best zone 0.25 < 2/6; the verdict names zones 1 and 6 (mirror
    images), no x, and the zone it reports is x's own."""
    from learn.pairs.verdict import place_keys

    beam = _six_zone_beam()
    a = _network([0.25, 0.14, 0.14, 0.14, 0.12, 0.22])
    keys = place_keys(a, beam)
    assert keys["place_determined"] is False and keys["location_zone"] == 3            # x = 0.576 m lies in zone 3
    assert keys["place_text"] == ("place undetermined: zone 1 of 6, 0-0.2 m (0.25) or zone 6 of 6, 1-1.2 m (0.22), "
                                  "its mirror")
    text = _damage_sentence({**a, **keys}, DamageWords("slit"))
    assert "at x =" not in text and "x/L" not in text and "zone 3" not in text
    assert text.startswith("damaged (probability 97.0%") and "a slit of hinge flexibility" in text
    flat = place_keys(_network([0.2, 0.16, 0.16, 0.16, 0.16, 0.16]), beam)["place_text"]
    assert flat == ("place undetermined: the zone probabilities are flat (largest zone 1 of 6, 0-0.2 m (0.20), "
                    "against 0.17 each if uniform)")


def test_a_peaked_place_distribution_keeps_its_place_and_zone_of_x():
    """0.05/0.55/0.25/0.05/0.05/0.05: zones 1-3 hold 0.85 and zone 2 is 3.3 times uniform: the place is x's."""
    from learn.pairs.verdict import place_keys

    a = _network([0.05, 0.55, 0.25, 0.05, 0.05, 0.05], x_over_L=0.25)
    keys = place_keys(a, _six_zone_beam())
    assert keys == {"place_determined": True, "place_text": None, "location_zone": 2}
    text = _damage_sentence({**a, **keys}, DamageWords("slit"))
    assert "a slit at x = 0.300 m" in text and "zone 2 of 6, 0.2-0.4 m" in text


def test_mirror_zones_count_as_one_place_on_a_beam_read_on_frequencies_alone():
    """0.42/0.05/0.03/0.03/0.05/0.42: two separate peaks, undetermined in general; on a symmetric beam read on
    frequencies alone a zone and its mirror are one place (0.94 held)."""
    from learn.pairs.verdict import place_keys

    a = _network([0.42, 0.05, 0.03, 0.03, 0.05, 0.42], x_over_L=0.08)
    assert place_keys(a, _six_zone_beam())["place_determined"] is False
    assert place_keys(a, _six_zone_beam(), mirror=True)["place_determined"] is True


def test_the_explanations_are_named_in_words():
    """Registry keys never reach the prose: each kind's label, and the base explanations' words."""
    from datagen.damage import DAMAGE_MODELS
    from learn.explanations.hypotheses import BASE_HYPOTHESES
    from learn.pairs.verdict import explanation_label

    assert explanation_label("mass_change") == "a mass change"
    assert explanation_label("global_stiffness") == "a stiffness change of the whole beam"
    for name in (*DAMAGE_MODELS, *BASE_HYPOTHESES):
        assert "_" not in explanation_label(name)


def test_a_rise_of_the_frequencies_is_no_slit_of_negative_size_in_the_classical_sentence():
    """A classical method flags a rise as a change (a mass lost, a stiffness gained), its size signed negative: a
    slit model says the frequencies rose, which a slit does not do; a mass-change model calls it a mass lost."""
    cl = {"method": "DLAC", **_answer(True, -0.178)}
    assert _classical_sentence(cl, DamageWords("slit")) == (
        "DLAC: changed, the natural frequencies rise, which a slit does not do: a stiffness gained or a mass lost "
        "near x = 0.3 m (zone 2 of 2, 0.2-0.6 m)")
    assert _classical_sentence(cl, DamageWords("mass_change")).startswith("DLAC: damaged, a mass lost at x = 0.300 m")
