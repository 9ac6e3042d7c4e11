"""Sessions within the baseline period (learn/sessions.py) and the detector held out a session at a time."""

import numpy as np
import pytest

import learn.monitor.statistics as statistics
from learn.monitor.normal_models import PCARemoval
from learn.sessions import JUMP_SIGMAS, baseline_sessions
from learn.monitor.statistics import detect, held_out_folds

LOG_F = np.log([20.0, 130.0, 370.0])


def _sessions(rng, offsets, per=10, noise=1e-4):
    """Log frequencies of sessions of ``per`` tests, each moving the three modes by its offset (about alike)."""
    load = 1.0 + 0.1 * rng.standard_normal(3)
    return LOG_F + np.concatenate([o * load + noise * rng.standard_normal((per, 3)) for o in offsets])


def test_the_sessions_are_read_at_the_jumps_between_runs_of_tests():
    rng = np.random.default_rng(1)
    X = _sessions(rng, [0.0, 0.005, -0.004, 0.002])
    found = baseline_sessions(X)
    assert found.starts == (0, 10, 20, 30) and found.sizes == (10, 10, 10, 10)
    assert min(found.jump_sigmas) > JUMP_SIGMAS and found.explained > 0.99
    labels = np.zeros(len(X), int)
    for k, fold in enumerate(found.folds()):
        labels[fold] = k
    np.testing.assert_array_equal(labels, np.repeat(np.arange(4), 10))
    folds, n_train, n_env = held_out_folds(X)
    assert [f.tolist() for f in folds] == [list(range(k, k + 10)) for k in (0, 10, 20, 30)]
    assert (n_train, n_env) == (30, 3)              # the tests and the sessions a held-out model sees
    assert baseline_sessions(X, min_training=31) is None
    X[14:16] += 0.003                                     # two tests off their session's level: still four
    assert baseline_sessions(X).sizes == (10, 10, 10, 10)
    X[9:11] = (X[5] + X[15]) / 2                          # two tests between two sessions' levels: none read
    assert baseline_sessions(X) is None


@pytest.mark.parametrize("case", ["noise", "drift", "outlier", "short run", "missing mode", "grid"])
def test_one_session_is_read_where_no_run_of_tests_stands_apart(case):
    rng = np.random.default_rng(2)
    hits = 0
    for _ in range(50 if case == "noise" else 1):
        X = LOG_F + 1e-4 * rng.standard_normal((40, 3))
        if case == "drift":
            X += np.linspace(0, 20e-4, 40)[:, None]     # 20 of its scatter over the period: no jump
        elif case == "outlier":
            X[17] += 50e-4
        elif case == "short run":
            X[20:22] += 50e-4                             # two tests apart: shorter than a session
        elif case == "grid":                              # readings on lines, most successive tests alike
            X = np.log(np.round(np.exp(X) / 0.05) * 0.05)
        elif case == "missing mode":
            X[20:] += 50e-4                               # two sessions, read on the modes every test holds
            X[::3, 1] = np.nan
        hits += baseline_sessions(X) is not None
    assert hits == (1 if case == "missing mode" else 0)


def _new_session_alarms(rng, n_draws, damage=0.0):
    flagged = []
    for _ in range(n_draws):
        X = _sessions(rng, rng.standard_normal(5) * 0.005)
        X[40:, 2] += damage                               # the later (fifth) session: mode 3 alone moved
        model = PCARemoval().fit(X[:40])
        det = detect(model, model.with_choices, X, None, np.arange(40), np.arange(40, 50), 0.01)
        flagged.append(det.alarm[40:].mean())
    return float(np.mean(flagged))


