"""Identified modes: the :class:`ModalEstimate` every method returns, shapes from residues, MPC."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from physics.errors import ShapeError
from physics.modal import eigenvalues_from_modal

__all__ = ["ModalEstimate", "checked_frf", "modal_estimate", "modal_phase_collinearity", "shapes_from_residues"]


def checked_frf(frequency_hz, frf):
    """Checked ``(frequency_hz, frf)`` as float64 (n_lines,) and complex128 (n_resp, n_ref, n_lines)."""
    f = np.asarray(frequency_hz, dtype=np.float64)
    h = np.asarray(frf, dtype=np.complex128)
    if h.ndim == 1:
        h = h[None, None, :]
    elif h.ndim == 2:
        h = h[:, None, :]
    if f.ndim != 1 or h.ndim != 3 or h.shape[-1] != f.size or f.size < 4:
        raise ShapeError("frf must be (n_resp, n_ref, n_lines) with n_lines = frequency_hz.size >= 4")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(h))) or np.any(np.diff(f) <= 0):
        raise ShapeError("frequency_hz must be finite and strictly increasing and frf finite")
    return f, h


def modal_phase_collinearity(shapes):
    """Modal phase collinearity (MPC) of complex mode shapes.

    ``MPC = |psi^T psi|^2 / (psi^H psi)^2``: 1 for a mode whose entries share
    one phase (a real, normal mode up to a complex factor), smaller for complex
    modes. Equal to the eigenvalue form of Pappa et al.

    Parameters
    ----------
    shapes : array_like, complex, shape (n_dofs, n_modes)

    Returns
    -------
    ndarray, shape (n_modes,), in [0, 1]
    """
    psi = np.asarray(shapes, dtype=complex)
    return np.abs(np.sum(psi**2, axis=0)) ** 2 / np.sum(np.abs(psi) ** 2, axis=0) ** 2


def shapes_from_residues(residues, drive=None):
    """Complex mode shapes from residues with unit-modal-A scaling.

    With ``H(w) = sum_j R_j/(i w - lambda_j) + conj(R_j)/(i w - conj(lambda_j))``
    and ``R_j = psi_j psi_j^T`` (package convention, eq. 1.10), a driving point
    ``(s, r)`` (response row ``s`` = reference DOF ``r``) gives
    ``psi_j = R_j[:, r] / sqrt(R_j[s, r])``.

    Parameters
    ----------
    residues : ndarray, complex, shape (n_resp, n_ref, n_modes)
    drive : (int, int) or None
        ``(response_row, reference_column)`` of the driving point. Without it the
        first reference column is returned normalised to unit largest entry
        (shape only, not scaled).

    Returns
    -------
    ndarray, complex, shape (n_resp, n_modes)
    """
    R = np.asarray(residues, dtype=complex)
    if drive is None:
        col = R[:, 0, :]
        k = np.argmax(np.abs(col), axis=0)
        return col / col[k, np.arange(col.shape[1])]
    s, r = drive
    return R[:, r, :] / np.sqrt(R[s, r, :])


@dataclass(frozen=True)
class ModalEstimate:
    """Identified modes.

    Attributes
    ----------
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
    eigenvalues : ndarray, complex, shape (n_modes,)
        ``lambda = -zeta w + i w sqrt(1 - zeta^2)`` (rad/s).
    shapes : ndarray, complex, shape (n_resp, n_modes)
        Complex mode shapes, unit-modal-A scaled when ``scaled`` is True.
    residues : ndarray, complex, shape (n_resp, n_ref, n_modes)
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        One-sigma uncertainty where the method gives one (NaN otherwise); see
        each method for what it means.
    mpc : ndarray, shape (n_modes,)
    method : str
    scaled : bool
    lower_residual, upper_residual : ndarray, shape (n_resp, n_ref) or None
    frequency_fit_std_hz, damping_fit_std : ndarray, shape (n_modes,) or None
        One-sigma uncertainty from the fit itself (LSFD variable-projection
        covariance of the poles, see :class:`LSFDResult`), where the method gives one.
    weakly_stable : ndarray of bool, shape (n_modes,), or None
        Modes stable over fewer model orders than the pole selection asks, kept because a clear spectral peak
        lies at them (SSI-cov); None for a method that does not flag them.
    """

    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    eigenvalues: np.ndarray
    shapes: np.ndarray
    residues: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    mpc: np.ndarray
    method: str
    scaled: bool
    lower_residual: np.ndarray | None = None
    upper_residual: np.ndarray | None = None
    frequency_fit_std_hz: np.ndarray | None = None
    damping_fit_std: np.ndarray | None = None
    weakly_stable: np.ndarray | None = None

    def take(self, keep) -> "ModalEstimate":
        """The modes ``keep`` (indices or a boolean mask over the modes), in that order."""
        idx = np.arange(self.natural_frequencies_hz.size)[keep]

        def per_mode(a):
            return None if a is None else a[..., idx]

        return replace(self, natural_frequencies_hz=self.natural_frequencies_hz[idx],
                       damping_ratios=self.damping_ratios[idx], eigenvalues=self.eigenvalues[idx],
                       shapes=self.shapes[:, idx], residues=self.residues[..., idx],
                       frequency_std_hz=self.frequency_std_hz[idx], damping_std=self.damping_std[idx],
                       mpc=self.mpc[idx], frequency_fit_std_hz=per_mode(self.frequency_fit_std_hz),
                       damping_fit_std=per_mode(self.damping_fit_std), weakly_stable=per_mode(self.weakly_stable))


def modal_estimate(f_hz, zeta, residues, drive, method, f_std=None, z_std=None, lower=None, upper=None,
                   f_fit_std=None, z_fit_std=None) -> ModalEstimate:
    """The :class:`ModalEstimate` of modes ``f_hz`` (Hz), ``zeta`` and ``residues`` (..., n_modes) by ``method``,
    in frequency order (shapes from the residues at the driving point ``drive``, None: unscaled); ``f_std``,
    ``z_std`` (None: NaN), the residual terms ``lower``, ``upper`` and the fit's one sigmas as the class holds
    them."""
    f_hz, zeta = np.asarray(f_hz, float), np.asarray(zeta, float)
    order = np.argsort(f_hz)
    nan = np.full(f_hz.size, np.nan)
    f_std = nan if f_std is None else np.asarray(f_std, float)
    z_std = nan if z_std is None else np.asarray(z_std, float)
    residues = np.asarray(residues, complex)[..., order]
    shapes = shapes_from_residues(residues, drive)
    lam = eigenvalues_from_modal(f_hz[order], zeta[order])
    fit_std = [None if a is None else np.asarray(a, float)[order] for a in (f_fit_std, z_fit_std)]
    return ModalEstimate(f_hz[order], zeta[order], lam, shapes, residues, f_std[order], z_std[order],
                         modal_phase_collinearity(shapes), method, drive is not None, lower, upper, *fit_std)

