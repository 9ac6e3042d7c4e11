"""The real-series bench's pure functions on a synthetic series: the FFT peaks in each mode's window, the plain
tests' quantile thresholds, the per-group scores."""

import numpy as np

from experiments.benches.bench_real_series import fft_frequencies, group_scores, mode_windows_hz, reference_fft_modes
from experiments.benches.plain_tests import plain_alarms


def _decays(freqs_hz, fs=1000.0, n=4000, zeta=0.01, seed=0):
    """Free decays of two modes, one per row of ``freqs_hz`` (Hz), a little noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    out = []
    for f in freqs_hz:
        y = sum(np.exp(-zeta * 2 * np.pi * fk * t) * np.cos(2 * np.pi * fk * np.sqrt(1 - zeta ** 2) * t)
                for fk in f)
        out.append((y + 1e-4 * rng.standard_normal(n))[None])
    return out


def test_the_fft_modes_of_a_series_of_decays_are_its_frequencies_and_a_moved_mode_is_followed_in_its_window():
    base = [(20.0 * (1 + 1e-3 * k), 90.0) for k in range(8)]
    moved = [(24.0, 90.0), (20.0, 70.0)]                   # mode 1 +20 %, mode 2 -22 %: within their windows
    recs = _decays(base + moved)
    fs = np.full(len(recs), 1000.0)
    ref = reference_fft_modes(recs[:8], fs[:8], (5.0, 200.0))
    np.testing.assert_allclose(ref, [20.0 * 1.0035, 90.0], rtol=3e-3)
    w = mode_windows_hz(ref, (5.0, 200.0))
    g = np.sqrt(ref[1] / ref[0])                            # half the log gap, either side of each mode
    np.testing.assert_allclose(w, [[ref[0] / g, ref[0] * g], [ref[1] / g, ref[1] * g]])
    np.testing.assert_allclose(mode_windows_hz([50.0], (5.0, 200.0)), [[5.0, 200.0]])     # one mode: the band
    F = fft_frequencies(recs, fs, w)
    # the peak of a decay lies at the damped frequency, within a fraction of the 0.25 Hz resolution
    np.testing.assert_allclose(F, np.sqrt(1 - 0.01 ** 2) * np.array(base + moved), rtol=2e-3)


def test_the_plain_tests_alarm_beyond_the_baselines_own_quantiles_on_either_side():
    rng = np.random.default_rng(1)
    F = np.array([10.0, 60.0]) * (1 + 1e-3 * rng.standard_normal((2003, 2)))
    F[2000] = [10.0 * 1.01, 60.0]       # mode 1 up 1 % (10 sd): the mean shift 0.5 % (7 sd), both tests see it
    F[2001] = [10.0 * 0.997, 60.0]      # mode 1 down 0.3 % (3 sd): beyond the per-mode 0.25 % quantile only
    F[2002] = [np.nan, np.nan]          # nothing found: no alarm
    a = plain_alarms(F, 2000, 0.01, sides=2, method="linear")
    rel = F / np.median(F[:2000], axis=0) - 1
    mean = rel.mean(axis=1)
    lo, hi = np.quantile(mean[:2000], [0.005, 0.995])
    np.testing.assert_array_equal(a["plain shift"][:2000], (mean[:2000] < lo) | (mean[:2000] > hi))
    assert a["plain shift"][:2000].mean() == 0.01           # the baseline's own quantiles: 1 % of its tests
    assert 0.01 <= a["plain per mode"][:2000].mean() <= 0.011
    assert a["plain shift"][2000] and a["plain per mode"][2000]
    assert not a["plain shift"][2001] and a["plain per mode"][2001]
    assert not a["plain shift"][2002] and not a["plain per mode"][2002]


def test_group_scores_count_each_groups_flags_and_split_the_first_methods_misses():
    groups = ["baseline"] * 4 + ["intact"] * 2 + ["change"] * 4
    mon = np.array([0, 1, 0, 0, 0, 0, 1, 0, 0, 0], bool)
    plain = np.array([0, 0, 0, 0, 1, 0, 1, 1, 1, 0], bool)
    ident = np.array([1, 1, 1, 1, 1, 1, 1, 0, 1, 1], bool)
    rows = group_scores(groups, {"monitor": mon, "plain": plain}, ident, 4, known=False)
    by = {r["group"]: r for r in rows}
    assert by["baseline"]["monitor"] == 0.25 and by["intact"]["plain"] == 0.5 and by["change"]["plain"] == 0.75
    assert by["intact"]["missed, below threshold"] == 1 and by["intact"]["missed, not identified"] == 0
    assert by["change"]["missed, not identified"] == 1 and by["change"]["missed, below threshold"] == 1
    assert by["change"]["identified"] == 3
    assert by["first flagged later test"] == {"group": "first flagged later test", "monitor": 6, "plain": 4}
