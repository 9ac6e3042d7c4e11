"""The per-mode statistic of the detector: each mode's frequency against its own prediction interval, the largest
over the modes found, judged family-wise over them.

A change of one mode alone (a crack near one mode's curvature peak, a drift of one mode) moves one coordinate of the
features; the residual index spreads it over the remaining components' degrees of freedom and the signed shift
averages it over the modes. ``mode`` (:func:`per_mode_z`, :func:`per_mode_threshold`) reads each mode on its own:
its log frequency about what the normal model explains (for the PCA, with which the detector combines it, the
baseline mean plus the removed components' part, the environment's factors; the conditions' prediction for the
regression; the baseline mean otherwise) over that mode's standard deviation about it (the diagonal of the residual
covariance: for the PCA the remaining components' part of the baseline covariance), held out like every statistic;
the index is the largest square over the modes found. A change of one mode that the removed components do not
explain is judged against that mode's scatter about them, not against the environment's range (which, for the PCA,
the environmental ``T^2`` judges). Its threshold is a Gaussian prediction interval per mode read family-wise: the
scaled ``F(1, n_train - 1 - q)`` law (``t^2`` of a new test against ``n_train`` tests: the small-baseline
correction) fitted to every mode's held-out squares and read at ``rate / m`` (Bonferroni over the ``m`` modes
found), and at least the held-out maxima's own ``1 - rate`` quantile.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from learn.monitor.alarm_threshold import Threshold, threshold
from learn.monitor.normal_models import PCARemoval, Regression

__all__ = ["per_mode_index", "per_mode_threshold", "per_mode_z", "residual_covariance"]


def residual_covariance(model) -> np.ndarray:
    """``(m, m)`` the baseline covariance of the features about what ``model`` (fitted) explains: the residual
    covariance of the regression, the remaining components' part ``V_r diag(var_r) V_r^T`` of the PCA's, the
    baseline covariance of the other models."""
    if isinstance(model, PCARemoval):
        V = model.components_[:, model.k_:]
        return (V * model.var_[model.k_:]) @ V.T
    return model.cov_


def per_mode_z(model, X, C=None) -> np.ndarray:
    """``(n, m)`` each test's log frequency of each mode about what the model explains (the conditions' prediction
    for the regression, the mean plus the removed components' part for the PCA, the baseline mean otherwise) over
    the mode's standard deviation about it (the square root of the diagonal of :func:`residual_covariance`); NaN
    where the test lacks the mode. ``X`` (n, m) log frequencies, ``model`` fitted."""
    X = np.asarray(X, float)
    if isinstance(model, Regression):
        centre = model.expected(X, C)
    elif isinstance(model, PCARemoval):
        centre = model.expected(X)
    else:
        centre = np.broadcast_to(model.mean_, X.shape)
    sd = np.sqrt(np.maximum(np.diag(residual_covariance(model)), 1e-300))
    return (X - centre) / sd


def per_mode_index(Z) -> np.ndarray:
    """``(n,)`` the largest ``z^2`` over the modes found of each row of ``Z`` (n, m) (0 where none is)."""
    Z = np.asarray(Z, float)
    sq = np.where(np.isfinite(Z), Z**2, -np.inf).max(axis=1) if Z.shape[1] else np.full(len(Z), -np.inf)
    return np.where(np.isfinite(sq), sq, 0.0)


def per_mode_threshold(Z_held, rate: float, n_train: int, n_conditions: int = 0, tail_share: float = 1.0,
                       heavy_tails: bool = True) -> Threshold:
    """The per-mode index's threshold at ``rate`` from the baseline's held-out ``Z_held`` (n, m) of
    :func:`per_mode_z`: the scaled ``F(1, n_train - 1 - n_conditions)`` law fitted to every finite held-out ``z^2``
    (:func:`~learn.monitor.alarm_threshold.threshold`) read at ``rate / m`` for the ``m`` modes judged (Bonferroni:
    a test of the normal variation exceeds it on any of them with probability at most ``rate``), and at least the
    held-out maxima's ``1 - rate`` quantile (plotting position). A mode no held-out test holds (dropped for a set of
    modes found) is not judged; ``tail_share``: as :func:`~learn.monitor.alarm_threshold.threshold`'s (the law
    fitted to the largest squares, for a statistic of the environment itself) and ``heavy_tails`` (the law's
    denominator degrees of freedom fitted with its scale) as its."""
    Z = np.asarray(Z_held, float)
    Z = Z[:, np.isfinite(Z).any(axis=0)]
    Z = Z[np.isfinite(Z).any(axis=1)]
    m = max(Z.shape[1], 1)
    t = threshold((Z[np.isfinite(Z)] ** 2), rate / m, 1, n_train, n_conditions, tail_share, heavy_tails=heavy_tails)
    maxima = per_mode_index(Z)
    empirical = float(np.quantile(maxima, 1 - rate, method="weibull")) if maxima.size else t.empirical_quantile
    value = max(t.law_value, empirical)
    return replace(t, value=value, rate=rate, empirical_quantile=empirical,
                   held_out_rate=float(np.mean(maxima > value)) if maxima.size else 0.0)
