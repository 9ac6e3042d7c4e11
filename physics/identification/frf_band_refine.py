"""Narrow-band refinement of FRF poles: each mode, with the modes close to it, fitted by output error in its own
band of the FRFs.

A model of a wide band (LSCF's z-domain polynomials over thousands of lines) places a mode's pole by an equation
error: the denominator times the FRF less the numerator, weighted by the denominator's magnitude, which the other
modes of the band shape too. A weak mode beside a strong one, or one of a few lines among thousands, comes out of
it biased by a fraction of its half-power width, a bias that changes from test to test with the noise (the pyFRF
hammer hits' 4128 Hz mode, 36 Hz below a lightly damped 4164 Hz one: 4 Hz low and 0.4-1.2 Hz of scatter over five
hits, where the FFT peak of the same records scatters 0.04 Hz).

Here each group of close poles is fitted again where the FRFs show it, by the FRFs' own model: in its band, every
FRF ``k`` of kind power ``p`` (0 receptance, 1 mobility, 2 accelerance) is

    H_k(w) = (i w)^p sum_j [R_jk / (i w - lambda_j) + conj(R_jk) / (i w - conj(lambda_j))] + P_k(w),

the sum over the group's poles (common to the FRFs), ``R_jk`` the residues (:func:`~physics.identification.lsfd.lsfd`'s
convention) and ``P_k`` a complex polynomial of order :data:`BACKGROUND_ORDER` in frequency across the band: what the
modes outside the group leave after their own terms are subtracted (their residues from an LSFD fit of the whole
band) and the smooth part a discrete record adds to the continuous kernel (a truncated impulse response's transform
on its own lines is ``c / (1 - exp((lambda - i w) dt))``, the kernel above plus a level and terms of order
``(w - Im lambda) dt``). Residues and background enter linearly and are projected out (variable projection); the
poles are refined by Levenberg-Marquardt steps
(:func:`~physics.identification.damped_sinusoids.levenberg_marquardt`), each FRF weighted by the inverse of its
residual's standard deviation in the band.

The bands and groups are those of :func:`~physics.identification.band_refine.mode_bands` with the record length
``1 / df`` of the FRF lines: :data:`~physics.identification.band_refine.BAND_WIDTHS` half-power half-widths
``sigma / (2 pi)`` of the mode either side, at least :data:`~physics.identification.band_refine.BAND_LINES` lines,
and modes every two of whose bands, grown by :data:`~physics.identification.band_refine.MERGE_FACTOR`, overlap
fitted together in the union of their bands (a strong neighbour that close is no smooth background: both poles are
fitted, each with its residues). A chain of such pairs is not one group (``mode_bands(..., chains=False)``): a weak
mode close to two strong ones that are not close to each other joins the nearer, and the farther is fitted in its
own band, the group's terms subtracted as every outside pole's are; one band over the chain would stretch one
linear background over modes that are no neighbours (on the pyFRF hit 1, a weak 823.6 Hz mode chains 810 and
851 Hz: one fit over 802-860 Hz gives 851.63 Hz against 851.55-851.57 Hz on the other hits; 851 Hz alone in its
band, 851.58 Hz). The bands are swept :data:`SWEEPS` times, from the second on those of the refined poles; before each
sweep the residues of every pole are fitted again over the whole band (LSFD, the poles of the sweep before),
so each band subtracts its outside modes at their refined poles. A group is fitted only where its band is narrow
beside its frequency (:data:`MAX_RELATIVE_HALF_WIDTH`). A group's fit that fails (singular: two poles on one peak;
a pole that leaves its band, stops decaying or moves farther from its start than :data:`MAX_SHIFT_BANDWIDTHS` and
:data:`MAX_SHIFT_LINES` allow) keeps its starting poles (:attr:`FRFBandFit.converged` False).

``s^2 (J^T J)^-1`` of the projected Jacobian is the covariance of the poles (residues and background unknown). A
starting pole within its refined pole's three-sigma region (:data:`CONSISTENT_CHI2`) is kept: where the model of
the whole band holds, its fit of every line is the more precise; outside, the refined pole replaces it
(:attr:`FRFBandFit.moved`), with the start's decay rate where that one alone agrees (:data:`CONSISTENT_STDS`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.frf import FRF_KINDS, check_frf_kind
from physics.identification.band_refine import mode_bands
from physics.identification.damped_sinusoids import levenberg_marquardt, pole_statistics
from physics.identification.lsfd import lsfd, lsfd_basis
from physics.identification.modes import checked_frf

__all__ = ["BACKGROUND_ORDER", "CONSISTENT_CHI2", "CONSISTENT_STDS", "MAX_RELATIVE_HALF_WIDTH", "MAX_SHIFT_BANDWIDTHS",
           "MAX_SHIFT_LINES", "SWEEPS", "FRFBandFit", "refine_frf_poles"]

#: Order of the complex polynomial in frequency that models each FRF's background across a band: a level and a
#: slope (with a curvature too, the beam-5 bench's 352 Hz mode, well modelled by the whole band, has an RMS damping
#: error of 0.18 % against 0.13 % over 10 seeds).
BACKGROUND_ORDER = 1
#: Sweeps over the bands; each after an LSFD fit of the residues of every pole over the whole band.
SWEEPS = 2
#: A refined pole lies within this many half-power bandwidths ``2 sigma / (2 pi)`` (its own or its starting pole's,
#: the wider) of its starting pole, or this many lines, whichever is wider: it refines the peak its starting pole
#: explains (:func:`~physics.identification.lscf.clear_peak_reach_hz`'s reach), it does not move to another.
MAX_SHIFT_BANDWIDTHS, MAX_SHIFT_LINES = 3.0, 3.0
#: A group is refined only where its band is narrow beside its frequency: half the band's width at most this fraction
#: of its centre (a mode damped up to ``0.1 / BAND_WIDTHS``, 1.7 %). Over a wider band the outside modes' remainder
#: is no polynomial of low order and the band's fit pulls a heavily damped pole.
MAX_RELATIVE_HALF_WIDTH = 0.1
#: A starting pole whose squared Mahalanobis distance from its refined pole (the refit's covariance of
#: ``(sigma, omega)``) is below this (chi-square of 2 degrees of freedom at 99.73 %: three sigma) agrees with its band
#: and is kept: fitted with every line of the whole band, it is the more precise where the model of the whole band
#: holds (the narrow band's fit has a background of its own). Farther, the start is biased and the refined pole
#: replaces it, its decay rate only where the start's lies more than :data:`CONSISTENT_STDS` standard deviations from
#: the refined one (a start off in frequency alone keeps its damping).
CONSISTENT_CHI2 = 11.83
CONSISTENT_STDS = 3.0


@dataclass(frozen=True)
class FRFBandFit:
    """Poles refined in their bands of the FRFs (see the module docstring).

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_poles,)
        ``-sigma + i omega`` (rad/s), in the order given; the starting pole where not :attr:`moved`.
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_poles,)
    frequency_std_hz, damping_std : ndarray, shape (n_poles,)
        One sigma from each group's covariance (NaN where not refined or not converged).
    bands_hz : ndarray, shape (n_poles, 2)
        The band each pole was fitted in (its group's; NaN where not refined).
    group : ndarray of int, shape (n_poles,)
        The group each pole was fitted with (-1 where not refined).
    converged : ndarray of bool, shape (n_poles,)
        True where the last sweep's fit of the pole's group succeeded.
    moved : ndarray of bool, shape (n_poles,)
        True where the refined pole replaced the starting one (converged, the start outside its confidence region,
        :data:`CONSISTENT_CHI2`; its decay rate only where the start's is off by :data:`CONSISTENT_STDS`);
        elsewhere :attr:`eigenvalues` holds the starting pole.
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    bands_hz: np.ndarray
    group: np.ndarray
    converged: np.ndarray
    moved: np.ndarray


def _columns(iw, sigma, omega, power, order):
    """Real-stacked basis (2L, 2m + 2(order+1)) and its pole derivatives (2L, 2 (sigma, omega), m, 2 (column)):
    per pole the columns of ``Re R`` and ``Im R``, then the background's powers of the band's relative frequency."""
    lam = -sigma + 1j * omega
    g = 1.0 / (iw[:, None] - lam[None, :])
    gc = 1.0 / (iw[:, None] - np.conj(lam)[None, :])
    s = (iw ** power)[:, None]
    a, b = s * (g + gc), s * 1j * (g - gc)
    dg, dgc = s * g ** 2, s * gc ** 2                     # d/d lambda, d/d conj(lambda)
    da_ds, da_dw = -(dg + dgc), 1j * (dg - dgc)
    db_ds, db_dw = 1j * (-dg + dgc), -(dg + dgc)
    w = iw.imag
    x = (w - 0.5 * (w[0] + w[-1])) / max(0.5 * (w[-1] - w[0]), np.finfo(float).tiny)
    powers = x[:, None] ** np.arange(order + 1)
    cols = np.concatenate([np.stack([a, b], axis=2).reshape(a.shape[0], -1), powers, 1j * powers], axis=1)
    d = np.stack([np.stack([da_ds, db_ds], axis=2), np.stack([da_dw, db_dw], axis=2)], axis=1)   # (L, 2, m, 2)
    return np.concatenate([cols.real, cols.imag], axis=0), np.concatenate([d.real, d.imag], axis=0)


def _projected(iw, Y, sigma, omega, weights, power, order):
    """Residuals, coefficients and Kaufman Jacobian (one block each, as
    :func:`~physics.identification.damped_sinusoids.levenberg_marquardt` takes them) of the FRFs ``Y``
    (n_frf, L) on the band's lines ``iw``, each FRF weighted by ``weights`` (n_frf,)."""
    m = sigma.size
    Phi, dPhi = _columns(iw, sigma, omega, power, order)
    Yr = np.concatenate([Y.T.real, Y.T.imag], axis=0) * weights[None, :]           # (2L, n_frf)
    norm = np.maximum(np.linalg.norm(Phi, axis=0), np.finfo(float).tiny)
    G_inv = np.linalg.pinv((Phi.T @ Phi) / np.outer(norm, norm), hermitian=True) / np.outer(norm, norm)
    C = G_inv @ (Phi.T @ Yr)                                                        # (p, n_frf)
    R = Yr - Phi @ C
    Cm = C[:2 * m].reshape(m, 2, -1)
    D = np.einsum("eqmc,mch->eqmh", dPhi, Cm).reshape(Phi.shape[0], 2 * m, -1)      # (2L, 2m, n_frf)
    D = D - np.einsum("ek,kph->eph", Phi, np.einsum("kl,el,eph->kph", G_inv, Phi, D, optimize=True))
    return [R], [C], [D.transpose(0, 2, 1).reshape(-1, 2 * m)]


def _fit_group(iw, Y, lam, origin, band_rad_s, line_hz, power, order):
    """``(sigma, omega, covariance)`` of the group's poles fitted to ``Y`` (n_frf, L) from ``lam``, or None where
    the band holds too few lines or the fit fails (singular, or a pole left the band, stopped decaying or moved
    farther from its ``origin`` than :data:`MAX_SHIFT_BANDWIDTHS` and :data:`MAX_SHIFT_LINES` allow)."""
    n_frf, n_lines = Y.shape
    n_values = 2 * n_lines * n_frf
    n_params = 2 * lam.size + n_frf * (2 * lam.size + 2 * (order + 1))
    if n_values <= 2 * n_params:
        return None
    try:
        sigma, omega, cov, *_ = levenberg_marquardt(
            lambda s, w, wt: _projected(iw, Y, s, w, wt, power, order), -lam.real, lam.imag, n_frf, n_values,
            n_params, decaying=True)
    except (ConvergenceError, np.linalg.LinAlgError):
        return None
    reach = np.maximum(MAX_SHIFT_BANDWIDTHS * 2 * np.maximum(sigma, -origin.real),
                       MAX_SHIFT_LINES * 2 * np.pi * line_hz)
    if np.any(sigma <= 0) or np.any(omega < band_rad_s[0]) or np.any(omega > band_rad_s[1]) \
            or np.any(np.abs(omega - origin.imag) > reach) or not np.all(np.isfinite(cov)):
        return None
    return sigma, omega, cov


def refine_frf_poles(frequency_hz, frf, eigenvalues, refine=None, *, kind="receptance",
                     background_order=BACKGROUND_ORDER) -> FRFBandFit:
    """Refine FRF poles, each group of close poles in its own band of the FRFs (see the module docstring).

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,), > 0, equally spaced
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        FRFs of kind ``kind`` (SI units).
    eigenvalues : array_like, complex, shape (n_poles,)
        Every pole of the model (``-sigma + i omega``, rad/s, Im > 0, Re < 0): those refined and those held fixed
        (their residues fitted, their terms subtracted from the bands).
    refine : array_like of bool, shape (n_poles,), optional
        The poles to refine (default: those inside the band of the lines).
    kind : {"receptance", "mobility", "accelerance"}
    background_order : int

    Returns
    -------
    FRFBandFit

    Raises
    ------
    ShapeError
        ``refine`` of another shape than the poles, or poles not decaying.
    """
    f, h = checked_frf(frequency_hz, frf)
    power = FRF_KINDS.index(check_frf_kind(kind))
    lam0 = np.asarray(eigenvalues, complex).ravel()
    if np.any(lam0.real >= 0) or np.any(lam0.imag <= 0):
        raise ShapeError("refine_frf_poles: poles must decay (Re < 0) and be given with Im > 0")
    fn0 = np.abs(lam0) / (2 * np.pi)
    todo = (fn0 >= f[0]) & (fn0 <= f[-1]) if refine is None else np.asarray(refine, bool)
    if todo.shape != lam0.shape:
        raise ShapeError(f"refine has shape {todo.shape}; expected {lam0.shape} (one flag per pole)")
    m_all = lam0.size
    lam = lam0.copy()
    f_std, z_std = np.full(m_all, np.nan), np.full(m_all, np.nan)
    bands = np.full((m_all, 2), np.nan)
    group = np.full(m_all, -1)
    converged = np.zeros(m_all, bool)
    off_pole, off_sigma = np.zeros(m_all, bool), np.zeros(m_all, bool)
    idx_todo = np.flatnonzero(todo)
    if idx_todo.size == 0 or f.size < 2:
        return _result(lam, f_std, z_std, bands, group, converged, converged)
    df = float(np.median(np.diff(f)))
    iw_all = 2j * np.pi * f
    hk = h.reshape(-1, f.size)
    for _ in range(SWEEPS):                             # from the second on, the bands of the refined poles
        b, g = mode_bands(np.where(converged, lam, lam0)[idx_todo], 1.0 / df, f[-1], chains=False)
        bands[idx_todo] = np.clip(b, f[0], f[-1])
        group[idx_todo] = g
        fit = lsfd(f, h, lam, kind=kind, weighting="estimated")
        R = fit.residues.reshape(-1, m_all)
        rest = hk - fit.synthesised.reshape(hk.shape)     # the data less the whole model; a group's terms added back
        new = lam.copy()
        converged[:] = False
        for k in np.unique(g):
            idx = idx_todo[g == k]
            band = bands[idx[0]]
            if band[1] - band[0] > MAX_RELATIVE_HALF_WIDTH * (band[0] + band[1]):
                continue
            sel = (f >= band[0]) & (f <= band[1])
            basis = lsfd_basis(iw_all[sel], lam[idx], power, False, False)     # the group's modal terms
            Y = rest[:, sel] + np.concatenate([R[:, idx].real, R[:, idx].imag], axis=1) @ basis.T
            fitted = _fit_group(iw_all[sel], Y, lam[idx], lam0[idx], 2 * np.pi * band, df, power, background_order)
            if fitted is None:
                continue
            sigma, omega, cov = fitted
            _, _, f_std[idx], z_std[idx] = pole_statistics(sigma, omega, cov)
            new[idx] = -sigma + 1j * omega
            converged[idx] = True
            m = idx.size
            d = np.stack([-lam0[idx].real - sigma, lam0[idx].imag - omega], axis=1)      # (m, 2)
            blocks = cov.reshape(2, m, 2, m)                                    # (sigma|omega, pole, ...)
            c2 = blocks[:, np.arange(m), :, np.arange(m)]                       # (m, 2, 2): each pole's block
            try:
                off_pole[idx] = np.einsum("mi,mi->m", d, np.linalg.solve(c2, d[:, :, None])[:, :, 0]) > CONSISTENT_CHI2
            except np.linalg.LinAlgError:
                off_pole[idx] = True
            off_sigma[idx] = np.abs(d[:, 0]) > CONSISTENT_STDS * np.sqrt(np.maximum(c2[:, 0, 0], 0.0))
        lam = new
    f_std[~converged], z_std[~converged] = np.nan, np.nan
    moved = converged & off_pole
    lam = np.where(moved & off_sigma, lam.real, lam0.real) + 1j * np.where(moved, lam.imag, lam0.imag)
    return _result(lam, f_std, z_std, bands, group, converged, moved)


def _result(lam, f_std, z_std, bands, group, converged, moved) -> FRFBandFit:
    wn = np.abs(lam)
    return FRFBandFit(lam, wn / (2 * np.pi), -lam.real / wn, f_std, z_std, bands, group, converged, moved)
