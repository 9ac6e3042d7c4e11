"""Memory: EWMA charts of the detector's whitened statistics, so that a small lasting change accumulates evidence
over the tests after it, with limits held out on the baseline period and its autocorrelation, and the onset of a
change dated.

Each chart smooths the whitened coordinates ``z_t`` (d per test) of one statistic of
:mod:`learn.monitor.statistics` (the residual's, the environmental scores', the common shift's), in time order:
``e_t = (1 - lam) e_{t-1} + lam z_t`` (``e_0 = 0``; a test not scored leaves it as it was), and charts
``c_t = |e_t|^2 / (lam / (2 - lam))`` (the multivariate EWMA of Lowry et al. 1992; ``lam / (2 - lam)`` is the
variance of ``e`` for independent unit ``z``).

The baseline tests' ``z`` (each from a model that did not see it) are autocorrelated (an environment that the
normal model leaves partly, a clamp re-made every week, a daily cycle), which widens ``e`` beyond that variance.
Each coordinate of the baseline sequence is fitted as an AR(1) plus white noise, ``z_t = sqrt(a) s_t +
sqrt(1 - a) w_t`` with ``s`` a unit AR(1) of coefficient ``phi`` (autocorrelation ``a phi^L`` at lag ``L >= 1``,
fitted to the baseline's by least squares; ``a = 1`` an AR(1), ``a = 0`` white noise), Gaussian series of the
model are simulated from a stationary start, the chart run on them, and the limit is their ``1 - rate`` quantile
after the EWMA's burn-in, or the baseline's own chart's quantile if larger: in control, a share ``rate`` of the
tests lie above it. The charts of a series share the family-wise rate equally, calibrated on the joint
distribution of the baseline's own charts after the burn-in (:func:`~learn.monitor.statistics.joint_rates`: the
charts of dependent statistics cost little of the rate, independent ones Šidák's split).

:func:`onset` dates a change: at an alarm, the start ``tau`` of the window ending there that maximises
``|sum z|^2 / length`` (the likelihood ratio of a lasting shift of unknown size in independent unit ``z``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from learn.monitor.statistics import joint_rates, sidak_rate

__all__ = ["CHARTS", "LAMBDA", "Chart", "Charts", "chart_limit", "ewma_chart", "fit_ar1_noise", "onset",
           "run_charts"]

#: The memory charts ``monitor`` offers (``--chart``).
CHARTS = ("ewma", "none")
#: EWMA weight of the newest test (an effective memory of about ``2 / lam - 1`` tests).
LAMBDA = 0.05
#: Largest AR(1) coefficient fitted (a baseline that drifts more than this is taken as this).
PHI_MAX = 0.999
#: Simulated in-control tests behind a limit: at least this many, and 200 / rate.
N_SIMULATED = 100_000


def _finite_rows(Z):
    Z = np.asarray(Z, float)
    if Z.ndim == 1:
        Z = Z[:, None]
    return Z, np.isfinite(Z).all(axis=1)


def ewma_chart(Z, lam: float = LAMBDA) -> np.ndarray:
    """The chart ``c_t`` (n,) of the whitened coordinates ``Z`` (n, d) or (n,) in time order (module docstring);
    NaN where a row of ``Z`` is not finite (the EWMA holds its value there)."""
    from scipy.signal import lfilter

    Z, ok = _finite_rows(Z)
    out = np.full(len(Z), np.nan)
    if ok.any():
        E = lfilter([lam], [1.0, lam - 1.0], Z[ok], axis=0)
        out[ok] = np.sum(E**2, axis=1) / (lam / (2.0 - lam))
    return out


def fit_ar1_noise(Z, max_lag: int = 500) -> tuple:
    """``(a (d,), phi (d,))`` of ``z = sqrt(a) AR(1; phi) + sqrt(1 - a) white`` per coordinate of the finite rows
    of ``Z`` (time order): the autocorrelation ``a phi^L`` fitted to the sample's at lags ``1..L_max`` (``L_max``
    the smaller of ``max_lag`` and a quarter of the rows) by least squares over a grid of ``phi`` up to
    :data:`PHI_MAX` (``a`` in closed form for each)."""
    Z, ok = _finite_rows(Z)
    Z = Z[ok] - Z[ok].mean(axis=0)
    n = len(Z)
    lags = np.arange(1, max(2, min(max_lag, n // 4)) + 1)
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    spec = np.fft.rfft(Z, nfft, axis=0)
    acov = np.fft.irfft(spec * np.conj(spec), nfft, axis=0)[:lags[-1] + 1] / n         # (L + 1, d)
    rho = acov[lags] / np.maximum(acov[0], 1e-300)                                      # (L, d)
    grid = 1.0 - np.geomspace(1.0, 1.0 - PHI_MAX, 200)                                  # 0 .. PHI_MAX
    P = grid[:, None] ** lags[None, :]                                                  # (g, L)
    a = np.clip((P @ rho) / np.maximum(np.sum(P * P, axis=1), 1e-300)[:, None], 0.0, 1.0)   # (g, d)
    sse = np.sum(rho**2, axis=0)[None] - 2 * a * (P @ rho) + a**2 * np.sum(P * P, axis=1)[:, None]
    best = np.argmin(sse, axis=0)
    d = np.arange(Z.shape[1])
    return a[best, d], grid[best]


def chart_limit(Zb, rate: float, lam: float = LAMBDA, seed: int = 0) -> tuple:
    """``(limit, phi, mean in-control run length in tests)`` of the chart of the baseline's whitened coordinates
    ``Zb`` (time order) at the in-control share ``rate`` of tests above the limit (the AR(1)-plus-noise model of
    the module docstring, or the baseline chart's own quantile if larger). The run length: tests from a
    stationary start to the first above the limit, of the model."""
    from scipy.signal import lfilter

    Zb, ok = _finite_rows(Zb)
    if ok.sum() < 8:
        raise ValueError("a chart limit needs at least 8 scored baseline tests")
    a, phi = fit_ar1_noise(Zb)
    sd = Zb[ok].std(axis=0)
    rng = np.random.default_rng([seed, 77])
    burn = int(math.ceil(5.0 / lam))                                   # z starts stationary, the EWMA at 0
    length = max(2000, 4 * burn, min(int(20.0 / (1.0 - float(phi.max()))), 50_000))
    reps = max(int(math.ceil(max(N_SIMULATED, 200.0 / rate) / length)), 8)
    d = Zb.shape[1]
    S = np.empty((reps, burn + length, d))
    for j in range(d):
        e = rng.standard_normal((reps, burn + length)) * math.sqrt(1.0 - phi[j] ** 2)
        S[:, :, j], _ = lfilter([1.0], [1.0, -phi[j]], e, axis=1, zi=phi[j] * rng.standard_normal((reps, 1)))
    Zs = (np.sqrt(a) * S + np.sqrt(1.0 - a) * rng.standard_normal(S.shape)) * sd
    E = lfilter([lam], [1.0, lam - 1.0], Zs, axis=1)
    c = np.sum(E[:, burn:] ** 2, axis=2) / (lam / (2.0 - lam))                        # (reps, length)
    limit = float(np.quantile(c, 1.0 - rate))
    own = ewma_chart(Zb, lam)[burn:]
    own = own[np.isfinite(own)]
    if own.size:
        limit = max(limit, float(np.quantile(own, 1.0 - rate)))
    above = c > limit
    first = np.where(above.any(axis=1), above.argmax(axis=1) + 1, length)
    return limit, phi, float(first.mean())


def onset(Z, t: int, window: int) -> int:
    """The estimated first test of a lasting change seen at test ``t``: the start ``tau`` in
    ``[t - window + 1, t]`` maximising ``|sum_{tau..t} z|^2 / (t - tau + 1)`` over the rows of ``Z`` (n, d) (NaN rows
    skipped: they add nothing)."""
    Z, ok = _finite_rows(Z)
    lo = max(0, t - window + 1)
    seg = np.where(ok[lo:t + 1, None], Z[lo:t + 1], 0.0)
    counts = np.cumsum(ok[lo:t + 1][::-1])[::-1]                                 # scored tests from tau to t
    S = np.cumsum(seg[::-1], axis=0)[::-1]                                       # sums from tau to t
    score = np.sum(S**2, axis=1) / np.maximum(counts, 1)
    score[~ok[lo:t + 1]] = -np.inf                                               # a change starts on a scored test
    return lo + int(np.argmax(score))


@dataclass(frozen=True)
class Chart:
    """One statistic's EWMA chart on a series: ``values`` (n,), its ``limit`` at ``rate`` (per test), the AR(1)
    coefficients ``phi`` fitted on the baseline and the simulated in-control ``run_length_tests``."""

    name: str
    lam: float
    rate: float
    limit: float
    phi: np.ndarray
    run_length_tests: float
    values: np.ndarray

    def to_dict(self) -> dict:
        return {"statistic": self.name, "lambda": self.lam, "limit": self.limit, "rate": self.rate,
                "ar1_phi": self.phi.tolist(), "in_control_run_length_tests": self.run_length_tests}


@dataclass(frozen=True)
class Charts:
    """The charts of a series: ``alarm`` (n,) where any chart lies above its limit, ``onset`` (n,) the estimated
    first test of the change behind each alarm (-1 without an alarm), ``rate`` family-wise."""

    charts: tuple
    rate: float
    alarm: np.ndarray
    onset: np.ndarray

    def to_dict(self) -> dict:
        return {"kind": "ewma", "false_alarm_rate": self.rate,
                "limits": "AR(1)-plus-noise simulation of the held-out baseline statistics, each chart at an "
                          "equal rate calibrated on the baseline charts' joint distribution (Gaussian copula)",
                "rate_per_chart": {c.name: c.rate for c in self.charts},
                "charts": [c.to_dict() for c in self.charts]}


def run_charts(vectors: dict, b_idx, rate: float, lam: float = LAMBDA, seed: int = 0,
               combination: str = "joint") -> Charts:
    """EWMA charts of every statistic's whitened coordinates (``vectors``: name -> (n, d), NaN rows not scored,
    the series in time order) with limits from the baseline rows ``b_idx``, each at an equal share of ``rate``
    calibrated on the baseline charts' joint distribution after the burn-in (:func:`joint_rates`; ``combination``
    ``sidak``: Šidák's split); an
    alarm episode's onset dated by :func:`onset` on the coordinates of the first chart (in
    ``vectors`` order) above its limit at the episode's first alarm."""
    names = [nm for nm, v in vectors.items() if v is not None]
    values = [ewma_chart(vectors[nm], lam) for nm in names]
    burn = int(math.ceil(5.0 / lam))
    own = np.column_stack([v[b_idx][burn:] for v in values]) if names else np.zeros((0, 0))
    each = rate if not names else (sidak_rate(rate, len(names)) if combination == "sidak"
                                   else float(joint_rates(own, rate)[0]))
    charts, ratios = [], []
    for k, (nm, vals) in enumerate(zip(names, values)):
        limit, phi, arl = chart_limit(vectors[nm][b_idx], each, lam, seed + k)
        charts.append(Chart(nm, lam, each, limit, phi, arl, vals))
        ratios.append(vals / limit)
    n = len(next(iter(vectors.values()))) if vectors else 0
    R = np.stack(ratios, axis=1) if ratios else np.full((n, 1), np.nan)
    alarm = np.nan_to_num(R, nan=0.0).max(axis=1) > 1.0
    first_chart = np.argmax(np.nan_to_num(R, nan=0.0) > 1.0, axis=1)
    out = np.full(n, -1)
    window = int(math.ceil(6.0 / lam))
    start = np.flatnonzero(alarm & ~np.r_[False, alarm[:-1]])
    ends = np.r_[start[1:], n]
    for s, e in zip(start, ends):
        tau = onset(vectors[names[first_chart[s]]], int(s), window)
        run = np.arange(s, e)
        run = run[alarm[run]]
        out[run] = tau
    return Charts(tuple(charts), rate, alarm, out)
