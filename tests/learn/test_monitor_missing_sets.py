"""A set of missing modes that some baseline test also lacked is judged at the rate against its own thresholds, not
alarmed by the product of the modes' shares: a seeded simulation of a 12-test baseline whose short records lose
modes 1, 2 and 4 together (the DROPBEAR two-channel walkthrough's held-out dwell 6)."""

import warnings

import numpy as np

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
    seen_rates, complete_rates = [], []
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
        seen_rates.append(det.alarm[nb:][some & lost_together].mean())
        complete_rates.append(det.alarm[nb:][~some].mean())
    # a flat 0.01-0.03 for both: the 12-test baseline's own scatter of the rate; the product of the shares alone
    # alarmed 0.45-0.55 of the tests of such sets
    assert np.mean(seen_rates) < 0.06
    assert np.mean(seen_rates) < 3 * max(np.mean(complete_rates), 0.01)
