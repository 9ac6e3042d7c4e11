"""Modal identification from measured FRFs.

Conventions: FRF arrays are ``(n_responses, n_references, n_lines)`` receptances
(m/N) unless stated; frequencies carry ``_hz`` or ``_rad_s`` in their names.
Complex modes follow the package's conjugate-pair convention (see
:mod:`physics.modal`).
"""

from __future__ import annotations

import numpy as np

from physics.errors import ShapeError


def real_modes_from_peaks(h_abs, phase_deg, omega_rad_s, zeta, drive_index=0):
    """Real mode shapes from peak FRF magnitudes and phases (eq. 3.25, Inman).

    ``|u_i u_i^T|_sr = 2 zeta_i omega_i^2 |H_sr(omega_i)|`` gives the drive-point
    entry ``a_r = sqrt(|u u^T|_rr)`` and the others ``a_s = |u u^T|_sr / a_r``;
    the sign of each entry is the sign of the phase at resonance (+90 deg gives a
    positive entry, -90 deg a negative one).

    Parameters
    ----------
    h_abs : array_like, shape (n_responses, n_modes)
        ``|H_sr(omega_i)|`` for the column of the drive point ``r``.
    phase_deg : array_like, shape (n_responses, n_modes)
        Phase of ``H_sr`` at resonance in degrees (about +90 or -90).
    omega_rad_s, zeta : array_like, shape (n_modes,)
        Natural frequencies (rad/s) and damping ratios.
    drive_index : int
        Row of the drive point (the driving-point FRF ``H_rr``).

    Returns
    -------
    ndarray, shape (n_responses, n_modes)
        Mode shapes ``u_i`` as columns.
    """
    h_abs = np.asarray(h_abs, dtype=float)
    phase_deg = np.asarray(phase_deg, dtype=float)
    omega = np.asarray(omega_rad_s, dtype=float)
    zeta = np.asarray(zeta, dtype=float)
    if h_abs.shape != phase_deg.shape or h_abs.ndim != 2 or h_abs.shape[1] != omega.size \
            or omega.shape != zeta.shape:
        raise ShapeError("h_abs and phase_deg must be (n_responses, n_modes) with one "
                         "omega_rad_s and zeta per mode")
    uu = 2 * zeta * omega**2 * h_abs  # eq. 3.25, one column of |u u^T| per mode
    a_r = np.sqrt(uu[drive_index])
    shapes = uu / a_r
    return np.where(np.cos(np.deg2rad(phase_deg - 90)) > 0, 1.0, -1.0) * shapes


def complex_modes_from_driving_point(h_peak, zeta, drive_index=0):
    """Complex mode shapes from FRF values at resonance (eqs. 3.33 and 3.34).

    ``Psi_s = (zeta/(-zeta + i) H_ss)^(1/2)`` at the drive point and
    ``Psi_r = zeta/(-zeta + i) H_rs / Psi_s`` elsewhere. These shapes follow the
    thesis's eq. 3.27 scaling (``lambda_j Psi Psi^T / (i w - lambda_j)``).

    Parameters
    ----------
    h_peak : array_like, complex, shape (n_responses, n_modes)
        FRF of each response to the drive point, at each mode's resonance.
    zeta : array_like, shape (n_modes,)
    drive_index : int

    Returns
    -------
    ndarray, complex, shape (n_responses, n_modes)
    """
    h_peak = np.asarray(h_peak, dtype=complex)
    zeta = np.asarray(zeta, dtype=float)
    if h_peak.ndim != 2 or h_peak.shape[1] != zeta.size:
        raise ShapeError("h_peak must be (n_responses, n_modes) with one zeta per mode")
    factor = zeta / (-zeta + 1j)
    psi_s = np.sqrt(factor * h_peak[drive_index])  # eq. 3.33
    return factor * h_peak / psi_s  # eq. 3.34 (gives psi_s again on the drive row)
