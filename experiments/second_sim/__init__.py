"""An independent beam simulator that writes test files as a test system would.

It shares no code with ``physics``, ``datagen`` or ``learn`` (only numpy, scipy,
pyuff and the standard library): a fine-mesh Euler-Bernoulli/Timoshenko
beam with springs at both ends (:mod:`.fem`), damping, FRFs and a measurement chain
(:mod:`.response`), UFF/JSON writers (:mod:`.writers`), specimen pairs with
slits (:mod:`.pairs`), a layered sandwich beam with face-core debonds (:mod:`.layered`) and pairs with a debond, a
slit or a mass (:mod:`.kind_pairs`), hidden-effect cases (:mod:`.effects`) and a catalogue of beams on
every support with their own sensors and bands (:mod:`.beams`), a steel cantilever with bolted masses
(:mod:`.bolted`), a one-accelerometer impact test of a steel cantilever (:mod:`.one_sensor`) and a monitoring
series of one cantilever (:mod:`.series`).
``python -m experiments.second_sim pairs|kinds|effects|beams|bolted|series`` writes them.

The names below load on first use (the CLI limits BLAS threads before numpy loads).
"""

import importlib

_API = {
    "Beam": "fem", "Slit": "fem", "PointMass": "fem", "Dashpot": "fem", "Assembled": "fem", "Modes": "fem",
    "assemble": "fem", "modes": "fem",
    "Damping": "response", "Noise": "response", "rayleigh_for": "response", "receptance": "response",
    "complex_modes": "response", "measure": "response",
    "Sandwich": "layered", "layered_assembled": "layered", "layered_frequencies_hz": "layered",
    "CHANGES": "kind_pairs", "simulate_kind_pairs": "kind_pairs",
    "PairRecord": "pairs", "PairSet": "pairs", "PAIR_SETS": "pairs", "simulate_pairs": "pairs",
    "write_pairs": "pairs",
    "CATALOGUE": "beams", "CatalogueBeam": "beams", "simulate_beam_pairs": "beams", "write_beam_pairs": "beams",
    "SeriesConfig": "series", "SeriesTest": "series", "SLIT_SIZES": "series", "simulate_series": "series",
    "slit_frequency_drop": "series", "write_series": "series",
    "EffectCase": "effects", "effect_cases": "effects", "write_effect_cases": "effects",
    "bolted_beam": "bolted", "bolted_test": "bolted", "write_bolted_test": "bolted",
}
__all__ = sorted(_API)


def __getattr__(name):
    if name in _API:
        return getattr(importlib.import_module(f"experiments.second_sim.{_API[name]}"), name)
    raise AttributeError(f"module 'experiments.second_sim' has no attribute {name!r}")
