"""Modal identification from measured FRFs.

Conventions: FRF arrays are ``(n_responses, n_references, n_lines)`` receptances
(m/N) unless stated; frequencies carry ``_hz`` or ``_rad_s`` in their names.
Complex modes follow the package's conjugate-pair convention (see
:mod:`physics.modal`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from physics.errors import ConfigError, ConvergenceError, ShapeError
from physics.io import MeasuredFRF, ModalData
from physics.frf import FRF_KINDS, check_frf_kind, convert_frf, pole_residue
from physics.modal import eigenvalues_from_modal

__all__ = ["CircleFit", "ESTIMATION_PASSES", "Identification", "LSCFIdentification", "LSFDResult", "MAX_LSCF_VALUES",
           "METHODS", "ModalEstimate", "STABILITY_CODES", "SelectedPoles", "StabilisationDiagram", "WEIGHTINGS",
           "circle_fit", "circle_fit_sdof", "complex_modes_from_driving_point", "estimate_noise_model",
           "find_peaks_indicator", "identify_file", "identify_frf", "identify_frfs", "identify_lscf", "lscf", "lsfd",
           "modal_phase_collinearity", "mode_indicator", "peak_picking", "read_measured_frf", "real_modes_from_peaks",
           "reconstruction_error_db", "select_poles", "shapes_from_residues"]


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


# ---------------------------------------------------------------------------
# Shared helpers
# ---------------------------------------------------------------------------

def _frf3(frequency_hz, frf):
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


def _estimate(f_hz, zeta, residues, drive, method, f_std=None, z_std=None, lower=None, upper=None,
              f_fit_std=None, z_fit_std=None):
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


# ---------------------------------------------------------------------------
# SDOF methods: peak picking with half-power damping, circle fit (eq. 3.13)
# ---------------------------------------------------------------------------

def mode_indicator(frf):
    """Sum of squared FRF magnitudes over all responses and references, shape (n_lines,)."""
    h = np.asarray(frf)
    return np.sum(np.abs(h.reshape(-1, h.shape[-1])) ** 2, axis=0)


def find_peaks_indicator(frequency_hz, frf, n_modes=None, prominence=0.2):
    """Line indices of resonance peaks of :func:`mode_indicator`.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
    n_modes : int, optional
        Keep the ``n_modes`` most prominent peaks (in log magnitude).
    prominence : float
        Minimum prominence of a peak of ``log10`` of the indicator (decades).

    Returns
    -------
    ndarray of int, ascending
    """
    from scipy.signal import find_peaks

    f, h = _frf3(frequency_hz, frf)
    mif = np.log10(mode_indicator(h) + np.finfo(float).tiny)
    idx, props = find_peaks(mif, prominence=prominence)
    if n_modes is not None:
        keep = np.argsort(props["prominences"])[::-1][:n_modes]
        idx = idx[keep]
    return np.sort(idx)


def peak_picking(frequency_hz, frf, n_modes=None, peaks=None, drive=None, prominence=0.2):
    """Peak picking with half-power damping and SDOF complex shapes (eqs. 3.33/3.34).

    The peak of :func:`mode_indicator` (sum of ``|H|^2``) is refined by a
    parabola through the log-magnitudes of the three highest lines; the
    half-power points are where the indicator falls to half the peak value
    (linear interpolation between lines), giving
    ``zeta = (f_b - f_a) / (2 f_n)``. FRF values at resonance are taken at the
    nearest line and corrected to ``f_n`` with the single-mode factor
    ``(i w_k - lambda)/(i w_n - lambda)``; eqs. 3.33/3.34 then give the
    complex shapes, rescaled to the package's unit-modal-A convention
    (``psi = sqrt(lambda) Psi``). Equivalent residues are ``R = psi psi[r]``.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        Receptances (m/N).
    n_modes : int, optional
    peaks : array of int, optional
        Line indices of the peaks (else :func:`find_peaks_indicator`).
    drive : (int, int), optional
        Driving point ``(response_row, reference_column)``; default row 0,
        column 0 (shapes then not unit-modal-A scaled).

    Returns
    -------
    ModalEstimate
        No uncertainty (NaN). Only the driving-point column is identified; its
        residues are repeated for every reference.
    """
    f, h = _frf3(frequency_hz, frf)
    idx = find_peaks_indicator(f, h, n_modes, prominence) if peaks is None else np.asarray(peaks, int)
    idx = idx[(idx > 0) & (idx < f.size - 1)]
    mif = mode_indicator(h)
    y0, y1, y2 = np.log(mif[idx - 1]), np.log(mif[idx]), np.log(mif[idx + 1])
    den = y0 - 2 * y1 + y2
    delta = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1), 0.0)
    df_line = 0.5 * (f[idx + 1] - f[idx - 1])
    fn = f[idx] + np.clip(delta, -0.5, 0.5) * df_line
    peak_val = np.exp(y1 - 0.25 * (y0 - y2) * delta)
    fa, fb = np.empty(idx.size), np.empty(idx.size)
    for m, (k, half) in enumerate(zip(idx, peak_val / 2)):
        lo = k
        while lo > 0 and mif[lo] > half:
            lo -= 1
        hi = k
        while hi < f.size - 1 and mif[hi] > half:
            hi += 1
        # linear interpolation of the crossing between the last line above and the first below
        fa[m] = np.interp(half, [mif[lo], mif[lo + 1]], [f[lo], f[lo + 1]]) if mif[lo] <= half else f[lo]
        fb[m] = np.interp(half, [mif[hi], mif[hi - 1]], [f[hi], f[hi - 1]]) if mif[hi] <= half else f[hi]
    zeta = (fb - fa) / (2 * fn)
    narrow = (fb - fa) < 2 * df_line
    if np.any(narrow):
        warnings.warn("peak picking: the half-power band of the mode(s) at "
                      + ", ".join(f"{x:.4g} Hz" for x in fn[narrow])
                      + " spans fewer than 2 frequency lines, so half-power and circle-fit damping are not "
                      "resolved there (overestimated); use finer lines or the lscf method", stacklevel=2)
    lam = eigenvalues_from_modal(fn, zeta)
    s, r = (0, 0) if drive is None else drive
    w_k = 2 * np.pi * f[idx]
    corr = (1j * w_k - lam) / (1j * np.abs(lam) * np.sqrt(1 - zeta**2) - lam)
    h_res = h[:, r, idx] * corr  # (n_resp, n_modes) at the damped natural frequency
    Psi = complex_modes_from_driving_point(h_res, zeta, drive_index=s)  # eqs. 3.33/3.34
    psi = np.sqrt(lam) * Psi  # eq. 3.27 scaling -> unit modal A
    # only the driving-point column is identified; it is repeated for every reference
    residues = np.repeat((psi * psi[s])[:, None, :], h.shape[1], axis=1)
    return _estimate(fn, zeta, residues, drive, "peak")


def _fit_circle(z):
    """Algebraic (Kasa) least-squares circle through complex points; returns (centre, radius)."""
    scale = np.max(np.abs(z))
    x, y = z.real / scale, z.imag / scale
    A = np.column_stack([x, y, np.ones_like(x)])
    sol = np.linalg.lstsq(A, -(x**2 + y**2), rcond=None)[0]
    c = -0.5 * (sol[0] + 1j * sol[1])
    r = np.sqrt(max(abs(c) ** 2 - sol[2], 0.0))
    return c * scale, r * scale


@dataclass(frozen=True)
class CircleFit:
    """Circle fit of one mode in one FRF (see :func:`circle_fit_sdof`).

    Attributes
    ----------
    fn_hz, fn_std_hz : float
        Natural frequency and its one-sigma standard error from the phase fit (Hz).
    zeta, zeta_std : float
        Damping ratio (mean of eq. 3.13 over point pairs) and the standard error of that mean.
    modal_constant : complex
        ``A`` of the receptance ``A / (w_n^2 - w^2 + 2 i zeta w_n w)`` near resonance (1/kg).
    centre : complex
        Centre of the fitted circle in the mobility plane (m/s/N).
    radius : float
        Radius of the fitted circle (m/s/N).
    """

    fn_hz: float
    fn_std_hz: float
    zeta: float
    zeta_std: float
    modal_constant: complex
    centre: complex
    radius: float


def circle_fit_sdof(frequency_hz, mobility, fn_guess_hz, zeta_guess):
    """Circle fit of one mode in one mobility FRF (Nyquist plot, eq. 3.13).

    Fits a circle to the points, then the angle of each point about the
    centre to the single-mode law ``phi = phi_r + 2 arctan((w_n^2 - w^2)/(2 zeta w_n w))``
    for ``w_n`` (nonlinear least squares). Damping follows eq. 3.13 for every
    pair of points a (below ``w_n``) and b (above):
    ``zeta = (w_b^2 - w_a^2) / (2 w_n (w_a tan(theta_a/2) + w_b tan(theta_b/2)))``,
    ``theta`` being the angle from the resonance point; the mean over pairs is
    returned and their spread gives ``zeta_std``.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_points,), at least 4 points around resonance
    mobility : ndarray, complex, shape (n_points,)
        Mobility ``i w H`` (its single-mode Nyquist plot is an exact circle).
    fn_guess_hz, zeta_guess : float

    Returns
    -------
    CircleFit
    """
    from scipy.optimize import least_squares

    w = 2 * np.pi * np.asarray(frequency_hz, float)
    c, rad = _fit_circle(np.asarray(mobility))
    phi = np.unwrap(np.angle(mobility - c))

    def resid(p):
        wn, z, phr = p
        return phi - phr - 2 * np.arctan((wn**2 - w**2) / (2 * z * wn * w))

    wn0 = 2 * np.pi * fn_guess_hz
    k0 = np.argmin(np.abs(w - wn0))
    sol = least_squares(resid, [wn0, max(zeta_guess, 1e-5), phi[k0]],
                        bounds=([w[0], 1e-6, -np.inf], [w[-1], 0.5, np.inf]), x_scale=[wn0 * 1e-3, 1e-3, 1])
    wn, z_fit, phr = sol.x
    dof = max(w.size - 3, 1)
    s2 = 2 * sol.cost / dof
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * s2
        wn_std = float(np.sqrt(max(cov[0, 0], 0)))
    except np.linalg.LinAlgError:
        wn_std = np.nan
    theta = np.abs(phi - phr)
    below, above = w < wn, w > wn
    wa, wb = w[below][:, None], w[above][None, :]
    ta, tb = theta[below][:, None], theta[above][None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        z_pairs = (wb**2 - wa**2) / (2 * wn * (wa * np.tan(ta / 2) + wb * np.tan(tb / 2)))  # eq. 3.13
    z_pairs = z_pairs[np.isfinite(z_pairs) & (z_pairs > 0)]
    if z_pairs.size:
        zeta, zeta_std = float(np.mean(z_pairs)), float(np.std(z_pairs) / np.sqrt(z_pairs.size))
    else:
        zeta, zeta_std = float(z_fit), np.nan
    A = 4 * rad * zeta * wn * np.exp(1j * phr)
    return CircleFit(float(wn / (2 * np.pi)), float(wn_std / (2 * np.pi)), zeta, zeta_std, complex(A),
                     complex(c), float(rad))


def circle_fit(frequency_hz, frf, n_modes=None, peaks=None, drive=None, bandwidths=3.0, min_points=5):
    """Circle-fit identification (Nyquist plot, eq. 3.13) of every mode in every FRF.

    Peaks come from :func:`peak_picking`; around each, the lines within
    ``bandwidths`` half-power bandwidths (at least ``min_points``, never past
    the midpoint to a neighbouring peak) are fitted by :func:`circle_fit_sdof`
    on the mobility. The global natural frequency and damping of a mode are
    means over FRFs weighted by circle diameter; their uncertainties are the
    weighted scatter over FRFs (single FRF: the fit's own standard errors).
    Residues ``R = A / (2 i w_d)`` follow from each FRF's modal constant.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        Receptances (m/N).
    n_modes, peaks, drive : see :func:`peak_picking`
    bandwidths : float
    min_points : int

    Returns
    -------
    ModalEstimate
    """
    f, h = _frf3(frequency_hz, frf)
    pk = peak_picking(f, h, n_modes, peaks, drive)
    idx = np.array([np.argmin(np.abs(f - x)) for x in pk.natural_frequencies_hz])
    mob = 2j * np.pi * f * h
    n_s, n_r, n_m = h.shape[0], h.shape[1], idx.size
    fn = np.empty((n_s, n_r, n_m))
    zz = np.empty_like(fn)
    fsd = np.empty_like(fn)
    zsd = np.empty_like(fn)
    A = np.empty((n_s, n_r, n_m), complex)
    edges = np.r_[0, (idx[1:] + idx[:-1]) // 2, f.size - 1]
    for m in range(n_m):
        fm, zm = pk.natural_frequencies_hz[m], pk.damping_ratios[m]
        sel = np.nonzero(np.abs(f - fm) <= bandwidths * max(zm, 1e-4) * fm)[0]
        lo, hi = (sel[0], sel[-1]) if sel.size else (idx[m], idx[m])
        while hi - lo + 1 < min_points:
            lo, hi = max(lo - 1, 0), min(hi + 1, f.size - 1)
        lo, hi = max(lo, edges[m]), min(hi, edges[m + 1])
        if hi - lo + 1 < 4:
            raise ShapeError(f"circle fit: fewer than 4 lines around the peak at {fm:.4g} Hz; "
                             "use finer lines or the lscf method")
        for s in range(n_s):
            for r in range(n_r):
                out = circle_fit_sdof(f[lo:hi + 1], mob[s, r, lo:hi + 1], fm, zm)
                fn[s, r, m], zz[s, r, m] = out.fn_hz, out.zeta
                fsd[s, r, m], zsd[s, r, m] = out.fn_std_hz, out.zeta_std
                A[s, r, m] = out.modal_constant
    weight = np.abs(A).reshape(-1, n_m)  # strong circles count more
    weight = weight / weight.sum(axis=0)
    f_mode = np.sum(weight * fn.reshape(-1, n_m), axis=0)
    z_mode = np.sum(weight * zz.reshape(-1, n_m), axis=0)
    n_frf = n_s * n_r
    if n_frf > 1:
        f_std = np.sqrt(np.sum(weight * (fn.reshape(-1, n_m) - f_mode) ** 2, axis=0) / (n_frf - 1))
        z_std = np.sqrt(np.sum(weight * (zz.reshape(-1, n_m) - z_mode) ** 2, axis=0) / (n_frf - 1))
    else:
        f_std, z_std = fsd[0, 0], zsd[0, 0]
    wd = 2 * np.pi * f_mode * np.sqrt(1 - z_mode**2)
    residues = A / (2j * wd)
    return _estimate(f_mode, z_mode, residues, drive, "circle", f_std, z_std)


# ---------------------------------------------------------------------------
# MDOF: poly-reference least-squares complex frequency domain (LSCF) + LSFD
# ---------------------------------------------------------------------------

#: Stability codes of poles in a stabilisation diagram.
STABILITY_CODES = {0: "new", 1: "stable frequency", 2: "stable frequency and damping",
                   3: "stable frequency and vector", 4: "stable"}


@dataclass(frozen=True)
class StabilisationDiagram:
    """Poles of LSCF models of increasing order (one row per pole).

    Attributes
    ----------
    order : ndarray of int, shape (n_poles,)
    eigenvalues : ndarray, complex, shape (n_poles,)  (rad/s, Im > 0)
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_poles,)
    participation : ndarray, complex, shape (n_poles, n_ref)
        Modal participation vectors (unit norm).
    status : ndarray of int, shape (n_poles,)
        See :data:`STABILITY_CODES`; compared with the previous order.
    band_hz : (float, float)
    """

    order: np.ndarray
    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    participation: np.ndarray
    status: np.ndarray
    band_hz: tuple


#: (frequency lines, dt, columns) -> (X, Q) of :func:`_lscf_basis`, the 4 most recent.
_LSCF_BASIS_CACHE: dict = {}


def _lscf_basis(f_hz, dt_s, n_cols):
    """LSCF polynomial basis ``X = exp(i w dt k)`` (N, n_cols) and an orthonormal basis (2N, n_cols) of its
    real-stacked columns (Householder QR); the first ``nb`` columns of ``Q`` span the first ``nb`` of ``X``.

    The last few results are cached by the frequency lines, ``dt_s`` and ``n_cols`` (files of one layout
    share them).
    """
    key = (f_hz.tobytes(), float(dt_s), int(n_cols))
    hit = _LSCF_BASIS_CACHE.get(key)
    if hit is None:
        X = np.exp(1j * np.outer(2 * np.pi * f_hz * dt_s, np.arange(n_cols)))
        Q, _ = np.linalg.qr(np.concatenate([X.real, X.imag], axis=0))
        hit = (X, Q)
        for a in (X, Q):
            a.setflags(write=False)
        if len(_LSCF_BASIS_CACHE) >= 4:
            _LSCF_BASIS_CACHE.pop(next(iter(_LSCF_BASIS_CACHE)))
        _LSCF_BASIS_CACHE[key] = hit
    return hit


def lscf(frequency_hz, frf, max_order=40, min_order=1, freq_tol=0.01, damping_tol=0.05, mpf_tol=0.98,
         max_damping=0.2, margin=0.0):
    """Poly-reference least-squares complex frequency-domain poles (pLSCF).

    Right matrix-fraction model in the z-domain, ``H_o(w) = B_o(z) A(z)^-1`` with
    ``z = exp(i w dt)``, ``dt = 1/(2 f_max)``, ``A(z) = sum_{k=0}^p z^k alpha_k``
    (``n_ref x n_ref``, ``alpha_p = I``). The linear least-squares problem is
    reduced to the normal equations of the denominator only
    (``M = sum_o T_o - S_o^T R^-1 S_o``, formed as ``sum_o Y_o^T (I - Q Q^T) Y_o``
    with a QR factor ``Q`` of the numerator basis, for conditioning; every order
    from one QR and one projection at ``max_order``). Poles are the roots of
    ``det A(z)`` (block companion matrix), ``lambda = ln(z)/dt``; participation
    vectors are the left null vectors of ``A(z)``. With one reference this is
    the common-denominator LSCF.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
        Band to fit (select it beforehand).
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
    max_order, min_order : int
        Model orders ``p`` (``p * n_ref`` poles each).
    freq_tol, damping_tol : float
        Relative change with respect to the nearest pole of the previous order
        below which frequency / damping are called stable.
    mpf_tol : float
        MAC between participation vectors above which the vector is stable
        (always stable with one reference).
    max_damping : float
        Poles with damping outside ``(0, max_damping)`` or outside the band are dropped.
    margin : float
        Keep poles up to a fraction ``margin`` outside the band (``f_min/(1+margin)``
        to ``f_max (1+margin)``), and place the z-domain Nyquist frequency at
        ``f_max (1+margin)`` so that a mode just above the band does not alias. The
        skirts of such modes dominate the band edges of lightly damped structures.

    Returns
    -------
    StabilisationDiagram
    """
    f, h = _frf3(frequency_hz, frf)
    n_o, n_i, N = h.shape
    if max_order < min_order or min_order < 1:
        raise ShapeError("lscf needs 1 <= min_order <= max_order")
    if N * n_o < (max_order + 1) * (n_i + 1):
        raise ShapeError(f"lscf: {N} lines x {n_o} responses are too few for model order {max_order}")
    dt = 1.0 / (2.0 * f[-1] * (1.0 + margin))
    P = max_order + 1
    X, Q = _lscf_basis(f, dt, P)
    Hrow = np.transpose(h, (0, 2, 1))  # (n_o, N, n_i)
    Y = -(X[None, :, :, None] * Hrow[:, :, None, :]).reshape(n_o, N, P * n_i)
    Yr = np.concatenate([Y.real, Y.imag], axis=1)  # (n_o, 2N, P n_i)
    # Eliminate the numerators: order p projects Y off the first nb = p + 1 columns of Q
    # (QR, so the conditioning of X is not squared), then solves the denominator normal
    # equations M_p alpha = 0 with alpha_p = I. With C = Q^T Y and Yperp = Y - Q C,
    # Y - Q[:, :nb] C[:nb] = Yperp + Q[:, nb:] C[nb:] (orthogonal parts), so
    # M_p = Yperp^T Yperp + sum_{k >= nb} C_k^T C_k on the first (p + 1) n_i columns:
    # a sum of positive semi-definite terms (no cancellation), all orders from one projection.
    C = np.matmul(Q.T, Yr)  # (n_o, P, P n_i)
    Yperp = Yr - np.matmul(Q, C)
    Yp2 = Yperp.reshape(-1, Yperp.shape[-1])
    M = Yp2.T @ Yp2
    orders, lams, mpfs = [], [], []
    for p in range(max_order, min_order - 1, -1):
        nb, na, m = p + 1, (p + 1) * n_i, p * n_i
        if nb < P:  # add the term of basis column nb, dropped from the numerator at this order
            M = M + C[:, nb, :].T @ C[:, nb, :]
        Mp = M[:na, :na]
        try:
            alpha = np.linalg.solve(Mp[:m, :m], -Mp[:m, m:])  # (m, n_i)
        except np.linalg.LinAlgError:
            continue
        # companion matrix of sum_k z^k alpha_k^T (left null vectors of A(z))
        coeffs = alpha.reshape(p, n_i, n_i).transpose(0, 2, 1)
        comp = np.zeros((m, m))
        comp[:m - n_i, n_i:] = np.eye(m - n_i)
        comp[m - n_i:, :] = -np.concatenate(list(coeffs), axis=1)
        z, V = np.linalg.eig(comp)
        ok = np.abs(z) > 0
        lam = np.log(z[ok].astype(complex)) / dt
        L = V[:n_i, ok].T
        fn = np.abs(lam) / (2 * np.pi)
        zeta = -lam.real / np.abs(lam)
        keep = (lam.imag > 0) & (zeta > 0) & (zeta < max_damping) & (fn >= f[0] / (1.0 + margin)) \
            & (fn <= f[-1] * (1.0 + margin))
        L = L[keep] / np.linalg.norm(L[keep], axis=1, keepdims=True)
        orders.append(np.full(keep.sum(), p))
        lams.append(lam[keep])
        mpfs.append(L)
    orders, lams, mpfs = orders[::-1], lams[::-1], mpfs[::-1]  # ascending order
    order = np.concatenate(orders)
    lam = np.concatenate(lams)
    mpf = np.concatenate(mpfs) if mpfs else np.zeros((0, n_i), complex)
    fn = np.abs(lam) / (2 * np.pi)
    zeta = -lam.real / np.abs(lam)
    status = np.zeros(lam.size, int)
    for p in np.unique(order)[1:]:
        cur = np.nonzero(order == p)[0]
        prev = np.nonzero(order == p - 1)[0]
        if prev.size == 0 or cur.size == 0:
            continue
        d = np.abs(fn[cur][:, None] - fn[prev][None, :])
        near = prev[np.argmin(d, axis=1)]
        f_ok = np.abs(fn[cur] - fn[near]) <= freq_tol * fn[cur]
        d_ok = np.abs(zeta[cur] - zeta[near]) <= damping_tol * zeta[cur]
        v_ok = (np.abs(np.sum(mpf[cur].conj() * mpf[near], axis=1)) ** 2 >= mpf_tol) if n_i > 1 \
            else np.ones(cur.size, bool)
        status[cur] = np.where(f_ok, np.where(d_ok & v_ok, 4, np.where(v_ok, 3, np.where(d_ok, 2, 1))), 0)
    return StabilisationDiagram(order, lam, fn, zeta, mpf, status, (float(f[0]), float(f[-1])))


@dataclass(frozen=True)
class SelectedPoles:
    """Physical poles picked from a stabilisation diagram.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
        Medians over the upper half (by model order) of the cluster of stable poles.
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        Standard deviation over those poles (spread across model orders, a
        measure of the estimate's sensitivity to model order, not a
        statistical confidence interval).
    count : ndarray of int, shape (n_modes,)
        Orders (upper half of the cluster) in which the pole was found stable.
    participation : ndarray, complex, shape (n_modes, n_ref)
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    count: np.ndarray
    participation: np.ndarray


