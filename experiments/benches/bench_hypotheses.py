"""Benchmark: the competing explanations of ``classify`` on pairs of the independent simulator, in one run.

Run: ``.venv/bin/python -m experiments.benches.bench_hypotheses [--n 24] [--seed 0] [--noise 0.0007] [--json FILE]
[--docs]``

Pairs of beam-5-like cantilevers from :mod:`experiments.second_sim` (its own finite elements, slits, point masses
and root spring; it shares no code with the package): each specimen drawn with EI +-5 %, mass +-3 % and a root
spring ``k_r L / EI`` log-uniform in 300-3000, tested twice with the day-to-day changes of the training
(temperature: EI +-0.4 %, re-clamping: root spring +-8 %) and a relative frequency noise per mode and test
(``--noise``, default 0.07 %: 0.1 % on the change). ``--n`` pairs of each truth:

* ``intact``: the day-to-day changes only;
* ``slit``: a slit anywhere (2-98 % of L), 1-10 mm wide, 30-90 % EI loss, dropping some mode by 0.5 % or more;
* ``support_change``: the root spring 2-5 times softer or stiffer;
* ``mass_change``: a point mass of 1-5 % of the beam's mass at 5-100 % of L, added or (half of them) removed;
* ``global_stiffness``: EI 1-4 % higher or lower.

Each pair's relative frequency changes of modes 1-4 are weighed by :func:`learn.explanations.hypotheses.weigh` on the
nominal beam's sensitivities (the second simulator's nominal EI and mass, root spring 948.7). Printed: the confusion
table of the most probable explanation against the truth, and for the slits the share whose position and hinge
flexibility lie inside the 68 % and 95 % intervals.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from experiments.second_sim.fem import Beam, PointMass, Slit, assemble, modes
from experiments.second_sim.pairs import DOF_LABELS, EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M, NODE_X_M
from experiments.second_sim.response import MODAL_NOISE, Damping, complex_modes, noisy_modal
from experiments.second_sim.writers import modal_dict
from experiments.benches.harness import emit_json, parser, publish, table
from learn.pairs.classify import classify_many
from datagen.damage import damage_defaults
from learn.network.features import BeamSpec
from learn.explanations.hypotheses import SHAPE_CHANGE_STD, _support_curves, kind_explanation, weigh
from learn.network.model_dir import load_model
from learn.explanations.sensitivity import beam_sensitivity
from learn.explanations.shapes import shape_changes
from physics.io import modal_data_from_dict

__all__ = ["TRUTHS", "main", "pairs", "run"]

TRUTHS = ("intact", "slit", "support_change", "mass_change", "global_stiffness")
KR_REL = 948.7


def _specimen(rng, L, EI, M):
    ei = EI * (1 + rng.uniform(-0.05, 0.05))
    kr = np.exp(rng.uniform(np.log(300), np.log(3000))) * ei / L
    return Beam(L, ei, M * (1 + rng.uniform(-0.03, 0.03)), root_k_theta_Nm_rad=kr)


def _frequencies(beam) -> np.ndarray:
    return modes(assemble(beam), n_refine=4).frequencies_hz[:4]


def _modal(beam, ratios, rng, shape_noise=None) -> dict:
    """The simulator's modal data of one test: modes 1-4 at the quarter points, its own modal noise (the shapes'
    std relative to each mode's largest entry ``shape_noise`` instead, when given)."""
    asm = assemble(beam)
    md = modes(asm, n_refine=4)
    dofs = asm.translation_dofs(NODE_X_M[1:])
    noise = MODAL_NOISE if shape_noise is None else (*MODAL_NOISE[:2], shape_noise)
    return modal_dict(*noisy_modal(*complex_modes(asm, md, Damping("modal", ratios), dofs, 4), rng, noise),
                      DOF_LABELS)


