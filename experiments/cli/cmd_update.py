"""``beam-damage update``: damping identification and stiffness updating from measured modes."""

from __future__ import annotations

import numpy as np

from experiments.cli.args import add_beam_argument
from physics import modal, updating
from physics.beam import Beam, load_beam
from physics.errors import BeamDamageError, ConfigError, ConvergenceError, FileFormatError, OverdampedError
from physics.identification import holds_response_records, identify_file
from physics.io import FRF, MODAL, TIME, accepted, dof_positions_text, modal_or_frf, prepare_measured, read, read_json

__all__ = ["add_parser", "run"]


def load_modal(modal_file, n_modes: int):
    """Modal data on the positive sense of every DOF; FRFs are identified first (LSCF + LSFD, ``n_modes`` modes).

    Returns the modal data and the FRFs it was identified from (None for a modal-data file).
    """
    if modal_or_frf(modal_file) == MODAL:
        _refuse_unscaled(modal_file)
        return prepare_measured(read(modal_file, MODAL)).data, None

    if holds_response_records(modal_file) and not read(modal_file, TIME).forces:
        raise FileFormatError(f"{modal_file}: response records without a force: output-only shapes are unscaled "
                              "(no modal mass), so 'update' cannot mass-normalise them; measure a driving-point "
                              "FRF (force and response at one DOF)")

    ident = identify_file(modal_file, n_modes=n_modes)
    return ident.modal_data, ident.frf


def _refuse_unscaled(modal_file) -> None:
    """Refuse a modal-data JSON that says its shapes are unscaled (output-only identification), in one line."""
    try:
        obj = read_json(modal_file, require_object=False)
    except FileNotFoundError:
        return                                        # the modal-data reader names the missing file
    scaling = obj.get("scaling", "") if isinstance(obj, dict) else ""
    if isinstance(scaling, str) and scaling.startswith("unscaled"):
        raise FileFormatError(f"{modal_file}: shapes are {scaling}: 'update' needs unit-modal-A shapes to "
                              "mass-normalise them and identify C and K; measure a driving-point FRF")


def unstable_mode_warnings(eigenvalues, real_eigenvalues=()) -> list:
    """One warning per mode of an updated model that is not damped: ``Re(lambda) >= 0`` (damping ratio <= 0).

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        The updated model's eigenvalues (rad/s), one of each conjugate pair.
    real_eigenvalues : ndarray, float, shape (n_real,), optional
        Its real (non-oscillating) eigenvalues (1/s); one ``>= 0`` is a mode that grows without oscillating.
    """
    f_hz, zeta = modal.modal_parameters(eigenvalues)
    out = [f"the updated model is unstable: mode {k + 1} at {f_hz[k]:.6g} Hz has damping ratio {zeta[k]:.3g} "
           "(eigenvalue real part >= 0); the measured modes have negative damping or are inconsistent with the "
           "mass" for k in np.flatnonzero(np.asarray(eigenvalues).real >= 0)]
    return out + [f"the updated model is unstable: a real eigenvalue {r:.6g} 1/s >= 0 (a mode that grows without "
                  "oscillating); the measured modes are inconsistent with the mass" for r in real_eigenvalues if r >= 0]


def model_modes(M, C, K, paired_eigenvalues, where) -> tuple:
    """Natural frequencies (Hz), damping ratios and warnings of the updated model ``(M, C, K)``.

    A model of ``n`` conjugate pairs gives its complex modes; one with real eigenvalues (overdamped or
    non-oscillating unstable modes) gives the frequencies and damping ratios of ``paired_eigenvalues``
    (its eigenvalues paired with the measured ones, :func:`physics.updating.eigenvalue_errors`) and a warning.
    Either way each unstable mode is warned of (:func:`unstable_mode_warnings`).
    """
    try:
        cm = modal.complex_modes(M, C, K)
    except OverdampedError:
        lam = np.linalg.eigvals(modal.state_matrix(M, C, K))
        upper = lam[lam.imag > 0]
        upper = upper[np.argsort(np.abs(upper))]
        real = np.sort(lam[lam.imag == 0].real)
        f_hz, zeta = modal.modal_parameters(paired_eigenvalues)
        return f_hz, zeta, [f"the updated model has {real.size} real eigenvalue(s) (overdamped or non-oscillating "
                            "modes): its natural frequencies and damping ratios are those of its eigenvalues paired "
                            "with the measured ones", *unstable_mode_warnings(upper, real)]
    except BeamDamageError as exc:
        raise type(exc)(f"{where}: the updated model: {exc}") from None
    return cm.natural_frequencies_hz, cm.damping_ratios, unstable_mode_warnings(cm.eigenvalues)