def select_poles(diagram: StabilisationDiagram, n_modes=None, min_status=4, freq_tol=0.01,
                 damping_tol=0.25, min_count=None, seed_orders=0.25):
    """Automatic pole selection from a stabilisation diagram (no GUI; rules are parameters).

    1. Candidate poles have ``status >= min_status`` (4 = stable in frequency,
       damping and participation vector).
    2. Seeds are the candidates of the highest ``seed_orders`` fraction of orders.
       For each seed, every order contributes its candidate nearest in frequency
       if within ``freq_tol`` (relative) and ``damping_tol`` (relative) of the seed.
    3. Clusters are taken largest first; a seed already in a taken cluster is
       skipped and poles already taken are removed from later clusters, which
       are dropped below ``min_count`` members (default: a third of the orders
       that hold any pole).
    4. With ``n_modes``, the ``n_modes`` largest clusters are kept.

    Parameters
    ----------
    diagram : StabilisationDiagram
    n_modes : int, optional
    min_status : int
    freq_tol, damping_tol : float
    min_count : int, optional
    seed_orders : float in (0, 1]

    Returns
    -------
    SelectedPoles
        Sorted by frequency.

    Raises
    ------
    ConvergenceError
        If no pole is stable enough.
    """
    from physics.errors import ConvergenceError

    d = diagram
    cand = np.nonzero(d.status >= min_status)[0]
    cand = cand[np.argsort(d.order[cand], kind="stable")]
    orders = np.unique(d.order)
    if min_count is None:
        min_count = max(2, int(np.ceil(orders.size / 3)))
    top = orders[int(np.floor((1 - seed_orders) * (orders.size - 1))):] if orders.size else orders
    seeds = cand[np.isin(d.order[cand], top)]
    # candidates by order, padded to a (n_orders, width) table (-1 = none)
    c_orders, c_group = np.unique(d.order[cand], return_inverse=True)
    slot = np.arange(cand.size) - np.searchsorted(c_group, c_group)  # cand is grouped by ascending order
    by_order = np.full((c_orders.size, max(1, np.bincount(c_group).max(initial=0))), -1)
    by_order[c_group, slot] = cand
    f_tab = np.where(by_order >= 0, d.natural_frequencies_hz[by_order], np.inf)
    # each order's candidate nearest in frequency to each seed, kept within the tolerances
    dist = np.abs(f_tab[None] - d.natural_frequencies_hz[seeds][:, None, None])  # (n_seeds, n_orders, width)
    near = by_order[np.arange(c_orders.size)[None, :], np.argmin(dist, axis=2)]  # (n_seeds, n_orders)
    fs, zs = d.natural_frequencies_hz[seeds][:, None], d.damping_ratios[seeds][:, None]
    ok = (np.abs(d.natural_frequencies_hz[near] - fs) <= freq_tol * fs) \
        & (np.abs(d.damping_ratios[near] - zs) <= damping_tol * zs)
    clusters = [(sd, near[k][ok[k]]) for k, sd in enumerate(seeds)]
    clusters.sort(key=lambda c: (-c[1].size, -d.order[c[0]]))
    chosen, used = [], set()
    for sd, mem in clusters:
        if sd in used:
            continue
        mem = np.array([j for j in mem if j not in used], int)
        if mem.size < min_count:
            continue
        chosen.append(mem)
        used.update(mem.tolist())
        used.add(sd)
    if n_modes is not None:
        chosen = chosen[:n_modes]
    if not chosen:
        raise ConvergenceError("no pole is stable over enough model orders: raise max_order, widen the "
                               "band or relax the selection tolerances")
    # low orders are biased (the z-domain model converges with order): summarise the
    # upper half of each cluster's orders
    chosen = [m[d.order[m] >= np.median(d.order[m])] for m in chosen]
    fn = np.array([np.median(d.natural_frequencies_hz[m]) for m in chosen])
    zeta = np.array([np.median(d.damping_ratios[m]) for m in chosen])
    f_std = np.array([np.std(d.natural_frequencies_hz[m], ddof=1) for m in chosen])
    z_std = np.array([np.std(d.damping_ratios[m], ddof=1) for m in chosen])
    count = np.array([m.size for m in chosen])
    mpf = np.array([d.participation[m[np.argmax(d.order[m])]] for m in chosen])
    o = np.argsort(fn)
    lam = eigenvalues_from_modal(fn[o], zeta[o])
    return SelectedPoles(lam, fn[o], zeta[o], f_std[o], z_std[o], count[o], mpf[o])