def test_a_new_session_like_the_baseline_ones_is_no_alarm_and_a_change_within_it_is(monkeypatch):
    """Four baseline sessions drawn alike lie beyond a fifth's range with chance 2/5: held out one test at a time,
    the session's mates kept in the model, the new session alarms on the environment statistics; held out a
    session at a time it alarms near the rate, and a change of one mode by 20 of the tests' scatter is seen."""
    assert _new_session_alarms(np.random.default_rng(3), 25) < 0.03
    assert _new_session_alarms(np.random.default_rng(4), 10, damage=20e-4) > 0.9
    monkeypatch.setattr(statistics, "held_out_sessions", lambda X, C=None: None)
    assert _new_session_alarms(np.random.default_rng(3), 25) > 0.1


def test_a_baseline_of_one_session_is_named_when_no_later_test_looks_healthy(tmp_path):
    """Later sessions 0.3 % apart against a one-session baseline of 0.03 % scatter: every later test is flagged, so
    there is no scatter ratio; the later tests beyond the baseline's conditions name the baseline too narrow."""
    from experiments.benches.bench_monitor_sessions import session_series
    from learn.monitor import IdentificationSettings, SeriesInput, monitor_series
    from learn.monitor.coverage import baseline_scatter

    files = session_series(tmp_path, 0.003, 0)
    res = monitor_series(SeriesInput.from_files(files), 30, IdentificationSettings(), progress=False, chart="none")
    assert not any(r["status"] == "no alarm" for r in res.rows[30:])
    sc = baseline_scatter(res.rows)
    assert sc.ratio is None and sc.warning.startswith("0 of the 90 later tests look healthy and 90 lie beyond")
    within = [{**r, "extrapolated": r["baseline"] or k % 2 == 0} for k, r in enumerate(res.rows)]
    assert baseline_scatter(within).warning.startswith("0 of the 90 later tests look healthy and 45 lie beyond")
    within = [{**r, "extrapolated": r["baseline"] or k % 3 == 0} for k, r in enumerate(res.rows)]
    assert baseline_scatter(within).warning is None                 # a third beyond: no warning


def _third_session_alarms(rng, n_draws, damage=0.0):
    """Share of a later third session's tests alarmed against a baseline of two sessions (``damage``: mode 3 moved
    in it), each session 10 tests."""
    flagged = []
    for _ in range(n_draws):
        offsets = [0.0, rng.choice([-1, 1]) * rng.uniform(0.004, 0.008), 0.005 * rng.standard_normal()]
        X = _sessions(rng, offsets)
        X[20:, 2] += damage
        model = PCARemoval().fit(X[:20])
        det = detect(model, model.with_choices, X, None, np.arange(20), np.arange(20, 30), 0.01)
        flagged.append(det.alarm[20:].mean())
    return float(np.mean(flagged))


def test_a_baseline_of_two_sessions_holds_the_pattern_statistics_out_one_test_at_a_time(monkeypatch):
    """A model fitted on one session holds none of the sessions' variation among its components: held out a
    session at a time, a baseline of two sessions gives the residual and the per-mode statistic thresholds beyond
    any change. Held out one test at a time (the components fitted on both sessions) a later session like them is
    no alarm and a change of one mode by 20 of the tests' scatter is seen; the environment is still judged as two
    values."""
    X = _sessions(np.random.default_rng(5), [0.0, 0.006])
    folds, n_train, n_env = held_out_folds(X)
    assert [f.tolist() for f in folds] == [list(range(10)), list(range(10, 20))] and (n_train, n_env) == (10, 1)
    folds, n_train, n_env = held_out_folds(X, environment=False)
    assert len(folds) == 20 and (n_train, n_env) == (19, None)
    assert statistics.training_sizes(X) == (10, 1, 19)
    assert _third_session_alarms(np.random.default_rng(6), 60) < 0.02
    assert _third_session_alarms(np.random.default_rng(7), 10, damage=20e-4) > 0.9
    every = held_out_folds
    monkeypatch.setattr(statistics, "held_out_folds", lambda X, C=None, environment=True: every(X, C))
    assert _third_session_alarms(np.random.default_rng(7), 10, damage=20e-4) < 0.1