def pairs(truth: str, n: int, rng, noise: float, modal_rng=None, shape_noise=None) -> list[dict]:
    """``n`` pairs of one truth: measured relative frequency changes and the truth's parameters; with a
    ``modal_rng`` also both tests' modal data (``modal``: baseline and current mappings with the simulator's own
    modal noise, drawn from that stream so that the frequency changes do not depend on it)."""
    L, EI, M = LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M
    out = []
    while len(out) < n:
        base = _specimen(rng, L, EI, M)
        day = dict(EI_Nm2=base.EI_Nm2 * (1 + rng.uniform(-0.004, 0.004)),
                   root_k_theta_Nm_rad=base.root_k_theta_Nm_rad * (1 + rng.uniform(-0.08, 0.08)))
        info = {}
        if truth == "slit":
            s = Slit(rng.uniform(0.02, 0.98) * L, rng.uniform(0.001, 0.01), rng.uniform(0.3, 0.9))
            cur = replace(base, **day, slits=(s,))
            info = {"x_m": s.x_m, "hinge_flexibility": s.hinge_flexibility(L)}
        elif truth == "support_change":
            factor = np.exp(rng.choice([-1, 1]) * rng.uniform(np.log(2), np.log(5)))
            cur = replace(base, **{**day, "root_k_theta_Nm_rad": day["root_k_theta_Nm_rad"] * factor})
            info = {"factor": float(factor)}
        elif truth == "mass_change":
            p = PointMass(rng.uniform(0.05, 1.0) * L, rng.uniform(0.01, 0.05) * M * L)
            if rng.random() < 0.5:
                cur = replace(base, **day, masses=(p,))
                info = {"x_m": p.x_m, "mass_ratio": p.mass_kg / (M * L)}
            else:
                cur, base = replace(base, **day), replace(base, masses=(p,))
                info = {"x_m": p.x_m, "mass_ratio": -p.mass_kg / (M * L)}
        elif truth == "global_stiffness":
            g = rng.choice([-1, 1]) * rng.uniform(0.01, 0.04)
            cur = replace(base, **{**day, "EI_Nm2": day["EI_Nm2"] * (1 + g)})
            info = {"EI_change": float(g)}
        else:
            cur = replace(base, **day)
        f0, f1 = _frequencies(base), _frequencies(cur)
        if truth == "slit" and np.max(1 - f1 / f0) < 0.005:
            continue                                          # not a slit these frequencies can show
        f0 = f0 * (1 + noise * rng.standard_normal(4))
        f1 = f1 * (1 + noise * rng.standard_normal(4))
        out.append({"truth": truth, "shifts": f1 / f0 - 1, **info})
        if modal_rng is not None:
            ratios = tuple(modal_rng.uniform(0.003, 0.02, 4))
            out[-1]["modal"] = tuple(_modal(b, ratios, modal_rng, shape_noise) for b in (base, cur))
    return out


def network_answers(model_dir, pair_list) -> list[dict]:
    """``classify`` (in this process) of each pair's modal data with the model in ``model_dir``: per pair the
    network's ``damaged``, the verdict's ``damaged`` and where it comes from, ``in_distribution``, the network's
    element, and ``support_changed`` when the model answers it."""
    model = load_model(model_dir)
    out = []
    for p in pair_list:
        base, cur = (modal_data_from_dict(d, f"{p['truth']} pair") for d in p["modal"])
        v = classify_many(model, base, [cur])[0]
        net = v.get("network") or {}
        out.append({"network_damaged": bool(net.get("damaged")), "verdict_damaged": bool(v["damaged"]),
                    "verdict_from": v["verdict_from"], "in_distribution": bool(v["in_distribution"]),
                    "network_element": net.get("location_element"),
                    "support_changed": net.get("support_changed")})
    return out


def network_table(rows: list[dict]) -> dict:
    """Per truth: pairs, called damaged by the network and by the verdict, inside the training data, slits in the
    right element (network), support changes named."""
    res = {}
    for t in TRUTHS:
        r = [x for x in rows if x["truth"] == t]
        res[t] = {"n": len(r), "network_damaged": sum(x["network_damaged"] for x in r),
                  "verdict_damaged": sum(x["verdict_damaged"] for x in r),
                  "in_distribution": sum(x["in_distribution"] for x in r),
                  "support_changed": sum(bool(x["support_changed"]) for x in r),
                  "element_right": sum(x["network_damaged"] and x["network_element"] == x.get("element")
                                       for x in r)}
    return res


