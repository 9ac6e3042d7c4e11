"""A trend within the baseline period.

The normal model learns the baseline period's variation as normal. When the modes drift through that period (wear,
damage that has already begun, a structure settling after assembly), the drift's direction is learnt as an
environmental factor and a later change that continues it reads as normal variation. :func:`baseline_trend` tests
each mode's baseline frequencies for a monotone course over the tests: Spearman's rank correlation with the test's
position, two-sided, at ``rate / m`` (Bonferroni over the ``m`` modes), and a size of at least :data:`MIN_SIZE_SD`
of the mode's baseline standard deviation between the medians of the first and the last third of the period (noise
has no such size). A season is a course within the period too: without measured conditions a baseline period of
dated tests that spans a year is not tested (its seasons would read as a trend wherever the year begins); with them
the residuals about the conditions' prediction are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MIN_SIZE_SD", "MIN_TESTS", "TREND_RATE", "Trend", "baseline_trend", "series_baseline_trend"]

#: Family-wise level of the trend test over the modes.
TREND_RATE = 0.01
#: Smallest drift reported, in baseline standard deviations of the mode (last third's median less the first's).
MIN_SIZE_SD = 1.0
#: Fewest baseline tests holding a mode for its trend to be tested (three per third).
MIN_TESTS = 9


@dataclass(frozen=True)
class Trend:
    """Each mode's course over the baseline period.

    Attributes
    ----------
    rho : list of float or None         Spearman's rank correlation of the mode with the test's position
    p_value : list of float or None     its two-sided p-value
    change_pct : list of float or None  the last third's median frequency over the first third's, less one (%)
    size_sd : list of float or None     that change in the mode's baseline standard deviations
    drifting : list of int              the modes (1-based) with a trend at ``rate / m`` of at least
                                        :data:`MIN_SIZE_SD`
    about : str                         what was tested (the frequencies, or their residuals about the conditions)
    warning : str or None
    """

    rho: list
    p_value: list
    change_pct: list
    size_sd: list
    drifting: list
    about: str
    warning: str | None

    def to_dict(self) -> dict:
        return {"rho": self.rho, "p_value": self.p_value, "change_pct": self.change_pct, "size_sd": self.size_sd,
                "drifting_modes": self.drifting, "about": self.about, "warning": self.warning,
                "rate": TREND_RATE, "min_size_sd": MIN_SIZE_SD}


def baseline_trend(log_values, about: str = "frequencies", rate: float = TREND_RATE) -> Trend:
    """:class:`Trend` of the baseline period's log frequencies.

    Parameters
    ----------
    log_values : array_like, shape (n_baseline, m)
        Each baseline test's log natural frequency per mode (or its residual about the conditions' prediction),
        in the tests' order; NaN where a mode was not found.
    about : str
        What the values are, for the text.
    rate : float
        Family-wise level over the modes.
    """
    from scipy.stats import spearmanr  # scipy.stats: heavy, only where a baseline is tested

    X = np.asarray(log_values, float)
    X = X.reshape(X.shape[0], -1)
    m = X.shape[1]
    rho, p, change, size = ([None] * m for _ in range(4))
    drifting = []
    for r in range(m):
        keep = np.flatnonzero(np.isfinite(X[:, r]))
        if keep.size < MIN_TESTS:
            continue
        x = X[keep, r]
        if np.ptp(x) == 0.0:
            continue
        sd = float(np.std(x, ddof=1))
        third = keep.size // 3
        d = float(np.median(x[-third:]) - np.median(x[:third]))
        res = spearmanr(np.arange(keep.size), x)
        rho[r], p[r] = float(res.statistic), float(res.pvalue)
        change[r], size[r] = float(100 * np.expm1(d)), d / sd
        if p[r] < rate / m and abs(size[r]) >= MIN_SIZE_SD:
            drifting.append(r + 1)
    warning = None
    if drifting:
        parts = [f"mode {r} {'falls' if change[r - 1] < 0 else 'rises'} {abs(change[r - 1]):.3g} % from the first "
                 f"third of the period to the last ({abs(size[r - 1]):.2g} of its standard deviations; Spearman "
                 f"{rho[r - 1]:+.2f}, p = {p[r - 1]:.2g})" for r in drifting]
        warning = (f"the baseline period drifts ({about}): " + "; ".join(parts) + ": the normal model learns the "
                   "drift as normal variation, and a later change that continues it reads as normal; choose a "
                   "baseline period without a trend (docs/monitoring.md: choosing a baseline period)")
    return Trend(rho, p, change, size, drifting, about, warning)


def series_baseline_trend(rows: list, model: str, covers_seasons: bool = False, rate: float = TREND_RATE) -> Trend:
    """:func:`baseline_trend` of a monitored series' baseline rows (``baseline``, ``identified``,
    ``frequencies_hz``, ``change_pct``): the log frequencies, or with the conditions regressed (``model ==
    "regression"``) their residuals about the conditions' prediction (``change_pct``), so that a course the
    measured conditions explain is no trend. Without conditions a baseline period that ``covers_seasons`` (dated,
    a year long) is not tested (``about`` says so)."""
    base = [r for r in rows if r["baseline"] and r["identified"]]
    regression = model == "regression"
    if covers_seasons and not regression:
        m = len(base[0]["frequencies_hz"]) if base else 0
        return Trend([None] * m, [None] * m, [None] * m, [None] * m, [], "not tested: the baseline period covers a "
                     "year of seasons without measured conditions", None)
    key = "change_pct" if regression else "frequencies_hz"
    X = np.array([[np.nan if v is None else v for v in r[key]] for r in base], float).reshape(len(base), -1)
    X = np.log1p(X / 100) if regression else np.log(X)
    return baseline_trend(X, "residuals about the conditions' prediction" if regression else "frequencies", rate)
