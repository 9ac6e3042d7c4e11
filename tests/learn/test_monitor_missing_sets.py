"""A set of missing modes each of which some baseline test also lacked is judged at the rate against its own
thresholds, not alarmed by the product of the modes' shares: a seeded simulation of a 12-test baseline whose short
records lose modes 1, 2 and 4 together (the DROPBEAR two-channel walkthrough's held-out dwell 6), or lose them in
sets the baseline lost apart but never together."""

import warnings

import numpy as np
import pytest

from learn.monitor.normal_models import PCARemoval
from learn.monitor.statistics import detect

#: Sets of modes (0-based) a short record loses, and their chances; half the records are short.
SETS, CHANCES = [(0, 1, 3), (0, 3), (1,), ()], [0.3, 0.3, 0.2, 0.2]


def _series(rng, n):
    """``ln f`` of 4 modes (0.2 % each, 0.3 % common), half the tests short, losing a set of :data:`SETS`."""
    X = 0.002 * rng.standard_normal((n, 4)) + 0.003 * rng.standard_normal((n, 1))
    pick = np.searchsorted(np.cumsum(CHANCES), rng.random(n))
    for i in np.flatnonzero(rng.random(n) < 0.5):
        X[i, list(SETS[pick[i]])] = np.nan
    return X


def test_a_set_of_modes_the_baseline_lost_together_alarms_at_about_the_rate():
    rate, nb, nn = 0.01, 12, 200
    seen_rates, apart_rates, complete_rates = [], [], []
    for seed in range(4):
        X = _series(np.random.default_rng(seed), nb + nn)
        model = PCARemoval(None).fit(X[:nb])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            det = detect(model, model.with_choices, X, None, np.arange(nb), np.arange(nb, nb + nn), rate,
                         statistics=("residual",))
        miss = ~np.isfinite(X)
        lost_together = np.array([miss[:nb][:, m].all(axis=1).any() for m in miss[nb:]])
        some = miss[nb:].any(axis=1)
        each_lost = (~miss[nb:] | miss[:nb].any(axis=0)).all(axis=1)
        seen_rates.append(det.alarm[nb:][some & lost_together].mean())
        apart = some & each_lost & ~lost_together
        if apart.any():                               # seeds 1 and 3: 22 and 30 tests
            apart_rates.append(det.alarm[nb:][apart].mean())
        complete_rates.append(det.alarm[nb:][~some].mean())
    # a flat 0.01-0.03 for both: the 12-test baseline's own scatter of the rate; the product of the shares alone
    # alarmed 0.45-0.55 of the tests of such sets, and every test of a set lost apart
    assert np.mean(seen_rates) < 0.06
    assert np.mean(seen_rates) < 3 * max(np.mean(complete_rates), 0.01)
    assert len(apart_rates) == 2 and np.mean(apart_rates) < 0.06


def test_a_held_out_baseline_test_carries_the_other_tests_evidence_in_its_threshold():
    """40 baseline tests of 6 modes driven by 4 factors; 3 tests lose modes 2, 3 and 6 together (mode 3 also alone
    in 17, mode 2 in 10). Held out, each of the 3 has the evidence of its loss against the other 39 tests in its
    index (``-2 ln`` of Laplace's shares 13/41, 20/41, 3/41: 8.963), the modes it keeps explained by the factors
    (residual 0.002). Its set is normal (2 other tests lost it): its threshold is the set's residual threshold
    (0.178) plus that same evidence, ratio 0.98. Against the evidence over all 40 tests (8.286) each would alarm, ratio
    1.059: 3 of 40 held-out baseline tests at a 1 % rate."""
    from learn.monitor.alarm_threshold import missing_evidence

    rng = np.random.default_rng(7)
    nb = 40
    X = 0.003 * rng.standard_normal((nb, 4)) @ rng.standard_normal((4, 6)) + 0.0003 * rng.standard_normal((nb, 6))
    X[:3, [1, 2, 5]] = np.nan
    X[3:20, 2] = np.nan
    X[20:30, 1] = np.nan
    model = PCARemoval(4).fit(X)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        det = detect(model, lambda: PCARemoval(4), X, None, np.arange(nb), np.arange(0), 0.01,
                     statistics=("residual",))
    P = np.array([0, 1, 1, 0, 0, 1], bool)
    ev_all = missing_evidence(np.where(P, np.nan, 0.0)[None], X)[0]
    ev_held = missing_evidence(np.where(P, np.nan, 0.0)[None], X[1:])[0]
    assert ev_held == pytest.approx(-2 * np.log(13 / 41 * 20 / 41 * 3 / 41)) and ev_all == pytest.approx(
        -2 * np.log(14 / 42 * 21 / 42 * 4 / 42))
    t = det.patterns["2, 3, 6"]["residual"][0].value                 # the set's threshold, all 40 tests' evidence
    np.testing.assert_allclose(det.ratios[:3, 0], det.values[:3, 0] / (t - ev_all + ev_held), rtol=1e-12)
    assert np.all(det.values[:3, 0] - ev_held < 0.01) and t - ev_all > 0.1
    assert not det.alarm[:3].any() and det.alarm.mean() == 0.0