def update(beam, modal_file, mass: str = "iirs", tol: float = 1e-10, max_iter: int = 500,
           method: str = "pilkey", max_eigenvalue_error: float = updating.REFUSAL_TOL) -> dict:
    """Identify ``C`` and update ``K`` of a beam (preset, beam file or :class:`Beam`) from a modal-data or FRF
    file; the analyst mass (IIRS or lumped, over the beam's measured DOFs, effects applied) is trusted.

    The measured DOFs are matched to the beam's by position (:meth:`Beam.map_dofs`), and the updated model
    is checked: its eigenvalues must reproduce the measured ones (:func:`physics.updating.eigenvalue_errors`).
    """
    b = beam if isinstance(beam, Beam) else load_beam(beam)
    beam = b.name
    mass = updating.mass_model_name(mass, "mass")
    model = b.fe_model()
    M = updating.reduced_mass(model.M, model.K, model.index(b.masters), mass)
    data, frf = load_modal(modal_file, M.shape[0])
    if data.eigenvectors is None:
        raise FileFormatError(f"{modal_file}: field 'eigenvectors' is required for updating "
                              f"({M.shape[0]} rows = measured DOFs, one column per mode)")
    n_rows, n_modes = data.eigenvectors.shape
    if n_modes != M.shape[0]:
        raise FileFormatError(f"{modal_file}: 'eigenvectors' has {n_modes} modes but {beam} has {M.shape[0]} "
                              f"measured DOFs ({', '.join(b.masters)}): a complete set of "
                              f"{M.shape[0]} modes is needed")
    if not data.dofs and n_rows != M.shape[0]:
        raise FileFormatError(f"{modal_file}: 'eigenvectors' has {n_rows} rows but {beam} has {M.shape[0]} "
                              f"measured DOFs ({', '.join(b.masters)}); label the rows with 'dofs'")
    dof_map = b.map_dofs(data.dofs, frf=frf, where=str(modal_file))
    vectors = data.eigenvectors[dof_map.rows(b.masters, str(modal_file))]
    try:
        if method == "direct":
            res = updating.lancaster_direct(M, data.eigenvalues, vectors)
        else:
            res = updating.pilkey(M, data.eigenvalues, vectors, tol=tol, max_iter=max_iter)
    except BeamDamageError as exc:
        if exc.parameter is not None:
            raise
        raise type(exc)(f"{modal_file}: {exc}") from None
    errors, model_lam = updating.eigenvalue_errors(M, res.C, res.K, data.eigenvalues)
    worst = int(np.argmax(errors))
    if not errors[worst] <= max_eigenvalue_error:
        raise ConvergenceError(
            f"{modal_file}: the updated model does not reproduce the measured modes: mode {worst + 1} at "
            f"{abs(data.eigenvalues[worst]) / (2 * np.pi):.6g} Hz is {abs(model_lam[worst]) / (2 * np.pi):.6g} Hz "
            f"in the model (relative eigenvalue error {errors[worst]:.3g} > {max_eigenvalue_error:g}); the "
            "eigenvectors are not a complete set of modes consistent with the mass (for real-valued shapes: only "
            "normal modes of proportional damping qualify)")
    warnings = []
    f_meas = np.asarray(data.natural_frequencies_hz, float)
    if np.any(np.diff(f_meas) < 0):
        warnings.append(f"{modal_file}: the modes are not in ascending order of frequency "
                        f"({', '.join(f'{x:.4g}' for x in f_meas)} Hz); each eigenvalue is updated with the shape "
                        "column of the same index, so check that every frequency sits beside its own shape")
    if errors[worst] > updating.REPRODUCTION_TOL:
        warnings.append(f"the updated model reproduces the measured eigenvalues only to {errors[worst]:.2%} "
                        f"(mode {worst + 1}; tolerance {updating.REPRODUCTION_TOL:.0%}): the measured modes are "
                        "not consistent with the trusted mass")
    f_hz, zeta, more = model_modes(M, res.C, res.K, model_lam, modal_file)
    warnings += more
    return {
        "beam": beam, "mass": mass, "dofs": list(b.masters), "dof_positions": dof_map.to_dict(),
        "M": M, "C": res.C, "K": res.K,
        "method": method, "iterations": res.iterations, "converged": res.converged, "residual": res.residual,
        "orthogonality_misfit": updating.orthogonality_misfit(M, data.eigenvalues, res.eigenvectors),
        "natural_frequencies_hz": f_hz, "damping_ratios": zeta,
        "measured_natural_frequencies_hz": data.natural_frequencies_hz,
        "measured_damping_ratios": data.damping_ratios,
        "eigenvalue_check": {"relative_errors": errors, "max_relative_error": float(errors[worst]),
                             "tolerance": updating.REPRODUCTION_TOL, "refused_above": max_eigenvalue_error,
                             "reproduces_measured": bool(errors[worst] <= updating.REPRODUCTION_TOL)},
        "warnings": warnings,
    }


def run(args) -> dict:
    if not (np.isfinite(args.max_eigenvalue_error) and args.max_eigenvalue_error > 0):
        raise ConfigError(f"--max-eigenvalue-error must be a positive number, got {args.max_eigenvalue_error}")
    out = update(args.beam, args.modal, args.mass, args.tol, args.max_iter, args.method, args.max_eigenvalue_error)
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
        for w in out["warnings"]:
            print(f"warning: {w}")
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
