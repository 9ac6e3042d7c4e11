"""Benchmark: the competing explanations weighed in one batch with and without each kind's exact refinement.

Pairs of the independent simulator (:mod:`experiments.second_sim.fem`: the thesis's 0.6095 m cantilever on its root
spring, modes 1-4), each a point mass of 1-20 % of the beam's mass added at a uniform place in 0.05-1 L; the slit
and mass-change explanations (a mass change's sizes -10 % to +25 %) weighed by
:func:`learn.explanations.hypotheses.weigh_many` on the frequency changes alone, first on the first-order grid alone,
then refined on the kinds' exact models (:mod:`learn.explanations.refine`), in one run. Printed per variant: seconds per
pair, the pairs the mass change fits, and the share whose true place and size lie in its 95 % intervals; and the ratio
of the times.

Run ``python -m experiments.benches.bench_refine [--n-pairs 64] [--seed 0] [--json]``.
"""

from __future__ import annotations

import json
import time

import numpy as np

from experiments.benches.harness import parser
from datagen.damage import damage_defaults
from experiments.second_sim.fem import Beam, PointMass, assemble, modes
from learn.network.features import BeamSpec
from learn.explanations.hypotheses import _support_curves, kind_explanation, weigh_many
from learn.explanations.refine import ExactKind, nominal_beam
from learn.explanations.sensitivity import beam_sensitivity

__all__ = ["main", "simulated_pairs"]

L, EI, M, KR_REL = 0.6095, 26.9, 0.15792 / 1.219, 948.7


def simulated_pairs(n: int, seed: int):
    """Relative frequency changes (n, 4) of point masses added to the simulator's cantilever, their places (m) and
    mass ratios."""
    rng = np.random.default_rng(seed)
    base = Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L)
    f0 = modes(assemble(base)).frequencies_hz[:4]
    x, ratio = rng.uniform(0.05, 1.0, n) * L, rng.uniform(0.01, 0.2, n)
    y = np.array([modes(assemble(Beam(L, EI, M, root_k_theta_Nm_rad=KR_REL * EI / L,
                                      masses=(PointMass(xi, ri * M * L),)))).frequencies_hz[:4] / f0 - 1
                  for xi, ri in zip(x, ratio)])
    return y, x, ratio


def _kinds(exact: bool) -> dict:
    out = {}
    for name, d in (("slit", damage_defaults("slit")),
                    ("mass_change", {**damage_defaults("mass_change"), "width_fraction": [0.0, 0.0],
                                     "mass_ratio": [-0.1, 0.25]})):
        ek = ExactKind(name, d, "beam5", nominal_beam((L, EI, M), KR_REL), np.arange(4)) if exact else None
        out[name] = kind_explanation(name, d, "beam5", beam_sensitivity((L, EI, M), KR_REL, kind=name), exact=ek)
    return out


def main(argv=None) -> int:
    p = parser(__file__, __doc__, json=True, seed=0)
    p.add_argument("--n-pairs", type=int, default=64)
    a = p.parse_args(argv)
    y, x, ratio = simulated_pairs(a.n_pairs, a.seed)
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    grid, curve, what, reclamp, _ = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    rows = []
    for exact in (False, True):
        kinds = _kinds(exact)
        weigh_many(y[:2], kinds, (grid, curve, what, reclamp), length_m=L)            # warm the caches
        t = time.perf_counter()
        ranked = weigh_many(y, kinds, (grid, curve, what, reclamp), length_m=L)
        dt = (time.perf_counter() - t) / a.n_pairs
        mass = [next(h for h in r if h.name == "mass_change") for r in ranked]
        inside = [h.fits and h.parameters["x_m_95"][0] <= xi <= h.parameters["x_m_95"][1]
                  and h.parameters["size_95"][0] <= ri <= h.parameters["size_95"][1]
                  for h, xi, ri in zip(mass, x, ratio)]
        rows.append({"variant": "exact refinement" if exact else "first-order grid", "seconds_per_pair": dt,
                     "mass_change_fits": int(sum(h.fits for h in mass)), "pairs": a.n_pairs,
                     "place_and_size_in_95": float(np.mean(inside))})
    if a.json:
        print(json.dumps({"n_pairs": a.n_pairs, "seed": a.seed, "rows": rows}, indent=1))
    else:
        for r in rows:
            print(f"{r['variant']:>18}: {1e3 * r['seconds_per_pair']:.1f} ms per pair; mass change fits "
                  f"{r['mass_change_fits']} / {r['pairs']}; true place and size in its 95 % intervals "
                  f"{r['place_and_size_in_95']:.0%}")
        print(f"time ratio {rows[1]['seconds_per_pair'] / rows[0]['seconds_per_pair']:.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