#: Weightings of :func:`lsfd` (or pass an array of noise standard deviations).
WEIGHTINGS = ("relative", "uniform", "estimated")
#: Refits of ``weighting="estimated"`` after the relative-weighted start.
ESTIMATION_PASSES = 3


@dataclass(frozen=True)
class LSFDResult:
    """Residues of a pole-residue model fitted by least squares (see :func:`lsfd`).

    Attributes
    ----------
    residues : ndarray, complex, shape (n_resp, n_ref, n_modes)
        Receptance residues ``R_j`` of ``H = sum_j R_j/(i w - lambda_j) + c.c.`` (m/N/s).
    residue_std : ndarray, shape (n_resp, n_ref, n_modes)
        One-sigma standard error of ``|R|`` from the weighted least-squares
        covariance (poles taken as exact).
    lower_residual, upper_residual : ndarray, shape (n_resp, n_ref)
        Real mass-like (``-LR/w^2``) and stiffness-like (``UR``) receptance terms of
        out-of-band modes (zero when not fitted).
    synthesised : ndarray, complex, shape (n_resp, n_ref, n_lines)
        The fitted model on the input lines, in the input's ``kind``.
    eigenvalues : ndarray, complex, shape (n_modes,)
        The poles of the model (as given).
    eigenvalue_std : ndarray, shape (n_modes, 2)
        One-sigma standard errors of ``Re lambda`` and ``Im lambda`` (rad/s) from the
        variable-projection covariance of the poles given every FRF (linearised,
        residuals white within each FRF after weighting).
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        The same covariance propagated to natural frequency and damping ratio.
    kind : str
    weighting : str
    """

    residues: np.ndarray
    residue_std: np.ndarray
    lower_residual: np.ndarray
    upper_residual: np.ndarray
    synthesised: np.ndarray
    eigenvalues: np.ndarray | None = None
    eigenvalue_std: np.ndarray | None = None
    frequency_std_hz: np.ndarray | None = None
    damping_std: np.ndarray | None = None
    kind: str = "receptance"
    weighting: str = "relative"


