"""``beam-damage update``: damping identification and stiffness updating from measured modes
(:func:`physics.beam_updating.update_beam`)."""

from __future__ import annotations

import numpy as np

from experiments.cli.args import add_beam_argument
from physics import updating
from physics.beam_updating import update_beam
from physics.errors import ConfigError
from physics.io import FRF, MODAL, accepted, dof_positions_text

__all__ = ["add_parser", "run"]


def run(args) -> dict:
    if not (np.isfinite(args.max_eigenvalue_error) and args.max_eigenvalue_error > 0):
        raise ConfigError(f"--max-eigenvalue-error must be a positive number, got {args.max_eigenvalue_error}")
    out = update_beam(args.beam, args.modal, args.mass, args.tol, args.max_iter, args.method,
                      args.max_eigenvalue_error).to_dict()
    if not args.json:
        np.set_printoptions(precision=5, linewidth=160)
        print(dof_positions_text(out["dof_positions"]))
        print(f"{out['beam']}, {out['mass']} mass, {args.method}: {out['iterations']} iterations; "
              f"orthogonality misfit of the modes {out['orthogonality_misfit']:.3g} (0 = consistent with M)")
        print("M =\n", out["M"], "\nC (N s/m) =\n", out["C"], "\nK (N/m) =\n", out["K"])
        print("model frequencies (Hz):   ", np.array2string(out["natural_frequencies_hz"], precision=3))
        print("measured frequencies (Hz):", np.array2string(out["measured_natural_frequencies_hz"], precision=3))
        print("model damping ratios:     ", np.array2string(out["damping_ratios"], precision=5))
        chk = out["eigenvalue_check"]
        print(f"eigenvalue check: the updated model reproduces the measured eigenvalues to "
              f"{chk['max_relative_error']:.3g} (relative; {'within' if chk['reproduces_measured'] else 'beyond'} "
              f"the {chk['tolerance']:g} tolerance)")
    return out


def add_parser(sub):
    p = sub.add_parser("update",
                       description="Identify the damping matrix by Pilkey's iteration of Lancaster's formula "
                                   "(eqs. 1.10, 1.11) and update the stiffness matrix (eq. 1.12) from measured "
                                   "complex modes and the beam's reduced or lumped mass matrix.")
    add_beam_argument(p)
    p.add_argument("--modal", required=True, metavar="FILE",
                   help=f"{accepted(MODAL, FRF)}. Modal data: eigenvalues and eigenvectors as complex strings "
                        "(rows = measured DOFs, columns = modes), as in beams.json; FRFs: with a driving point, "
                        "identified first by 'identify --method lscf'")
    p.add_argument("--mass", default="iirs", choices=updating.MASS_MODELS + tuple(updating.MASS_MODEL_ALIASES),
                   help="analyst mass: iirs = the 4-element consistent mass reduced by IIRS (default; 'reduced' "
                        "is an alias) or lumped = eq. 4.6")
    p.add_argument("--method", default="pilkey", choices=("pilkey", "direct"),
                   help="pilkey: the thesis's iteration (default); direct: non-iterative least-squares scaling "
                        "by Lancaster's orthogonality relations (exact for consistent modes at any damping)")
    p.add_argument("--tol", type=float, default=1e-10, help="relative change of C that counts as converged")
    p.add_argument("--max-iter", type=int, default=500, help="iteration limit (non-convergence is an error)")
    p.add_argument("--max-eigenvalue-error", type=float, default=updating.REFUSAL_TOL, metavar="REL",
                   help="refuse an updated model whose eigenvalues miss the measured ones by more than this "
                        f"(relative; default {updating.REFUSAL_TOL:g}; above {updating.REPRODUCTION_TOL:g} the "
                        "output warns). Measured DOFs are matched to the beam's by position: the file's node "
                        "geometry (UFF 15/2411), else the beam file's measured_x_m, else nodes 2..5 at the "
                        "quarter points; the output says which")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: M, C, K, iterations, converged, natural_frequencies_hz, damping_ratios")
    p.set_defaults(func=run, flags={"mass": "--mass", "tol": "--tol", "max_iter": "--max-iter"})
