"""The plainest tests the monitoring benches set beside ``monitor``: alarms on the modal frequencies' relative change
from their baseline medians, beyond the baseline's own quantiles (:func:`plain_alarms`; held out on the baseline:
:func:`held_out_plain_alarms`), and the same two tests calibrated to hold a false-alarm rate: Gaussian prediction
intervals (:func:`plain_p_values`) read at the rate or at the threshold that flags as many held-out healthy tests as
another detector does (:func:`matched_threshold`, :func:`matched_alarms`: a point of their ROC curve)."""

from __future__ import annotations

import numpy as np
from scipy import special

__all__ = ["held_out_plain_alarms", "matched_alarms", "matched_threshold", "plain_alarms", "plain_p_values"]


def plain_alarms(F, n_baseline: int, rate: float, *, sides: int, method: str, sign: float = 1.0) -> dict:
    """``"plain shift"``: the mean relative change of the modes beyond the baseline's ``rate`` quantile; ``"plain per
    mode"``: any mode's relative change beyond its baseline ``rate / m`` quantile. Each bool (n,); a test without any
    frequency found alarms neither.

    ``F`` (n, m): each test's frequency (Hz) of each mode, NaN where not found; the baseline its first ``n_baseline``
    rows. The changes are multiplied by ``sign`` first (``-1``: a rise is the alarmed side). ``sides=1``: below the
    quantile; ``sides=2``: the rate split between the tails, below the ``rate / 2`` or above the ``1 - rate / 2``
    quantile (per mode ``rate / (2 m)``). ``method``: :func:`numpy.nanquantile`'s rule, ``"linear"`` or ``"weibull"``
    (the ``k``-th smallest of ``n`` at level ``k / (n + 1)``, as :func:`~learn.monitor.alarm_threshold.threshold`).
    """
    if sides not in (1, 2):
        raise ValueError(f"sides must be 1 or 2, not {sides!r}")
    F = np.asarray(F, float)
    rel = sign * (F / np.nanmedian(F[:n_baseline], axis=0) - 1.0)
    found = np.isfinite(rel).any(axis=1)
    mean = np.nanmean(np.where(found[:, None], rel, 0.0), axis=1)
    q = rate / sides
    lo, hi = np.nanquantile(mean[:n_baseline], [q, 1 - q], method=method)
    plo, phi = np.nanquantile(rel[:n_baseline], [q / F.shape[1], 1 - q / F.shape[1]], axis=0, method=method)
    with np.errstate(invalid="ignore"):
        shift, per = mean < lo, (rel < plo).any(axis=1)
        if sides == 2:
            shift |= mean > hi
            per |= (rel > phi).any(axis=1)
    return {"plain shift": found & shift, "plain per mode": found & per}


def held_out_plain_alarms(F, n_baseline: int, rate: float, **kwargs) -> dict:
    """:func:`plain_alarms` with each baseline test judged against the thresholds of the other ``n_baseline - 1``
    (the later tests against the whole baseline, as :func:`plain_alarms`): its baseline rows are out-of-sample
    false alarms. ``kwargs``: :func:`plain_alarms`' keywords."""
    F = np.asarray(F, float)
    out = plain_alarms(F, n_baseline, rate, **kwargs)
    for i in range(n_baseline):
        order = np.r_[np.delete(np.arange(n_baseline), i), i]
        one = plain_alarms(F[order], n_baseline - 1, rate, **kwargs)
        for k in out:
            out[k][i] = one[k][-1]
    return out


def _nanmean(a, axis: int) -> np.ndarray:
    """Mean over ``axis`` (kept, of length 1) of the finite values, NaN where there are none."""
    ok = np.isfinite(a)
    n = ok.sum(axis=axis, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.where(ok, a, 0.0).sum(axis=axis, keepdims=True) / n, np.nan)


