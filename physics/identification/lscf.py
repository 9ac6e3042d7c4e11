"""Poly-reference least-squares complex frequency-domain (LSCF) poles, and the automatic LSCF + LSFD
identification of FRF arrays."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from physics.errors import BeamDamageError, ConvergenceError, ShapeError
from physics.frf import check_frf_kind, convert_frf
from physics.identification.frf_band_refine import refine_frf_poles
from physics.identification.half_power import half_power_bandwidth_hz
from physics.identification.lsfd import LSFDResult, lsfd
from physics.identification.modes import ModalEstimate, checked_frf, modal_estimate
from physics.identification.poles import (MAX_DAMPING, NO_STABLE_POLE, SelectedPoles, StabilisationDiagram,
                                          select_poles, stability_status)

__all__ = ["LSCFIdentification", "clear_peak_reach_hz", "highest_order", "identify_lscf", "lscf",
           "octave_median_peaks", "octave_median_peaks_and_reach", "prominent_peaks"]


#: (frequency lines, dt, columns) -> (X, Q) of :func:`_lscf_basis`, the 4 most recent.
_LSCF_BASIS_CACHE: dict = {}


def _lscf_basis(f_hz, dt_s, n_cols, weight=None):
    """LSCF polynomial basis ``X = exp(i w dt k)`` (N, n_cols) and an orthonormal basis (2N, n_cols) of its
    real-stacked columns (Householder QR); the first ``nb`` columns of ``Q`` span the first ``nb`` of ``X``.

    The last few results are cached by the frequency lines, ``dt_s`` and ``n_cols`` (files of one layout
    share them).
    """
    key = (f_hz.tobytes(), float(dt_s), int(n_cols), None if weight is None else weight.tobytes())
    hit = _LSCF_BASIS_CACHE.get(key)
    if hit is None:
        X = np.exp(1j * np.outer(2 * np.pi * f_hz * dt_s, np.arange(n_cols)))
        if weight is not None:
            X = weight[:, None] * X
        Q, _ = np.linalg.qr(np.concatenate([X.real, X.imag], axis=0))
        hit = (X, Q)
        for a in (X, Q):
            a.setflags(write=False)
        if len(_LSCF_BASIS_CACHE) >= 4:
            _LSCF_BASIS_CACHE.pop(next(iter(_LSCF_BASIS_CACHE)))
        _LSCF_BASIS_CACHE[key] = hit
    return hit


#: Each lower sub-band of :func:`_with_refit_poles` ends at this fraction of the one above it.
SUBBAND_STEP = 0.25
#: A sub-band's pole joins the modes only where the FRF shows a peak: its magnitude at the pole this many times
#: the median magnitude of the lines within +-:data:`PEAK_WINDOW` (relative) of it.
PEAK_PROMINENCE = 3.0
PEAK_WINDOW = 0.15
#: A peak of the FRFs this many times the median of the lines within a factor :data:`CLEAR_PEAK_WINDOW` of it is one
#: a person sees (:func:`octave_median_peaks`): a noise floor's Rayleigh-distributed magnitudes exceed it with a
#: probability of 3e-8 per line.
CLEAR_PEAK_PROMINENCE = 5.0
#: The floor of a clear peak is the median of the lines within this factor of it (an octave either side). A
#: resonance's own skirt falls as ``zeta f / |f - f_r|``: over +-15 % its median is a quarter of a 2 %-damped peak,
#: so a narrower window would hide every mode damped above 1.5 %, however high it stands over the noise.
CLEAR_PEAK_WINDOW = 2.0
#: A clear peak also stands this many dB above the lowest line between it and a higher peak on either side (its
#: topographic prominence, as :data:`physics.identification.fdd.PEAK_PROMINENCE_DB`): a ripple of the noise on a
#: resonance's flank, high above the octave's median, is no peak of its own.
CLEAR_PEAK_VALLEY_DB = 6.0
#: A clear peak that no selected pole explains is fitted again over the band within the first of these factors of
#: it, then the next, until a fit places a pole within the peak's reach (:func:`clear_peak_reach_hz`). The second
#: band, +-2 %, holds every pole that may explain the peak and few neighbours: over +-25 % (and +-10 %) one model
#: spends its order on a stronger mode nearby (the pyFRF hit's 4164 Hz peak, 36 Hz above the 4128 Hz mode, gets its
#: pole over +-2 % only).
CLEAR_PEAK_BANDS = (1.25, 1.02)
#: A pole explains a clear peak within this many of the peak's own half-power bandwidths
#: (:func:`~physics.identification.half_power.half_power_bandwidth_hz`; ``2 zeta f`` for a lone light mode) ...
CLEAR_PEAK_BANDWIDTHS = 3.0
#: ... or this many frequency lines (the peak's line lies up to half a line off the resonance, and a mode narrower
#: than a line shows no measurable bandwidth), whichever is wider ...
CLEAR_PEAK_LINES = 3.0
#: ... and never farther than this relative distance: a mode damped 0.33 % or more reaches this cap (3 bandwidths of
#: ``2 zeta f``), one damped 0.05 % at 4 kHz with 1 Hz lines is explained only within 12 Hz (0.3 %) ...
CLEAR_PEAK_TOLERANCE = 0.02
#: ... unless the cap is less than this many lines: a peak's top line lies up to half a line from its resonance (a
#: line more where the noise lifts its neighbour), so a mode at 7.74 Hz on 1 Hz lines, its peak on the 8 Hz line,
#: is explained within 1.5 Hz, not 0.16 Hz (2 %).
CLEAR_PEAK_MIN_LINES = 1.5
#: A clear peak's refit (:data:`CLEAR_PEAK_BANDS`) spans at least this many lines, the nearest to the peak: a low mode
#: a few lines above the band's start has too few lines within a factor 1.25 for a model of order 4 (a first mode at
#: 7.74 Hz on 1 Hz lines: 4), and 24 lines give orders up to 11.
CLEAR_PEAK_REFIT_LINES = 24


def prominent_peaks(db, min_prominence_db: float) -> np.ndarray:
    """Indices of the local maxima of ``db`` (n,) whose topographic prominence is at least ``min_prominence_db``:
    on either side, the lowest line between the peak and the first higher line (or the end) lies that far below it
    (the definition of :func:`scipy.signal.peak_prominences`, without importing scipy.signal on the FRF path)."""
    db = np.asarray(db, float)
    top = np.flatnonzero((db[1:-1] > db[:-2]) & (db[1:-1] >= db[2:])) + 1
    keep = np.zeros(top.size, bool)
    for k, p in enumerate(top):                 # local maxima only; each side read up to its first higher line
        bases = []
        for side in (db[p - 1::-1], db[p + 1:]):
            higher = np.flatnonzero(side > db[p])
            bases.append(side[:higher[0]].min() if higher.size else side.min())
        keep[k] = db[p] - max(bases) >= min_prominence_db
    return top[keep]


def clear_peak_reach_hz(frequency_hz, magnitude, idx, tolerance: float = CLEAR_PEAK_TOLERANCE) -> np.ndarray:
    """How far (Hz) from each peak ``idx`` a pole lies that explains it: :data:`CLEAR_PEAK_BANDWIDTHS` of the peak's
    half-power bandwidths (:func:`~physics.identification.half_power.half_power_bandwidth_hz`) or
    :data:`CLEAR_PEAK_LINES` frequency lines, whichever is wider, at most ``tolerance`` (relative) of the peak's
    frequency or :data:`CLEAR_PEAK_MIN_LINES` lines, whichever is wider, shape (n,)."""
    f = np.asarray(frequency_hz, float)
    idx = np.atleast_1d(np.asarray(idx, int))
    line = np.diff(f)[np.clip(idx, 0, f.size - 2)] if f.size > 1 else np.zeros(idx.size)
    reach = np.maximum(CLEAR_PEAK_BANDWIDTHS * half_power_bandwidth_hz(f, magnitude, idx), CLEAR_PEAK_LINES * line)
    return np.minimum(reach, np.maximum(tolerance * f[idx], CLEAR_PEAK_MIN_LINES * line))


def _clear_peak_lines(f, mag) -> np.ndarray:
    """Indices of the clear peaks of :func:`octave_median_peaks`, before any is explained."""
    db = 20 * np.log10(np.maximum(mag, np.finfo(float).tiny))
    idx = prominent_peaks(db, CLEAR_PEAK_VALLEY_DB)
    idx = idx[(f[idx] > f[0] * 1.02) & (f[idx] < f[-1] / 1.02)]
    lo = np.searchsorted(f, f[idx] / CLEAR_PEAK_WINDOW, side="left")       # window [f/w, f w] of each peak
    hi = np.searchsorted(f, f[idx] * CLEAR_PEAK_WINDOW, side="right")
    floor = np.array([np.median(mag[a:b]) if b - a >= 5 else np.inf for a, b in zip(lo, hi)])
    return idx[mag[idx] >= CLEAR_PEAK_PROMINENCE * floor]


def octave_median_peaks_and_reach(frequency_hz, magnitude, known_hz=(), tolerance: float = CLEAR_PEAK_TOLERANCE):
    """The clear peaks of :func:`octave_median_peaks` and their reaches: ``(frequency_hz, reach_hz)``, each shape
    (n,), of the clear peaks with no frequency of ``known_hz`` within their reach (:func:`clear_peak_reach_hz`,
    capped at ``tolerance`` relative)."""
    f = np.asarray(frequency_hz, float)
    mag = np.asarray(magnitude, float)
    idx = _clear_peak_lines(f, mag)
    reach = clear_peak_reach_hz(f, mag, idx, tolerance)
    known = np.asarray(known_hz, float)
    if known.size and idx.size:
        keep = np.min(np.abs(known[None, :] - f[idx, None]), axis=1) > reach
        idx, reach = idx[keep], reach[keep]
    return f[idx], reach


def octave_median_peaks(frequency_hz, magnitude, known_hz=(), tolerance: float = CLEAR_PEAK_TOLERANCE) -> np.ndarray:
    """Frequencies (Hz) of plainly visible peaks of ``magnitude``: local maxima :data:`CLEAR_PEAK_PROMINENCE` times
    the median of the lines within a factor :data:`CLEAR_PEAK_WINDOW` (at least 5 lines) and
    :data:`CLEAR_PEAK_VALLEY_DB` above the valleys on either side, the band's outer 2 % left aside (a mode's skirt),
    with no frequency of ``known_hz`` within the peak's reach: :data:`CLEAR_PEAK_BANDWIDTHS` half-power bandwidths or
    :data:`CLEAR_PEAK_LINES` lines, at most ``tolerance`` (relative) or :data:`CLEAR_PEAK_MIN_LINES` lines
    (:func:`clear_peak_reach_hz`)."""
    return octave_median_peaks_and_reach(frequency_hz, magnitude, known_hz, tolerance)[0]


def visible_peak(frequency_hz, magnitude, fn_hz) -> np.ndarray:
    """Whether the FRF magnitude shows a peak at each ``fn_hz`` (prominence over the local median, batched).

    Parameters
    ----------
    frequency_hz : ndarray, shape (n_lines,)
    magnitude : ndarray, shape (n_lines,)    e.g. the RMS of ``|H|`` over responses and references
    fn_hz : ndarray, shape (n,)

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    f = np.asarray(frequency_hz, float)
    out = np.zeros(np.size(fn_hz), bool)
    for k, fn in enumerate(np.atleast_1d(fn_hz)):
        i = int(np.clip(np.searchsorted(f, fn), 1, f.size - 2))
        near = magnitude[i - 1:i + 2].max()
        window = magnitude[(f >= fn * (1 - PEAK_WINDOW)) & (f <= fn * (1 + PEAK_WINDOW))]
        out[k] = window.size >= 5 and near >= PEAK_PROMINENCE * np.median(window)
    return out


