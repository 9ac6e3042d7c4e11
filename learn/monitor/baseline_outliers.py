"""Baseline tests that are outliers of their own baseline period, named and left out of it.

With a short baseline period the threshold of a small false-alarm rate is the largest held-out index (a rate below
``1 / (n + 1)``: :func:`~learn.monitor.alarm_threshold.threshold`), so one baseline test far from the others (a
record started during the hit, a first test before the structure settled) sets it. The rule: the largest held-out
residual index of the ``n`` baseline tests is compared with the threshold of the family-wise rate over the baseline,
``rate / n`` (Bonferroni), of the scaled F law fitted to the *other* ``n - 1`` indices (the candidate left out, so
that it does not widen its own yardstick), read as a prediction from a scale fitted to ``n - 1`` indices
(:func:`largest_outlier`); beyond it, the test is an outlier of its baseline. It is left out, the
normal model fitted again and every remaining test's index held out again, and the rule applied again, up to
:data:`OUTLIER_SHARE` of the baseline period and never below the fewest baseline tests the model needs.

Only the largest index is a candidate in each round: the fitted scale grows with each index it is fitted to, so a
larger index has the lower leave-out threshold, and if the largest does not exceed its own none exceeds theirs. Only
the residual (the frequencies' pattern the normal variation does not produce) names an outlier: a test far along
the environment's directions (a re-made clamp, a re-placed mass) is the normal variation the baseline period must
hold, and the statistics of the environment judge it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from learn.monitor.alarm_threshold import missing_evidence, threshold, training_size

__all__ = ["BASELINE_OUTLIER", "OUTLIER_SHARE", "BaselineOutliers", "Outlier", "exclude_baseline_outliers",
           "largest_outlier", "outlier_novelty"]

#: The status of a baseline test named an outlier of its baseline period and left out of it.
BASELINE_OUTLIER = "baseline outlier"
#: At most this share of the baseline period is left out as outliers (``floor``).
OUTLIER_SHARE = 0.25


@dataclass(frozen=True)
class Outlier:
    """One baseline test named an outlier: ``index`` (position in the series), its held-out residual index
    ``novelty`` among the ``n_baseline`` baseline tests of round ``round`` (1-based), and ``threshold``, the threshold
    at ``rate / n_baseline`` of the law fitted to the other held-out indices."""

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
    baseline (each round's threshold at ``rate / n``); ``cap``: most tests that may be left out; ``stopped``: a test
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
        return {"rule": "the largest held-out residual index of the n baseline tests beyond the threshold at rate / n "
                        "of the scaled F law fitted to the other n - 1 (Bonferroni over the baseline); left out, the "
                        "model refitted and the rule applied again, at most a quarter of the baseline period",
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


def largest_outlier(held_out, rate: float, dof_num: int, n_conditions: int = 0) -> tuple:
    """``(position, its index, its threshold)`` of the largest finite held-out index of ``held_out`` (n,) and the
    threshold at ``rate / n`` of the scaled F law fitted to the other indices (the scale and the degrees of freedom
    ``(d1, d2)`` of :func:`~learn.monitor.alarm_threshold.threshold`, ``dof_num`` the index's, models fitted on
    :func:`~learn.monitor.alarm_threshold.training_size` of ``n`` tests), read as a prediction: the scale is
    estimated from ``m`` indices, so the candidate over the fitted scale follows ``F(d1, d2')`` with ``1 / d2' =
    1 / d2 + 1 / (m d1)`` (the fitted scale's own chi-square scatter, ``m d1`` degrees of freedom, pooled with the
    law's denominator, as a Student prediction interval widens a normal one); the test is an outlier when its index
    exceeds that threshold. ``(None, nan, nan)`` with fewer than 3 finite indices."""
    from scipy import stats  # scipy.stats: heavy, only where a threshold is read

    s = np.asarray(held_out, float)
    finite = np.flatnonzero(np.isfinite(s))
    if finite.size < 3:
        return None, math.nan, math.nan
    n = finite.size
    i = int(finite[np.argmax(s[finite])])
    others = np.delete(s, i)
    t = threshold(others, rate / n, dof_num, training_size(n), n_conditions)
    if t.scale <= 0:                                           # a point mass at zero: the empirical threshold
        return i, float(s[i]), float(t.value)
    m = int(np.sum(np.isfinite(others))) * (1.0 - t.zero_share)
    d2 = 1.0 / (1.0 / t.dof_den + 1.0 / max(m * t.dof_num, 1.0))
    level = 1.0 - min(rate / n / max(1.0 - t.zero_share, 1e-12), 0.5)
    return i, float(s[i]), float(t.scale * stats.f.ppf(level, t.dof_num, d2))


def exclude_baseline_outliers(fitted, b_idx, rate: float, minimum: int, n_conditions: int = 0,
                              keep: bool = False):
    """The baseline rows ``b_idx`` less the outliers of their baseline period (module docstring).

    ``fitted(rows)`` returns ``(model, held)``: the normal model fitted on the baseline rows ``rows`` and their
    held-out statistics (:func:`~learn.monitor.statistics.held_out_statistics`, the residual's under
    ``"residual"``). ``minimum``: fewest baseline tests the model
    needs; at most ``floor(OUTLIER_SHARE * len(b_idx))`` tests are left out. ``keep``: the first round's outlier is
    named, nothing left out. Returns ``(rows, model, held, BaselineOutliers)``."""
    b_idx = np.asarray(b_idx, int)
    model, held = fitted(b_idx)
    cap = int(math.floor(OUTLIER_SHARE * b_idx.size))
    named, stopped = [], None
    rows = b_idx
    while True:
        pos, value, limit = largest_outlier(held["residual"][0], rate, model.dof_, n_conditions)
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
