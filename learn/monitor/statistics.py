"""The detector's statistics of a test against the normal variation, each judged against its own held-out baseline
distribution, combined family-wise at the chosen false-alarm rate.

:data:`STATISTICS`:

* ``residual``: the novelty index of :mod:`learn.monitor.normal_models` (the residual's squared Mahalanobis
  distance, Q/SPE-like, plus the missing-mode evidence of :func:`~learn.monitor.alarm_threshold.missing_evidence`):
  a change of the pattern of the frequencies that the normal variation does not produce;
* ``environment``: with a PCA that removes components, Hotelling's ``T^2`` of the test's scores on the removed
  (environmental) components, each scaled by its baseline variance: a change along the directions the residual
  cannot see, judged against how far the baseline period's environment went;
* ``shift``: the signed common shift, the mean relative frequency change weighted by the inverse of each mode's
  normal variance (about the conditions' prediction for the regression, about the baseline mean otherwise),
  standardised by its baseline standard deviation; its square is the index (one degree of freedom).

Each index is a squared Mahalanobis distance of some part of the residual; its threshold is
:func:`~learn.monitor.alarm_threshold.threshold` of the held-out baseline indices (a scaled F law and their empirical
quantile; for the statistics of the environment itself the law fitted to their tail) at the Šidák rate
``1 - (1 - rate)^(1/K)`` of the ``K`` statistics used, so that a test of the normal variation alarms on any of them
with probability at most ``rate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from learn.monitor.alarm_threshold import TAIL_SHARE, Threshold, _folds, missing_evidence, threshold, training_size
from learn.monitor.normal_models import PCARemoval, Regression, _impute
from datetime import datetime

__all__ = ["STATISTICS", "Detection", "detect", "environmental", "held_out_statistics", "season_warning",
           "sidak_rate", "statistics_of"]

#: The detector's statistics (module docstring).
STATISTICS = ("residual", "environment", "shift")


def sidak_rate(rate: float, k: int) -> float:
    """Per-statistic rate of ``k`` statistics whose union alarms at most at ``rate`` (exact for independent ones)."""
    return 1.0 - (1.0 - rate) ** (1.0 / max(int(k), 1))


def _inv_sqrt(cov):
    """Symmetric ``cov^(-1/2)`` (pseudo-inverse on the null space)."""
    lam, V = np.linalg.eigh(cov)
    keep = lam > 1e-12 * max(lam.max(), 1e-300)
    return (V[:, keep] / np.sqrt(lam[keep])) @ V[:, keep].T


def _centre_and_cov(model, X, C):
    """``(centre (n, p), covariance (p, p))`` the shift is measured about: the conditions' prediction and the
    residual covariance for the regression, the baseline mean and covariance for the latent models."""
    if isinstance(model, Regression):
        return model.expected(X, C), model.cov_
    return np.broadcast_to(model.mean_, X.shape), model.cov_


def statistics_of(model, X, C=None) -> dict:
    """Each statistic of :data:`STATISTICS` that ``model`` (fitted) supports for the tests ``X`` (n, p) of log
    frequencies (NaN: missing, imputed as the model does), ``{name: (index (n,), vectors (n, d) or None)}``.

    ``vectors`` are the standardised parts of the residual the index sums (its whitened coordinates), which the
    memory charts (:mod:`learn.monitor.charts`) smooth: the remaining components' scores over their standard
    deviations (PCA), the residual times ``cov^(-1/2)`` (regression), the residual over the specific standard
    deviations (factor analysis); the mixture gives none. The residual index here excludes the missing-mode evidence
    (the caller adds it against its training tests)."""
    X = np.asarray(X, float)
    out = {"residual": (model.novelty(X, C), _residual_vectors(model, X, C))}
    centre, cov = _centre_and_cov(model, X, C)
    D = _impute(X, centre, cov) - centre
    if isinstance(model, PCARemoval) and model.k_ > 0:
        sd = np.sqrt(np.maximum(model.var_[:model.k_], 1e-300))
        U = (_impute(X, model.mean_, model.cov_) - model.mean_) @ model.components_[:, :model.k_] / sd
        out["environment"] = (np.sum(U**2, axis=1), U)
    var = np.maximum(np.diag(cov), 1e-300)
    w = (1.0 / var) / np.sum(1.0 / var)
    sd_shift = math.sqrt(max(float(w @ cov @ w), 1e-300))
    z = D @ w / sd_shift
    out["shift"] = (z**2, z[:, None])
    return out


def _residual_vectors(model, X, C):
    if isinstance(model, PCARemoval):
        V = model.components_[:, model.k_:]
        return ((_impute(X, model.mean_, model.cov_) - model.mean_) @ V
                / np.sqrt(np.maximum(model.var_[model.k_:], 1e-300)))
    if isinstance(model, Regression):
        mean = model.expected(X, C)
        return (_impute(X, mean, model.cov_) - mean) @ _inv_sqrt(model.cov_)
    if hasattr(model, "fa_"):
        Y = (_impute(X, model.mean_, model.cov_) - model.mean_) / model.scale_
        R = Y - model.fa_.transform(Y) @ model.fa_.components_
        return R / np.sqrt(np.maximum(model.fa_.noise_variance_, 1e-12))
    return None


def shift_fraction(model, X, C=None) -> np.ndarray:
    """The weighted mean relative frequency change of each test (fraction, signed; ``ln f`` differences)."""
    X = np.asarray(X, float)
    centre, cov = _centre_and_cov(model, X, C)
    var = np.maximum(np.diag(cov), 1e-300)
    w = (1.0 / var) / np.sum(1.0 / var)
    return (_impute(X, centre, cov) - centre) @ w


def held_out_statistics(make_model, X, C=None) -> dict:
    """:func:`statistics_of` of every baseline test by a model fitted on the other baseline tests (the folds of
    :func:`~learn.monitor.alarm_threshold.held_out_novelty`), the residual index with its missing-mode evidence."""
    X = np.asarray(X, float)
    out: dict = {}
    for held in _folds(len(X)):
        train = np.setdiff1d(np.arange(len(X)), held)
        model = make_model().fit(X[train], None if C is None else C[train])
        stats = statistics_of(model, X[held], None if C is None else C[held])
        stats["residual"] = (stats["residual"][0] + missing_evidence(X[held], X[train]), stats["residual"][1])
        for name, (value, vec) in stats.items():
            if name not in out:
                out[name] = (np.full(len(X), np.nan),
                             None if vec is None else np.full((len(X), vec.shape[1]), np.nan))
            out[name][0][held] = value
            if vec is not None:
                out[name][1][held] = vec
    return out


@dataclass(frozen=True)
class Detection:
    """The detector's verdict on every test of a series.

    Attributes
    ----------
    names : tuple of str                  the statistics used (a subset of :data:`STATISTICS`, in that order)
    values : ndarray (n, K)               each statistic's index per test (NaN: not scored); baseline tests held out
    thresholds : tuple of Threshold       each statistic's threshold at ``rate_each``
    rate : float                          the family-wise false-alarm rate
    rate_each : float                     Šidák's per-statistic rate
    ratio : ndarray (n,)                  ``max_k values / threshold_k`` (> 1: alarm)
    alarm : ndarray of bool (n,)
    vectors : dict                        name -> (n, d) whitened coordinates (see :func:`statistics_of`)
    shift_pct : ndarray (n,)              the weighted mean relative frequency change, %
    """

    names: tuple
    values: np.ndarray
    thresholds: tuple
    rate: float
    rate_each: float
    ratio: np.ndarray
    alarm: np.ndarray
    vectors: dict
    shift_pct: np.ndarray

    def alarmed_by(self, i: int) -> list:
        """Names of the statistics above their thresholds on test ``i``."""
        return [nm for k, nm in enumerate(self.names) if self.values[i, k] > self.thresholds[k].value]

    def to_dict(self) -> dict:
        return {"statistics": list(self.names), "false_alarm_rate": self.rate,
                "rate_per_statistic": self.rate_each,
                "combination": "an alarm when any statistic exceeds its threshold at the Sidak rate "
                               "1 - (1 - rate)^(1/K) of the K statistics",
                "thresholds": {nm: t.to_dict() for nm, t in zip(self.names, self.thresholds)}}


def detect(model, make_model, X, C, b_idx, rest, rate: float, n_conditions: int = 0,
           statistics=STATISTICS, held=None) -> Detection:
    """The detector on a series: ``model`` fitted on the baseline tests ``X[b_idx]`` (``make_model()`` an unfitted
    copy for the held-out fits), the monitoring tests ``rest`` (indices) scored by it, the baseline tests held
    out (``held``: their :func:`held_out_statistics`, computed when None); every statistic of ``statistics`` that
    the model supports, thresholded at the Šidák rate of ``rate``."""
    X = np.asarray(X, float)
    n = len(X)
    Cb = None if C is None else C[b_idx]
    if held is None:
        held = held_out_statistics(make_model, X[b_idx], Cb)
    now = statistics_of(model, X[rest], None if C is None else C[rest]) if len(rest) else {}
    names = tuple(nm for nm in STATISTICS if nm in held and nm in statistics)
    each = sidak_rate(rate, len(names))
    values = np.full((n, len(names)), np.nan)
    vectors, thresholds = {}, []
    for k, nm in enumerate(names):
        hv, hvec = held[nm]
        values[b_idx, k] = hv
        if len(rest):
            values[rest, k] = now[nm][0]
        if nm == "residual" and len(rest):
            values[rest, k] += missing_evidence(X[rest], X[b_idx])
        if hvec is not None:
            vec = np.full((n, hvec.shape[1]), np.nan)
            vec[b_idx] = hvec
            if len(rest):
                vec[rest] = now[nm][1]
            vectors[nm] = vec
        dof = model.dof_ if nm == "residual" else (hvec.shape[1] if hvec is not None else 1)
        thresholds.append(threshold(hv, each, dof, training_size(len(b_idx)), n_conditions,
                                    TAIL_SHARE if environmental(model, nm) else 1.0))
    r = values / np.array([t.value for t in thresholds]) if names else np.full((n, 1), np.nan)
    ratio = np.where(np.isnan(r), -np.inf, r).max(axis=1)
    ratio[~np.isfinite(ratio)] = np.nan
    shift = np.full(n, np.nan)
    scored = np.r_[b_idx, rest].astype(int)
    shift[scored] = shift_fraction(model, X[scored], None if C is None else C[scored])
    return Detection(names, values, tuple(thresholds), rate, each, ratio, np.nan_to_num(ratio) > 1.0, vectors,
                     100 * shift)


def environmental(model, name: str) -> bool:
    """Whether statistic ``name`` of ``model`` measures the environment itself (the removed components' scores, a
    shift about the baseline mean), whose bounded distribution gets a threshold law fitted to its tail
    (:func:`~learn.monitor.alarm_threshold.threshold`'s ``tail_share``), rather than a residual about what the
    normal variation explains."""
    return name == "environment" or (name == "shift" and not isinstance(model, Regression))


#: A baseline period of dated tests shorter than this (days) does not cover the seasons.
SEASONS_DAYS = 330.0


def season_warning(times, time_values, n_baseline: int, names) -> str | None:
    """The warning for environmental statistics judged against a baseline period of dated tests (``times`` ISO
    dates, ``time_values`` days) that spans less than :data:`SEASONS_DAYS` while later tests lie beyond it: the
    seasons it did not see move the environmental scores and the shift about the baseline mean as a change would
    (None otherwise)."""

    env = [nm for nm in names if nm in ("environment", "shift")]
    if not env or times is None or not len(times) or times[0] is None:
        return None
    try:
        datetime.fromisoformat(str(times[0]).strip())
    except ValueError:
        return None
    t = np.asarray(time_values, float)
    span = float(t[n_baseline - 1] - t[0])
    if span >= SEASONS_DAYS or t[-1] - t[0] <= span:
        return None
    return (f"the baseline period spans {span:.0f} days: the {' and '.join(env)} statistics judge the environment "
            "against it, and the seasons it did not see will alarm; cover a year, give the conditions "
            "(--conditions) or leave them out (--statistics residual)")


def residual_threshold(det: Detection) -> Threshold:
    """The residual statistic's threshold within the family."""
    return det.thresholds[det.names.index("residual")]