def _prediction_p(x, train) -> np.ndarray:
    """Two-sided p-value of each ``x`` (..., k, m) against the Gaussian prediction interval of the columns of
    ``train`` (..., n, m; NaN ignored): ``t = (x - mean) / (s sqrt(1 + 1 / n))`` on ``t(n - 1)``; NaN where ``x``
    is NaN or a column has fewer than 2 values or none of spread."""
    n = np.isfinite(train).sum(axis=-2, keepdims=True)
    mean = _nanmean(train, axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.sqrt(np.nansum((train - mean) ** 2, axis=-2, keepdims=True) / (n - 1))
        t = (x - mean) / (s * np.sqrt(1 + 1 / n))
        p = 2 * special.stdtr(np.maximum(n - 1, 1), -np.abs(t))
    return np.where((n >= 2) & (s > 0), p, np.nan)


def _scores(x, train) -> tuple:
    """``(shift p (..., k), per-mode p (..., k))`` of log frequencies ``x`` (..., k, m) against ``train``
    (..., n, m)."""
    m = x.shape[-1]
    centre = _nanmean(train, axis=-2)
    shift = _prediction_p(_nanmean(x - centre, axis=-1), _nanmean(train - centre, axis=-1))[..., 0]
    per = _prediction_p(x, train)
    found = np.isfinite(per).any(axis=-1)
    with np.errstate(invalid="ignore"):
        low = np.where(np.isfinite(per), per, 1.0).min(axis=-1)
    return shift, np.where(found, np.minimum(1.0, m * low), np.nan)


def plain_p_values(F, n_baseline: int) -> dict:
    """The plain tests as Gaussian prediction intervals: ``"plain shift"``, the two-sided p-value of the mean over
    the modes found of ``ln f`` less its baseline mean, against the baseline's such means; ``"plain per mode"``, the
    smallest over the modes of each mode's two-sided p-value of ``ln f`` against its baseline values, times ``m``
    (Bonferroni, at most 1). Each (n,), NaN for a test without any mode found. The p-value of ``x`` against ``k``
    values of mean ``xbar`` and standard deviation ``s`` is that of ``t = (x - xbar) / (s sqrt(1 + 1 / k))`` on
    Student's ``t(k - 1)``: for a new test exchangeable with Gaussian baseline tests ``P(p < a) = a`` exactly (the
    shift; the per-mode p at most ``a``). Each baseline test is scored against the other ``n_baseline - 1``
    (held out), every later test against the whole baseline.

    ``F`` (n, m): each test's frequency (Hz) of each mode, NaN where not found; the baseline its first
    ``n_baseline`` rows."""
    x = np.log(np.asarray(F, float))
    shift, per = np.full(x.shape[0], np.nan), np.full(x.shape[0], np.nan)
    shift[n_baseline:], per[n_baseline:] = _scores(x[n_baseline:], x[:n_baseline])
    others = np.array([np.delete(np.arange(n_baseline), i) for i in range(n_baseline)]).reshape(n_baseline, -1)
    held = _scores(x[:n_baseline, None, :], x[others])
    shift[:n_baseline], per[:n_baseline] = held[0][:, 0], held[1][:, 0]
    return {"plain shift": shift, "plain per mode": per}


def matched_threshold(p, healthy, n_allowed: int) -> float:
    """The largest p-value threshold that flags at most ``n_allowed`` of the ``healthy`` tests (bool mask, (n,)):
    the ``n_allowed + 1``-th smallest healthy p-value (NaN read as 1, never flagged); ``inf`` (every finite p
    flagged) when ``n_allowed`` is at least the healthy tests with a finite p."""
    h = np.sort(np.asarray(p, float)[np.asarray(healthy, bool)])
    h = h[np.isfinite(h)]
    return float(h[n_allowed]) if n_allowed < h.size else np.inf


def matched_alarms(p, healthy, n_allowed: int) -> np.ndarray:
    """Flags ``p <`` :func:`matched_threshold` (bool, (n,); NaN never flagged)."""
    p = np.asarray(p, float)
    return np.isfinite(p) & (p < matched_threshold(p, healthy, n_allowed))
