"""What the baseline period saw: whether a later test lies beyond the baseline's measured conditions or beyond its
position in the normal model's environmental subspace (outside the convex hull of the baseline tests there: the test
is then judged by an extrapolation of the normal variation, "extrapolated"), and whether the tests after the
baseline that look healthy scatter more than the baseline tests did (a baseline period too short, or from one
session)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learn.monitor.baseline_outliers import BASELINE_OUTLIER
from learn.monitor.normal_models import FactorRemoval, PCARemoval, Regression, _cov, _impute, _mahalanobis

__all__ = ["HULL_MAX_DIM", "HULL_VERTEX_SHARE", "SCATTER_RATIO_WARN", "Coverage", "Scatter", "baseline_scatter",
           "coverage", "environment_coordinates", "outside_hull", "series_coverage"]

#: Ratio of the later healthy-looking tests' scatter to the baseline's above which the baseline period is named as
#: too narrow (a baseline that saw the normal variation gives about 1: both are held-out indices below the threshold).
SCATTER_RATIO_WARN = 1.3
#: Fewest later non-alarmed tests the scatter ratio is computed from.
MIN_LATER = 5
#: Most environment coordinates whose baseline convex hull :func:`coverage` builds (its facets grow as
#: ``n^((k - 1) / 2)``); beyond, the Mahalanobis distance stands for it.
HULL_MAX_DIM = 4
#: Largest share ``V / (m + 1)`` of the baseline's ``m`` tests that are vertices ``V`` of their convex hull at which
#: :func:`coverage` judges by the hull: a new test of the normal variation lies outside it with that probability
#: (exchangeability); a small baseline (35 tests in two coordinates: 28 to 36 %) puts a third of them outside, and
#: the ellipse of the largest held-out distance stands for the hull.
HULL_VERTEX_SHARE = 0.05
#: Rows of later tests checked against the hull's facets at a time (a (rows, facets) array).
HULL_CHUNK = 4096


@dataclass(frozen=True)
class Coverage:
    """Where each test lies against the baseline period's environment.

    Attributes
    ----------
    names : tuple of str        the environment's coordinates: the measured conditions (regression) or the normal
                                model's removed factors (``factor 1``, ...); empty when the model has none
    coordinates : ndarray (n, k)    every test's coordinates (NaN where a condition is not measured)
    low, high : ndarray (k,)     the baseline's range
    mahalanobis : ndarray (n,)   squared Mahalanobis distance of each test's coordinates from the baseline's
    mahalanobis_max : float      the largest held-out (leave-one-out) value of a baseline test (NaN for k < 2)
    extrapolated : ndarray bool (n,)    a later test beyond the range, outside the baseline's convex hull or
                                        beyond ``mahalanobis_max``
    reasons : list of str or None       why, per test
    outside_hull : ndarray bool (n,) or None    a test outside the convex hull of the baseline tests' coordinates
                                        (None where it was not built: k < 2, k > :data:`HULL_MAX_DIM`, a flat
                                        baseline)
    """

    names: tuple
    coordinates: np.ndarray
    low: np.ndarray
    high: np.ndarray
    mahalanobis: np.ndarray
    mahalanobis_max: float
    extrapolated: np.ndarray
    reasons: list
    outside_hull: np.ndarray | None = None


def environment_coordinates(model, X, C, names=()) -> tuple[tuple, np.ndarray | None]:
    """``(names, coordinates (n, k))`` of the tests in the environment the normal model learnt: the measured
    conditions for the regression, the scores on the removed principal components for ``pca`` (``factor 1``...),
    the factor scores for factor analysis; ``((), None)`` for a model without one (``pca0``, the mixture)."""

    if isinstance(model, Regression):
        return tuple(names), np.asarray(C, float)
    if isinstance(model, PCARemoval) and model.k_ > 0:
        U = model.components_[:, :model.k_]
        return tuple(f"factor {j + 1}" for j in range(model.k_)), (_impute(X, model.mean_, model.cov_)
                                                                     - model.mean_) @ U
    if isinstance(model, FactorRemoval):
        Y = (_impute(X, model.mean_, model.cov_) - model.mean_) / model.scale_
        S = model.fa_.transform(Y)
        return tuple(f"factor {j + 1}" for j in range(S.shape[1])), S
    return (), None


def _held_out_mahalanobis(E):
    """Each row's squared Mahalanobis distance from the other rows' mean and covariance (leave-one-out, in closed
    form by Sherman-Morrison: ``d_(i) = (n / (n - 1))^2 (n - 2) a / (1 - n a / (n - 1))``, ``a = d_i / (n - 1)``
    with ``d_i`` the full fit's distance)."""
    n = len(E)
    a = _mahalanobis(E - E.mean(axis=0), _cov(E)) / (n - 1)
    return (n / (n - 1)) ** 2 * (n - 2) * a / np.maximum(1 - n * a / (n - 1), 1e-12)


def outside_hull(Eb, E, max_vertex_share: float = HULL_VERTEX_SHARE) -> np.ndarray | None:
    """Whether each row of ``E`` (n, k) lies outside the convex hull of the rows of ``Eb`` (m, k) (both finite;
    the hull built in the baseline's standardised coordinates, a point on a facet inside, to a relative 1e-9);
    None when the hull is not built: ``k < 2``, ``k >`` :data:`HULL_MAX_DIM`, fewer than ``k + 2`` rows, the
    rows flat (in a subspace), or more than ``max_vertex_share`` of ``m + 1`` of them its vertices
    (:data:`HULL_VERTEX_SHARE`: the hull would flag a new test of the same law that often)."""
    from scipy.spatial import ConvexHull, QhullError  # scipy.spatial: heavy, only where a hull is built

    Eb, E = np.asarray(Eb, float), np.asarray(E, float)
    k = Eb.shape[1]
    if not 2 <= k <= HULL_MAX_DIM or len(Eb) < k + 2:
        return None
    centre, scale = Eb.mean(axis=0), Eb.std(axis=0)
    if not np.all(scale > 0):
        return None
    try:
        hull = ConvexHull((Eb - centre) / scale)
    except QhullError:
        return None
    if len(hull.vertices) > max_vertex_share * (len(Eb) + 1):
        return None
    A, b = hull.equations[:, :-1], hull.equations[:, -1]            # A x + b <= 0 inside, |A rows| = 1
    Z = (E - centre) / scale
    tol = 1e-9 * max(float(np.max(np.abs(b))), 1.0)
    out = np.zeros(len(Z), bool)
    for lo in range(0, len(Z), HULL_CHUNK):
        out[lo:lo + HULL_CHUNK] = (Z[lo:lo + HULL_CHUNK] @ A.T + b).max(axis=1) > tol
    return out


def coverage(names, E, baseline, later) -> Coverage:
    """Flag every later test whose environment coordinates ``E`` (n, k) lie beyond the baseline tests' range in any
    coordinate, or (k >= 2) outside the baseline tests' convex hull (:func:`outside_hull`: a combination the baseline
    never saw with each coordinate inside its range), or beyond the largest held-out squared Mahalanobis distance of
    a baseline test from the others (the hull's proxy where it is not built; a point beyond it lies outside the
    hull). ``baseline``, ``later``: index arrays (the baseline tests the normal model was fitted on; the tests judged
    after the baseline period).

    The hull is the baseline's coverage itself: the normal variation that the baseline period holds in a direction
    (a season's extreme with the clamp's, the shift of every mode) is bounded, and the ellipse of the largest held-out
    distance reaches beyond it wherever the baseline's environment is not elliptical (a seasonal cycle, a clamp
    re-made uniformly). A new test exchangeable with ``m`` baseline tests lies outside their hull with probability
    ``E[V] / (m + 1)``, ``V`` the vertices of the hull of ``m + 1`` (two Gaussian coordinates: 4.8 % of 200 tests;
    the simulator's environment, 3.0 % of 365, 0.12 % of 17 520); where that exceeds :data:`HULL_VERTEX_SHARE`
    the hull is not built."""
    n = len(E)
    k = E.shape[1]
    baseline, later = np.asarray(baseline, int), np.asarray(later, int)
    Eb = E[baseline]
    low, high = np.nanmin(Eb, axis=0), np.nanmax(Eb, axis=0)
    maha = np.full(n, np.nan)
    mmax = np.nan
    if k >= 2 and len(Eb) > k + 2:
        maha = _mahalanobis(E - Eb.mean(axis=0), _cov(Eb))
        mmax = float(np.max(_held_out_mahalanobis(Eb)))
    hull = None
    finite_b = np.isfinite(Eb).all(axis=1)
    finite_l = later[np.isfinite(E[later]).all(axis=1)] if later.size else later
    if k >= 2:
        outside = outside_hull(Eb[finite_b], E[finite_l])
        if outside is not None:
            hull = np.zeros(n, bool)
            hull[finite_l] = outside
    flag = np.zeros(n, bool)
    reasons = [None] * n
    for i in later:
        why = [f"{names[j]} {E[i, j]:.4g} beyond the baseline's {low[j]:.4g} to {high[j]:.4g}" for j in range(k)
               if np.isfinite(E[i, j]) and not low[j] <= E[i, j] <= high[j]]
        if not why and hull is not None and hull[i]:
            why.append(f"{' and '.join(names)} in a combination outside the baseline's convex hull (Mahalanobis "
                       f"{maha[i]:.3g}, baseline's largest held out {mmax:.3g})")
        elif not why and np.isfinite(maha[i]) and maha[i] > mmax:
            why.append(f"{' and '.join(names)} in a combination beyond the baseline's (Mahalanobis {maha[i]:.3g}, "
                       f"baseline's largest held out {mmax:.3g})")
        if why:
            flag[i] = True
            reasons[i] = "; ".join(why)
    return Coverage(tuple(names), E, low, high, maha, mmax, flag, reasons, hull)


@dataclass(frozen=True)
class Scatter:
    """The residual scatter of the later non-alarmed tests against the baseline tests'.

    Attributes
    ----------
    ratio : float or None           square root of the later non-alarmed tests' mean novelty index over the
                                    baseline's non-alarmed held-out one; None with fewer than :data:`MIN_LATER`
                                    such tests
    per_mode : list                 per mode, the ratio of their root-mean-square z-scores
    n_later : int                   later non-alarmed tests used
    baseline_days, series_days : float or None      the spans of the baseline period and of the series (times)
    warning : str or None
    """

    ratio: float | None
    per_mode: list
    n_later: int
    baseline_days: float | None
    series_days: float | None
    warning: str | None

    def to_dict(self) -> dict:
        return {"ratio": self.ratio, "per_mode": self.per_mode, "n_later": self.n_later,
                "baseline_span": self.baseline_days, "series_span": self.series_days, "warning": self.warning,
                "warn_above": SCATTER_RATIO_WARN}


def baseline_scatter(rows: list, has_times: bool = False) -> Scatter:
    """:class:`Scatter` of a monitored series' rows (``novelty``, ``mode_z_scores``, ``baseline``, ``status``,
    ``time_value``): the scatter of the later tests that look healthy (judged, no alarm) against the baseline
    tests', the square root of the ratio of their mean novelty indices (each baseline test's held out, so both are
    indices of tests the model did not see, and both without the alarms: the same truncation at the threshold), and
    per mode the ratio of their root-mean-square z-scores (the baseline's in sample: smaller out of sample after a
    latent model's removed factors, information only); a warning naming the ratio when it exceeds
    :data:`SCATTER_RATIO_WARN` (the baseline period saw less of the normal variation than the later tests show).
    With fewer than :data:`MIN_LATER` later tests that look healthy, no ratio; a warning when at least half of the
    later judged tests (and :data:`MIN_LATER`) lie beyond the baseline's conditions (``extrapolated``)."""

    def z(sel):
        Z = np.array([[np.nan if v is None else v for v in r["mode_z_scores"]] for r in sel], float)
        return Z.reshape(len(sel), -1)

    base = [r for r in rows if r["baseline"] and r["status"] == "no alarm" and r["novelty"] is not None]
    later = [r for r in rows if not r["baseline"] and r["status"] == "no alarm" and r["novelty"] is not None]
    t = np.array([r["time_value"] for r in rows], float)
    tb = np.array([r["time_value"] for r in rows if r["baseline"]], float)
    spans = (float(np.ptp(tb)), float(np.ptp(t))) if has_times and tb.size else (None, None)
    if len(later) < MIN_LATER or len(base) < 2:
        judged = [r for r in rows if not r["baseline"] and r["status"] not in ("not identified", "not judged")]
        beyond = sum(bool(r.get("extrapolated")) for r in judged)
        warning = None
        if len(judged) >= MIN_LATER and 2 * beyond >= len(judged):
            warning = (f"{len(later)} of the {len(judged)} later tests look healthy and {beyond} lie beyond the "
                       "baseline's conditions (extrapolated): the baseline period saw less of the normal variation "
                       "than the later tests show (too short, or one session), or the structure changed from the "
                       "first alarm on (docs/monitoring.md: choosing a baseline period)")
        return Scatter(None, [], len(later), *spans, warning)
    ratio = float(np.sqrt(np.mean([r["novelty"] for r in later]) / np.mean([r["novelty"] for r in base])))
    zb, zl = z(base), z(later)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_mode = np.sqrt(np.nanmean(zl**2, axis=0) / np.nanmean(zb**2, axis=0))
    warning = None
    if ratio > SCATTER_RATIO_WARN:
        span = (f"; the baseline period spans {spans[0]:.3g} of the series' {spans[1]:.3g} days"
                if spans[0] is not None else "")
        warning = (f"the {len(later)} later tests without an alarm scatter {ratio:.2f} times as much as the "
                   f"{len(base)} baseline tests about the normal model (root of the ratio of their mean novelty "
                   f"indices; z-scores mode by mode " + ", ".join(f"{v:.2f}" for v in per_mode) + f"){span}: the "
                   "baseline period saw less of the normal variation than the later tests show (too short, or one "
                   "session); alarms may be normal variation the baseline did not see (docs/monitoring.md: choosing "
                   "a baseline period)")
    return Scatter(ratio, [float(v) for v in per_mode], len(later), *spans, warning)


def series_coverage(result) -> Coverage | None:
    """:func:`coverage` of a monitored series (:class:`learn.monitor.alarms.SeriesResult`) in its normal model's
    environment (:func:`environment_coordinates`), its rows given ``extrapolated`` (bool) and
    ``extrapolated_because`` (text or None); None (and every row ``extrapolated: False``) for a model without an
    environment."""
    rows = result.rows
    judged = np.array([r["status"] not in ("not identified", "not judged", BASELINE_OUTLIER) for r in rows])
    base = np.flatnonzero(judged & np.array([r["baseline"] for r in rows]))
    later = np.flatnonzero(judged & ~np.array([r["baseline"] for r in rows]))
    C = result.series.conditions
    names, E = environment_coordinates(result.model, np.log(result.frequencies_hz), C,
                                       result.series.condition_names)
    cov = None
    if E is not None and E.shape[1] and base.size:
        E = np.where(judged[:, None], E, np.nan)
        cov = coverage(names, E, base, later)
    for i, r in enumerate(rows):
        r["extrapolated"] = bool(cov is not None and cov.extrapolated[i])
        r["extrapolated_because"] = None if cov is None else cov.reasons[i]
    return cov
