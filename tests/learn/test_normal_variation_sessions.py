"""Several baselines that fall into sessions (learn/pairs/normal_variation.py with learn/sessions.py): a later
session judged against the sessions' levels, not against tests counted as independent."""

import numpy as np
import pytest

from learn.pairs.normal_variation import NormalVariation
from learn.pairs.verdict import normal_variation_text
from learn.sessions import baseline_sessions

#: Sessions of this many tests; the sessions' levels scatter by SIGMA_B (common to the modes and each mode's own),
#: the tests within a session by SIGMA_W (relative, ln f).
SESSION_TESTS, SIGMA_B, SIGMA_W = 10, 5e-3, 5e-5
F_HZ = np.array([25.0, 160.0, 450.0])


def _sessions(rng, g, offsets=None):
    """``g`` sessions of SESSION_TESTS tests (ln f, (g * SESSION_TESTS, 3)), then one test of a new session; the
    sessions' levels drawn, or their common part ``offsets`` (g,) times SIGMA_B."""
    def level(k):
        common = rng.standard_normal() if offsets is None or k >= g else offsets[k]
        return np.log(F_HZ) + SIGMA_B * (0.8 * common + 0.6 * rng.standard_normal(F_HZ.size))
    base = np.concatenate([level(k) + SIGMA_W * rng.standard_normal((SESSION_TESTS, F_HZ.size)) for k in range(g)])
    return base, level(g) + SIGMA_W * rng.standard_normal(F_HZ.size)


def _nv(base, sessions=True):
    names = tuple(f"t{k}" for k in range(len(base)))
    return NormalVariation(names, base, None, np.zeros_like(base), 0, sessions=baseline_sessions(base) if sessions
                           else None)


def test_a_new_session_is_judged_against_the_sessions_levels():
    """400 draws of 4 baseline sessions of 10 tests and one test of a fifth session (levels 100x the scatter within
    a session): read as sessions, a test of the new session alarms at about the 1 % asked for (binomial mean 4, 95 %
    range 1-9); its 40 tests counted as independent, on most draws. A change of 4 standard deviations of a new
    session's level in one mode is found more often than the false alarms, though 3 degrees of freedom make the
    threshold wide."""
    rng = np.random.default_rng(11)
    alarms, naive, found, read = 0, 0, 0, 0
    for _ in range(400):
        base, new = _sessions(rng, 4)
        nv = _nv(base)
        read += nv.sessions is not None and len(nv.sessions.sizes) == 4
        alarms += nv.test(new, 0.01)["beyond"]
        naive += _nv(base, sessions=False).test(new, 0.01)["beyond"]
        found += nv.test(new + np.array([-4 * SIGMA_B, 0.0, 0.0]), 0.01)["beyond"]
    assert read >= 360
    assert 1 <= alarms <= 12, alarms
    assert naive >= 200, naive
    assert found >= 4 * max(alarms, 5), found


def test_the_prediction_of_a_new_session_is_the_one_way_layout_s_closed_form():
    """Balanced sessions: the location is the grand mean, the variance ``s_m^2 (1 + 1/g) + s_w^2 (1 - 1/n)`` from
    the one-way analysis of variance computed here (between and within mean squares), the degrees of freedom
    Satterthwaite's; one session: the mean, ``s sqrt(1 + 1/N)`` and ``N - 1``."""
    rng = np.random.default_rng(5)
    base, _ = _sessions(rng, 5, [0.0, 2.0, -1.0, 1.0, -2.0])
    nv = _nv(base)
    assert nv.sessions.sizes == (10,) * 5
    loc, std, dof = nv.prediction()
    Y = base.reshape(5, SESSION_TESTS, -1)
    means = Y.mean(axis=1)
    ms_between = SESSION_TESTS * np.var(means, axis=0, ddof=1)           # the one-way layout's mean squares
    ms_within = np.sum((Y - means[:, None]) ** 2, axis=(0, 1)) / (5 * (SESSION_TESTS - 1))
    a = ms_between / SESSION_TESTS * (1 + 1 / 5)
    b = ms_within * (1 - 1 / SESSION_TESTS)
    np.testing.assert_allclose(loc, base.mean(axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(std, np.sqrt(a + b), rtol=1e-10)
    np.testing.assert_allclose(dof, (a + b) ** 2 / (a**2 / 4 + b**2 / (5 * (SESSION_TESTS - 1))), rtol=1e-10)
    assert np.all((dof > 3.9) & (dof < 5.0))
    one = _nv(base[:SESSION_TESTS])
    assert one.sessions is None
    loc1, std1, dof1 = one.prediction()
    np.testing.assert_allclose(std1, base[:SESSION_TESTS].std(axis=0, ddof=1) * np.sqrt(1 + 1 / SESSION_TESTS))
    np.testing.assert_array_equal(dof1, np.full(3, SESSION_TESTS - 1.0))


def test_the_summary_names_the_sessions_and_the_test_runs_no_hotelling():
    rng = np.random.default_rng(2)
    base, new = _sessions(rng, 3, [0.0, 2.0, -1.0])
    nv = _nv(base)
    summary = nv.summary()["sessions"]
    assert summary["count"] == 3 and summary["sizes"] == [10, 10, 10] and summary["first_tests"] == ["t0", "t10", "t20"]
    assert "30 baseline tests fall into 3 sessions of 10/10/10 tests" in summary["text"]
    assert nv.test(new)["tests"] == ["largest_z"]
    assert _nv(base, sessions=False).test(new)["tests"] == ["hotelling", "largest_z"]
    assert _nv(base, sessions=False).summary()["sessions"] is None
    assert nv.frequency_mean_hz == pytest.approx(np.exp(base.mean(axis=0)))


def test_the_verdicts_text_says_the_baselines_sessions():
    """The verdict's normal-variation line names the sessions and what they do to the test."""
    rng = np.random.default_rng(2)
    base, new = _sessions(rng, 3, [0.0, 2.0, -1.0])
    nv = _nv(base)
    text = normal_variation_text({**nv.summary(), **nv.test(new), "false_alarm_rate": 0.01})
    assert text.startswith("Normal variation measured on 30 baseline tests (reference t0)")
    assert ("; the 30 baseline tests fall into 3 sessions of 10/10/10 tests (their levels jump by" in text
            and "a test is judged against the scatter of 3 sessions' levels, not of 30 independent tests" in text)
    assert "; this test's frequencies change by" in text