def _lsfd_basis(iw, lam, power, lower, upper):
    """Complex design matrix (n_lines, n_par): Re R, Im R per pole, then LR, UR; in the kind of ``power``."""
    g = 1 / (iw[:, None] - lam[None, :])
    gc = 1 / (iw[:, None] - np.conj(lam)[None, :])
    cols = [g + gc, 1j * (g - gc)]  # basis of Re R and Im R
    if lower:
        cols.append((1 / iw**2)[:, None])
    if upper:
        cols.append(np.ones((iw.size, 1)))
    return np.concatenate(cols, axis=1) * (iw**power)[:, None]


def _lsfd_weights(h, weighting):
    """Weights like ``h`` (n_resp, n_ref, n_lines): 1/|H| (relative), ones (uniform) or 1/sigma (noise-based)."""
    if isinstance(weighting, str):
        if weighting not in WEIGHTINGS:
            raise ShapeError(f"weighting {weighting!r} must be one of {', '.join(WEIGHTINGS)} or an array "
                             "of noise standard deviations")
        if weighting == "uniform":
            return np.ones(h.shape)
        mag = np.abs(h)
        floor = 1e-9 * np.max(mag, axis=-1, keepdims=True)
        if np.any(floor == 0):
            raise ShapeError("relative weighting needs FRFs that are not identically zero")
        return 1 / np.maximum(mag, floor)
    try:
        sigma = np.broadcast_to(np.asarray(weighting, dtype=float), h.shape)
    except ValueError:
        raise ShapeError(f"noise standard deviations (weighting) of shape {np.shape(weighting)} do not "
                         f"broadcast to the FRF shape {h.shape}") from None
    if not (np.all(np.isfinite(sigma)) and np.all(sigma > 0)):
        raise ShapeError("noise standard deviations (weighting) must be finite and > 0")
    return 1 / sigma


