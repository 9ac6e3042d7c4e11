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
  standardised by its baseline standard deviation; its square is the index (one degree of freedom);
* ``mode``: with a PCA that removes components, each mode's frequency against its own prediction interval: its
  deviation from what the removed components explain over its scatter about them (the diagonal of the remaining
  components' covariance), the largest square over the modes found (:mod:`learn.monitor.per_mode`: its threshold
  the per-mode interval read at ``rate / m``): a change of one mode alone, which the residual spreads over its
  degrees of freedom and the shift averages over the modes.

Each index is a squared Mahalanobis distance of some part of the residual; its threshold is
:func:`~learn.monitor.alarm_threshold.threshold` of the held-out baseline indices (a scaled F law and their
empirical quantile; for the statistics of the environment itself the law fitted to their tail), the shift's on each
side of its sign (a drop, a rise). The family-wise rate is shared by :data:`SHARES` (one share per one-sided test:
the residual one, the shift's drop and rise one each; the environmental ``T^2``, which holds the shift's direction
among its own, and the per-mode statistic, which reads the residual's coordinates, a quarter each) and calibrated on
the statistics' joint held-out distribution, so that a test of the normal variation alarms on any of them with
probability ``rate``: the level of the shares at which the held-out baseline tests alarm on some statistic at
``rate`` at the plotting position (:func:`_union_rates`, :mod:`learn.monitor.union_calibration`: the tails'
dependence and each law's fit included), or, with fewer than ``1 / rate`` baseline tests, from the Gaussian copula
of their ranks (:func:`joint_rates`); strongly dependent statistics cost little of the rate, independent ones the
weighted Šidák split. A test whose set of modes found the baseline does not hold throughout is judged against the
thresholds of that set (:func:`held_out_statistics` with its ``pattern``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from learn.monitor.alarm_threshold import (TAIL_SHARE, Threshold, _folds, minimum_baseline, missing_evidence, threshold,
                                           training_size)
from learn.monitor.normal_models import PCARemoval, Regression, _impute
from learn.monitor.per_mode import per_mode_index, per_mode_threshold, per_mode_z
from learn.sessions import Sessions, baseline_sessions
from learn.monitor.union_calibration import union_rates, value_at
from physics.errors import ConfigError

__all__ = ["COMBINATIONS", "DEFAULT_STATISTICS", "PATTERN_MIN", "SHARES", "SHIFT_SIDES", "STATISTICS", "Detection",
           "detect", "environmental", "family_rates", "held_out_folds", "held_out_sessions", "held_out_statistics",
           "joint_rate", "joint_rates", "shift_weights", "sidak_rate", "statistics_of", "training_sizes"]

#: The detector's statistics (module docstring).
STATISTICS = ("residual", "environment", "shift", "mode")
#: Those :func:`detect` and ``monitor`` combine unless told otherwise (each where the model supports it: the
#: environment and the per-mode statistic with a PCA that removes components).
DEFAULT_STATISTICS = ("residual", "environment", "shift", "mode")


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


def shift_weights(cov) -> np.ndarray:
    """The shift's weights (p,) of the modes' ``ln f`` changes: each mode's inverse normal variance
    ``1 / cov_ii`` (``cov`` (p, p) the normal covariance), normalised to sum to 1, so that ``w . d`` is the relative
    change ``d`` common to the modes and its variance under the normal variation is ``w^T cov w``.

    For a common change (``d`` along ``1``) the most efficient linear weights are ``cov^-1 1`` (generalised least
    squares); with the normal variation one common factor plus each mode's own scatter, ``cov = a 1 1^T + D``,
    those are ``D^-1 1`` and their signal-to-noise ratio ``sqrt(s / (1 + a s))``, ``s = sum 1 / D_ii``, against
    ``1 / sqrt(w^T cov w)`` here: equal when ``a = 0`` (``cov`` diagonal), and within a fraction of a percent when
    the common factor dominates (the temperature: every weighting's variance is then about ``a``). The inverse
    variances need no inverse of a covariance estimated from 8-15 baseline tests."""
    var = np.maximum(np.diag(cov), 1e-300)
    return (1.0 / var) / np.sum(1.0 / var)


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
    w = shift_weights(cov)
    sd_shift = math.sqrt(max(float(w @ cov @ w), 1e-300))
    z = D @ w / sd_shift
    out["shift"] = (z**2, z[:, None])
    if isinstance(model, PCARemoval) and model.k_ > 0:
        Z = per_mode_z(model, X, C)
        out["mode"] = (per_mode_index(Z), Z)
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
    w = shift_weights(cov)
    return (_impute(X, centre, cov) - centre) @ w


def held_out_sessions(X, C=None) -> Sessions | None:
    """The sessions of the baseline ``X`` (n, p) (conditions ``C`` (n, q)) that :func:`held_out_folds` holds out
    (:func:`learn.sessions.baseline_sessions`, each leaving the others at least
    :func:`~learn.monitor.alarm_threshold.minimum_baseline` less one tests), or None."""
    X = np.asarray(X, float)
    q = 0 if C is None else np.asarray(C).reshape(len(X), -1).shape[1]
    return baseline_sessions(X, minimum_baseline(X.shape[1], q) - 1)


def held_out_folds(X, C=None, environment: bool = True) -> tuple:
    """``(folds, n_train, n_sessions)``: the held-out folds of the baseline ``X`` (n, p) (conditions ``C`` (n, q)),
    the fewest tests a fold's model is fitted on, and the sessions a fold's model sees (None without sessions). A
    baseline of several sessions (:func:`held_out_sessions`) is held out a session at a time, and
    its environment has one value per session (the statistics of the environment are judged by a law of
    ``n_sessions`` values); otherwise the folds of
    :func:`~learn.monitor.alarm_threshold.held_out_novelty` (leave-one-out up to
    :data:`~learn.monitor.alarm_threshold.LOO_MAX` tests), each test a value.

    ``environment=False``: the folds of the statistics of a change of the modes' pattern (the residual, the per-mode
    statistic). A model fitted on one session holds none of the sessions' variation among its components, so a
    baseline of two sessions holds those statistics out one test at a time (the components then fitted on both
    sessions); with three or more, a session at a time."""
    sessions = held_out_sessions(X, C)
    if sessions is None or (not environment and len(sessions.sizes) < 3):
        return _folds(len(X)), training_size(len(X)), None
    return sessions.folds(), len(X) - max(sessions.sizes), len(sessions.sizes) - 1


def training_sizes(X, C=None) -> tuple:
    """``(n_tests, n_sessions, n_pattern)`` of the baseline ``X`` (conditions ``C``) for :func:`_thresholds`: the
    fewest tests and the sessions a held-out model of the environment's statistics sees (:func:`held_out_folds`),
    and the fewest tests one of the residual's and the per-mode statistic's sees."""
    return (*held_out_folds(X, C)[1:], held_out_folds(X, C, environment=False)[1])


def held_out_statistics(make_model, X, C=None, pattern=None) -> dict:
    """:func:`statistics_of` of every baseline test by a model fitted on the other baseline tests (the folds of
    :func:`held_out_folds`: a session at a time when the baseline holds several, else leave-one-out; the residual
    and the per-mode statistic of a baseline of two sessions one test at a time), the residual index with its
    missing-mode evidence.

    ``pattern`` (bool (p,)): the indices of a set of modes found instead, without the evidence: each baseline test
    whose missing modes lie within ``pattern`` (all of them when fewer than :data:`PATTERN_MIN` do) scored with the
    modes of ``pattern`` dropped (NaN where the test was not scored); the models are those of the folds above."""
    X = np.asarray(X, float)
    out: dict = {}
    rows = np.ones(len(X), bool)
    if pattern is not None:
        pattern = np.asarray(pattern, bool)
        rows = ~(~np.isfinite(X) & ~pattern).any(axis=1)
        if rows.sum() < PATTERN_MIN:
            rows[:] = True
    folds, _, seen = held_out_folds(X, C)
    pattern_folds, _, pattern_seen = held_out_folds(X, C, environment=False)
    runs = [(folds, None)] if seen == pattern_seen else [(folds, True), (pattern_folds, False)]
    for fold_set, env in runs:
        for held in fold_set:
            _held_out_fold(make_model, X, C, held, rows, pattern, env, out)
    return out


def _held_out_fold(make_model, X, C, held, rows, pattern, env, out) -> None:
    """:func:`held_out_statistics` of one fold ``held`` into ``out``; ``env``: only the statistics of the environment
    (True), only the others (False), or all (None)."""
    train = np.setdiff1d(np.arange(len(X)), held)
    held = held[rows[held]]
    if not held.size:
        return
    model = make_model().fit(X[train], None if C is None else C[train])
    Xh = X[held].copy()
    if pattern is not None:
        Xh[:, pattern] = np.nan
    stats = statistics_of(model, Xh, None if C is None else C[held])
    if pattern is None:
        stats["residual"] = (stats["residual"][0] + missing_evidence(Xh, X[train]), stats["residual"][1])
    for name, (value, vec) in stats.items():
        if env is not None and environmental(model, name) != env:
            continue
        if name not in out:
            out[name] = (np.full(len(X), np.nan), None if vec is None else np.full((len(X), vec.shape[1]), np.nan))
        out[name][0][held] = value
        if vec is not None:
            out[name][1][held] = vec


#: Fewest baseline tests whose missing modes lie within a test's that calibrate its pattern's thresholds on their
#: own (:func:`held_out_statistics`); below it, every baseline test with the test's missing modes dropped.
PATTERN_MIN = 10
#: Draws of the Gaussian copula that :func:`joint_rate` reads its quantile from.
COPULA_DRAWS = 200_000


def sidak_rate(rate: float, k: int) -> float:
    """Per-statistic rate of ``k`` statistics whose union alarms at most at ``rate`` (exact for independent ones)."""
    return 1.0 - (1.0 - rate) ** (1.0 / max(int(k), 1))


#: Each statistic's share of the family-wise rate (relative weights, :func:`joint_rates`): one per one-sided test,
#: a quarter for a statistic that re-reads evidence another one holds. The residual's index is one test, the signed
#: shift two (a drop, a rise: the plainest tests of a change common to the modes, of either sign); the environmental
#: ``T^2`` of the removed components holds the shift's direction among its own (for a common change it is the
#: weaker test of the same evidence) and keeps a quarter share, for a change along a removed direction that leaves
#: the modes' mean; the per-mode statistic reads each coordinate of the residual about the removed components (for a
#: change of several modes the residual is the stronger test of the same evidence) and keeps a quarter share, for a
#: change of one mode alone, which the residual spreads over its degrees of freedom.
SHARES = {"residual": 1.0, "environment": 0.25, "shift": 2.0, "mode": 0.25}
#: The drop's and the rise's shares of the shift's rate (:func:`detect`'s ``shift_sides``): half each, a change of
#: either sign seen alike. A larger drop share finds a drop of every mode (a loss of stiffness along the
#: temperature's direction) on more tests and a rise (a mass lost, a stiffening) on as many fewer, the family's
#: rate unchanged (docs/monitoring.md, "The shift's weights and its two sides").
SHIFT_SIDES = (0.5, 0.5)
#: How :func:`detect` shares the rate: ``joint`` (:data:`SHARES`, calibrated on the joint held-out distribution),
#: ``equal`` (equal shares, so calibrated), ``sidak`` (equal shares, independent statistics assumed).
COMBINATIONS = ("joint", "equal", "sidak")


def joint_rates(held, rate: float, weights=None, seed: int = 0) -> np.ndarray:
    """Per-statistic rates ``r_k`` (K,) at which a test of the normal variation alarms on any of the statistics with
    probability ``rate``, shared by ``weights`` (K,) (relative; None: equal) and calibrated on the statistics' joint
    held-out distribution: ``held`` (n, K) the baseline tests' held-out indices; each column's ranks turned to
    normal scores ``Phi^-1((rank - 1/2) / n)``, their correlation ``R``; ``r_k = 1 - (1 - s)^(v_k)``,
    ``v_k = w_k / max w``, with ``s`` the ``rate`` quantile over :data:`COPULA_DRAWS` seeded draws of ``K`` standard
    normals correlated by ``R`` (a Gaussian copula) of ``min_k 1 - (1 - Phi(-g_k))^(1/v_k)`` (the draw alarms on
    some statistic at ``s`` exactly when that is below ``s``). Independent statistics give the weighted Šidák split
    ``prod (1 - r_k) = 1 - rate``, identical ones ``max r_k = rate``; ``s`` is kept between the two. Equal weights:
    :func:`joint_rate` for each."""
    from scipy import stats  # scipy.stats: ranks and the normal law, only where the family is calibrated

    H = np.asarray(held, float)
    H = H[np.isfinite(H).all(axis=1)]
    k = H.shape[1]
    w = np.ones(k) if weights is None else np.asarray(weights, float)
    v = w / w.max()
    low = 1.0 - (1.0 - rate) ** (1.0 / v.sum())
    s = rate if k < 2 else low
    if k >= 2 and len(H) >= 10:
        S = stats.norm.ppf((stats.rankdata(H, axis=0) - 0.5) / len(H))
        R = np.corrcoef(S, rowvar=False)
        lam, V = np.linalg.eigh(np.nan_to_num(R))
        L = V * np.sqrt(np.maximum(lam, 0.0))
        G = np.random.default_rng(seed).standard_normal((COPULA_DRAWS, k)) @ L.T
        P = stats.norm.sf(G)                                            # each draw's p-value per statistic
        first = np.min(-np.expm1(np.log1p(-P) / v), axis=1)            # the s at which the draw alarms
        s = float(np.clip(np.quantile(first, rate), low, rate))
    return -np.expm1(v * math.log1p(-s))


def joint_rate(held, rate: float, seed: int = 0) -> float:
    """The per-statistic rate of equal shares (:func:`joint_rates` with equal weights): between Šidák's
    ``1 - (1 - rate)^(1/K)`` (independent statistics) and ``rate`` (one statistic repeated)."""
    return float(joint_rates(held, rate, None, seed)[0])


def family_rates(held, rate: float, names, combination: str = "joint", shares=None) -> np.ndarray:
    """Per-statistic rates (K,) of ``names`` (their held-out indices ``held`` (n, K)) by ``combination``
    (:data:`COMBINATIONS`; ``joint`` with ``shares``, name -> weight, :data:`SHARES` when None)."""
    if combination == "joint":
        shares = SHARES if shares is None else shares
        return joint_rates(held, rate, [shares[nm] for nm in names])
    if combination == "equal":
        return joint_rates(held, rate)
    if combination == "sidak":
        return np.full(len(names), sidak_rate(rate, len(names)))
    raise ValueError(f"combination {combination!r}: expected one of {', '.join(COMBINATIONS)}")


@dataclass(frozen=True)
class Detection:
    """The detector's verdict on every test of a series.

    Attributes
    ----------
    names : tuple of str                  the statistics used (a subset of :data:`STATISTICS`, in that order)
    values : ndarray (n, K)               each statistic's index per test (NaN: not scored); baseline tests held out
    thresholds : tuple of Threshold       each statistic's threshold at its rate of ``rate_each`` for the tests
                                          holding every mode (the shift's: its drop side, ``shift_rise`` the other)
    rate : float                          the family-wise false-alarm rate
    rate_each : ndarray (K,)              each statistic's rate (:func:`family_rates`; the shift's two sides
                                          together)
    ratio : ndarray (n,)                  ``max_k ratios`` (> 1: alarm)
    alarm : ndarray of bool (n,)
    vectors : dict                        name -> (n, d) whitened coordinates (see :func:`statistics_of`)
    shift_pct : ndarray (n,)              the weighted mean relative frequency change, %
    ratios : ndarray (n, K)               each index over its threshold for the test's set of modes found (the
                                          shift's on the side of its sign)
    combination : str                     one of :data:`COMBINATIONS`
    shift_rise : Threshold or None        the shift's rise side
    shares : dict                         name -> the statistic's share of the rate (``joint``)
    calibration : str                     ``union``: the shares' level from the union of the held-out tests'
                                          alarms (:func:`_union_rates`), ``copula``: from the Gaussian copula
                                          of their ranks (:func:`joint_rates`), empty for ``sidak``
    patterns : dict                       missing modes (1-based, text) -> per statistic ``[Threshold]`` (the
                                          shift's drop and rise), for each set of modes found that the baseline
                                          period does not hold throughout
    shift_sides : tuple                   the drop's and the rise's shares of the shift's rate
    """

    names: tuple
    values: np.ndarray
    thresholds: tuple
    rate: float
    rate_each: np.ndarray
    ratio: np.ndarray
    alarm: np.ndarray
    vectors: dict
    shift_pct: np.ndarray
    ratios: np.ndarray | None = None
    combination: str = "joint"
    shift_rise: Threshold | None = None
    patterns: dict = field(default_factory=dict)
    shares: dict = field(default_factory=dict)
    calibration: str = "copula"
    shift_sides: tuple = SHIFT_SIDES

    def alarmed_by(self, i: int) -> list:
        """Names of the statistics above their thresholds on test ``i``."""
        return [nm for k, nm in enumerate(self.names) if self.ratios[i, k] > 1.0]

    def to_dict(self) -> dict:
        how = {"joint": "per-statistic rates shared by " + ", ".join(f"{nm} {w:g}" for nm, w in self.shares.items())
                        + " and calibrated on the baseline's joint held-out statistics "
                        + ("(the union of their alarms over the held-out tests at the plotting position)"
                           if self.calibration == "union" else "(a Gaussian copula of their ranks)")
                        + " so that any statistic alarms at the rate",
               "equal": "equal per-statistic rates calibrated on the baseline's joint held-out statistics (a Gaussian "
                        "copula of their ranks) so that any statistic alarms at the rate",
               "sidak": "the Sidak rate 1 - (1 - rate)^(1/K) of the K statistics"}[self.combination]
        th = {nm: t.to_dict() for nm, t in zip(self.names, self.thresholds)}
        if self.shift_rise is not None:
            th["shift"] = {"drop": th["shift"], "rise": self.shift_rise.to_dict(),
                           "signed": f"the drop at {self.shift_sides[0]:g} and the rise at {self.shift_sides[1]:g} "
                                     "of the shift's rate"}
        return {"statistics": list(self.names), "false_alarm_rate": self.rate,
                "rate_per_statistic": {nm: float(r) for nm, r in zip(self.names, self.rate_each)},
                "combination": "an alarm when any statistic exceeds its threshold at " + how,
                "thresholds": th,
                "per_set_of_modes_found": {key: {nm: [t.to_dict() for t in ts] for nm, ts in v.items()}
                                           for key, v in self.patterns.items()}}


def _thresholds(model, held, names, each, n_train, n_conditions, missing=0, evidence=0.0, split=None):
    """Per statistic of ``names``, its thresholds ``[Threshold]`` at its rate ``each[name]`` from the held-out
    statistics ``held``: one, or the shift's drop and rise sides at the shares ``split`` of its rate
    (:data:`SHIFT_SIDES` when None; a side with fewer than 2
    held-out tests: the two-sided threshold for both). ``missing``: modes dropped (the residual's degrees of
    freedom less by as many); ``evidence``: added to the residual's threshold (the missing-mode evidence of a set of
    modes found that the baseline period holds often: a normal set). ``n_train``: the tests each held-out model is
    fitted on, or ``(tests, sessions, pattern tests)`` (:func:`training_sizes`; sessions None: each test a value of
    the environment), the first two for the statistics of the environment, the last for the others."""
    out = {}
    n_tests, n_sessions, n_pattern = (n_train, None, n_train) if np.isscalar(n_train) else n_train
    for nm in names:
        hv, hvec = held[nm]
        # the environment of a baseline of sessions: a law of as many values, fitted to all of them (a truncated
        # tail of so few degrees of freedom is a power law, which holds no scale)
        sessions = environmental(model, nm) and n_sessions is not None
        tail = TAIL_SHARE if environmental(model, nm) and not sessions else 1.0
        n_fit = n_sessions if sessions else n_tests if environmental(model, nm) else n_pattern
        if nm == "residual":
            t = threshold(hv, each[nm], max(model.dof_ - missing, 1), n_fit, n_conditions, tail)
            out[nm] = [replace(t, value=t.value + evidence, law_value=t.law_value + evidence,
                               empirical_quantile=t.empirical_quantile + evidence)]
        elif nm == "environment":
            out[nm] = [threshold(hv, each[nm], hvec.shape[1], n_fit, n_conditions, tail)]
        elif nm == "mode":
            out[nm] = [per_mode_threshold(hvec, each[nm], n_fit, n_conditions, tail)]
        else:
            z = hvec[:, 0][np.isfinite(hvec[:, 0])]
            sides = []
            for sign, part in zip((-1.0, 1.0), SHIFT_SIDES if split is None else split):
                y = (sign * z)[sign * z > 0] ** 2
                if y.size < 2:
                    sides = [threshold(z**2, each[nm], 1, n_fit, n_conditions, tail)] * 2
                    break
                sides.append(threshold(y, each[nm] * part, 1, n_fit, n_conditions, tail, y.size / z.size))
            out[nm] = sides
    return out


def _ratios(values, z, ths, names):
    """``values`` (n, K) over the thresholds ``ths`` (name -> [Threshold]); the shift's on the side of ``z``."""
    R = np.empty_like(values)
    for k, nm in enumerate(names):
        t = ths[nm]
        if nm == "shift":
            R[:, k] = values[:, k] / np.where(z < 0, t[0].value, t[1].value)
        else:
            R[:, k] = values[:, k] / t[0].value
    return R


def detect(model, make_model, X, C, b_idx, rest, rate: float, n_conditions: int = 0,
           statistics=DEFAULT_STATISTICS, held=None, combination: str = "joint", shares=None,
           shift_sides=SHIFT_SIDES) -> Detection:
    """The detector on a series: ``model`` fitted on the baseline tests ``X[b_idx]`` (``make_model()`` an unfitted
    copy for the held-out fits), the monitoring tests ``rest`` (indices) scored by it, the baseline tests held
    out (``held``: their :func:`held_out_statistics`, computed when None); every statistic of ``statistics`` that
    the model supports, thresholded at its rate of ``combination`` (:func:`family_rates`: ``joint`` the shares
    :data:`SHARES`, or ``shares``, calibrated on the held-out statistics, ``equal``, ``sidak``); the shift signed,
    its drop and its rise at the shares ``shift_sides`` of its rate (:data:`SHIFT_SIDES`: half each).

    A test whose set of modes found differs from some baseline test's is judged against thresholds of its own
    set: :func:`held_out_statistics` with its missing modes dropped (``pattern``); the residual's missing-mode
    evidence is added to its index, and the evidence of those of its missing modes that some baseline test lacked
    to its threshold: a mode the baseline period loses now and then is normal to lose, alone or with any others it
    loses, however rare each loss (the set's statistics judged at the rate against its own thresholds, as the
    baseline's tests of that set are; judged by the product of their shares, every such set would alarm at about the
    rate, and their union at several times it: 10 of the 45 later healthy tests beyond the residual's threshold on
    the building series of ``bench_resplit``). A mode the baseline period always held keeps its evidence in the
    index alone: lost, it raises it by ``2 ln(n + 2)``. A baseline test's set is one the baseline period lost; held
    out, its index's evidence is against the other baseline tests (each lost mode's count one less), and so is the
    evidence its threshold carries."""
    sides = tuple(float(v) for v in shift_sides)
    if len(sides) != 2 or min(sides) <= 0.0 or abs(sum(sides) - 1.0) > 1e-9:
        raise ConfigError(f"shift_sides: expected the drop's and the rise's shares of the shift's rate, two numbers "
                          f"above 0 summing to 1, not {shift_sides!r}")
    X = np.asarray(X, float)
    n = len(X)
    Cb = None if C is None else C[b_idx]
    if held is None:
        held = held_out_statistics(make_model, X[b_idx], Cb)
    now = statistics_of(model, X[rest], None if C is None else C[rest]) if len(rest) else {}
    names = tuple(nm for nm in STATISTICS if nm in held and nm in statistics)
    values = np.full((n, len(names)), np.nan)
    vectors = {}
    for k, nm in enumerate(names):
        hv, hvec = held[nm]
        values[b_idx, k] = hv
        if len(rest):
            values[rest, k] = now[nm][0]
        if nm == "residual" and len(rest):
            values[rest, k] += missing_evidence(X[rest], X[b_idx])
        if hvec is not None and nm != "mode":          # the charts smooth whitened coordinates: not per mode
            vec = np.full((n, hvec.shape[1]), np.nan)
            vec[b_idx] = hvec
            if len(rest):
                vec[rest] = now[nm][1]
            vectors[nm] = vec
    rates = family_rates(values[b_idx], rate, names, combination, shares) if names else np.zeros(0)
    n_train = training_sizes(X[b_idx], Cb)
    calibration = {"joint": "copula", "equal": "copula"}.get(combination, "")
    if combination == "joint" and len(names) > 1:
        union = _union_rates(model, held, names, rate, rates, n_train, n_conditions, shares, sides)
        if union is not None:
            rates, calibration = union, "union"
    each = dict(zip(names, rates))
    ths = _thresholds(model, held, names, each, n_train, n_conditions, split=sides)
    z = vectors["shift"][:, 0] if "shift" in vectors else np.zeros(n)
    R = np.full((n, max(len(names), 1)), np.nan)
    if names:
        R = _ratios(values, z, ths, names)
    miss = ~np.isfinite(X)
    scored = np.r_[b_idx, rest].astype(int)
    base_miss = miss[b_idx]
    patterns = {}
    for pat in {tuple(r) for r in miss[scored]}:
        P = np.asarray(pat, bool)
        if not names or (base_miss == P).all() or P.all():
            continue
        rows = scored[(miss[scored] == P).all(axis=1)]
        hp = held_out_statistics(make_model, X[b_idx], Cb, pattern=P)
        lost = P & base_miss.any(axis=0)                   # the modes of P that some baseline test lacked
        ev = float(missing_evidence(np.where(lost, np.nan, 0.0)[None], X[b_idx])[0])
        tp = _thresholds(model, hp, names, each, n_train, n_conditions, int(P.sum()), ev, sides)
        R[rows] = _ratios(values[rows], z[rows], tp, names)
        held_rows = rows[np.isin(rows, b_idx)]
        if "residual" in names and held_rows.size:
            # a baseline test's set is one the baseline period lost; held out, its index's evidence is against the
            # other baseline tests, and so is the evidence its threshold carries (every such test lacks every mode
            # of P: the same evidence without any one of them)
            others = np.delete(X[b_idx], np.flatnonzero(b_idx == held_rows[0]), axis=0)
            lost_others = P & ~np.isfinite(others).all(axis=0)
            ev_held = float(missing_evidence(np.where(lost_others, np.nan, 0.0)[None], others)[0])
            k = names.index("residual")
            R[held_rows, k] = values[held_rows, k] / (tp["residual"][0].value - ev + ev_held)
        patterns[", ".join(str(j + 1) for j in np.flatnonzero(P)) or "none"] = tp
    ratio = np.where(np.isnan(R), -np.inf, R).max(axis=1)
    ratio[~np.isfinite(ratio)] = np.nan
    shift = np.full(n, np.nan)
    shift[scored] = shift_fraction(model, X[scored], None if C is None else C[scored])
    return Detection(names, values, tuple(ths[nm][0] for nm in names), rate, rates, ratio, np.nan_to_num(ratio) > 1.0,
                     vectors, 100 * shift, R, combination, ths["shift"][1] if "shift" in ths else None, patterns,
                     {nm: (SHARES if shares is None else shares)[nm] for nm in names} if combination == "joint" else {},
                     calibration, sides)


def _union_rates(model, held, names, rate: float, rates, n_train: int, n_conditions: int, shares=None,
                 sides=SHIFT_SIDES):
    """Per-statistic rates (K,) of ``names`` at the shares :data:`SHARES` (or ``shares``) whose union alarms on the
    held-out baseline tests scored on every statistic (``held``: :func:`held_out_statistics`) at ``rate`` at the
    plotting position (:func:`~learn.monitor.union_calibration.union_rates`); each statistic's threshold as
    :func:`_thresholds` sets it (its law fitted once, at the rates ``rates``, and read at each level by
    :func:`~learn.monitor.union_calibration.value_at`); None when the baseline holds no held-out test at the
    rate."""
    shares = SHARES if shares is None else shares
    H = np.column_stack([held[nm][0] for nm in names])
    rows = np.isfinite(H).all(axis=1)
    z = held["shift"][1][rows, 0] if "shift" in names else np.zeros(int(rows.sum()))
    base = _thresholds(model, held, names, dict(zip(names, rates)), n_train, n_conditions, split=sides)
    parts = {}                          # name -> [(threshold, its held-out indices, side share, share of the rate)]
    for nm in names:
        if nm != "shift":
            parts[nm] = [(base[nm][0], held[nm][0], 1.0, 1.0)]
            continue
        zs = held[nm][1][:, 0][np.isfinite(held[nm][1][:, 0])]
        if base[nm][0] is base[nm][1]:                      # a side with fewer than 2 tests: both sides' squares
            parts[nm] = [(base[nm][0], zs**2, 1.0, 1.0)] * 2
        else:
            parts[nm] = [(t, (sign * zs)[sign * zs > 0] ** 2, float(np.mean(sign * zs > 0)), part)
                         for t, sign, part in zip(base[nm], (-1.0, 1.0), sides)]

    def count(r):
        ths = {nm: [replace(t, value=value_at(t, y, f * r_k, side)) for t, y, side, f in parts[nm]]
               for nm, r_k in zip(names, r)}
        return int((_ratios(H[rows], z, ths, names) > 1.0).any(axis=1).sum())

    return union_rates(count, [shares[nm] for nm in names], rate, int(rows.sum()))


def environmental(model, name: str) -> bool:
    """Whether statistic ``name`` of ``model`` measures the environment itself (the removed components' scores, a shift
    about the baseline mean; not the per-mode statistic, a residual about the removed components' part), whose
    bounded distribution gets a threshold law fitted to its tail
    (:func:`~learn.monitor.alarm_threshold.threshold`'s ``tail_share``), rather than a residual about what the
    normal variation explains."""
    return name == "environment" or (name == "shift" and not isinstance(model, Regression))


def residual_threshold(det: Detection) -> Threshold:
    """The residual statistic's threshold within the family."""
    return det.thresholds[det.names.index("residual")]