def kind_weight(frequency_hz, kind) -> np.ndarray:
    """LSCF line weight ``|w|^k / max`` that turns a receptance's residual into that of an FRF of ``kind``
    (k = 0 receptance, 1 mobility, 2 accelerance), shape (n_lines,)."""
    w = np.abs(convert_frf(np.ones(np.size(frequency_hz)), 2 * np.pi * np.asarray(frequency_hz, float), "receptance",
                           kind))
    return w / w.max()


def highest_order(n_lines, n_outputs, n_inputs) -> int:
    """Highest model order :func:`lscf` takes for ``n_lines`` lines of ``n_outputs`` x ``n_inputs`` FRFs: the one
    whose ``(order + 1) (n_inputs + 1)`` is at most ``n_lines n_outputs``."""
    return n_lines * n_outputs // (n_inputs + 1) - 1


def _refits(f, weight):
    """``(lines, line weight, highest frequency of a pole that joins)`` of each fit after the whole band's: the whole
    band weighted by ``weight`` (if given), then the sub-bands ``[f_min, f_max q^k]`` unweighted."""
    if weight is not None:
        yield np.ones(f.size, bool), weight, f[-1]
    hi = f[-1] * SUBBAND_STEP
    while hi > 4 * f[0]:
        yield f <= hi, None, hi
        hi *= SUBBAND_STEP