def estimate_noise_model(h, residual, iterations: int = 4):
    """Noise standard deviation of each line, ``sigma = sqrt((a |h|)^2 + b^2)`` per FRF, from fit residuals.

    A measured FRF carries noise proportional to its magnitude (``a``, relative) and a floor (``b``, in the
    FRF's units) that dominates the antiresonances of a lightly damped structure. ``|residual|^2`` estimates
    ``sigma^2`` line by line; ``a^2`` and ``b^2`` (>= 0) are fitted by iteratively reweighted least squares
    (weights ``1 / sigma^4``, the variance of ``|residual|^2``).

    Parameters
    ----------
    h : ndarray, complex, shape (n_frf, n_lines)
        Model FRFs (a first fit), whose magnitude carries the relative part.
    residual : ndarray, complex, shape (n_frf, n_lines)
        Measured minus model.

    Returns
    -------
    ndarray, shape (n_frf, n_lines)  standard deviations, > 0
    """
    m2 = np.abs(h) ** 2
    r2 = np.abs(residual) ** 2
    A = np.stack([m2, np.ones_like(m2)], axis=-1)                 # (n_frf, n_lines, 2)
    w = np.ones_like(m2)
    for _ in range(iterations):
        Aw = A * w[..., None]
        G = np.einsum("fni,fnj->fij", Aw, A)
        rhs = np.einsum("fni,fn->fi", Aw, r2)
        coef = np.linalg.solve(G + 1e-300 * np.eye(2), rhs[..., None])[..., 0]
        coef = np.maximum(coef, 0.0)
        var = coef[:, None, 0] * m2 + coef[:, None, 1]
        tiny = 1e-24 * np.max(m2, axis=-1, keepdims=True) + np.finfo(float).tiny
        var = np.maximum(var, tiny)
        w = 1 / var**2
    return np.sqrt(var)


