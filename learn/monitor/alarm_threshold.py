"""The alarm statistics: every baseline test's novelty index by a model that did not see it (leave-one-out or
k-fold), the evidence of missing modes, and the threshold of a false-alarm rate from a scaled F law fitted to the
held-out indices."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from learn.monitor.normal_models import PCARemoval, Regression

__all__ = ["BISECTIONS", "HEAVY_DOF_MIN", "HEAVY_GRID", "HEAVY_MIN", "LOO_MAX", "N_FOLDS", "Threshold", "f_scale",
           "held_out_novelty", "held_out_pca", "held_out_regression", "minimum_baseline", "missing_evidence",
           "threshold", "training_size"]

#: Held-out indices by leave-one-out up to this many baseline tests, else by this many interleaved folds.
LOO_MAX, N_FOLDS = 200, 20
#: For a statistic of the environment the law's scale is fitted to the largest held-out indices: this share of
#: them, and at least ``TAIL_MIN`` (:func:`threshold`'s ``tail_share``).
TAIL_SHARE, TAIL_MIN = 0.25, 10
#: Held-out indices at most this share of the largest are exact zeros (a test its model predicts exactly, e.g. a
#: frequency on the same FFT line or a statistic that a test's modes leave at zero): a point mass of the statistic,
#: kept out of the law's fit (:func:`threshold`).
RESOLUTION = 1e-12
#: Fewest held-out indices above zero that the law's scale is fitted to; with fewer the threshold is their
#: empirical quantile (at least the resolution).
LAW_MIN = 3
#: The law's log scale is searched within this many e-folds of its median estimate.
LOG_SCALE_SPAN = 30.0
#: The law's denominator degrees of freedom fitted with its scale (maximum likelihood over this many values from
#: ``HEAVY_DOF_MIN`` up to the formula's, geometrically spaced) when the scale is fitted to at least ``HEAVY_MIN``
#: held-out indices: a heavier tail than Gaussian residuals give (:func:`threshold`'s ``heavy_tails``).
HEAVY_DOF_MIN, HEAVY_GRID, HEAVY_MIN = 4.0, 8, 20
#: Bisection steps of :func:`f_scale` over ``2 LOG_SCALE_SPAN`` e-folds (a relative precision below 1e-13).
BISECTIONS = 50
#: Step in the log scale of the second difference whose curvature is the fitted tail scale's information
#: (:func:`threshold`: ``scale_log_std``, its inverse square root); Gauss-Hermite nodes of :meth:`Threshold.law_at`.
SCALE_STEP, SCALE_NODES = 1e-3, 24
#: The log of the largest float: a quantile beyond it is ``inf``.
LOG_FLOAT_MAX = math.log(np.finfo(float).max)


def minimum_baseline(n_features: int, n_conditions: int = 0) -> int:
    """Fewest baseline tests for ``n_features`` features and ``n_conditions`` regressors: every held-out index
    comes from a model fitted on the others, whose residual covariance then keeps at least 4 degrees of freedom
    beyond the features (the F distribution of the index has a finite variance)."""
    return n_features + n_conditions + 6


def f_scale(Z, d1: float, d2) -> np.ndarray:
    """The maximum-likelihood scale ``c`` of ``c F(d1, d2)`` fitted to each row of ``Z`` (..., m), all above zero:
    the root of ``mean(u / (1 + u)) = d1 / (d1 + d2)``, ``u = d1 z / (d2 c)`` (the score of ``log c``), found by
    bisection on ``log c`` (vectorised over the rows, ``d2`` a number or one per row; the likelihood of
    :func:`threshold` with every index in its fit)."""
    Z = np.asarray(Z, float)
    d2 = np.asarray(d2, float)
    target = d1 / (d1 + d2)
    mid = np.log(np.median(Z, axis=-1))
    lo, hi = mid - LOG_SCALE_SPAN, mid + LOG_SCALE_SPAN
    for _ in range(BISECTIONS):
        c = 0.5 * (lo + hi)
        u = (d1 / d2)[..., None] * Z / np.exp(c)[..., None]
        high = np.mean(u / (1.0 + u), axis=-1) > target           # the scale too small
        lo, hi = np.where(high, c, lo), np.where(high, hi, c)
    return np.exp(0.5 * (lo + hi))


def _folds(n: int):
    if n <= LOO_MAX:
        return [np.array([i]) for i in range(n)]
    return [np.arange(k, n, N_FOLDS) for k in range(N_FOLDS)]


def training_size(n: int) -> int:
    """How many of ``n`` baseline tests a held-out model of :func:`held_out_novelty` is fitted on: ``n - 1`` by
    leave-one-out, else ``n - n // N_FOLDS``."""
    return n - (1 if n <= LOO_MAX else n // N_FOLDS)


def missing_evidence(X, X_train) -> np.ndarray:
    """``-2 ln P`` of each test's missing modes (NaN features of ``X``, (n, p)) under the training tests' share
    missing them (``(count + 1) / (n_train + 2)`` per mode, independent): a mode the baseline period always held adds
    ``2 ln(n_train + 2)`` to the index when a test lacks it, a mode often lost adds little. The features of the
    missing modes are filled from the others (:mod:`learn.monitor.normal_models`), so the index would otherwise
    never see a mode that a change has moved beyond its tracking tolerance."""
    miss = ~np.isfinite(np.asarray(X, float))
    train = ~np.isfinite(np.asarray(X_train, float))
    log_p = np.log((train.sum(axis=0) + 1.0) / (train.shape[0] + 2.0))        # (p,)
    return -2.0 * (miss * log_p).sum(axis=1)


def held_out_novelty(make_model, X, C=None) -> np.ndarray:
    """Every baseline test's novelty index (plus :func:`missing_evidence`) by a model fitted on the other
    baseline tests (leave-one-out up to :data:`LOO_MAX` tests, else :data:`N_FOLDS` interleaved folds): the index of
    a test is never computed by a model that saw it. Leave-one-out on complete tests of a
    :class:`~learn.monitor.normal_models.PCARemoval` with its components set, or of a
    :class:`~learn.monitor.normal_models.Regression` on ``C``: the closed forms :func:`held_out_pca` and
    :func:`held_out_regression`, the refits' indices to 1e-9."""
    X = np.asarray(X, float)
    model = make_model()
    if len(X) <= LOO_MAX and np.isfinite(X).all():
        if isinstance(model, PCARemoval) and model.k is not None:
            return held_out_pca(X, min(model.k, X.shape[1] - 1))[0]
        if isinstance(model, Regression) and C is not None:
            return held_out_regression(X, C)
    out = np.empty(len(X))
    for held in _folds(len(X)):
        train = np.setdiff1d(np.arange(len(X)), held)
        model = make_model().fit(X[train], None if C is None else C[train])
        out[held] = (model.novelty(X[held], None if C is None else C[held])
                     + missing_evidence(X[held], X[train]))
    return out


def held_out_pca(X, k: int) -> tuple:
    """``(residual, environment)`` (..., n): every test's held-out indices (leave-one-out) by a PCA of the other
    tests of ``X`` (..., n, p), complete, with ``k`` leading components removed: the squared scores on the remaining
    (environmental) components over their variances, as :class:`~learn.monitor.normal_models.PCARemoval` and
    :func:`~learn.monitor.statistics.statistics_of` give them; the other tests' mean and covariance by the
    rank-one downdate of the whole set's."""
    X = np.asarray(X, float)
    n = X.shape[-2]
    D = X - X.mean(axis=-2, keepdims=True)
    S = np.einsum("...ni,...nj->...ij", D, D)                                   # (..., p, p)
    Si = (S[..., None, :, :] - (n / (n - 1.0)) * D[..., :, None] * D[..., None, :]) / (n - 2.0)
    lam, V = np.linalg.eigh(Si)                                                  # ascending: the removed last
    scores = np.einsum("...nij,...ni->...nj", V, (n / (n - 1.0)) * D)
    sq = scores**2 / np.maximum(lam, 1e-300)
    p = X.shape[-1]
    return sq[..., :p - k].sum(axis=-1), sq[..., p - k:].sum(axis=-1)


def held_out_regression(X, conditions) -> np.ndarray:
    """Every test's held-out residual index (leave-one-out, (..., n)) by the regression of ``X`` (..., n, p),
    complete, on ``conditions`` (n, q) fitted on the other tests, as
    :class:`~learn.monitor.normal_models.Regression` gives it: the held-out error ``e / (1 - H)`` and the other
    tests' residual covariance ``(R'R - e e' / (1 - H)) / (n - 1 - (q + 1))`` (``H`` the hat-matrix diagonal)."""
    X = np.asarray(X, float)
    n = X.shape[-2]
    A = np.c_[np.ones(n), np.asarray(conditions, float).reshape(n, -1)]
    P = A @ np.linalg.pinv(A)
    H = np.diag(P)
    E = X - P @ X                                                               # (..., n, p)
    RSS = np.einsum("...ni,...nj->...ij", E, E)
    Ec = E / (1.0 - H)[:, None]
    Si = (RSS[..., None, :, :] - (E / np.sqrt(1.0 - H)[:, None])[..., :, None]
          * (E / np.sqrt(1.0 - H)[:, None])[..., None, :]) / max(n - 1 - A.shape[1], 1)
    sol = np.linalg.solve(Si, Ec[..., None])[..., 0]
    return np.einsum("...ni,...ni->...n", Ec, sol)


@dataclass(frozen=True)
class Threshold:
    """The novelty threshold of a false-alarm rate and how it was set.

    ``value = max(law_value, empirical_quantile)``: ``law_value = scale * F.ppf(1 - rate; dof_num, dof_den)``,
    the held-out indices taken to follow ``scale * F(dof_num, dof_den)`` (the exact law of a held-out squared
    Mahalanobis distance with Gaussian residuals, Hotelling's prediction region, up to the scale; ``dof_den`` the
    formula's, or lower where :func:`threshold` fitted it to a heavier tail) with the scale fitted to them (or to
    their largest share, the law truncated below) by maximum likelihood; ``empirical_quantile`` the held-out
    indices' own ``1 - rate`` quantile at the plotting position ``k / (n + 1)`` (the ``k``-th smallest of ``n``,
    interpolated linearly between ranks; the largest beyond ``n / (n + 1)``).
    ``zero_share``: the share of the held-out indices that are exact zeros (at most :data:`RESOLUTION` times the
    largest), a point mass the law is not fitted to; the law is fitted to the others and read at
    ``1 - rate / (1 - zero_share)``. With fewer than :data:`LAW_MIN` indices above zero the law is degenerate
    (``scale = law_value = 0``) and the threshold is the empirical quantile (at least the resolution, and above
    zero). ``scale_log_std``: the standard deviation of the fitted log scale when it is fitted to a tail (the
    inverse square root of the likelihood's curvature), integrated out of the law's quantile
    (:meth:`law_at`); 0 for a scale fitted to every held-out index, whose leave-one-out sum is nearly an identity.
    """

    value: float
    rate: float
    law_value: float
    scale: float
    dof_num: int
    dof_den: float
    empirical_quantile: float
    held_out_rate: float
    zero_share: float = 0.0
    scale_log_std: float = 0.0

    def law_at(self, level: float) -> float:
        """The law's ``level`` quantile, its fitted scale's uncertainty integrated out: the value ``v`` at which
        ``E[sf(v / (scale e^u))] = 1 - level`` over ``u ~ N(0, scale_log_std^2)`` (Gauss-Hermite nodes
        :data:`SCALE_NODES`); ``scale * ppf(level)`` for a scale known exactly (``scale_log_std = 0``). A plug-in
        scale fitted to few indices is exceeded more often than the rate (its error enters the tail convexly). A scale
        so uncertain that the quantile lies beyond the floats (a law of two or three values) gives ``inf``: the
        statistic cannot alarm."""
        from scipy import optimize, stats  # scipy: heavy, only where a threshold is read

        law = stats.f(self.dof_num, self.dof_den)
        plug = float(self.scale * law.ppf(level))
        if not self.scale_log_std > 0 or not plug > 0:
            return plug
        x, w = np.polynomial.hermite_e.hermegauss(SCALE_NODES)
        u, w = self.scale_log_std * x, w / w.sum()

        def excess(log_v):
            with np.errstate(over="ignore"):
                return float(np.sum(w * law.sf(np.exp(log_v - u) / self.scale))) - (1.0 - level)

        span = 10.0 * self.scale_log_std + 5.0
        while excess(math.log(plug) + span) > 0 and span < 1e3:
            span *= 2
        if excess(math.log(plug) + span) > 0:
            return math.inf
        log_v = optimize.brentq(excess, math.log(plug) - span, math.log(plug) + span, xtol=1e-10)
        return math.exp(log_v) if log_v < LOG_FLOAT_MAX else math.inf

    def to_dict(self) -> dict:
        return {"value": self.value, "false_alarm_rate": self.rate,
                "method": "the larger of a scaled F law fitted to the held-out baseline indices (maximum likelihood) "
                          "and their empirical quantile", "law_value": self.law_value, "scale": self.scale,
                "dof": [self.dof_num, self.dof_den], "scale_log_std": self.scale_log_std,
                "empirical_quantile_of_held_out": self.empirical_quantile,
                "held_out_false_alarm_rate": self.held_out_rate, "zero_share_of_held_out": self.zero_share}


def threshold(held_out, rate: float, dof_num: int, n_train: int, n_conditions: int = 0,
              tail_share: float = 1.0, side_share: float = 1.0, heavy_tails: bool = True) -> Threshold:
    """The threshold of the novelty index at false-alarm rate ``rate`` from the held-out indices of the baseline
    tests (:func:`held_out_novelty`), each from a model fitted on ``n_train`` tests.

    A small baseline period cannot give a 1 % quantile empirically (it needs 100 tests to reach it, and more to
    trust it); the F law of a held-out squared Mahalanobis distance, ``d (n+1)(n-1) / (n (n-d)) F(d, n-d)`` for
    ``d`` features and ``n`` training tests, extrapolates its tail from all of them. Its scale is fitted to the
    held-out indices (one parameter: a residual that is not Gaussian, or a model that leaves some variation,
    widens it) rather than taken from the formula. A statistic of the environment itself (its scores, a common
    shift about the baseline mean) is not Gaussian: a season or a mass re-placed within a few cm is bounded, with a
    lighter tail than a Gaussian fit to the bulk; ``tail_share < 1`` fits the scale to the largest ``tail_share``
    of the indices (at least :data:`TAIL_MIN`), the tail that the threshold extrapolates. The threshold is the
    larger of the law's and the indices' own quantile (an effect that is not linear gives a heavier tail, which
    the quantile shows). That quantile is read at the plotting position ``k / (n + 1)``: a new test exchangeable
    with ``n`` held-out indices exceeds their ``k``-th smallest with probability ``(n + 1 - k) / (n + 1)``, so the
    ``1 - rate`` quantile is exceeded with probability ``rate`` (the linear interpolation of ``np.quantile``'s
    default, at ``(k - 1) / (n - 1)``, is exceeded with ``(1 + (n - 1) rate) / (n + 1)``: 0.59 % for 0.32 % of 365
    indices, 9.5 % for 0.5 % of 10); a rate below ``1 / (n + 1)`` gets the largest index, exceeded with
    ``1 / (n + 1)``, unless the law's threshold lies above it.

    ``side_share < 1``: one side of a signed statistic (``held_out`` its squares on that side only, this share of all
    the baseline tests): the law, fitted to that side's squares (the same law as both sides' for a symmetric
    statistic), is read at ``1 - rate / side_share`` and so is their quantile, so that a test of the normal
    variation lies beyond the side's threshold with probability ``rate``.

    A scale fitted to a tail of 10-20 indices is uncertain, and a threshold read at it is exceeded more often than
    the rate (0.57 % for 0.3 % on one side of 40 Gaussian tests, tests/learn/test_monitor.py): the law is read with
    that uncertainty integrated out (:meth:`Threshold.law_at`; 0.27 %).

    ``heavy_tails``: a law fitted to every held-out index (``tail_share`` 1, or a tail that holds them all) of at
    least :data:`HEAVY_MIN` indices has its denominator degrees of freedom fitted with its scale, by maximum
    likelihood over :data:`HEAVY_GRID` values from :data:`HEAVY_DOF_MIN` up to the formula's (``dof_den`` then that
    value): identification errors that now and then misread a mode (a close pair's frequency 4 scatters off, a mode
    lost) give the held-out indices a heavier tail than Gaussian residuals, which a scale alone fits to the bulk and
    a later test then passes several times more often than the rate. Gaussian residuals keep the formula's in most
    baselines (a lower value where the likelihood prefers it: a threshold a little higher).

    Exact zeros among the held-out indices (a test its model predicts exactly) are a point mass that no scaled F
    law has (its density diverges at zero for one degree of freedom, dragging the fitted scale to zero): the law is
    fitted to the indices above zero and read at ``1 - rate / (side_share * share above zero)``, so that a test lies
    beyond the threshold with probability ``rate`` overall; with fewer than :data:`LAW_MIN` of them above zero, the
    empirical quantile (see :class:`Threshold`).
    """
    from scipy import optimize, stats  # scipy.stats/optimize: heavy, only where a threshold is fitted

    s = np.asarray(held_out, float)
    s = s[np.isfinite(s)]
    d1 = max(int(dof_num), 1)
    d2 = max(int(n_train) - d1 - int(n_conditions), 1)
    resolution = RESOLUTION * float(np.max(np.abs(s))) if s.size else 0.0
    pos = np.sort(s[s > resolution])
    positive_share = pos.size / s.size if s.size else 0.0
    level = 1 - min(rate / max(side_share, 1e-12), 0.5)
    empirical = float(np.quantile(s, level, method="weibull")) if s.size else math.nan
    if pos.size < LAW_MIN:                       # a point mass at zero: the law's scale fits to 0
        value = max(empirical, resolution, np.finfo(float).tiny) if s.size else math.inf
        return Threshold(value, rate, 0.0, 0.0, d1, d2, empirical,
                         float(side_share * np.mean(s > value)) if s.size else 0.0, 1.0 - positive_share)
    n_tail = min(pos.size, max(TAIL_MIN, int(math.ceil(tail_share * pos.size))))
    u = pos[-n_tail - 1] if n_tail < pos.size else 0.0                      # the tail: the indices above u
    tail = pos[pos.size - n_tail:]

    if u == 0:                                   # every index: the score's root (f_scale), per degrees of freedom
        heavy = heavy_tails and tail.size >= HEAVY_MIN and d2 > HEAVY_DOF_MIN
        dofs = np.geomspace(HEAVY_DOF_MIN, d2, HEAVY_GRID) if heavy else np.array([float(d2)])
        scales = f_scale(np.broadcast_to(tail, (dofs.size, tail.size)), d1, dofs)
        best = int(np.argmin(-stats.f.logpdf(tail / scales[:, None], d1, dofs[:, None]).sum(axis=1)
                             + tail.size * np.log(scales)))           # the tail's heaviness: F(d1, dof)
        if best < dofs.size - 1:
            d2 = float(dofs[best])
        log_c, log_std = math.log(scales[best]), 0.0
    else:                                        # the tail's scale: an estimate from few indices, its uncertainty
        law = stats.f(d1, d2)

        def nll(log_c):
            c = math.exp(log_c)
            return -np.sum(law.logpdf(tail / c)) + tail.size * log_c + tail.size * law.logsf(u / c)

        start = math.log(np.median(pos) / law.median())
        log_c = optimize.minimize_scalar(nll, bounds=(start - LOG_SCALE_SPAN, start + LOG_SCALE_SPAN),
                                         method="bounded").x
        h = SCALE_STEP
        information = (nll(log_c + h) - 2 * nll(log_c) + nll(log_c - h)) / h**2
        log_std = 1.0 / math.sqrt(information) if information > 0 else 0.0
    t = Threshold(math.nan, rate, math.nan, math.exp(log_c), d1, d2, empirical, math.nan, 1.0 - positive_share,
                  log_std)
    law_value = t.law_at(1 - min(rate / max(side_share * positive_share, 1e-12), 0.5))
    value = max(law_value, empirical)
    return replace(t, value=value, law_value=law_value, held_out_rate=float(side_share * np.mean(s > value)))
