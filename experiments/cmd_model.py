"""``beam-damage model``: a preset beam's FE matrices and natural frequencies."""

from __future__ import annotations

import numpy as np

from physics import fem, modal, properties, reduction
from physics.errors import BeamDamageError


def build(beam: str, elements: int, mass: str, method: str, bc: str = "clamped-free") -> dict:
    """Matrices of a preset beam, optionally reduced to the translational DOFs.

    ``mass="consistent"``: the consistent mass (eq. 3.8), reduced with ``K``;
    ``mass="lumped"`` replaces the reduced mass matrix by the translation
    partition of the consistent mass matrix (eq. 4.6 for 4 elements); its
    stiffness still comes from the chosen reduction.
    """
    preset = properties.beam_preset(beam)
    model = fem.beam_model(elements, preset.length_m, preset.EI_Nm2, preset.mass_per_length_kg_m, bc=bc)
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
    w, _ = modal.undamped_modes(M, K)
    closed = None
    if bc == "clamped-free":
        closed = properties.cantilever_frequencies_hz(preset.EI_Nm2, preset.mass_per_length_kg_m, preset.length_m,
                                                      properties.cantilever_beta_l(min(len(dofs), 8)))
    return {
        "beam": beam, "elements": elements, "mass": mass, "reduction": method, "bc": bc,
        "M": M, "K": K, "dofs": list(dofs),
        "natural_frequencies_hz": w / (2 * np.pi),
        "closed_form_frequencies_hz": closed,
        "iterations": iterations,
    }


def run(args) -> dict:
    out = build(args.beam, args.elements, args.mass, args.reduction, args.bc)
    if not args.json:
        np.set_printoptions(precision=6, linewidth=160)
        print(f"{args.beam}: {args.elements} elements, {args.bc}, mass {args.mass}, reduction {args.reduction}"
              + (f" ({out['iterations']} iterations)" if args.reduction == "iirs" else ""))
        print("DOFs:", " ".join(out["dofs"]))
        print("M (kg) =\n", out["M"], "\nK (N/m) =\n", out["K"])
        print("natural frequencies (Hz):", np.array2string(out["natural_frequencies_hz"][:8], precision=3))
        if out["closed_form_frequencies_hz"] is not None:
            print("closed form, eq. 4.5 (Hz):", np.array2string(out["closed_form_frequencies_hz"], precision=3))
    return out


def add_parser(sub):
    p = sub.add_parser("model", help="FE matrices and natural frequencies of a preset beam",
                       description="Assemble a preset beam (Table 4.1) with Euler-Bernoulli elements (eqs. 3.8, "
                                   "3.9), optionally reduce it to the translational DOFs (Guyan, IRS, IIRS) and "
                                   "print matrices and natural frequencies.")
    p.add_argument("--beam", default="beam5", choices=sorted(properties.PRESETS), help="preset (default beam5)")
    p.add_argument("--elements", type=int, default=4, help="number of elements (default 4, as in the thesis)")
    p.add_argument("--mass", default="consistent", choices=("consistent", "lumped"),
                   help="consistent (reduced with K) or lumped (translation partition, eq. 4.6)")
    p.add_argument("--reduction", default="none", choices=("none",) + tuple(reduction.REDUCTIONS),
                   help="reduce to the translational DOFs (default none)")
    p.add_argument("--bc", default="clamped-free", choices=fem.BOUNDARY_CONDITIONS, help="boundary condition")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: M, K, dofs, natural_frequencies_hz, closed_form_frequencies_hz, iterations")
    p.set_defaults(func=run, flags={"n_elements": "--elements", "mass": "--mass", "method": "--reduction"})