def _with_refit_poles(f, rec, poles, max_order, margin, select, lscf_options, weight=None):
    """``poles`` of the whole band plus the physical poles that other fits resolve.

    One z-domain model over a wide band (an accelerance over five decades, 0.3-2000 Hz) resolves its lowest modes
    poorly: their poles crowd near ``z = 1`` and a mode narrower than two lines barely weighs in the fit. A noise
    floor even in the measured kind, divided by ``w^k`` into a receptance, can swamp it from the lowest lines. So
    the whole band is fitted again weighted by ``weight`` (the measured kind's residual, :func:`kind_weight`), and
    the band ``[f_min, f_max q^k]`` (``q`` = :data:`SUBBAND_STEP`, k = 1, 2, ...) while it holds enough lines; a
    pole found there that the fits before lacked (no pole within 1 %) joins when it lies inside that band and the
    FRF shows a peak at it (:func:`visible_peak`).
    """
    n_o, n_i = rec.shape[0], rec.shape[1]
    mag = np.sqrt(np.mean(np.abs(rec) ** 2, axis=(0, 1)))
    found = [poles]
    for sel, w, hi in _refits(f, weight):
        order = min(max_order, highest_order(sel.sum(), n_o, n_i))
        if order < 4:
            break
        try:
            with warnings.catch_warnings():  # a band without a stable pole: empty clusters
                warnings.simplefilter("ignore", RuntimeWarning)
                sub = select_poles(lscf(f[sel], rec[..., sel], max_order=order, margin=margin,
                                        **{**lscf_options, "line_weight": w}), **(select or {}))
        except BeamDamageError:
            if w is None:
                break
            continue
        known = np.concatenate([p.natural_frequencies_hz for p in found])
        fn = sub.natural_frequencies_hz
        new = ((fn >= f[0]) & (fn <= hi)
               & np.all(np.abs(fn[:, None] / known[None, :] - 1) > 0.01, axis=1) & visible_peak(f, mag, fn))
        if new.any():
            found.append(_take(sub, np.nonzero(new)[0]))
    return _merged(found)


