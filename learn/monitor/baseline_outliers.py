"""Baseline tests that are outliers of their own baseline period, named and left out of it.

With a short baseline period the threshold of a small false-alarm rate is the largest held-out index (a rate below
``1 / (n + 1)``: :func:`~learn.monitor.alarm_threshold.threshold`), so one baseline test far from the others (a
record started during the hit, a first test before the structure settled) sets it. The rule: the largest held-out
residual index of the ``n`` baseline tests (a regression's each over its own widening ``1 + h``, ``h`` its
conditions' leverage, :func:`held_out_leverage`) over the scale of the scaled F law fitted to the *other* ``n - 1``
(:func:`f_scale`; the candidate left out, so that it does not widen its own yardstick) is compared with the critical
ratio of the family-wise rate over the baseline: the ratio that outlier-free Gaussian baselines of ``n`` tests
under the fitted normal model exceed at that rate, by a seeded simulation of the same statistic
(:func:`simulated_critical_ratio`: the held-out indices of a regression on the baseline's conditions, or of a PCA
with the fitted components' variances and the same components removed, leave-one-out in closed form). Beyond it,
the test is an outlier of its baseline (:func:`largest_outlier`). It is left out, the normal model fitted again and
every remaining test's index held out again, and the rule applied again, up to :data:`OUTLIER_SHARE` of the
baseline period and never below the fewest baseline tests the model needs. Where the simulation does not apply (a
factor or mixture model, folds beyond :data:`~learn.monitor.alarm_threshold.LOO_MAX` tests, exact zeros among the
indices) the critical ratio is the law's prediction quantile at ``rate / n`` (Bonferroni).

The largest of ``n`` held-out indices is not one index of the law: the indices share their models' training tests
and the fitted scale scatters, so a Bonferroni read of the law at ``rate / n`` leaves a test out of 1.4 % (``pca``)
and 1.35 % (``regression``) of outlier-free Gaussian baselines of 15 tests at 1 % targeted (docs/monitoring.md);
the simulated ratio holds the rate for the statistic the rule reads.

Only the largest (reduced) index is a candidate in each round: the fitted scale grows with each index it is fitted
to, so a larger index has the lower leave-out threshold, and if the largest does not exceed its own none exceeds
theirs. Only the residual (the frequencies' pattern the normal variation does not produce) names an outlier: a test
far along the environment's directions (a re-made clamp, a re-placed mass) is the normal variation the baseline
period must hold, and the statistics of the environment judge it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from learn.monitor.alarm_threshold import (BISECTIONS, LOO_MAX, f_scale, held_out_pca, held_out_regression,
                                           missing_evidence, threshold, training_size)
from learn.monitor.normal_models import PCARemoval, Regression

__all__ = ["BASELINE_OUTLIER", "BISECTIONS", "OUTLIER_SHARE", "SIMULATIONS", "SIMULATION_CHUNK",
           "SIMULATION_CONFIDENCE", "SIMULATION_SEED", "BaselineOutliers", "Outlier", "candidate_ratio",
           "exclude_baseline_outliers", "f_scale", "held_out_leverage", "largest_outlier", "outlier_novelty",
           "simulated_critical_ratio"]

#: The status of a baseline test named an outlier of its baseline period and left out of it.
BASELINE_OUTLIER = "baseline outlier"
#: At most this share of the baseline period is left out as outliers (``floor``).
OUTLIER_SHARE = 0.25
#: Outlier-free Gaussian baselines drawn to read the critical ratio (:func:`simulated_critical_ratio`), in chunks of
#: this many, from this seed.
SIMULATIONS, SIMULATION_CHUNK, SIMULATION_SEED = 2000, 500, 0
#: The critical ratio's simulated exceedance is below the rate with this confidence (:func:`simulated_critical_ratio`).
SIMULATION_CONFIDENCE = 0.75


@dataclass(frozen=True)
class Outlier:
    """One baseline test named an outlier: ``index`` (position in the series), its held-out residual index
    ``novelty`` among the ``n_baseline`` baseline tests of round ``round`` (1-based), and ``threshold``, its threshold
    at the family-wise rate over them (:func:`largest_outlier`)."""

    index: int
    novelty: float
    threshold: float
    n_baseline: int
    round: int

    def to_dict(self, files=None) -> dict:
        return {"index": self.index, "file": None if files is None else str(files[self.index]),
                "held_out_novelty": self.novelty, "threshold": self.threshold, "baseline_tests": self.n_baseline,
                "round": self.round}


@dataclass(frozen=True)
class BaselineOutliers:
    """The baseline tests named outliers of their baseline period.

    ``outliers``: those named, in the order named; ``excluded``: whether they were left out of the baseline
    (``False``: kept on request, named only, the first round's alone); ``rate``: the family-wise rate over the
    baseline (each round's threshold at it); ``cap``: most tests that may be left out; ``stopped``: a test
    beyond its threshold left in because the cap or the fewest baseline tests was reached (its :class:`Outlier`), or
    None."""

    outliers: tuple
    excluded: bool
    rate: float
    cap: int
    stopped: Outlier | None = None

    @property
    def indices(self) -> list:
        return [o.index for o in self.outliers]

    def to_dict(self, files=None) -> dict:
        return {"rule": "the largest held-out residual index of the n baseline tests (a regression's over 1 + its "
                        "leverage) over the scaled F law's scale fitted to the other n - 1, beyond the ratio that "
                        "outlier-free Gaussian baselines under the fitted model exceed at the family-wise rate "
                        "(seeded simulation); left out, the model refitted and the rule applied again, at most a "
                        "quarter of the baseline period",
                "family_wise_rate": self.rate, "excluded": self.excluded, "cap": self.cap,
                "outliers": [o.to_dict(files) for o in self.outliers],
                "left_in_at_cap": None if self.stopped is None else self.stopped.to_dict(files)}

    def warning(self, files) -> str | None:
        """The warning naming the outliers (None without any)."""
        if not self.outliers and self.stopped is None:
            return None
        parts = [f"{files[o.index]} (held-out novelty {o.novelty:.4g} against {o.threshold:.4g} at "
                 f"{self.rate:g} over {o.n_baseline} baseline tests)" for o in self.outliers]
        text = ""
        if parts:
            text = (f"baseline outlier{'s' if len(parts) > 1 else ''}: {'; '.join(parts)}: "
                    + ("left out of the baseline period (status 'baseline outlier'; --keep-baseline-outliers keeps "
                       "them)" if self.excluded else "kept in the baseline period (--keep-baseline-outliers): they "
                                                         "set the threshold"))
        if self.stopped is not None:
            o = self.stopped
            text += ("; " if text else "") + (
                f"{files[o.index]} (held-out novelty {o.novelty:.4g} against {o.threshold:.4g}) lies beyond the "
                f"baseline too but is kept: at most {self.cap} tests are left out and the model needs the rest")
        return text


def held_out_leverage(conditions) -> np.ndarray:
    """Each baseline test's leverage ``h`` (n,) in the regression on its ``conditions`` (n, q) fitted on the other
    tests: ``h = a' (A' A)^-1 a`` of its row ``a = [1, c]`` against the other rows ``A``, by leave-one-out
    ``H / (1 - H)`` of the baseline's own hat-matrix diagonal ``H`` (Sherman-Morrison). Its held-out residual has
    ``(1 + h)`` times the normal variation's covariance, so its held-out index follows ``(1 + h)`` times the scaled
    F law (Hotelling's prediction region): a test of far conditions widens its own."""
    A = np.c_[np.ones(len(conditions)), np.asarray(conditions, float).reshape(len(conditions), -1)]
    H = np.einsum("ij,jk,ik->i", A, np.linalg.pinv(A.T @ A), A)
    return H / np.maximum(1.0 - H, 1e-12)


def candidate_ratio(Z, d1: float, d2: float) -> tuple:
    """``(position, ratio)`` of each row of ``Z`` (..., n): its largest index over :func:`f_scale` of the others."""
    Z = np.asarray(Z, float)
    i = np.argmax(Z, axis=-1)
    top = np.take_along_axis(Z, i[..., None], axis=-1)[..., 0]
    keep = np.arange(Z.shape[-1]) != i[..., None]
    others = Z[keep].reshape(*Z.shape[:-1], Z.shape[-1] - 1)
    return i, top / f_scale(others, d1, d2)


def simulated_critical_ratio(model, n: int, rate: float, conditions=None, draws: int | None = None,
                             seed: int = SIMULATION_SEED) -> float | None:
    """The critical ratio of the family-wise ``rate``: :func:`candidate_ratio` of the held-out residual indices
    (a regression's over ``1 + h``, :func:`held_out_leverage`) of ``draws`` outlier-free Gaussian baselines of
    ``n`` tests under ``model``'s normal variation, seeded, read at the order statistic that ``rate`` of all such
    baselines exceed at most, with :data:`SIMULATION_CONFIDENCE` (of 2000 draws at 1 %, the 17th largest: its
    exceedance is below 1 % with probability 0.78, 0.85 % on average). None when ``model`` is not a
    :class:`~learn.monitor.normal_models.PCARemoval` nor a :class:`~learn.monitor.normal_models.Regression` with its
    ``conditions`` (n, q), or ``n`` lies outside ``[4, LOO_MAX]``
    (:data:`~learn.monitor.alarm_threshold.LOO_MAX`: beyond it the held-out indices come from folds).

    The ratio is free of the normal variation's scale and orientation (a regression's residual covariance, a PCA's
    components): the regression's baselines are standard normal residuals on the baseline's conditions (their
    leverages), the PCA's are drawn with the fitted variances of its components (their spread sets how far the
    removed components' estimation leaks into the residual of a test far along them), the same ``k`` removed. The
    held-out indices are those of :func:`~learn.monitor.alarm_threshold.held_out_pca` and
    :func:`~learn.monitor.alarm_threshold.held_out_regression` (the models' own on
    complete tests)."""
    from scipy import stats  # scipy.stats: heavy, only where a threshold is read

    draws = SIMULATIONS if draws is None else int(draws)
    if n > LOO_MAX or n < 4:
        return None
    rng = np.random.default_rng(seed)
    ratios = []
    for start in range(0, draws, SIMULATION_CHUNK):
        b = min(SIMULATION_CHUNK, draws - start)
        if isinstance(model, PCARemoval):
            p, k = model.var_.size, model.k_
            X = rng.standard_normal((b, n, p)) * np.sqrt(np.maximum(model.var_, 1e-300 * model.var_.max()))
            res, h = held_out_pca(X, k)[0], 0.0
            d2 = max(n - 1 - (p - k), 1)
        elif isinstance(model, Regression) and conditions is not None:
            p = model.cov_.shape[0]
            res = held_out_regression(rng.standard_normal((b, n, p)), conditions)
            h = held_out_leverage(conditions)
            d2 = max(n - 1 - p - model.n_conditions, 1)
        else:
            return None
        ratios.append(candidate_ratio(res / (1.0 + h), model.dof_, d2)[1])
    above = max(int(stats.binom.ppf(1.0 - SIMULATION_CONFIDENCE, draws, rate)) - 1, 0)
    while above > 0 and stats.binom.cdf(above, draws, rate) > 1.0 - SIMULATION_CONFIDENCE:
        above -= 1
    return float(np.sort(np.concatenate(ratios))[draws - 1 - above])


def largest_outlier(held_out, rate: float, dof_num: int, n_conditions: int = 0, leverage=None,
                    critical=None) -> tuple:
    """``(position, its index, its threshold)`` of the largest finite held-out index of ``held_out`` (n,), each over
    its own widening ``1 + leverage`` (:func:`held_out_leverage`; None: all alike), and its threshold: the scale of
    ``F(d1, d2)`` fitted to the other indices so reduced (the degrees of freedom of
    :func:`~learn.monitor.alarm_threshold.threshold`, ``d1 = dof_num``, models fitted on
    :func:`~learn.monitor.alarm_threshold.training_size` of ``n`` tests) times ``critical`` (the ratio of the
    family-wise rate, :func:`simulated_critical_ratio`) when given (a callable returning it or None is called only
    for a candidate beyond the law's prediction quantile at ``rate`` itself, below which no family-wise ratio lies,
    that quantile the threshold returned below it; None: the law below); else times the law's quantile at ``rate / n``
    (Bonferroni) read as a prediction: the scale is estimated from ``m`` indices, so the candidate over the fitted
    scale follows ``F(d1, d2')`` with ``1 / d2' = 1 / d2 + 1 / (m d1)`` (the fitted scale's own chi-square scatter,
    ``m d1`` degrees of freedom, pooled with the law's denominator, as a Student prediction interval widens a normal
    one). The threshold returned is that times the candidate's own ``1 + leverage``; the test is an outlier when its
    index exceeds it. ``(None, nan, nan)`` with fewer than 3 finite indices."""
    from scipy import stats  # scipy.stats: heavy, only where a threshold is read

    s = np.asarray(held_out, float)
    w = np.ones(s.size) if leverage is None else 1.0 + np.asarray(leverage, float)
    z = s / w
    finite = np.flatnonzero(np.isfinite(z))
    if finite.size < 3:
        return None, math.nan, math.nan
    n = finite.size
    i = int(finite[np.argmax(z[finite])])
    others = np.delete(z, i)
    t = threshold(others, rate / n, dof_num, training_size(n), n_conditions, heavy_tails=False)
    if t.scale <= 0:                                           # a point mass at zero: the empirical threshold
        return i, float(s[i]), float(t.value * w[i])
    m = int(np.sum(np.isfinite(others))) * (1.0 - t.zero_share)
    d2 = 1.0 / (1.0 / t.dof_den + 1.0 / max(m * t.dof_num, 1.0))
    if critical is not None and t.zero_share == 0:         # t.scale: f_scale of the others
        if callable(critical):
            floor = float(stats.f.ppf(1.0 - rate, t.dof_num, d2))
            critical = critical() if z[i] > t.scale * floor else floor
        if critical is not None:
            return i, float(s[i]), float(w[i] * t.scale * critical)
    level = 1.0 - min(rate / n / max(1.0 - t.zero_share, 1e-12), 0.5)
    return i, float(s[i]), float(w[i] * t.scale * stats.f.ppf(level, t.dof_num, d2))


def exclude_baseline_outliers(fitted, b_idx, rate: float, minimum: int, n_conditions: int = 0,
                              keep: bool = False, conditions=None):
    """The baseline rows ``b_idx`` less the outliers of their baseline period (module docstring).

    ``fitted(rows)`` returns ``(model, held)``: the normal model fitted on the baseline rows ``rows`` and their
    held-out statistics (:func:`~learn.monitor.statistics.held_out_statistics`, the residual's under
    ``"residual"``). ``minimum``: fewest baseline tests the model
    needs; at most ``floor(OUTLIER_SHARE * len(b_idx))`` tests are left out. ``keep``: the first round's outlier is
    named, nothing left out. ``conditions`` (n_series, q): the regression's measured conditions (indexed as
    ``b_idx``), whose leverage widens each held-out index (:func:`held_out_leverage`) and whose design the critical
    ratio is simulated on (:func:`simulated_critical_ratio`; without them a regression's is the law's).
    Returns ``(rows, model, held, BaselineOutliers)``."""
    b_idx = np.asarray(b_idx, int)
    model, held = fitted(b_idx)
    cap = int(math.floor(OUTLIER_SHARE * b_idx.size))
    named, stopped = [], None
    rows = b_idx
    while True:
        Cr = None if conditions is None else np.asarray(conditions, float)[rows]
        lev = None if Cr is None else held_out_leverage(Cr)
        critical = partial(simulated_critical_ratio, model, rows.size, rate, Cr) \
            if isinstance(model, (PCARemoval, Regression)) else None
        pos, value, limit = largest_outlier(held["residual"][0], rate, model.dof_, n_conditions, lev, critical)
        if pos is None or not value > limit:
            break
        o = Outlier(int(rows[pos]), value, limit, int(rows.size), len(named) + 1)
        if keep:
            named.append(o)
            break
        if len(named) >= cap or rows.size - 1 < minimum:
            stopped = o
            break
        named.append(o)
        rows = np.delete(rows, pos)
        model, held = fitted(rows)
    return rows, model, held, BaselineOutliers(tuple(named), not keep, rate, cap, stopped)


def outlier_novelty(model, X, b_idx, idx, C=None) -> np.ndarray:
    """The residual index (with the missing-mode evidence) of the tests ``X[idx]`` (conditions ``C[idx]``) by
    ``model``, fitted on the baseline rows ``b_idx`` of ``X`` without them: a held-out index of each outlier left
    out."""
    X = np.asarray(X, float)
    idx = np.asarray(idx, int)
    if not idx.size:
        return np.zeros(0)
    return model.novelty(X[idx], None if C is None else C[idx]) + missing_evidence(X[idx], X[b_idx])
