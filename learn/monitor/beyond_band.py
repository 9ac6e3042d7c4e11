"""A reference mode missing from its band, looked for beyond it and read against the baseline period: moved (a
pole beyond the band within the mode's reach) or lost, each reading weighed by the baseline's chance of it, and a
run of moved readings, a mode settled at a new frequency, by the chance of the run."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from learn.monitor.one_mode import shapes_at
from learn.monitor.tracking import MAC_MIN, MODE_LOST, MODE_MOVED, ReferenceModes, reach_bands_hz
from physics.modal import mac

__all__ = ["BeyondBands", "beyond_bands", "run_chances"]


@dataclass(frozen=True)
class BeyondBands:
    """The reference modes missing from their bands, read against the baseline period.

    Attributes
    ----------
    moved_hz : ndarray (n, m)      the pole that is the mode moved beyond its band (NaN elsewhere)
    moved_col : ndarray int (n, m) its column in the test (-1 elsewhere)
    lost : ndarray bool (n, m)     missing from its band with no pole within its reach, in a test with poles
    chance : ndarray (n, m)        the baseline period's chance of that reading (NaN where neither), from ``u``
                                   and ``w`` of its ``n`` tests (a baseline test's: of the other baseline tests):
                                   ``u`` lacking the mode in its band (tests not identified included), ``w``
                                   holding a pole no mode claims within its reach beyond its band; a lost mode
                                   ``(u + 1) / (n + 2)`` (Laplace's rule, as the index's
                                   :func:`learn.monitor.alarm_threshold.missing_evidence`); a moved mode
                                   ``u / n * (w + 1) / (n + 2)``: the share lacking the mode times Laplace's chance
                                   of a pole beyond its band (a mode the baseline found in every test gives 0)
    flagged : ndarray bool (n, m)  ``chance <= false_alarm_rate / m`` (the rate shared among the modes), or
                                   ``run_chance`` so, or any reading of a test :attr:`unplaced` against the
                                   baseline's odds
    missing_share, beyond_share : ndarray (m,)     ``u / n`` and ``w / n`` over the whole baseline period
    n_baseline : int               baseline tests of the series
    reach_hz : ndarray (m, 2)      :func:`reach_bands_hz` of a pole (``by_shape``)
    unplaced : ndarray bool (n,)   a test with poles none of which lies in any reference mode's band (the
                                   detector has no feature of it to judge)
    unplaced_chance : ndarray (n,) the baseline period's chance of that (NaN elsewhere): ``v / n``, ``v`` of its
                                   ``n`` tests (a baseline test's: of the other baseline tests) lacking every mode in
                                   its band (tests not identified included); 0 when every baseline test held a mode
    unplaced_flagged : ndarray bool (n,)   ``unplaced_chance <= false_alarm_rate``: every reading of the test flagged
    by_fft : ndarray bool (n, m)   a moved mode read by its FFT peak beyond its band (an FFT-peak-read mode,
                                   :mod:`learn.monitor.fft_beyond`; ``moved_col`` -1), its ``u`` and ``w`` the FFT
                                   peak's: baseline tests without an FFT peak in the band, with one beyond it within
                                   the reach
    run_chance, run_tests : ndarray (n, m)   :func:`run_chances`: the chance of the run of tests, ending at each,
                                   that read the mode moved and settled, and the run's length
    """

    moved_hz: np.ndarray
    moved_col: np.ndarray
    lost: np.ndarray
    chance: np.ndarray
    flagged: np.ndarray
    missing_share: np.ndarray
    beyond_share: np.ndarray
    reach_hz: np.ndarray
    n_baseline: int = 0
    unplaced: np.ndarray | None = None
    unplaced_chance: np.ndarray | None = None
    unplaced_flagged: np.ndarray | None = None
    by_fft: np.ndarray | None = None
    run_chance: np.ndarray | None = None
    run_tests: np.ndarray | None = None

    def status(self, i: int) -> str | None:
        """:data:`MODE_MOVED` when a mode of test ``i`` moved beyond its band against the baseline's odds, else
        :data:`MODE_LOST` when one was lost so, else None."""
        if (self.flagged[i] & np.isfinite(self.moved_hz[i])).any():
            return MODE_MOVED
        return MODE_LOST if (self.flagged[i] & self.lost[i]).any() else None

    def readings(self, i: int, ref: ReferenceModes) -> list:
        """Test ``i``'s modes missing from their bands: per mode ``mode`` (1-based), ``reading`` (``moved`` or
        ``lost``), ``frequency_hz`` and ``change_pct`` (against the reference frequency) of a moved one, ``chance``,
        ``flagged`` and ``unplaced`` (the test's poles all lie beyond the bands, against the baseline's odds:
        :attr:`unplaced_flagged`)."""
        out = []
        unplaced = bool(self.unplaced_flagged is not None and self.unplaced_flagged[i])
        for r in np.flatnonzero(np.isfinite(self.moved_hz[i]) | self.lost[i]):
            f = float(self.moved_hz[i, r])
            moved = math.isfinite(f)
            out.append({"mode": int(r) + 1, "reading": "moved" if moved else "lost",
                        "frequency_hz": f if moved else None,
                        "change_pct": 100 * (f / float(ref.frequencies_hz[r]) - 1) if moved else None,
                        "chance": float(self.chance[i, r]), "flagged": bool(self.flagged[i, r]),
                        "unplaced": unplaced, "run_tests": int(self.run_tests[i, r]) if moved else 0,
                        "run_chance": float(self.run_chance[i, r]) if moved else None})
        return out


def beyond_bands(tests: list, ref: ReferenceModes, cols, baseline, false_alarm_rate: float,
                 fft=None) -> BeyondBands:
    """The reference modes each test lacks in their bands, looked for beyond them and read against the baseline.

    ``cols``: the poles' columns from :func:`track_modes` (-1: the mode missing from its band); ``baseline``:
    indices of the baseline tests of the series (identified or not; a test of another kind, band or beam left out).
    In a test with poles, each missing mode takes the pole nearest it within its reach (:func:`reach_bands_hz`
    ``by_shape``; an FFT peak's by frequency, its open side the other side's half gap) beyond its band that no
    reference mode claims (with shapes of 2 or more sensors, MAC >= :data:`MAC_MIN`), one to one
    (``linear_sum_assignment`` of ``ln(f / f_ref)^2``): the mode moved, never a neighbour (a neighbour's band lies
    beyond the reach, or its shape differs); a mode with no such pole is lost. Each reading is weighed by the
    baseline period's chance of it (:class:`BeyondBands`) and flagged at or below ``false_alarm_rate / m`` (the rate
    shared among the modes). A moved mode is positive evidence: one the baseline found in every test is flagged; one
    the baseline lacked now and then only when the baseline was long enough to make a pole beyond its band rare by
    Laplace's rule. A lost mode is an absence only: by Laplace's rule a single one is flagged when the baseline held
    the mode in nearly all of at least ``m / false_alarm_rate - 2`` tests (298 for 3 modes at 1 %; never one the
    baseline lacked in half its tests); on a shorter baseline it adds its evidence to the novelty index
    (``missing_evidence`` of :mod:`learn.monitor.alarm_threshold`) and is reported unflagged in the row. A run of
    tests reading the mode moved, settled at a new frequency within half the gap to its neighbours (mirrored on an
    open side), is weighed by the run's chance (:func:`run_chances`, at least the baseline's own runs' share),
    flagged alike.

    A test with poles none of which lies in any reference mode's band (:attr:`BeyondBands.unplaced`) has no feature
    the detector can judge, yet its identification found modes: each mode is read moved (the pole nearest it in
    ``ln f`` within its reach, one to one) or lost as above, and when the baseline period's share of tests lacking
    every mode in its band is at most ``false_alarm_rate`` (none of 12: every baseline test held a reference mode)
    every reading is flagged, whatever the baseline's odds of each alone: such a test is a mode moved or lost, not a
    test not identified. A baseline whose tests lacked every mode now and then (FFT peaks jumping between modes)
    makes that reading ordinary: each mode is then weighed alone.
    """
    from scipy.optimize import linear_sum_assignment

    n, m = len(tests), ref.frequencies_hz.size
    cols = np.asarray(cols, int).reshape(n, m)
    chosen = np.zeros(m, bool) if fft is None else np.asarray(fft.chosen, bool)
    fft_miss = np.zeros((n, m), bool) if fft is None else chosen[None] & ~np.asarray(fft.in_band, bool)
    moved_hz, moved_col = np.full((n, m), np.nan), np.full((n, m), -1)
    by_fft = np.zeros((n, m), bool)                 # moved: the FFT peak beyond the band of an FFT-peak-read mode
    lost = np.zeros((n, m), bool)
    beyond = np.zeros((n, m), bool)                 # a pole no mode claims within the reach beyond the band
    beyond_fft = np.zeros((n, m), bool)             # an FFT peak within the reach beyond the band
    unplaced = np.zeros(n, bool)                    # poles, none in any band
    ln_ref = np.log(ref.frequencies_hz)
    reach = np.log(reach_bands_hz(ref, open_factor=False)) - ln_ref[:, None]     # (m, 2): -, + (FFT peaks)
    reach_pole = np.log(reach_bands_hz(ref, by_shape=True)) - ln_ref[:, None]     # poles: by shape too
    for i, t in enumerate(tests):
        if t is None or t.frequencies_hz.size == 0 or m == 0:
            continue
        unplaced[i] = bool((cols[i] < 0).all())
        free = np.setdiff1d(np.arange(t.frequencies_hz.size), cols[i][cols[i] >= 0])
        peaks = np.zeros((0, 2)) if fft is None else np.asarray(fft.peaks_hz[i], float)          # (m, 2)
        owner, _ = np.nonzero(np.isfinite(peaks))
        f = np.r_[t.frequencies_hz[free], peaks[np.isfinite(peaks)]]   # the free poles, then the FFT peaks
        if f.size == 0:
            lost[i] = cols[i] < 0
            continue
        is_fft = np.r_[np.zeros(free.size, bool), np.ones(owner.size, bool)]
        d = np.log(f)[:, None] - ln_ref[None]                                       # (k, m)
        r_k = np.where(is_fft[:, None, None], reach[None], reach_pole[None])                  # (k, m, 2)
        side = np.where(d < 0, r_k[..., 0], r_k[..., 1])
        ok = (np.abs(d) > ref.tolerance[None]) & (d / side <= 1.0)
        S = shapes_at(t, ref.dofs) if ref.shapes is not None else None
        if S is not None:
            ok[:free.size] &= mac(S[:, free], ref.shapes) >= MAC_MIN
        ok[free.size:] &= owner[:, None] == np.arange(m)[None]      # an FFT peak of its own mode's windows only
        beyond[i] = ok[:free.size].any(axis=0)
        beyond_fft[i] = ok[free.size:].any(axis=0)
        # an FFT-peak-read mode without a peak in its band is read by its FFT peak beyond it, else as the
        # identification reads it (a pole beyond the band where the identification lacks the mode in its band)
        ok[:free.size] &= ((cols[i] < 0) & ~(fft_miss[i] & beyond_fft[i]))[None]
        ok[free.size:] &= fft_miss[i][None]
        miss = np.flatnonzero((cols[i] < 0) | fft_miss[i])
        if miss.size:
            cost = np.where(ok[:, miss], d[:, miss] ** 2, 1e9)
            r, c = linear_sum_assignment(cost)
            keep = ok[:, miss][r, c]
            r, c = r[keep], miss[c[keep]]
            moved_hz[i, c] = f[r]
            by_fft[i, c] = is_fft[r]
            pole = ~is_fft[r]
            moved_col[i, c[pole]] = free[r[pole]]
            lost[i] = cols[i] < 0
            lost[i, c] = False
    base = np.asarray(baseline, int)
    lacking = np.array([[tests[i] is None or cols[i, r] < 0 for r in range(m)] for i in base], bool).reshape(-1, m)
    lacking_fft = np.array([[tests[i] is None or fft_miss[i, r] for r in range(m)] for i in base],
                           bool).reshape(-1, m)
    nb = max(base.size, 1)
    u, w = lacking.sum(axis=0).astype(float), beyond[base].sum(axis=0).astype(float)
    q, s, n_q = _baseline_shares(lacking, beyond[base], base, n)
    q_fft, s_fft, _ = _baseline_shares(lacking_fft, beyond_fft[base], base, n)
    q, s = np.where(by_fft, q_fft, q), np.where(by_fft, s_fft, s)
    moved = np.isfinite(moved_hz)
    none = np.array([tests[i] is None or bool((cols[i] < 0).all()) for i in base], bool)
    v = float(none.sum())
    share = np.full(n, v / nb)
    if base.size > 1:
        share[base] = (v - none) / (base.size - 1)
    unplaced_chance = np.where(unplaced, share, np.nan)
    unplaced_flagged = unplaced & (share <= false_alarm_rate)
    pole = (s * n_q + 1) / (n_q + 2)                # Laplace's chance of a pole beyond the band
    chance = np.where(moved, q * pole, np.where(lost, (q * n_q + 1) / (n_q + 2), np.nan))
    # runs only within half the gap to the neighbour mirrored on an open side: beyond it, where the open side's
    # factor reaches, a mode the reference modes lack (present in spells the baseline barely sampled) would run
    mirrored = np.log(reach_bands_hz(ref, by_shape=True, open_factor=False)) - ln_ref[:, None]
    with np.errstate(invalid="ignore"):
        d_moved = np.log(moved_hz) - ln_ref[None]
        near = (d_moved >= mirrored[None, :, 0]) & (d_moved <= mirrored[None, :, 1])
    run, run_tests = run_chances(chance, np.broadcast_to(pole, chance.shape), moved_hz, ref.tolerance, near)
    run = _runs_seen(run, run_tests, base, n_q)
    with np.errstate(invalid="ignore"):
        flagged = (moved | lost) & ((chance <= false_alarm_rate / max(m, 1)) | unplaced_flagged[:, None])
        flagged |= moved & (run <= false_alarm_rate / max(m, 1))
    return BeyondBands(moved_hz, moved_col, lost, chance, flagged, u / nb, w / nb,
                       reach_bands_hz(ref, by_shape=True), int(base.size), unplaced, unplaced_chance,
                       unplaced_flagged, by_fft, run, run_tests)


def run_chances(chance, pole_chance, moved_hz, tolerance, joins=None) -> tuple:
    """``(run_chance, run_tests)``, each (n, m): for a mode read moved beyond its band (``moved_hz`` finite, (n,
    m)), the chance of the run of consecutive tests, ending at it, that read the mode moved, each within
    ``tolerance`` (m,; the band's half-width in ``ln f``) of the one before (a mode settled at a new frequency, as
    a change leaves it and spurious poles scattered over the reach do not), and the run's length (NaN and 0
    elsewhere). A test with the mode in its band, lost or not identified ends a run; a reading outside ``joins``
    (bool (n, m); default every one) is a run of its own. The run's chance is its first
    reading's ``chance`` (n, m) times the ``pole_chance`` (n, m) of each later one (a pole beyond the band where the
    mode is lacking): a mode's absence from a record can persist over tests (a quiet spell), so it counts once,
    and the poles of a healthy structure's tests lie beyond the band independently."""
    moved_hz = np.asarray(moved_hz, float)
    n, m = moved_hz.shape
    moved = np.isfinite(moved_hz)
    linked = moved & (True if joins is None else np.asarray(joins, bool))
    ln_f = np.log(np.where(moved, moved_hz, 1.0))
    step = np.vstack([np.full((1, m), np.inf), np.abs(np.diff(ln_f, axis=0))])
    prev = np.vstack([np.zeros((1, m), bool), linked[:-1]])
    start = moved & ~(linked & prev & (step <= np.asarray(tolerance, float)[None]))
    idx = np.arange(n)[:, None] * np.ones((1, m), int)
    cols = np.arange(m)[None] * np.ones((n, 1), int)
    first = np.maximum.accumulate(np.where(start, idx, 0), axis=0)
    tiny = np.finfo(float).tiny                     # a chance of 0 as the least float: the sums stay finite
    c = np.where(moved, np.asarray(chance, float), 1.0)
    logs = np.log(np.maximum(np.where(moved, np.asarray(pole_chance, float), 1.0), tiny))
    cum = np.vstack([np.zeros((1, m)), np.cumsum(logs, axis=0)])
    run = np.exp(np.log(np.maximum(c[first, cols], tiny)) + cum[idx + 1, cols] - cum[first + 1, cols])
    run = np.where(c[first, cols] == 0.0, 0.0, run)
    return np.where(moved, run, np.nan), np.where(moved, idx - first + 1, 0)