def _weighted_solve(B, h, W):
    """Batched weighted least squares of ``h_k = B x_k`` (real x) for each FRF row ``k``.

    Returns the solution (n_frf, p), residual variances (n_frf,), the standard
    errors of ``x`` (n_frf, p) and the orthonormal range basis (n_frf, 2N, p) of the
    weighted design (columns beyond its rank zeroed).
    """
    A = W[:, :, None] * B[None]
    Ar = np.concatenate([A.real, A.imag], axis=1)  # (n_frf, 2N, p)
    wh = W * h
    br = np.concatenate([wh.real, wh.imag], axis=1)  # (n_frf, 2N)
    scale = np.linalg.norm(Ar, axis=1)
    scale[scale == 0] = 1.0
    U, s, Vt = np.linalg.svd(Ar / scale[:, None, :], full_matrices=False)
    keep = s > s[:, :1] * max(Ar.shape[1:]) * np.finfo(float).eps
    sinv = np.where(keep, 1 / np.where(keep, s, 1), 0.0)
    V = np.swapaxes(Vt, 1, 2) * sinv[:, None, :]  # (n_frf, p, p): V diag(1/s)
    x = np.einsum("fpk,fnk,fn->fp", V, U, br) / scale
    resid = br - np.einsum("fnp,fp->fn", Ar, x)
    dof = np.maximum(Ar.shape[1] - keep.sum(axis=1), 1)
    s2 = np.sum(resid**2, axis=1) / dof
    x_std = np.sqrt(np.sum(V**2, axis=-1) * s2[:, None]) / scale
    return x, s2, x_std, U * keep[:, None, :]


def _pole_information(iw, lam, R, power, W, Q, s2):
    """Variable-projection (Kaufman) information matrix of the poles, shape (2m, 2m).

    ``J`` is the derivative of the weighted model with respect to ``Re lambda_j`` and
    ``Im lambda_j`` for every FRF; projected off the residue/residual columns (``Q``)
    and weighted by each FRF's residual variance, ``S = sum_k J_k^T J_k / s2_k`` is the
    inverse covariance of the poles had they been fitted with the residues.
    """
    d = 1 / (iw[:, None] - lam[None, :]) ** 2
    dc = 1 / (iw[:, None] - np.conj(lam)[None, :]) ** 2
    Rc = np.conj(R)
    d_re = R[:, None, :] * d[None] + Rc[:, None, :] * dc[None]  # (n_frf, N, m)
    d_im = 1j * (R[:, None, :] * d[None] - Rc[:, None, :] * dc[None])
    J = np.concatenate([d_re, d_im], axis=-1) * ((iw**power)[None, :, None] * W[:, :, None])
    Jr = np.concatenate([J.real, J.imag], axis=1)  # (n_frf, 2N, 2m)
    Jp = Jr - np.matmul(Q, np.matmul(np.swapaxes(Q, 1, 2), Jr))
    return np.einsum("fnp,fnq,f->pq", Jp, Jp, 1 / s2)


