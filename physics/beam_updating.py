"""A beam's model updated from a measured file: its damping identified and its stiffness updated (Lancaster,
Pilkey; :mod:`physics.updating`) on the analyst mass of its measured DOFs, and the updated model checked.

:func:`update_beam` reads modal data (or identifies FRFs first), places the measured DOFs on the beam's by
position (:meth:`physics.beam.Beam.map_dofs`), updates, and refuses a model that does not reproduce the measured
eigenvalues (:func:`physics.updating.eigenvalue_errors`); ``beam-damage update`` calls it.
"""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, replace

import numpy as np

from physics import modal, updating
from physics.beam import Beam, load_beam
from physics.discrepancy import bending_modes
from physics.errors import BeamDamageError, ConvergenceError, FileFormatError, OverdampedError
from physics.identification import holds_response_records, identify_file
from physics.io import MODAL, TIME, modal_or_frf, prepare_measured, read, read_json

__all__ = ["BeamUpdate", "load_modal", "unstable_mode_warnings", "update_beam", "updated_model_modes"]


@dataclass(frozen=True)
class BeamUpdate:
    """A beam's updated model and its checks (:func:`update_beam`).

    ``M``, ``C``, ``K``: the analyst mass (kg), identified damping (N s/m) and updated stiffness (N/m) on the
    measured DOFs ``dofs`` (shape (n, n)); ``natural_frequencies_hz`` and ``damping_ratios`` of the updated model
    beside the measured ones; ``eigenvalue_check``: its eigenvalues' relative errors against the measured ones,
    the tolerance and the refusal threshold; ``warnings``: one line each.
    """

    beam: str
    mass: str
    dofs: list
    dof_positions: dict
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    method: str
    iterations: int
    converged: bool
    residual: float
    orthogonality_misfit: float
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    measured_natural_frequencies_hz: np.ndarray
    measured_damping_ratios: np.ndarray | None
    eigenvalue_check: dict
    warnings: list

    def to_dict(self) -> dict:
        """The fields as a dict, in their order (the JSON result of ``beam-damage update``)."""
        return asdict(self)


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

    ident = identify_file(modal_file)
    f = ident.estimate.natural_frequencies_hz
    if f.size > n_modes:
        warnings.warn(f"{modal_file}: {f.size} modes identified in the FRFs' band, the model pairs the lowest "
                      f"{n_modes}: {', '.join(f'{x:.4g}' for x in np.sort(f)[n_modes:])} Hz left out of the update "
                      "(more elements, or a band that stops below them, would pair them)")
        ident = replace(ident, estimate=ident.estimate.take(np.sort(np.argsort(f, kind="stable")[:n_modes])))
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


def updated_model_modes(M, C, K, paired_eigenvalues, where) -> tuple:
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


#: A measured shape pairs the model's mode of its index when their MAC is at least this (as ``classify``'s pairs).
MIN_SHAPE_MAC = 0.8


def shape_pairing_warnings(beam: Beam, model, vectors, where) -> list[str]:
    """Warnings for measured shapes (columns of ``vectors``, rows the beam's measured DOFs) that do not pair the
    analytical ``model``'s bending mode of the same index (MAC below :data:`MIN_SHAPE_MAC`;
    :func:`physics.discrepancy.bending_modes`: a free beam's rigid-body modes left out), naming the model's mode each
    resembles most. Lancaster's construction reproduces any pairing of eigenvalues and shapes, so the eigenvalue
    check cannot see a shape beside another mode's frequency (columns swapped in a file, or a mode missing and
    another in its place); the model's shapes at the sensors can."""
    m = vectors.shape[1]
    _, phi = bending_modes(beam, model, m)
    pairing = modal.mac(vectors, phi[model.index(beam.masters)])
    best = np.argmax(pairing, axis=1)
    bad = [k for k in range(m) if pairing[k, k] < MIN_SHAPE_MAC]
    return [f"{where}: measured mode {k + 1}'s shape does not pair the model's mode {k + 1} (MAC {pairing[k, k]:.2f} "
            f"< {MIN_SHAPE_MAC:g}); it is most like the model's mode {best[k] + 1} (MAC {pairing[k, best[k]]:.2f}): "
            "check that each frequency sits beside its own shape, and that no mode is missing" for k in bad]


def update_beam(beam, modal_file, mass: str = "iirs", tol: float = 1e-10, max_iter: int = 500,
                method: str = "pilkey", max_eigenvalue_error: float = updating.REFUSAL_TOL) -> BeamUpdate:
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
    warnings = shape_pairing_warnings(b, model, vectors, modal_file)
    f_meas = np.asarray(data.natural_frequencies_hz, float)
    if np.any(np.diff(f_meas) < 0):
        warnings.append(f"{modal_file}: the modes are not in ascending order of frequency "
                        f"({', '.join(f'{x:.4g}' for x in f_meas)} Hz); each eigenvalue is updated with the shape "
                        "column of the same index, so check that every frequency sits beside its own shape")
    if errors[worst] > updating.REPRODUCTION_TOL:
        warnings.append(f"the updated model reproduces the measured eigenvalues only to {errors[worst]:.2%} "
                        f"(mode {worst + 1}; tolerance {updating.REPRODUCTION_TOL:.0%}): the measured modes are "
                        "not consistent with the trusted mass")
    f_hz, zeta, more = updated_model_modes(M, res.C, res.K, model_lam, modal_file)
    warnings += more
    return BeamUpdate(
        beam=beam, mass=mass, dofs=list(b.masters), dof_positions=dof_map.to_dict(), M=M, C=res.C, K=res.K,
        method=method, iterations=res.iterations, converged=res.converged, residual=res.residual,
        orthogonality_misfit=updating.orthogonality_misfit(M, data.eigenvalues, res.eigenvectors),
        natural_frequencies_hz=f_hz, damping_ratios=zeta,
        measured_natural_frequencies_hz=data.natural_frequencies_hz, measured_damping_ratios=data.damping_ratios,
        eigenvalue_check={"relative_errors": errors, "max_relative_error": float(errors[worst]),
                          "tolerance": updating.REPRODUCTION_TOL, "refused_above": max_eigenvalue_error,
                          "reproduces_measured": bool(errors[worst] <= updating.REPRODUCTION_TOL)},
        warnings=warnings,
    )
