"""``beam-damage update``: damping identification and stiffness updating from measured modes."""

from __future__ import annotations

import numpy as np

from experiments.cmd_model import add_beam_argument
from physics import modal, updating
from physics.beam import Beam, load_beam
from physics.errors import FileFormatError
from physics.io import read_modal_json


def load_modal(modal_file, n_modes: int):
    """Modal JSON as is; an FRF file (UFF58, CSV, NPZ) is identified first (LSCF + LSFD, ``n_modes`` modes)."""
    if str(modal_file).lower().endswith(".json"):
        return read_modal_json(modal_file)
    from physics.identification import identify_file

    return identify_file(modal_file, n_modes=n_modes).modal_data


def update(beam, modal_file, mass: str = "iirs", tol: float = 1e-10, max_iter: int = 500,
           method: str = "pilkey") -> dict:
    """Identify ``C`` and update ``K`` of a beam (preset, beam file or :class:`Beam`) from a modal-data or FRF
    file; the analyst mass (IIRS or lumped, over the beam's measured DOFs, effects applied) is trusted."""
    b = beam if isinstance(beam, Beam) else load_beam(beam)
    beam = b.name
    mass = updating.mass_model_name(mass, "mass")
    model = b.fe_model()
    M = updating.reduced_mass(model.M, model.K, model.index(b.masters), mass)
    data = load_modal(modal_file, M.shape[0])
    if data.eigenvectors is None:
        raise FileFormatError(f"{modal_file}: field 'eigenvectors' is required for updating "
                              f"({M.shape[0]} rows = measured DOFs, one column per mode)")
    if data.eigenvectors.shape != M.shape:
        raise FileFormatError(f"{modal_file}: 'eigenvectors' is {data.eigenvectors.shape[0]}x"
                              f"{data.eigenvectors.shape[1]} but {beam} has {M.shape[0]} measured DOFs "
                              f"({', '.join(b.masters)}): a complete set of "
                              f"{M.shape[0]} modes is needed")
    if method == "direct":
        res = updating.lancaster_direct(M, data.eigenvalues, data.eigenvectors)
    else:
        res = updating.pilkey(M, data.eigenvalues, data.eigenvectors, tol=tol, max_iter=max_iter)
    cm = modal.complex_modes(M, res.C, res.K)
    return {
        "beam": beam, "mass": mass, "M": M, "C": res.C, "K": res.K,
        "method": method, "iterations": res.iterations, "converged": res.converged, "residual": res.residual,
        "orthogonality_misfit": updating.orthogonality_misfit(M, data.eigenvalues, res.eigenvectors),
        "natural_frequencies_hz": cm.natural_frequencies_hz, "damping_ratios": cm.damping_ratios,
        "measured_natural_frequencies_hz": data.natural_frequencies_hz,
        "measured_damping_ratios": data.damping_ratios,
    }


def run(args) -> dict:
    out = update(args.beam, args.modal, args.mass, args.tol, args.max_iter, args.method)
    if not args.json:
        np.set_printoptions(precision=5, linewidth=160)
        print(f"{out['beam']}, {out['mass']} mass, {args.method}: {out['iterations']} iterations; "
              f"orthogonality misfit of the modes {out['orthogonality_misfit']:.3g} (0 = consistent with M)")
        print("M =\n", out["M"], "\nC (N s/m) =\n", out["C"], "\nK (N/m) =\n", out["K"])
        print("model frequencies (Hz):   ", np.array2string(out["natural_frequencies_hz"], precision=3))
        print("measured frequencies (Hz):", np.array2string(out["measured_natural_frequencies_hz"], precision=3))
        print("model damping ratios:     ", np.array2string(out["damping_ratios"], precision=5))
    return out


def add_parser(sub):
    p = sub.add_parser("update", help="identify C and update K from measured complex modes (Lancaster/Pilkey)",
                       description="Identify the damping matrix by Pilkey's iteration of Lancaster's formula "
                                   "(eqs. 1.10, 1.11) and update the stiffness matrix (eq. 1.12) from measured "
                                   "complex modes and the beam's reduced or lumped mass matrix.")
    add_beam_argument(p)
    p.add_argument("--modal", required=True, metavar="FILE",
                   help="modal-data JSON: eigenvalues and eigenvectors as complex strings (rows = measured DOFs, "
                        "columns = modes), as in beams.json; or an FRF file (.uff/.unv, .csv, .npz) with a "
                        "driving point, identified first by 'identify --method lscf'")
    p.add_argument("--mass", default="iirs", choices=updating.MASS_MODELS + tuple(updating.MASS_MODEL_ALIASES),
                   help="analyst mass: iirs = the 4-element consistent mass reduced by IIRS (default; 'reduced' "
                        "is an alias) or lumped = eq. 4.6")
    p.add_argument("--method", default="pilkey", choices=("pilkey", "direct"),
                   help="pilkey: the thesis's iteration (default); direct: non-iterative least-squares scaling "
                        "by Lancaster's orthogonality relations (exact for consistent modes at any damping)")
    p.add_argument("--tol", type=float, default=1e-10, help="relative change of C that counts as converged")
    p.add_argument("--max-iter", type=int, default=500, help="iteration limit (non-convergence is an error)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: M, C, K, iterations, converged, natural_frequencies_hz, damping_ratios")
    p.set_defaults(func=run, flags={"mass": "--mass", "tol": "--tol", "max_iter": "--max-iter"})
