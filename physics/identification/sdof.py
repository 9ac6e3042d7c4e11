"""Single-degree-of-freedom identification: peak picking with half-power damping, circle fit (eq. 3.13).

Also the thesis's SDOF shape formulas from FRF values at resonance (eqs. 3.25, 3.33, 3.34).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError
from physics.identification.modes import checked_frf, modal_estimate
from physics.identification.poles import MAX_DAMPING
from physics.modal import eigenvalues_from_modal

__all__ = ["CircleFit", "circle_fit", "circle_fit_sdof", "complex_modes_from_driving_point", "find_peaks_indicator",
           "mode_indicator", "peak_picking", "real_modes_from_peaks"]


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

    f, h = checked_frf(frequency_hz, frf)
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
    f, h = checked_frf(frequency_hz, frf)
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
    broad = ~(zeta <= MAX_DAMPING)
    if np.any(broad):
        warnings.warn("peak picking: the peak(s) at " + ", ".join(f"{x:.4g} Hz" for x in fn[broad])
                      + f" left out: the half-power band gives a damping ratio above {MAX_DAMPING:g}, "
                      "a bump of the noise, not a mode", stacklevel=2)
        idx, fn, zeta, fa, fb, df_line = (a[~broad] for a in (idx, fn, zeta, fa, fb, df_line))
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
    return modal_estimate(fn, zeta, residues, drive, "peak")


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
    # the peak's own estimates may fall outside the fitted lines' range (a peak at the band edge, a broad one)
    start = [float(np.clip(wn0, w[0], w[-1])), float(np.clip(zeta_guess, 1e-5, 0.4)), phi[k0]]
    sol = least_squares(resid, start,
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
    f, h = checked_frf(frequency_hz, frf)
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
    line_hz = 0.5 * (f[np.minimum(idx + 1, f.size - 1)] - f[np.maximum(idx - 1, 0)])
    unresolved = 2 * pk.damping_ratios * pk.natural_frequencies_hz < 2 * line_hz      # as peak picking judges it
    fitted = np.ones(n_m, bool)
    for m in range(n_m):
        fm, zm = pk.natural_frequencies_hz[m], pk.damping_ratios[m]
        sel = np.nonzero(np.abs(f - fm) <= bandwidths * max(zm, 1e-4) * fm)[0]
        lo, hi = (sel[0], sel[-1]) if sel.size else (idx[m], idx[m])
        while hi - lo + 1 < min_points:
            lo, hi = max(lo - 1, 0), min(hi + 1, f.size - 1)
        lo, hi = max(lo, edges[m]), min(hi, edges[m + 1])
        if hi - lo + 1 < 4:
            fitted[m] = False
            warnings.warn(f"circle fit: the peak at {fm:.4g} Hz was skipped: fewer than 4 lines around it "
                          "(finer lines or the lscf method fit it)", stacklevel=2)
            continue
        for s in range(n_s):
            for r in range(n_r):
                out = circle_fit_sdof(f[lo:hi + 1], mob[s, r, lo:hi + 1], fm, zm)
                fn[s, r, m], zz[s, r, m] = out.fn_hz, out.zeta
                fsd[s, r, m], zsd[s, r, m] = out.fn_std_hz, out.zeta_std
                A[s, r, m] = out.modal_constant
    if not fitted.any():
        raise ShapeError("circle fit: no peak has 4 lines around it; use finer lines or the lscf method")
    fn, zz, fsd, zsd, A = (a[..., fitted] for a in (fn, zz, fsd, zsd, A))
    n_m = int(fitted.sum())
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
    broad = ~(z_mode <= MAX_DAMPING)
    unresolved, peak_hz = unresolved[fitted], pk.natural_frequencies_hz[fitted]
    for which, why in ((broad & ~unresolved, "a bump of the noise, not a mode"),
                       (broad & unresolved, "its half-power band spans fewer than 2 frequency lines, so no circle "
                                            "follows it; use finer lines or the lscf method")):
        if np.any(which):
            warnings.warn("circle fit: the peak(s) at " + ", ".join(f"{x:.4g} Hz" for x in peak_hz[which])
                          + f" left out: the circles give a damping ratio above {MAX_DAMPING:g}: {why}",
                          stacklevel=2)
    if np.any(broad):
        f_mode, z_mode, f_std, z_std, A = (a[..., ~broad] for a in (f_mode, z_mode, f_std, z_std, A))
    wd = 2 * np.pi * f_mode * np.sqrt(1 - z_mode**2)
    residues = A / (2j * wd)
    return modal_estimate(f_mode, z_mode, residues, drive, "circle", f_std, z_std)