def run(n: int = 24, seed: int = 0, noise: float = 7e-4, model_dir=None, shape_noise=None,
          shape_sigma=None) -> dict:
    """Every pair weighed: the confusion counts and the slits' interval cover; with ``model_dir`` also the
    network's answers on the pairs' modal data (:func:`network_table`)."""
    L, EI, M = LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M
    spec = BeamSpec("beam5", L, ("2:y", "3:y", "4:y", "5:y"), "iirs")
    # the priors span this bench's pairs: hinge flexibilities up to 0.15, masses within +-10 % of the beam's
    kinds = {"slit": kind_explanation("slit", damage_defaults("slit"), "beam5", beam_sensitivity((L, EI, M), KR_REL),
                                      np.linspace(0.0, 0.15, 201)),
             "mass_change": kind_explanation("mass_change", {**damage_defaults("mass_change"),
                                                             "width_fraction": [0.0, 0.0]}, "beam5",   # point masses
                                             beam_sensitivity((L, EI, M), KR_REL, kind="mass_change"),
                                             np.linspace(-0.1, 0.1, 201))}
    *support, support_shapes = _support_curves(spec, EI, M, KR_REL, (-0.08, 0.08))
    rng = np.random.default_rng(seed)
    confusion = {t: {h: 0 for h in TRUTHS} for t in TRUTHS}
    with_shapes = {t: {h: 0 for h in TRUTHS} for t in TRUTHS}
    cover = {"x_68": 0, "x_95": 0, "theta_68": 0, "theta_95": 0, "n": 0}
    rows = []
    modal_rng = np.random.default_rng([seed, 1])
    for truth in TRUTHS:
        plist = pairs(truth, n, rng, noise, modal_rng, shape_noise)
        answers = network_answers(model_dir, plist) if model_dir else [{}] * len(plist)
        for p, a in zip(plist, answers):
            ranked = weigh(p["shifts"], kinds, tuple(support), (-0.004, 0.004), length_m=L)
            top = ranked[0].name
            confusion[truth][top] += 1
            tests = [modal_data_from_dict(d, truth).eigenvectors for d in p["modal"]]
            shaped = weigh(p["shifts"], kinds, tuple(support), (-0.004, 0.004), length_m=L,
                           shapes=shape_changes(np.stack(tests)[None])[0], support_shapes=support_shapes,
                           shape_sigma=SHAPE_CHANGE_STD if shape_sigma is None else shape_sigma)
            with_shapes[truth][shaped[0].name] += 1
            element = min(4, int(p["x_m"] // (L / 4)) + 1) if truth == "slit" else None
            rows.append({"truth": truth, "top": top, "probabilities": {r.name: r.probability for r in ranked},
                         "shifts_pct": [float(v) for v in 100 * p["shifts"]], "element": element, **a})
            if truth == "slit":
                q = next(r for r in ranked if r.name == "slit").parameters
                cover["n"] += 1
                for level in ("68", "95"):
                    lo, hi = q[f"x_m_{level}"] if q[f"x_m_{level}"] else (np.nan, np.nan)
                    cover[f"x_{level}"] += lo <= p["x_m"] <= hi
                    lo, hi = q[f"size_{level}"] if q[f"size_{level}"] else (np.nan, np.nan)
                    cover[f"theta_{level}"] += lo <= p["hinge_flexibility"] <= hi
    res = {"n": n, "seed": seed, "noise": noise, "confusion": confusion, "confusion_with_shapes": with_shapes,
           "slit_cover": cover, "pairs": rows}
    if model_dir:
        res["model"] = str(model_dir)
        res["network"] = network_table(rows)
    return res


def _confusion_lines(confusion: dict) -> list[str]:
    return [table(["truth \\ most probable", *TRUTHS, "right"],
                  [[t, *(confusion[t][h] for h in TRUTHS), f"{confusion[t][t] / sum(confusion[t].values()):.0%}"]
                   for t in TRUTHS])]


def markdown(res: dict) -> str:
    lines = _confusion_lines(res["confusion"])
    c = res["slit_cover"]
    lines.append("")
    lines.append(f"Slits ({c['n']}): position inside the 68 % interval {c['x_68'] / c['n']:.0%}, the 95 % interval "
                 f"{c['x_95'] / c['n']:.0%}; hinge flexibility {c['theta_68'] / c['n']:.0%} and "
                 f"{c['theta_95'] / c['n']:.0%}. {res['n']} pairs per truth, seed {res['seed']}, frequency noise "
                 f"{100 * res['noise']:.2g} % per mode and test.")
    lines += ["", "Weighed on the frequency and shape changes (the same pairs' modal data: modes 1-4 at the quarter "
              "points, the simulator's own modal noise):", ""] + _confusion_lines(res["confusion_with_shapes"])
    if "network" in res:
        lines += ["", f"The network ({res['model']}) on the same pairs' modal data (modes 1-4 at the quarter points, "
                  "the simulator's own modal noise):", "",
                  table(["truth", "pairs", "network: damaged", "verdict: damaged", "inside the training data",
                         "support change named", "slit in the right element"],
                        [[t, r["n"], r["network_damaged"], r["verdict_damaged"], r["in_distribution"],
                          r["support_changed"], r["element_right"] if t == "slit" else "-"]
                         for t, r in res["network"].items()])]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="classifier.md", json="FILE", seed=0)
    p.add_argument("--n", type=int, default=24, help="pairs per truth (default 24)")
    p.add_argument("--noise", type=float, default=7e-4, help="relative frequency noise per mode and test")
    p.add_argument("--shape-noise", type=float, default=None,
                   help="std of the modal data's shapes per test, relative to each mode's largest entry (default: "
                        "the simulator's 0.5 %%)")
    p.add_argument("--shape-sigma", type=float, default=None,
                   help="std of a shape entry's change the explanations assume (default learn.explanations.hypotheses."
                        "SHAPE_CHANGE_STD)")
    p.add_argument("--model", metavar="MODEL_DIR", help="also classify every pair's modal data with this model")
    args = p.parse_args(argv)
    res = run(args.n, args.seed, args.noise, args.model, args.shape_noise, args.shape_sigma)
    md = markdown(res)
    sys.stdout.write(md)
    emit_json(args, res)
    publish(args, "hypotheses", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