def _with_peak_poles(f, h, rec, poles, max_order, margin, select, lscf_options):
    """``poles`` plus, for each clear peak of the FRFs ``h`` (:func:`octave_median_peaks`, in the kind measured) that no
    pole explains (none within the peak's reach, :func:`clear_peak_reach_hz`: a few of its half-power bandwidths or
    lines, at most :data:`CLEAR_PEAK_TOLERANCE`), the pole nearest to it (within that reach) of an LSCF fit of the
    band within a factor of the peak, the first of :data:`CLEAR_PEAK_BANDS` whose fit has one there: one model over
    a wide band can spend its order on the many modes above a low first mode and leave that mode out, or on a
    stronger light mode 1 % from the peak and leave the peak's out. Each band holds at least the
    :data:`CLEAR_PEAK_REFIT_LINES` lines nearest to the peak (a first mode a few lines above the band's start).

    The peak itself shows the mode, so its pole needs no stability over the whole range of orders: the cluster
    nearest the peak is taken from poles stable in frequency to :data:`CLEAR_PEAK_TOLERANCE` (the few lines around
    a low, well-damped mode under a noise floor move its pole by 1-2 % from one order to the next) over at least 3
    orders (:func:`select_poles` with the peak as ``peaks_hz``), their dampings compared against at least the
    damping the lines resolve (``duration_s`` ``1 / df`` of :func:`lscf`): a mode narrower than a line has a
    damping the lines do not measure, which wanders from order to order."""
    mag = np.sqrt(np.mean(np.abs(h) ** 2, axis=(0, 1)))
    missed, reach = octave_median_peaks_and_reach(f, mag, poles.natural_frequencies_hz)
    found = [poles]
    n_o, n_i = rec.shape[0], rec.shape[1]
    duration_s = 1.0 / float(np.median(np.diff(f))) if f.size > 1 else float("inf")
    nearest = np.argsort(np.abs(f[None, :] - missed[:, None]), axis=1, kind="stable")[:, :CLEAR_PEAK_REFIT_LINES]
    for fp, tol_hz, near_lines in zip(missed, reach, nearest):
        tried = []
        for band in CLEAR_PEAK_BANDS:
            sel = (f >= fp / band) & (f <= fp * band)
            sel[near_lines] = True
            if any(np.array_equal(sel, t) for t in tried):
                continue
            tried.append(sel)
            order = min(max_order, highest_order(sel.sum(), n_o, n_i))
            if order < 4:
                break
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    sub = select_poles(lscf(f[sel], rec[..., sel], max_order=order, margin=margin,
                                        **{"duration_s": duration_s, **lscf_options}),
                                       **{**(select or {}), "min_status": 1, "freq_tol": CLEAR_PEAK_TOLERANCE,
                                          "peaks_hz": [fp], "peak_tol_hz": [tol_hz], "weak_min_count": 3})
            except BeamDamageError:
                continue
            near = np.abs(sub.natural_frequencies_hz - fp)
            if near.size and near.min() <= tol_hz:
                found.append(_take(sub, [int(np.argmin(near))]))
                break
    return _merged(found)