def _runs_seen(run, run_tests, base, n_q) -> np.ndarray:
    """``run`` (n, m) where the baseline period held no run as long (each baseline test's of the other baseline
    tests) or the run is one reading; elsewhere at least Laplace's chance of a run that long, ``(w_k + 1) / (n +
    2)`` of the ``w_k`` baseline tests ending one of ``k`` tests or more: a structure whose poles beyond the band
    persist over tests (a mode the reference modes do not hold, a harmonic) is judged by its own runs, not by
    independent tests'."""
    out = np.array(run, float)
    base = np.asarray(base, int)
    own = np.zeros(len(out), bool)
    own[base] = True
    for j in range(out.shape[1]):
        k = run_tests[:, j]
        seen = np.sort(run_tests[base, j])
        w = seen.size - np.searchsorted(seen, k, side="left")          # baseline tests ending a run of >= k
        w = w - (own & (k > 0))                                          # a baseline test: of the others
        floor = (w + 1) / (n_q[:, 0] + 2)
        out[:, j] = np.where((k > 1) & (w > 0), np.maximum(out[:, j], floor), out[:, j])
    return out


def _baseline_shares(lacking, beyond, base, n: int):
    """``(q, s, n_q)``: per test (n, m) the baseline period's share of tests lacking the mode in its band
    (``lacking``, (b, m)) and holding a peak within its reach beyond it (``beyond``, (b, m)), each baseline test's
    of the other baseline tests, and the tests they count (n, 1)."""
    b, m = lacking.shape[0], lacking.shape[1]
    nb = max(b, 1)
    u, w = lacking.sum(axis=0).astype(float), beyond.sum(axis=0).astype(float)
    q = np.broadcast_to(u / nb, (n, m)).copy()
    s = np.broadcast_to(w / nb, (n, m)).copy()
    n_q = np.full((n, 1), float(b))
    if b > 1:                                       # a baseline test read against the other baseline tests
        q[base] = (u[None] - lacking) / (b - 1)
        s[base] = (w[None] - beyond) / (b - 1)
        n_q[base] = b - 1
    return q, s, n_q