def lsfd(frequency_hz, frf, eigenvalues, lower_residual=True, upper_residual=True, *, kind="receptance",
         weighting="relative"):
    """Least-squares frequency-domain residues, fitted to the FRFs as measured.

    Fits, for every FRF with the poles common,
    ``H(w) = (i w)^p {sum_j [R_j/(i w - lambda_j) + conj(R_j)/(i w - conj(lambda_j))] - LR/w^2 + UR}``
    with complex residues ``R_j`` and real ``LR``, ``UR``; ``p`` = 0, 1, 2 for a
    receptance, mobility or accelerance ``frf`` (``kind``), so the data are never
    divided by ``i w`` and their noise is not reshaped. Real and imaginary parts are
    stacked so conjugate symmetry holds exactly.

    Weighting (why): measured FRFs span many decades, from the mass line of a
    free-free beam at the lowest lines to antiresonances 60 dB down. Uniform
    weights fit the largest values (the mass line, the resonance peaks) and leave
    the rest to chance. ``"relative"`` (default) divides each line by ``|H|``, so
    every line counts by its relative (about: decibel) error, the error a person
    reads off an overlay plot; ``"uniform"`` is the classical unweighted fit; an
    array of noise standard deviations (same units and shape as ``frf``, or
    broadcastable) gives the maximum-likelihood fit for known noise.

    Residual terms (why real): the rigid-body modes of a free-free test and
    elastic modes far below the band act as a real mass line ``-LR/w^2``; modes far
    above as a real stiffness ``UR``. Their damping adds imaginary parts of order
    ``zeta`` (1e-4 here), below any noise, so complex residual terms would only fit
    noise. A mode *close* to the band is not a residual: pass its pole (see
    ``margin`` of :func:`lscf`).

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,), > 0 when ``lower_residual``
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        FRFs of kind ``kind`` (SI units).
    eigenvalues : ndarray, complex, shape (n_modes,)
    lower_residual, upper_residual : bool
    kind : {"receptance", "mobility", "accelerance"}
    weighting : {"relative", "uniform", "estimated"} or ndarray
        ``"estimated"``: a relative-weighted start, then :data:`ESTIMATION_PASSES` refits weighted by the noise
        model ``sqrt((a |H|)^2 + b^2)`` of each FRF fitted to the previous residuals
        (:func:`estimate_noise_model`): relative weighting where the data have no floor, noise weighting where
        a floor dominates the antiresonances (the default of :func:`identify_lscf`).

    Returns
    -------
    LSFDResult
        Residues in the receptance convention whatever ``kind``; ``synthesised`` in ``kind``.
    """

    f, h = _frf3(frequency_hz, frf)
    power = FRF_KINDS.index(check_frf_kind(kind))
    lam = np.asarray(eigenvalues, dtype=complex).ravel()
    if (lower_residual or power == 0) and f[0] <= 0:
        raise ShapeError("lsfd with a lower residual needs frequencies > 0 Hz (drop the 0 Hz line)")
    iw = 2j * np.pi * f
    n_s, n_r, N = h.shape
    hk = h.reshape(-1, N)
    n_m = lam.size
    B = _lsfd_basis(iw, lam, power, lower_residual, upper_residual)
    if isinstance(weighting, str) and weighting == "estimated":
        W = _lsfd_weights(hk, "relative")
        for _ in range(ESTIMATION_PASSES):   # noise model from the residuals, refit with its weights
            synth0 = _weighted_solve(B, hk, W)[0] @ B.T
            W = 1 / estimate_noise_model(synth0, hk - synth0)
    else:
        W = _lsfd_weights(h, weighting).reshape(-1, N)
    x, s2, x_std, Q = _weighted_solve(B, hk, W)
    R = x[:, :n_m] + 1j * x[:, n_m:2 * n_m]
    S = _pole_information(iw, lam, R, power, W, Q, s2)
    cov = np.linalg.pinv(S)
    var_re, var_im = np.clip(np.diag(cov)[:n_m], 0, None), np.clip(np.diag(cov)[n_m:], 0, None)
    cov_ri = np.diag(cov, n_m)[:n_m]
    a = np.abs(lam)
    # f = |lambda|/2 pi, zeta = -Re lambda/|lambda|: first-order propagation
    df = np.stack([lam.real, lam.imag]) / (2 * np.pi * a)
    dz = np.stack([-1 / a + lam.real**2 / a**3, lam.real * lam.imag / a**3])
    f_std = np.sqrt(np.clip(df[0] ** 2 * var_re + df[1] ** 2 * var_im + 2 * df[0] * df[1] * cov_ri, 0, None))
    z_std = np.sqrt(np.clip(dz[0] ** 2 * var_re + dz[1] ** 2 * var_im + 2 * dz[0] * dz[1] * cov_ri, 0, None))
    R = R.reshape(n_s, n_r, n_m)
    R_std = np.hypot(x_std[:, :n_m], x_std[:, n_m:2 * n_m]).reshape(n_s, n_r, n_m)
    k = 2 * n_m
    LR = UR = np.zeros((n_s, n_r))
    if lower_residual:
        LR = x[:, k].reshape(n_s, n_r)
        k += 1
    if upper_residual:
        UR = x[:, k].reshape(n_s, n_r)
    synth = (x @ B.T).reshape(h.shape)
    return LSFDResult(R, R_std, LR, UR, synth, lam, np.column_stack([np.sqrt(var_re), np.sqrt(var_im)]),
                      f_std, z_std, kind, weighting if isinstance(weighting, str) else "noise")


def reconstruction_error_db(measured, synthesised):
    """Median and 90th percentile over all lines and FRFs of ``|20 log10(|H_fit| / |H_meas|)|`` (dB).

    Lines where either magnitude is zero are left out.
    """
    m, s = np.abs(np.asarray(measured)).ravel(), np.abs(np.asarray(synthesised)).ravel()
    ok = (m > 0) & (s > 0)
    if not np.any(ok):
        return float("nan"), float("nan")
    err = np.abs(20 * np.log10(s[ok] / m[ok]))
    return float(np.median(err)), float(np.percentile(err, 90))


@dataclass(frozen=True)
class LSCFIdentification:
    """Result of :func:`identify_lscf`.

    Attributes
    ----------
    estimate : ModalEstimate
        The modes in the band; ``frequency_std_hz``/``damping_std`` are the spread
        of each pole over model orders, ``frequency_fit_std_hz``/``damping_fit_std``
        the one-sigma errors of the LSFD fit.
    diagram : StabilisationDiagram
    fit : LSFDResult
        Over all poles used, those of the band and those just outside it.
    out_of_band_hz : ndarray, shape (n_out,)
        Natural frequencies of the poles outside the band that the fit used.
    """

    estimate: ModalEstimate
    diagram: StabilisationDiagram
    fit: LSFDResult
    out_of_band_hz: np.ndarray


def identify_lscf(frequency_hz, frf, n_modes=None, drive=None, max_order=40, select=None, *, kind="receptance",
                  weighting="estimated", margin=0.1, **lscf_options):
    """LSCF poles, automatic selection and LSFD residues/shapes in one call.

    Poles come from LSCF on the receptance (stabilisation over model orders),
    including stable poles up to ``margin`` outside the band; the residues and the
    residual terms are then fitted to ``frf`` as given (``kind``, ``weighting``,
    see :func:`lsfd`) with every selected pole. Only modes inside the band are
    returned as modes; the others serve the fit.

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,), > 0
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        FRFs of kind ``kind`` (SI units).
    n_modes : int, optional
        Keep the ``n_modes`` in-band modes stable over most orders.
    drive : (int, int), optional
        Driving point for unit-modal-A scaling (see :func:`shapes_from_residues`).
    max_order : int
    select : dict, optional
        Keyword arguments of :func:`select_poles`.
    kind, weighting :
        See :func:`lsfd`.
    margin : float
        See :func:`lscf`.
    **lscf_options
        Keyword arguments of :func:`lscf`.

    Returns
    -------
    LSCFIdentification
    """

    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):  # small dense products and eigenproblems: one BLAS thread is fastest
        return _identify_lscf(frequency_hz, frf, n_modes, drive, max_order, select, kind, weighting, margin,
                              lscf_options)


