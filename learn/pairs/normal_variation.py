"""The normal variation between tests of the intact beam, measured on several baseline tests.

Each baseline test's modes are placed on the model's modes by the rule every pair of ``classify`` follows
(:func:`learn.pairs.measured.modal_pair`). Across the ``N`` baselines that hold a mode ``k``:

- ``frequency_std_rel[k]``: the sample standard deviation of ``ln f_k`` (a relative frequency scatter);
- ``shape_std[:, k]``: the sample standard deviation of each entry of the real unit-norm shape at the sensors
  (signs following the reference baseline's);
- ``damping_std[k]``: the sample standard deviation of the damping ratio.

A later test lies *beyond the normal variation* when its natural frequencies differ from the baselines' by more
than these tests' own scatter allows at the chosen false-alarm rate ``alpha``. Two tests, each at ``alpha / 2``
where both run (so at most ``alpha`` together):

- the largest ``|z_k| = |ln f_k - mean_k| / (s_k sqrt(1 + 1 / n_k))`` against Student's ``t`` with ``n_k - 1``
  degrees of freedom at ``alpha / (2 p)`` per mode (Bonferroni over the ``p`` modes compared: valid however the
  modes correlate; the stronger test when they move independently);
- with ``n >= p + 4`` baselines holding all the modes compared, Hotelling's ``T^2 = n / (n + 1) d^T S^-1 d`` of
  the test's ``ln f`` against the baselines' mean and covariance, with the exact threshold of a new observation
  from the same Gaussian population, ``T^2 (n - p) / (p (n - 1)) ~ F(p, n - p)``: the stronger test when the
  modes move together (temperature), since it sees a change break their common pattern.

Baselines given in test order that fall into sessions (:func:`learn.sessions.baseline_sessions`: runs of at least
three tests at one level of the frequencies, separated by jumps far beyond the scatter from one test to the next: a
set-up re-mounted, a day's temperature) hold as many values of that level as sessions, not one per test. A later
test, from a later session, is then judged about the mean of the sessions' levels with the variance of a new test of
a new session, ``s_m^2 (1 + 1 / g) + s_w^2 (1 - h)`` (``s_m^2`` the variance of the ``g`` sessions' means, ``s_w^2``
the pooled variance within them, ``h`` the mean of ``1 / n_i`` over the sessions' sizes: in expectation
``sigma_b^2 (1 + 1 / g) + sigma_w^2 (1 + h / g)``), against Student's ``t`` with Satterthwaite's degrees of freedom
(about ``g - 1`` where the sessions' levels differ most); Hotelling's test, whose covariance the sessions' levels would
have to give, is not run. Treating ``N`` tests of ``g`` sessions as independent reads a new session's level against
``t(N - 1)`` and the within-session scatter and alarms on most new sessions.

Standard deviations never fall below :data:`FREQUENCY_STD_FLOOR` and :data:`SHAPE_STD_FLOOR` (the finest
repeatability the training draws), so noise-free or identical baselines do not make every change significant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learn.densest_window import densest_window
from learn.explanations.shapes import real_shapes, sign_aligned
from learn.pairs.measured import BASELINE_PAIR_BAND, RATIO_TOLERANCE, modal_pair
from learn.sessions import Sessions, baseline_sessions
from physics.errors import BeamDamageError

__all__ = ["FREQUENCY_STD_FLOOR", "HOTELLING_MIN_EXTRA", "SHAPE_STD_FLOOR", "NormalVariation", "measure",
           "model_modes"]

#: Smallest relative frequency scatter taken (0.002 %: the lower end of the training's frequency scatter).
FREQUENCY_STD_FLOOR = 2e-5
#: Smallest scatter of a unit-norm shape entry taken (0.001: the lower end of the training's shape scatter).
SHAPE_STD_FLOOR = 1e-3
#: Hotelling's test runs with ``n >= p + HOTELLING_MIN_EXTRA`` baselines for ``p`` modes (below, its threshold
#: ``F(p, n - p)`` grows so large that it detects almost nothing).
HOTELLING_MIN_EXTRA = 4


def model_modes(data, beam, nominal_hz, name: str = "baseline", tolerance=None):
    """One test's modes on the model's modes: ``(ln f (m,), real unit-norm shapes (S, m) or None, damping ratios
    (m,))``, NaN where the test lacks a mode; the pairing of :func:`learn.pairs.measured.modal_pair` (against
    ``nominal_hz`` within ``tolerance``: with several baselines, :attr:`NormalVariation.targets`)."""
    pair = modal_pair(data, data, beam, nominal_hz, (name, name), tolerance=tolerance)
    m = beam.n_modes
    lnf, zeta = np.full(m, np.nan), np.full(m, np.nan)
    lam = np.asarray(pair.eigenvalues[0])
    lnf[pair.mode_index] = np.log(np.abs(lam) / (2 * np.pi))
    zeta[pair.mode_index] = -lam.real / np.abs(lam)
    shapes = None
    if not pair.frequency_only:
        shapes = np.full((pair.eigenvectors.shape[1], m), np.nan)
        shapes[:, pair.mode_index] = real_shapes(pair.eigenvectors[0])
    return lnf, shapes, zeta


@dataclass(frozen=True)
class NormalVariation:
    """The baselines' modes on the model's modes and their scatter.

    Attributes
    ----------
    names : tuple of str                     the baseline tests
    log_frequency : ndarray, shape (N, m)    ``ln f`` (f in Hz) per baseline and model mode, NaN where absent
    shapes : ndarray, shape (N, S, m) or None  real unit-norm shapes at the sensors, signs following the reference's
    damping_ratio : ndarray, shape (N, m)
    reference : int                          the baseline nearest the population's centre: the one the pair
                                             methods (network, classical, explanations' shapes) compare with
    pairing_hz : ndarray, shape (m,)         what every test's poles are paired with: the baselines' median
                                             frequency of each mode they hold (the nominal beam's elsewhere)
    pairing_band : ndarray, shape (m,)       relative: :data:`learn.pairs.measured.BASELINE_PAIR_BAND` where the
                                             baselines hold the mode, :data:`learn.pairs.measured.RATIO_TOLERANCE`
                                             elsewhere (both narrowed to half the gap to the neighbours when paired)
    sessions : Sessions or None              the baselines' sessions in the order given (module docstring); None for
                                             one session
    """

    names: tuple
    log_frequency: np.ndarray
    shapes: np.ndarray | None
    damping_ratio: np.ndarray
    reference: int
    pairing_hz: np.ndarray | None = None
    pairing_band: np.ndarray | None = None
    sessions: Sessions | None = None

    @property
    def targets(self) -> tuple:
        """``(frequencies Hz (m,), tolerance (m,))`` to pair a test's poles with (``modal_pair(..., nominal_hz,
        ..., tolerance=)``)."""
        return self.pairing_hz, self.pairing_band

    @property
    def n_baselines(self) -> int:
        return len(self.names)

    @property
    def counts(self) -> np.ndarray:
        """Baselines holding each model mode, shape (m,)."""
        return np.sum(np.isfinite(self.log_frequency), axis=0)

    @property
    def frequency_mean_hz(self) -> np.ndarray:
        """Geometric mean of each mode's frequency over the baselines (Hz; with sessions, over the sessions'
        levels), NaN where none holds it."""
        with np.errstate(invalid="ignore"):
            return np.exp(self.prediction()[0])

    def prediction(self) -> tuple:
        """A later test's ``ln f`` per model mode against the baselines: ``(location (m,), standard deviation of the
        test about it (m,), degrees of freedom (m,))``; NaN where fewer than 2 baselines (with sessions: 2
        sessions) hold the mode. One session: the mean, ``s sqrt(1 + 1 / n)`` and ``n - 1``; several: the mean of
        the sessions' levels, the variance of a new test of a new session and Satterthwaite's degrees of freedom
        (module docstring)."""
        X = self.log_frequency
        if self.sessions is None:
            n = self.counts
            std = self.frequency_std_rel * np.sqrt(1 + 1 / np.maximum(n, 1))
            return _nanmean(X), std, np.where(n >= 2, n - 1.0, np.nan)
        folds = self.sessions.folds()
        levels = np.stack([_nanmean(X[f]) for f in folds])                       # (g, m)
        sizes = np.stack([np.sum(np.isfinite(X[f]), axis=0) for f in folds])     # (g, m)
        g = np.sum(sizes > 0, axis=0)
        df_w = np.sum(np.maximum(sizes - 1, 0), axis=0)
        ss_w = sum(np.nansum((X[f] - levels[j]) ** 2, axis=0) for j, f in enumerate(folds))
        h = np.sum(np.where(sizes > 0, 1.0 / np.maximum(sizes, 1), 0.0), axis=0) / np.maximum(g, 1)
        a = _nanstd(levels, 0.0) ** 2 * (1 + 1 / np.maximum(g, 1))
        b = ss_w / np.maximum(df_w, 1) * (1 - h)
        den = a**2 / np.maximum(g - 1, 1) + b**2 / np.maximum(df_w, 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            dof = np.where(den > 0, (a + b) ** 2 / den, g - 1.0)
        var = np.maximum(a + b, FREQUENCY_STD_FLOOR**2 * (1 + 1 / np.maximum(g, 1)))
        ok = g >= 2
        return _nanmean(levels), np.where(ok, np.sqrt(var), np.nan), np.where(ok, dof, np.nan)

    @property
    def frequency_std_rel(self) -> np.ndarray:
        """Relative frequency scatter per mode (std of ``ln f``, floored), NaN where fewer than 2 hold it."""
        return _nanstd(self.log_frequency, FREQUENCY_STD_FLOOR)

    @property
    def shape_std(self) -> np.ndarray | None:
        """Scatter of each unit-norm shape entry, shape (S, m) (floored), None without shapes."""
        return None if self.shapes is None else _nanstd(self.shapes, SHAPE_STD_FLOOR)

    @property
    def damping_std(self) -> np.ndarray:
        """Scatter of the damping ratios per mode (absolute), NaN where fewer than 2 hold it."""
        return _nanstd(self.damping_ratio, 0.0)

    def test(self, log_frequency, false_alarm_rate: float = 0.01) -> dict:
        """Whether one test's frequencies lie beyond the normal variation (the module's two tests).

        Parameters
        ----------
        log_frequency : array, shape (m,)    the test's ``ln f`` on the model's modes (NaN where absent)
        false_alarm_rate : float             in (0, 0.5)

        Returns
        -------
        dict: ``test`` (the one of smaller p-value: "hotelling" or "largest_z"), ``tests`` (those run),
        ``mode_index`` (0-based model modes compared), ``z_scores`` (per
        model mode, None where not compared), ``statistic``, ``threshold``, ``p_value``, ``beyond`` (bool),
        ``frequency_change_pct`` (against the baselines' mean, per model mode).
        """
        from scipy import stats  # heavy: loaded only when several baselines are tested

        if not 0.0 < false_alarm_rate < 0.5:
            raise BeamDamageError(f"false-alarm rate must lie in (0, 0.5), got {false_alarm_rate}")
        x = np.asarray(log_frequency, float)
        mean, std, dof = self.prediction()
        use = np.flatnonzero(np.isfinite(x) & np.isfinite(std))
        if use.size == 0:
            held = "sessions" if self.sessions is not None else "tests"
            raise BeamDamageError(f"no mode of the test is held by 2 or more baseline {held}: the normal variation "
                                  "cannot be measured")
        d = x - mean
        z = d / std
        dof = dof[use]
        full = self.log_frequency[:, use]
        complete = full[np.all(np.isfinite(full), axis=1)]
        n, p = complete.shape
        share = 2 if n >= p + HOTELLING_MIN_EXTRA and self.sessions is None else 1      # each test at alpha / share
        # the largest |z|: Bonferroni over the modes (p times the smallest two-sided p-value)
        tests = {"largest_z": (float(np.max(np.abs(z[use]))),
                               float(stats.t.isf(false_alarm_rate / (2 * use.size * share), int(np.median(dof)))),
                               float(min(1.0, use.size * np.min(2 * stats.t.sf(np.abs(z[use]), dof)))))}
        if share == 2:
            dev = complete - complete.mean(axis=0)
            S = dev.T @ dev / (n - 1) + FREQUENCY_STD_FLOOR**2 * np.eye(p)
            e = x[use] - complete.mean(axis=0)
            t2 = float(n / (n + 1) * e @ np.linalg.solve(S, e))
            scale = p * (n - 1) / (n - p)
            tests["hotelling"] = (t2, float(scale * stats.f.isf(false_alarm_rate / share, p, n - p)),
                                  float(stats.f.sf(t2 / scale, p, n - p)))
        kind = min(tests, key=lambda k: tests[k][2])
        statistic, threshold, p_value = tests[kind]
        p_value = min(1.0, share * p_value)
        with np.errstate(invalid="ignore"):
            change = 100 * np.expm1(d)
        return {"test": kind, "tests": sorted(tests), "mode_index": [int(k) for k in use],
                "z_scores": [float(v) if k in use else None for k, v in enumerate(z)],
                "statistic": statistic, "threshold": threshold, "p_value": p_value,
                "beyond": bool(p_value < false_alarm_rate),
                "frequency_change_pct": [float(v) if np.isfinite(v) else None for v in change]}

    def summary(self) -> dict:
        """The measured scatter for a verdict: counts, frequency (% of f), shape (largest entry's std per mode)
        and damping (percentage points) per model mode, and the reference baseline."""
        def listed(v, scale=1.0):
            return [float(scale * a) if np.isfinite(a) else None for a in v]

        shape = self.shape_std
        sessions = None
        if self.sessions is not None:
            g, sizes = len(self.sessions.sizes), "/".join(map(str, self.sessions.sizes))
            sessions = {"count": g, "sizes": list(self.sessions.sizes),
                        "first_tests": [self.names[k] for k in self.sessions.starts],
                        "jump_sigmas": [round(float(j), 1) for j in self.sessions.jump_sigmas],
                        "text": f"the {self.n_baselines} baseline tests fall into {g} sessions of {sizes} tests (their "
                                f"levels jump by {min(self.sessions.jump_sigmas):.0f}-"
                                f"{max(self.sessions.jump_sigmas):.0f} times the scatter between successive tests): a "
                                f"test is judged against the scatter of {g} sessions' levels, not of "
                                f"{self.n_baselines} independent tests; more sessions sharpen it"}
        return {"n_baselines": self.n_baselines, "measured": True, "reference_baseline": self.names[self.reference],
                "sessions": sessions,
                "modes_counts": [int(c) for c in self.counts],
                "frequency_mean_hz": listed(self.frequency_mean_hz),
                "frequency_std_pct": listed(self.frequency_std_rel, 100),
                "shape_std": None if shape is None else listed(np.nanmax(shape, axis=0)),
                "damping_std_pct": listed(self.damping_std, 100)}


def measure(baselines: list, beam, nominal_hz, names=None) -> NormalVariation:
    """The normal variation of several baseline tests (:class:`physics.io.ModalData` on the model's DOFs).

    Each baseline's poles are paired with the nominal beam's modes (:func:`learn.pairs.measured.modal_pair`, within
    :data:`learn.pairs.measured.RATIO_TOLERANCE`), then again with the baselines' median frequency of each mode, within
    :data:`learn.pairs.measured.BASELINE_PAIR_BAND` (:attr:`NormalVariation.targets`, the pairing of every later test):
    a spurious pole that the wide nominal rule paired in a baseline lacking the mode leaves that baseline without
    it. The reference baseline is the one holding the most modes whose frequencies lie nearest the baselines'
    medians (the sum of squared z-scores over the modes it holds). The baselines are taken in the order given, as
    tests in time order: their sessions (:func:`learn.sessions.baseline_sessions` over the modes every baseline
    holds) are :attr:`NormalVariation.sessions`.
    """
    names = tuple(names) if names else tuple(f"baseline {k + 1}" for k in range(len(baselines)))
    if len(baselines) < 2:
        raise BeamDamageError(f"the normal variation needs at least 2 baseline tests, got {len(baselines)}")
    first = np.stack([model_modes(b, beam, nominal_hz, n)[0] for b, n in zip(baselines, names)])
    m = first.shape[1]
    held = np.isfinite(first).any(axis=0)
    target_hz = np.asarray(nominal_hz, float)[:m].copy()
    poles = [np.log(np.abs(np.asarray(b.eigenvalues)) / (2 * np.pi)) for b in baselines]
    for j in np.flatnonzero(held):
        target_hz[j] = _baselines_mode_hz(poles, first[:, j])
    band = np.where(held, BASELINE_PAIR_BAND, RATIO_TOLERANCE)
    per = [model_modes(b, beam, target_hz, n, band) for b, n in zip(baselines, names)]
    lnf = np.stack([p[0] for p in per])
    zeta = np.stack([p[2] for p in per])
    held = np.sum(np.isfinite(lnf), axis=1)
    spread = _nanstd(lnf, FREQUENCY_STD_FLOOR)
    with np.errstate(invalid="ignore"):
        score = np.nansum(((lnf - np.nanmedian(lnf, axis=0)) / np.where(np.isfinite(spread), spread, 1.0)) ** 2,
                          axis=1)
    score = np.where(held == held.max(), score, np.inf)
    ref = int(np.argmin(score))
    shapes = None
    if all(p[1] is not None for p in per) and len({p[1].shape for p in per}) == 1:
        u = np.stack([p[1] for p in per])                                  # (N, S, m)
        anchor = np.nan_to_num(u[ref])
        shapes = np.where(np.isfinite(u), sign_aligned(np.nan_to_num(u), anchor[None]), np.nan)
    return NormalVariation(names, lnf, shapes, zeta, ref, target_hz, band, baseline_sessions(lnf))


def _baselines_mode_hz(poles: list, paired) -> float:
    """The baselines' frequency of one mode (Hz): among their poles within the nominal rule's reach of the mode
    (as far from the median of ``paired``, each baseline's ``ln f`` the nominal rule paired, NaN where none, as the
    farthest of them), the window ``+-BASELINE_PAIR_BAND / 2`` holding poles of the most baselines (the nearest to
    that median among equals: :func:`learn.densest_window.densest_window`); the median of each such baseline's pole
    nearest the window's centre. A spurious pole nearer the nominal frequency than the mode, which the nominal rule
    pairs in the baselines holding it, is outnumbered by the mode every baseline holds."""
    centre = float(np.nanmedian(paired))
    reach = float(np.nanmax(np.abs(paired - centre))) + BASELINE_PAIR_BAND
    x = np.concatenate(poles)
    who = np.concatenate([np.full(p.size, k) for k, p in enumerate(poles)])
    near = np.abs(x - centre) <= reach
    x, who = x[near], who[near]
    half = np.log1p(BASELINE_PAIR_BAND) / 2
    c = densest_window(x, who, half, centre)
    inside = np.abs(x - c) <= half
    pick = []
    for k in np.unique(who[inside]):
        xs = x[inside & (who == k)]
        pick.append(xs[np.argmin(np.abs(xs - c))])
    return float(np.exp(np.median(pick)))


def _nanmean(a: np.ndarray) -> np.ndarray:
    n = np.sum(np.isfinite(a), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.nansum(a, axis=0) / np.maximum(n, 1), np.nan)


def _nanstd(a: np.ndarray, floor: float) -> np.ndarray:
    """Sample std over axis 0 ignoring NaN, at least ``floor``; NaN where fewer than 2 values."""
    n = np.sum(np.isfinite(a), axis=0)
    dev = np.where(np.isfinite(a), a - _nanmean(a), 0.0)
    var = np.sum(dev**2, axis=0) / np.maximum(n - 1, 1)
    return np.where(n >= 2, np.maximum(np.sqrt(var), floor), np.nan)
