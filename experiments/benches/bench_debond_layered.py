"""The debond kind against the independent layered sandwich beam: relative frequency changes per debond.

Run::

    python -m experiments.benches.bench_debond_layered [--docs]

Beam 5 as a rigidly clamped cantilever with the project's sandwich section and no test-day changes; seven debonds of
1-20 % of L at the root, in the span and at the free end (:data:`CASES`, the layered mesh's elements). For each,
the relative changes of modes 1-4 (%) from datagen's generator (``draw_batch``/``simulate_batch``, 40 elements,
flexibility-exact elements of the ``debond`` kind) and from :mod:`experiments.second_sim.layered` (two
Euler-Bernoulli beams with their own axial displacements, 120 elements) with the face sliding over the debond and
with its tips tied; the largest difference of generator and sliding model in % of the damaged frequency. A few
seconds. ``--docs`` writes the table into docs/datasets.md (block ``debond-layered``);
``tests/datagen/test_debond.py`` holds the same comparison to its tolerances.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from datagen.batch_inputs import draw_batch
from datagen.config import DEFAULTS, merge
from datagen.pipeline import simulate_batch
from datagen.setup import get_setup
from experiments.benches.harness import parser, publish, table
from experiments.second_sim.layered import Sandwich, face_modulus_for, layered_frequencies_hz
from physics.modal import modal_parameters
from physics.properties import beam_preset

__all__ = ["CASES", "N_LAYERED", "QUIET", "changes", "main", "markdown"]

#: Rigid clamp, Euler-Bernoulli, the preset's EI and mass, no test-day changes, no contact damping: the current
#: state differs from the baseline by the debond alone.
QUIET = {"specimen": {"root_spring_relative": [], "ei_band": 0.0, "mass_band": 0.0},
         "mesh": {"truth_elements": 40},
         "damage": {"kind": "debond", "length_m": [0.006, 0.12], "debond_damping_s": [0.0, 0.0]},
         "measurement": {"lines": 64}}

#: Elements of the layered model (the debonds' tips are its nodes).
N_LAYERED = 120

#: Debonds (first element, elements) of the layered mesh: 1-20 % of L at the root, in the span, near the tip.
CASES = ((0, 2), (10, 1), (30, 4), (55, 8), (70, 24), (100, 12), (114, 6))


def changes(cases=CASES, n_layered: int = N_LAYERED, seed: int = 0) -> dict:
    """Relative frequency changes of modes 1-4, shape ``(len(cases), 4)`` each: ``generator``, ``sliding`` and
    ``tied`` (the layered model's face sliding over the debond, or held at its tips); ``span_m`` ``(len(cases),
    2)``, the debonds' ends (m); ``length_m`` the beam's length (m). ``seed`` draws the batch's other inputs (the
    debonds are set, the rest of the specimen is fixed by :data:`QUIET`)."""
    setup = get_setup(merge(QUIET))
    L = setup.length_m
    h = L / n_layered
    start = np.array([[a * h] for a, _ in cases])
    length = np.array([[k * h] for _, k in cases])
    inp = draw_batch(np.random.default_rng(seed), len(cases), setup)
    inp = dataclasses.replace(inp, n_damages=np.ones(len(cases), int), x_m=start + length / 2,
                              damage={**inp.damage, "length_m": length, "beta_s": np.zeros_like(length)})
    f, _ = modal_parameters(simulate_batch(setup, inp)["truth_poles"][..., :4])
    p = beam_preset("beam5")
    sec = DEFAULTS["section"]
    ef = face_modulus_for(p.EI_Nm2, p.width_m, p.thickness_m, sec["face_thickness_m"], sec["core_modulus_pa"])
    s = Sandwich(p.width_m, p.thickness_m, sec["face_thickness_m"], ef, sec["core_modulus_pa"])
    m = p.mass_per_length_kg_m
    f0 = layered_frequencies_hz(L, s, m, (), n_layered)

    def layered(tied):
        return np.array([layered_frequencies_hz(L, s, m, [(a * h, (a + k) * h)], n_layered, tied_tips=tied) / f0 - 1
                         for a, k in cases])

    return {"generator": f[:, 1] / f[:, 0] - 1, "sliding": layered(False), "tied": layered(True),
            "span_m": np.hstack([start, start + length]), "length_m": L}


def markdown(c: dict) -> str:
    """The docs' table: per debond its span (m), its length in % of L, the changes of modes 1/2/3/4 (%) of the
    generator, the sliding and the tied layered model, and the generator's largest difference from the sliding
    model in % of the damaged frequency."""
    def modes(v):
        return " / ".join(f"{100 * x:.2f}" for x in v)

    diff = 100 * np.max(np.abs(c["generator"] - c["sliding"]) / (1 + c["sliding"]), axis=1)
    rows = [[f"{a:.3f}-{b:.3f}", f"{100 * (b - a) / c['length_m']:.1f}", modes(g), modes(s), f"{d:.3f}", modes(t)]
            for (a, b), g, s, d, t in zip(c["span_m"], c["generator"], c["sliding"], diff, c["tied"])]
    return table(["debonded (m)", "% of L", "generator", "layered, sliding", "largest difference (% of f)",
                  "layered, tips tied"], rows)


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="datasets.md")
    a = ap.parse_args(argv)
    md = markdown(changes())
    print(md)
    publish(a, "debond-layered", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
