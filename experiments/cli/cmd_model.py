"""``beam-damage model``: FE matrices and natural frequencies of a preset beam or a beam file."""

from __future__ import annotations

import numpy as np

from experiments.cli.args import add_beam_argument
from physics import modal, properties, reduction
from physics.beam import Beam, load_beam
from physics.errors import BeamDamageError
from physics.supports import SUPPORTS, THESIS_SUPPORT, support

__all__ = ["add_parser", "run"]


def build(beam, elements: int | None, mass: str, method: str, bc: str | None = None) -> dict:
    """Matrices of a beam (preset name, beam file or :class:`Beam`), optionally reduced to the translations.

    ``mass="consistent"``: the consistent mass (eq. 3.8), reduced with ``K``;
    ``mass="lumped"`` replaces the reduced mass matrix by the translation
    partition of the consistent mass matrix (eq. 4.6 for 4 elements); its
    stiffness still comes from the chosen reduction. ``elements`` and ``bc``
    default to the beam's own; every effect of a beam file is applied.
    """
    b = beam if isinstance(beam, Beam) else load_beam(beam)
    elements = b.n_elements if elements is None else elements
    bc = support(bc or b.bc, "--bc").name
    model = b.with_effects(b.effects, bc=bc).fe_model(elements)
    M, K, dofs, iterations = model.M, model.K, model.dofs, 0
    if method != "none":
        masters = model.translations()
        red = reduction.reduce_model(model.M, model.K, model.index(masters), method)
        M, K, dofs, iterations = red.M, red.K, masters, red.iterations
    if mass == "lumped":
        if method == "none":
            raise BeamDamageError("mass 'lumped' is a mass matrix over the translations only; choose a reduction "
                                  "(guyan, irs or iirs) for the stiffness", parameter="mass")
        idx = model.index(dofs)
        M = model.M[np.ix_(idx, idx)]
    w = modal.undamped_frequencies_rad_s(M, K)
    w = w[SUPPORTS[bc].rigid_body_modes:]                          # a free beam's bounce and pitch left out
    closed = None
    if not b.effects:                                   # eq. 4.5 and its kin: the uniform beam on ideal supports
        closed = properties.cantilever_frequencies_hz(
            b.EI_Nm2, b.mass_per_length_kg_m, b.length_m, properties.uniform_beta_l(bc, min(w.size, 8)))
    return {
        "beam": b.name, "effects": b.effects_dict(), "elements": elements, "mass": mass, "reduction": method,
        "bc": bc,
        "M": M, "K": K, "dofs": list(dofs),
        "natural_frequencies_hz": w / (2 * np.pi),
        "closed_form_frequencies_hz": closed,
        "iterations": iterations,
    }


def run(args) -> dict:
    out = build(args.beam, args.elements, args.mass, args.reduction, args.bc)
    if not args.json:
        np.set_printoptions(precision=6, linewidth=160)
        print(f"{out['beam']}: {out['elements']} elements, {out['bc']}, mass {args.mass}, reduction {args.reduction}"
              + (f", effects {', '.join(out['effects'])}" if out["effects"] else "")
              + (f" ({out['iterations']} iterations)" if args.reduction == "iirs" else ""))
        print("DOFs:", " ".join(out["dofs"]))
        print("M (kg) =\n", out["M"], "\nK (N/m) =\n", out["K"])
        print("natural frequencies (Hz):", np.array2string(out["natural_frequencies_hz"][:8], precision=3))
        if out["closed_form_frequencies_hz"] is not None:
            print(f"closed form{', eq. 4.5' if out['bc'] == THESIS_SUPPORT else ''}, the uniform beam (Hz):",
                  np.array2string(out["closed_form_frequencies_hz"], precision=3))
    return out


def add_parser(sub):
    p = sub.add_parser("model",
                       description="Assemble a preset beam (Table 4.1) or a TOML beam file with Euler-Bernoulli "
                                   "elements (eqs. 3.8, 3.9; Timoshenko elements and the other effects of a beam "
                                   "file applied), optionally reduce it to the translational DOFs (Guyan, IRS, "
                                   "IIRS) and print matrices and natural frequencies.")
    add_beam_argument(p)
    p.add_argument("--elements", type=int, default=None,
                   help="number of elements (default: the beam's, 4 for the presets as in the thesis)")
    p.add_argument("--mass", default="consistent", choices=("consistent", "lumped"),
                   help="consistent (reduced with K) or lumped (translation partition, eq. 4.6)")
    p.add_argument("--reduction", default="none", choices=("none",) + tuple(reduction.REDUCTIONS),
                   help="reduce to the translational DOFs (default none)")
    p.add_argument("--bc", default=None, choices=tuple(SUPPORTS),
                   help="boundary condition (default: the beam's, clamped-free for the presets): "
                        + "; ".join(f"{s.name}: {s.help}" for s in SUPPORTS.values()))
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: M, K, dofs, natural_frequencies_hz, closed_form_frequencies_hz, "
                        "iterations")
    p.set_defaults(func=run, flags={"n_elements": "--elements", "mass": "--mass", "method": "--reduction"})
