"""A mode whose frequency glides over its decay: the band refinement merges every unresolved pair it leaves (also
after its last planned sweep), :func:`mode_glide` reads the glide against the closed-form weighted slopes of the
phase, and ``era`` warns of a gliding mode it fitted as one pole for a peak its first fit split."""

import warnings

import numpy as np
import pytest

from physics.identification import band_refine
from physics.identification.band_refine import refine_in_bands
from physics.identification.free_decay import identify_era
from physics.identification.glide import mode_glide


def _poles(f_hz, zeta):
    w = 2 * np.pi * np.asarray(f_hz, float)
    z = np.asarray(zeta, float)
    return -z * w + 1j * w * np.sqrt(1 - z ** 2)


def _weighted_hz(t, delta, w, f0, sigma):
    """The undamped natural frequency of the ``w``-weighted least-squares slope of the phase ``delta(t)``."""
    tm = np.sum(w * t) / np.sum(w)
    return np.hypot(f0 + np.sum(w * (t - tm) * delta) / np.sum(w * (t - tm) ** 2) / (2 * np.pi), sigma / (2 * np.pi))


@pytest.mark.parametrize("start_hz", [[99.4, 100.1], [99.8, 100.5]])
def test_a_sweep_that_leaves_an_unresolved_pair_is_followed_by_another(monkeypatch, start_hz):
    # one sweep planned (SWEEPS = 1): two starting poles of one exact damped exponential (100 Hz damped, 1 %),
    # unresolved after it, are merged and the one left is refitted alone: the mode, exact
    monkeypatch.setattr(band_refine, "SWEEPS", 1)
    fs, n, zeta = 1000.0, 2000, 0.01
    t = np.arange(n) / fs
    sigma = zeta * 2 * np.pi * 100.0
    y = (np.exp(-sigma * t) * np.cos(2 * np.pi * 100.0 * t))[None]
    res = refine_in_bands([y], fs, _poles(start_hz, [zeta, zeta]))
    kept = np.flatnonzero(res.converged & ~res.merged)
    assert kept.size == 1 and res.merged.sum() == 1, (res.natural_frequencies_hz, res.merged)
    np.testing.assert_allclose(res.natural_frequencies_hz[kept[0]], np.hypot(100.0, sigma / (2 * np.pi)), rtol=1e-9)
    assert np.all(res.merged_into[res.merged] == kept[0]) and np.all(res.merged_into[~res.merged] == -1)
    assert np.all(np.isfinite(res.merged_with_hz[res.merged])) and np.all(np.isnan(res.merged_with_hz[~res.merged]))


FS, N, F0, ZETA = 1000.0, 4000, 50.0, 0.005
SIGMA = 2 * np.pi * F0 * ZETA


@pytest.mark.parametrize("c_hz", [0.2, -0.5])
def test_the_glide_of_a_stiffening_or_softening_decay_lies_between_the_weighted_slopes(c_hz):
    # instantaneous frequency f0 + c A(t), A = exp(-sigma t): each half's one-pole fit reads between the A- and the
    # A^2-weighted slopes of its phase (first order; the band is narrower than the full least squares)
    t = np.arange(N) / FS
    a = np.exp(-SIGMA * t)
    delta = 2 * np.pi * c_hz * (1 - a) / SIGMA
    y = (a * np.cos(2 * np.pi * F0 * t + delta))[None]
    fit = refine_in_bands([y], FS, [-SIGMA + 2j * np.pi * F0])
    g = mode_glide([y], FS, fit.eigenvalues, fit.amplitudes, 0)
    h = N // 2
    for got, part in ((g.early_hz, slice(0, h)), (g.late_hz, slice(h, N))):
        lo, hi = sorted(_weighted_hz(t[part], delta[part], w, F0, SIGMA) for w in (a[part], a[part] ** 2))
        assert lo - 1e-3 * abs(c_hz) <= got <= hi + 1e-3 * abs(c_hz), (got, lo, hi)
    assert g.significant and np.sign(g.relative) == -np.sign(c_hz)


def test_a_linear_decay_does_not_glide():
    t = np.arange(N) / FS
    y = np.exp(-SIGMA * t) * np.cos(2 * np.pi * F0 * t)
    fn = np.hypot(F0, SIGMA / (2 * np.pi))
    fit = refine_in_bands([y[None]], FS, [-SIGMA + 2j * np.pi * F0])
    g = mode_glide([y[None]], FS, fit.eigenvalues, fit.amplitudes, 0)
    np.testing.assert_allclose([g.early_hz, g.late_hz], fn, rtol=1e-10)          # noise-free: exact
    noisy = (y + 0.01 * np.random.default_rng(2).standard_normal(N))[None]
    fit = refine_in_bands([noisy], FS, [-SIGMA + 2j * np.pi * F0])
    g = mode_glide([noisy], FS, fit.eigenvalues, fit.amplitudes, 0)
    assert not g.significant and abs(g.late_hz - g.early_hz) < 3 * np.hypot(g.early_std_hz, g.late_std_hz)


def _board(c_hz, seed):
    """A hit board (one channel, 20 kHz, 0.14 s): a 1.2 %-damped mode at 755 Hz whose frequency is ``755 + c A(t)``
    (``c > 0``: stiffer at the loud start), a 4.4-kHz mode, 0.2 % noise, 10 ms of silence before the hit."""
    fs, n, f0, zeta = 20000.0, 2800, 755.0, 0.012
    t = np.arange(n) / fs
    sigma = 2 * np.pi * f0 * zeta
    a = np.exp(-sigma * t)
    delta = 2 * np.pi * c_hz * (1 - a) / sigma
    y = a * np.cos(2 * np.pi * f0 * t + delta) + 0.3 * np.exp(-2 * np.pi * 44.0 * t) * np.cos(2 * np.pi * 4400 * t)
    y = np.r_[np.zeros(200), y + 0.002 * np.random.default_rng(seed).standard_normal(n)]
    return y[None], fs, t, a, delta, f0, sigma


def _era(y, fs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify_era(y, fs, (400.0, 6000.0))
    return res, [str(w.message) for w in caught if "glides" in str(w.message)]


@pytest.mark.slow
def test_era_warns_of_a_gliding_mode_it_read_as_one_pole_and_not_of_a_linear_one():
    y, fs, t, a, delta, f0, sigma = _board(25.0, 1)
    res, said = _era(y, fs)
    f = res.estimate.natural_frequencies_hz
    mode = f[(f > 700) & (f < 800)]
    assert mode.size == 1 and res.bands.merged.any()
    lo, hi = (_weighted_hz(t, delta, w, f0, sigma) for w in (a, a ** 2))      # 761.4 and 766.2 Hz
    assert lo <= mode[0] <= hi, (mode, lo, hi)
    assert len(said) == 1 and f"mode at {mode[0]:.6g} Hz" in said[0] and "glides -" in said[0], said
    y, fs, *_ = _board(0.0, 1)
    res, said = _era(y, fs)
    f = res.estimate.natural_frequencies_hz
    assert not said and np.min(np.abs(f - np.hypot(755.0, sigma / (2 * np.pi)))) < 0.1, f
