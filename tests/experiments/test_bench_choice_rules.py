"""bench_choice_rules' residual-based estimator choice on a baseline with a closed-form residual scatter."""

import numpy as np

from experiments.benches.bench_choice_rules import held_out_residuals, rule_choice
from learn.pairs.noise_calibration import robust_std

N = 60
SIG_A, SIG_B = 1e-4, 3e-4
U = np.full(4, 0.5)                         # the environment's direction: every mode alike
V = np.array([0.5, -0.5, 0.5, -0.5])        # estimator A's common error (a glide shared by its modes)


def _baseline(seed=0):
    """``ln f`` (N, 4) by two estimators: A with a large error common to its modes (sd 6e-3 along V) and small
    independent ones (SIG_A), B with independent errors (SIG_B) alone; both see the environment (sd 4e-3 along U)."""
    rng = np.random.default_rng(seed)
    env = rng.normal(0, 4e-3, N)[:, None] * U
    XA = 4.0 + env + rng.normal(0, 6e-3, N)[:, None] * V + rng.normal(0, SIG_A, (N, 4))
    XB = 4.0 + env + rng.normal(0, SIG_B, (N, 4))
    return XA, XB


def test_the_held_out_residual_scatter_is_the_independent_error_left_by_the_removed_components():
    XA, XB = _baseline()
    RA, kA = held_out_residuals(XA)
    RB, kB = held_out_residuals(XB)
    assert (kA, kB) == (2, 1)               # A: environment and glide removed; B: the environment
    # per mode, (I - U U') of independent noise: sigma^2 (1 - sum_k U_rk^2), each U_rk^2 = 1/4
    sA = np.exp(np.mean(np.log([robust_std(r) for r in RA.T])))
    sB = np.exp(np.mean(np.log([robust_std(r) for r in RB.T])))
    np.testing.assert_allclose(sA, SIG_A * np.sqrt(0.5), rtol=0.3)
    np.testing.assert_allclose(sB, SIG_B * np.sqrt(0.75), rtol=0.3)


def test_the_common_error_loses_the_raw_comparison_and_wins_on_the_residual():
    XA, XB = _baseline()
    raw = np.array([[robust_std(XA[:, r]), robust_std(XB[:, r])] for r in range(4)])
    assert np.all(raw[:, 1] < raw[:, 0])    # per mode by raw scatter: B everywhere
    eligible = np.ones(4, bool)
    for rule in ("one-residual", "one-volume", "mode-residual"):
        chosen, _ = rule_choice(rule, XA, XB, eligible)
        assert not chosen.any(), rule       # on what the normal model leaves: A everywhere
    chosen, _ = rule_choice("one-residual", XB, XA, eligible)   # the roles swapped: the FFT peak is A
    assert chosen.all()
    chosen, _ = rule_choice("one-residual", XB, XA, np.zeros(4, bool))
    assert not chosen.any()                 # nothing eligible: nothing chosen