def _identify_lscf(frequency_hz, frf, n_modes, drive, max_order, select, kind, weighting, margin, lscf_options):
    f, h = _frf3(frequency_hz, frf)
    rec = convert_frf(h, 2 * np.pi * f, check_frf_kind(kind), "receptance")
    diagram = lscf(f, rec, max_order=max_order, margin=margin, **lscf_options)
    poles = select_poles(diagram, **(select or {}))
    fn = poles.natural_frequencies_hz
    inside = np.nonzero((fn >= f[0]) & (fn <= f[-1]))[0]
    if inside.size == 0:
        raise ConvergenceError("no stable pole inside the band: raise max_order or widen the band")
    if n_modes is not None:
        inside = np.sort(inside[np.argsort(-poles.count[inside], kind="stable")[:n_modes]])
    outside = np.nonzero((fn < f[0]) | (fn > f[-1]))[0]
    use = np.r_[inside, outside]
    fit = lsfd(f, h, poles.eigenvalues[use], kind=kind, weighting=weighting)
    k = np.arange(inside.size)
    est = _estimate(fn[inside], poles.damping_ratios[inside], fit.residues[..., k], drive, "lscf",
                    poles.frequency_std_hz[inside], poles.damping_std[inside], fit.lower_residual,
                    fit.upper_residual, fit.frequency_std_hz[k], fit.damping_std[k])
    return LSCFIdentification(est, diagram, fit, np.abs(fit.eigenvalues[inside.size:]) / (2 * np.pi))


# ---------------------------------------------------------------------------
# Identification of a measured FRF file
# ---------------------------------------------------------------------------

METHODS = ("lscf", "circle", "peak")
#: Largest lines x responses an LSCF identification takes (its cost grows with both).
MAX_LSCF_VALUES = 100_000


@dataclass(frozen=True)
class Identification:
    """An identification run on a :class:`~physics.io.MeasuredFRF`.

    Attributes
    ----------
    frf : MeasuredFRF
        The band-limited FRFs that were fitted, of the input's kind (SI units).
    estimate : ModalEstimate
    synthesised : ndarray, complex, shape like ``frf.frf``
        The identified model on the same lines, of the same kind and units.
    diagram : StabilisationDiagram or None
        LSCF only.
    drive : str or None
        Reference DOF label of the driving point that scaled the shapes.
    out_of_band_hz : ndarray
        Poles just outside the band that the fit used (LSCF only; not reported as modes).
    """

    frf: MeasuredFRF
    estimate: ModalEstimate
    synthesised: np.ndarray
    diagram: StabilisationDiagram | None
    drive: str | None
    out_of_band_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def modal_data(self) -> ModalData:
        """Eigenvalues and shapes over the response DOFs, for updating."""
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.frf.response_dofs)


def identify_frf(frf: MeasuredFRF, method="lscf", band_hz=None, n_modes=None, max_order=40) -> Identification:
    """Identify modes of a :class:`~physics.io.MeasuredFRF` (band-limited, fitted in its own kind).

    The first driving point (a response DOF equal to a reference DOF) scales the
    shapes to unit modal A; without one the shapes are unscaled (a warning).

    Parameters
    ----------
    frf : MeasuredFRF
    method : {"lscf", "circle", "peak"}
    band_hz : (float, float), optional
        ``(fmin, fmax)`` in Hz.
    n_modes : int, optional
        Modes to keep (default: all found).
    max_order : int
        Highest LSCF model order.

    Returns
    -------
    Identification
    """
    if method not in METHODS:
        raise ConfigError(f"method {method!r} must be one of {', '.join(METHODS)}")
    if frf.frequency_hz[0] == 0:
        frf = frf.select_band(fmin_hz=np.nextafter(0.0, 1.0))
    if band_hz is not None:
        fmin, fmax = band_hz
        if not fmin < fmax:
            raise ConfigError(f"band_hz ({fmin}, {fmax}): the lower bound must be below the upper")
        frf = frf.select_band(fmin, fmax)
    drives = frf.driving_points
    drive = drives[0] if drives else None
    if drive is None:
        warnings.warn("no driving point (response DOF equal to a reference DOF): mode shapes are not "
                      "unit-modal-A scaled and cannot feed 'update' directly", stacklevel=2)
    f = frf.frequency_hz
    if method == "lscf" and f.size * len(frf.response_dofs) > MAX_LSCF_VALUES:
        raise ShapeError(f"{frf.metadata.get('source', 'FRF')}: {f.size} lines x {len(frf.response_dofs)} responses "
                         f"exceed the {MAX_LSCF_VALUES} values LSCF fits in reasonable time; select a band "
                         "(band_hz) with fewer lines")
    diagram, outside = None, np.zeros(0)
    if method == "lscf":
        res = identify_lscf(f, np.asarray(frf.frf), n_modes=n_modes, drive=drive, max_order=max_order,
                            kind=frf.kind)
        est, diagram, synth, outside = res.estimate, res.diagram, res.fit.synthesised, res.out_of_band_hz
    else:
        h = np.asarray(frf.to_kind("receptance").frf)
        est = (circle_fit if method == "circle" else peak_picking)(f, h, n_modes=n_modes, drive=drive)
        synth = convert_frf(pole_residue(est.eigenvalues, est.residues, frf.omega_rad_s), frf.omega_rad_s,
                            "receptance", frf.kind)
    label = frf.reference_dofs[drive[1]] if drive else None
    return Identification(frf, est, synth, diagram, label, outside)


def identify_frfs(frfs, method="lscf", band_hz=None, n_modes=None, max_order=40) -> list[Identification]:
    """:func:`identify_frf` on each of several :class:`~physics.io.MeasuredFRF` (same arguments for all).

    Files of one layout (the same frequency lines and band) share the LSCF basis and
    its QR factor, computed once (see :func:`lscf`); results are in input order.

    Returns
    -------
    list of Identification
    """
    return [identify_frf(frf, method, band_hz, n_modes, max_order) for frf in frfs]


def identify_file(path, method="lscf", band_hz=None, n_modes=None, max_order=40) -> Identification:
    """:func:`identify_frf` on an FRF file (UFF 58, CSV or ``.npz``; see :func:`physics.io.read_frf`).

    A universal file of time records (force and responses, no FRF) is estimated
    first (:func:`physics.time_records.estimate_from_records`, H1, random
    excitation defaults), with a warning that says so.
    """
    return identify_frf(read_measured_frf(path), method, band_hz, n_modes, max_order)


def read_measured_frf(path) -> MeasuredFRF:
    """FRFs of a file: read as FRFs, or estimated from its time records (with a warning saying how)."""
    from physics.errors import FileFormatError
    from physics.io import read_frf

    try:
        return read_frf(path)
    except FileFormatError as exc:
        if "1 (time response)" not in str(exc):
            raise
    from physics.io.timedata import read_uff_time_records
    from physics.time_records import estimate_from_records

    est = estimate_from_records(read_uff_time_records(path))
    warnings.warn(f"{path}: holds time records, not FRFs: estimated {est.description} before identifying",
                  stacklevel=2)
    return est.frf