def _selected(diagram, select):
    """:func:`select_poles` of ``diagram``, None where no pole is stable over enough orders."""
    try:
        return select_poles(diagram, **(select or {}))
    except ConvergenceError:
        return None


def _no_poles(n_ref):
    """An empty :class:`SelectedPoles` (``n_ref`` references)."""
    z = np.zeros(0)
    return SelectedPoles(z.astype(complex), z, z, z, z, z.astype(int), np.zeros((0, n_ref), complex), z.astype(bool))


def _merged(found):
    """One set of poles, ascending in frequency, of the sets ``found`` (the first returned as it is when alone)."""
    if len(found) == 1:
        return found[0]
    poles = found[0]
    merged = type(poles)(**{k: np.concatenate([getattr(p, k) for p in found]) for k in poles.__dataclass_fields__})
    return _take(merged, np.argsort(merged.natural_frequencies_hz, kind="stable"))


def _take(poles, idx):
    return type(poles)(**{k: getattr(poles, k)[idx] for k in poles.__dataclass_fields__})


def lscf(frequency_hz, frf, max_order=40, min_order=1, freq_tol=0.01, damping_tol=0.05, mpf_tol=0.98,
         max_damping=MAX_DAMPING, margin=0.0, line_weight=None, duration_s=float("inf")):
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
    line_weight : ndarray, shape (n_lines,), optional
        Weight of each line's equation error.
    duration_s : float
        Length (s) of the record the lines resolve (``1 / df`` for lines ``df`` apart; infinite: unknown): a
        damping change is judged against at least :func:`~physics.identification.poles.damping_resolution` of it,
        by the stability status and by the selection's clusters.

    Returns
    -------
    StabilisationDiagram
    """
    f, h = checked_frf(frequency_hz, frf)
    n_o, n_i, N = h.shape
    if max_order < min_order or min_order < 1:
        raise ShapeError("lscf needs 1 <= min_order <= max_order")
    if max_order > highest_order(N, n_o, n_i):
        raise ShapeError(f"lscf: {N} lines x {n_o} responses are too few for model order {max_order} (at most "
                         f"{highest_order(N, n_o, n_i)}: a lower --max-order, a wider band or finer lines)",
                         parameter="max_order")
    dt = 1.0 / (2.0 * f[-1] * (1.0 + margin))
    P = max_order + 1
    M, C = _projected_normal_equations(f, h, dt, P, None if line_weight is None else np.asarray(line_weight, float))
    f_lo, f_hi = f[0] / (1.0 + margin), f[-1] * (1.0 + margin)
    orders, lams, mpfs = [], [], []
    for p in range(max_order, min_order - 1, -1):
        if p + 1 < P:  # add the term of basis column p + 1, dropped from the numerator at this order
            M = M + C[:, p + 1, :].T @ C[:, p + 1, :]
        poles = _denominator_poles(M, p, n_i, dt)
        if poles is None:
            continue
        lam, L = poles
        fn = np.abs(lam) / (2 * np.pi)
        zeta = -lam.real / np.abs(lam)
        keep = (lam.imag > 0) & (zeta > 0) & (zeta < max_damping) & (fn >= f_lo) & (fn <= f_hi)
        orders.append(np.full(keep.sum(), p))
        lams.append(lam[keep])
        mpfs.append(L[keep] / np.linalg.norm(L[keep], axis=1, keepdims=True))
    orders, lams, mpfs = orders[::-1], lams[::-1], mpfs[::-1]  # ascending order
    order = np.concatenate(orders)
    lam = np.concatenate(lams)
    mpf = np.concatenate(mpfs) if mpfs else np.zeros((0, n_i), complex)
    fn = np.abs(lam) / (2 * np.pi)
    zeta = -lam.real / np.abs(lam)
    status = stability_status(order, fn, zeta, mpf, freq_tol, damping_tol, mpf_tol, duration_s)
    return StabilisationDiagram(order, lam, fn, zeta, mpf, status, (float(f[0]), float(f[-1])), duration_s)


def _projected_normal_equations(f_hz, h, dt_s, n_cols, weight=None):
    """Denominator normal equations of the highest order, with the numerators eliminated.

    Order ``p`` projects ``Y`` off the first ``nb = p + 1`` columns of ``Q`` (QR, so the
    conditioning of ``X`` is not squared), then solves ``M_p alpha = 0`` with ``alpha_p = I``.
    With ``C = Q^T Y`` and ``Yperp = Y - Q C``, ``Y - Q[:, :nb] C[:nb] = Yperp + Q[:, nb:] C[nb:]``
    (orthogonal parts), so ``M_p = Yperp^T Yperp + sum_{k >= nb} C_k^T C_k`` on the first
    ``(p + 1) n_ref`` columns: a sum of positive semi-definite terms (no cancellation), all
    orders from one projection.

    Returns
    -------
    M : ndarray, shape (n_cols n_ref, n_cols n_ref)
        ``Yperp^T Yperp`` (the normal equations of order ``n_cols - 1``).
    C : ndarray, shape (n_resp, n_cols, n_cols n_ref)
        ``Q^T Y`` per response, whose rows ``C[:, k]`` add the terms of lower orders.
    """
    n_o, N, n_i = h.shape[0], h.shape[2], h.shape[1]
    X, Q = _lscf_basis(f_hz, dt_s, n_cols, weight)
    Hrow = np.transpose(h, (0, 2, 1))  # (n_o, N, n_i)
    Y = -(X[None, :, :, None] * Hrow[:, :, None, :]).reshape(n_o, N, n_cols * n_i)
    Yr = np.concatenate([Y.real, Y.imag], axis=1)  # (n_o, 2N, P n_i)
    C = np.matmul(Q.T, Yr)  # (n_o, P, P n_i)
    Yperp = Yr - np.matmul(Q, C)
    Yp2 = Yperp.reshape(-1, Yperp.shape[-1])
    return Yp2.T @ Yp2, C


def _denominator_poles(M, p, n_i, dt_s):
    """Poles (rad/s) and participation vectors (rows, not normalised) of the order-``p`` denominator.

    Solves the normal equations ``M[:(p+1) n_i, :(p+1) n_i]`` for ``alpha`` with ``alpha_p = I``;
    the poles are ``ln(z)/dt`` of the eigenvalues ``z`` of the companion matrix of
    ``sum_k z^k alpha_k^T``, the participation vectors the first ``n_i`` entries of its
    eigenvectors (left null vectors of ``A(z)``). None when the normal equations are singular.
    """
    na, m = (p + 1) * n_i, p * n_i
    Mp = M[:na, :na]
    try:
        alpha = np.linalg.solve(Mp[:m, :m], -Mp[:m, m:])  # (m, n_i)
    except np.linalg.LinAlgError:
        return None
    coeffs = alpha.reshape(p, n_i, n_i).transpose(0, 2, 1)
    comp = np.zeros((m, m))
    comp[:m - n_i, n_i:] = np.eye(m - n_i)
    comp[m - n_i:, :] = -np.concatenate(list(coeffs), axis=1)
    z, V = np.linalg.eig(comp)
    ok = np.abs(z) > 0
    return np.log(z[ok].astype(complex)) / dt_s, V[:n_i, ok].T


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

    Poles come from LSCF on the receptance (stabilisation over model orders; the whole band, again weighted as an
    FRF of ``kind``, and lower sub-bands add the poles it lacks, see :func:`_with_refit_poles`, and each clear peak
    no pole explains is fitted in its own band, see :func:`_with_peak_poles`; where no pole of the whole band is
    stable over enough orders, weighted or not, the poles are those of these fits alone),
    including stable poles up to ``margin`` outside the band; each pole inside the band is then refined by output
    error in its own narrow band of ``frf`` where the LSCF pole disagrees with that band
    (:func:`~physics.identification.frf_band_refine.refine_frf_poles`); the residues and the
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

    with threadpool_limits(1):  # small dense products and eigenproblems: one BLAS thread is fastest
        return _identify_lscf(frequency_hz, frf, n_modes, drive, max_order, select, kind, weighting, margin,
                              lscf_options)


def _identify_lscf(frequency_hz, frf, n_modes, drive, max_order, select, kind, weighting, margin, lscf_options):
    f, h = checked_frf(frequency_hz, frf)
    rec = convert_frf(h, 2 * np.pi * f, check_frf_kind(kind), "receptance")
    weight = None if "line_weight" in lscf_options or kind == "receptance" else kind_weight(f, kind)
    diagram = lscf(f, rec, max_order=max_order, margin=margin, **lscf_options)
    first = _selected(diagram, select)
    if first is None and weight is not None:
        diagram = lscf(f, rec, max_order=max_order, margin=margin, line_weight=weight, **lscf_options)
        first, weight = _selected(diagram, select), None
    poles = _with_refit_poles(f, rec, _no_poles(rec.shape[1]) if first is None else first, max_order, margin, select,
                              lscf_options, weight)
    poles = _with_peak_poles(f, h, rec, poles, max_order, margin, select, lscf_options)
    fn = poles.natural_frequencies_hz
    inside = np.nonzero((fn >= f[0]) & (fn <= f[-1]))[0]
    if inside.size == 0:
        raise ConvergenceError(NO_STABLE_POLE if first is None else
                               "no stable pole inside the band: raise max_order or widen the band")
    if n_modes is not None:
        inside = np.sort(inside[np.argsort(-poles.count[inside], kind="stable")[:n_modes]])
    outside = np.nonzero((fn < f[0]) | (fn > f[-1]))[0]
    use = np.r_[inside, outside]
    k = np.arange(inside.size)
    lam = refine_frf_poles(f, h, poles.eigenvalues[use], np.isin(np.arange(use.size), k), kind=kind).eigenvalues
    fit = lsfd(f, h, lam, kind=kind, weighting=weighting)
    fn_in, zeta_in = np.abs(lam[k]) / (2 * np.pi), -lam[k].real / np.abs(lam[k])
    est = modal_estimate(fn_in, zeta_in, fit.residues[..., k], drive, "lscf",
                    poles.frequency_std_hz[inside], poles.damping_std[inside], fit.lower_residual,
                    fit.upper_residual, fit.frequency_std_hz[k], fit.damping_std[k])
    return LSCFIdentification(est, diagram, fit, np.abs(fit.eigenvalues[inside.size:]) / (2 * np.pi))


