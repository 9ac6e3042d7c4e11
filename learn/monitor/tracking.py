"""The baseline period's modes (clustered poles, their median frequencies and dominant shapes) and each test's
poles assigned to them by frequency and, with 2 or more sensors, MAC."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from learn.densest_window import densest_window
from learn.pairs.measured import refit_missing_modes
from learn.monitor.identification import IdentificationSettings, cached_identification, with_narrow_band_poles
from learn.monitor.one_mode import dominant_shape, one_mode_groups, picks, shapes_at
from learn.monitor.two_modes import pair_cut, two_mode_groups
from learn.pairs.noise_calibration import robust_std
from physics.modal import mac

__all__ = ["APART_MAC", "CLUSTER_GAP", "MAC_MIN", "MIN_COUNT", "MIN_PRESENCE", "MODE_LOST", "MODE_MOVED",
           "REACH_FACTOR", "SEARCH_MIN", "ReferenceModes", "admissible", "identified_by", "narrow_bands_hz",
           "narrow_identifier", "reach_bands_hz", "reference_modes", "refit_missing", "search_bands_hz",
           "shape_accepts", "shapes_at", "track_modes"]

#: Baseline poles closer than this (relative) in frequency fall into one cluster.
CLUSTER_GAP = 0.05
#: A cluster is a reference mode when at least this share of the baseline tests, and at least :data:`MIN_COUNT`
#: of them, hold a pole within ``CORE`` (relative, half the cluster gap) of its centre. A mode that a test's
#: identification finds one time in four or five (a weakly excited mode, one near a node of the sensors) is then
#: tracked as itself, its presence reported, and keeps its poles out of its neighbours' slots; random spurious
#: poles, 1-2 per test spread over the band, put a pole in one 5 %-wide window in 4-8 % of the tests
#: (docs/monitoring.md).
MIN_PRESENCE = 0.15
#: The fewest baseline tests holding a reference mode: ``learn.monitor.alarm_threshold.minimum_baseline(1)``, the
#: fewest on which one feature's normal variation is learnt with its held-out index of finite variance.
MIN_COUNT = 7
CORE = math.log1p(CLUSTER_GAP / 2)
#: A pole is assigned to a reference mode within its tracking band: ``TOLERANCE_SIGMAS`` times the baseline's robust
#: scatter of the mode (std) in log frequency, at least ``MIN_TOLERANCE`` (``CORE``, the window that gathered the
#: mode's poles in the baseline) and the baseline's own reading of the mode furthest from it, never beyond
#: ``NEIGHBOUR_SHARE`` of the log gap to the next reference mode. A pole further off is no reading of the mode in
#: place but the mode moved (or a spurious pole): read beyond the band
#: (:func:`learn.monitor.beyond_band.beyond_bands`).
TOLERANCE_SIGMAS, MIN_TOLERANCE, NEIGHBOUR_SHARE = 10.0, CORE, 0.45
#: A reference mode is re-identified (:func:`refit_missing`, :mod:`learn.monitor.pole_confirmation`) over its search
#: band, at least this wide in log frequency either way (never beyond ``NEIGHBOUR_SHARE`` of the log gap to the next
#: reference mode), and only a pole of it within the mode's tracking band is taken: an output-only identification of a
#: short record over a band as narrow as the tracking band finds no stable pole where one over the wider band does.
SEARCH_MIN = math.log(1.15)
#: With 2 or more sensors, a pole is assigned only when its shape's MAC with the reference shape reaches this.
MAC_MIN = 0.6
#: With 2 or more sensors, two reference modes whose shapes' MAC lies below this are told apart by shape: neither
#: narrows the other's tracking band (``NEIGHBOUR_SHARE`` of the log gap), and a pole in the band so widened is the
#: mode's only when its MAC reaches :data:`MAC_MIN` with the mode and not with the neighbour (:func:`admissible`).
APART_MAC = 1 - MAC_MIN
#: A reference mode missing from its band is looked for beyond it up to half the log gap to the neighbouring
#: reference mode on each side, never beyond this factor in frequency (the open side of the lowest and highest mode,
#: and a lone mode's either side: up to this factor).
REACH_FACTOR = 2.0
#: The statuses of a test whose reference mode moved beyond its band, or was lost, against what the baseline period
#: makes likely (:attr:`learn.monitor.beyond_band.BeyondBands.flagged`).
MODE_MOVED, MODE_LOST = "mode moved", "mode lost"


@dataclass(frozen=True)
class ReferenceModes:
    """The baseline period's modes.

    Attributes
    ----------
    frequencies_hz : ndarray (m,)     median over the baseline tests
    log_std : ndarray (m,)            robust std of ``ln f`` over the baseline tests (1.4826 MAD)
    tolerance : ndarray (m,)          largest ``|ln(f / f_ref)|`` of an assigned pole: the tracking band
                                      (``TOLERANCE_SIGMAS`` std, the baseline's reading furthest from ``f_ref``, at
                                      least ``MIN_TOLERANCE``; within ``NEIGHBOUR_SHARE`` of the log gap to a neighbour
                                      not told apart by shape, :data:`APART_MAC`)
    shapes : ndarray complex (s, m) or None    dominant shape over the baseline tests (unit norm)
    dofs : tuple of str               rows of ``shapes``
    presence : ndarray (m,)           share of the baseline tests holding the mode
    frequency_tolerance : ndarray (m,) or None     the tracking band by frequency alone (within ``NEIGHBOUR_SHARE``
                                      of the log gap to every neighbour): a reading without a shape (an FFT peak) is
                                      the mode's within it; None: ``tolerance``
    """

    frequencies_hz: np.ndarray
    log_std: np.ndarray
    tolerance: np.ndarray
    shapes: np.ndarray | None
    dofs: tuple
    presence: np.ndarray
    frequency_tolerance: np.ndarray | None = None

    @property
    def by_frequency(self) -> np.ndarray:
        """:attr:`frequency_tolerance` (``tolerance`` where None), shape (m,)."""
        return self.tolerance if self.frequency_tolerance is None else self.frequency_tolerance


def reference_modes(tests: list) -> ReferenceModes:
    """Reference modes from the baseline tests (identified ones; None entries skipped).

    The baseline poles' ``ln f`` are pooled and split where consecutive ones lie more than :data:`CLUSTER_GAP`
    apart (a cluster holding on average 1.5 poles per test or more is split again at its widest gap, or where that
    chips off a side held by fewer tests than a core needs, where the most tests hold poles on both sides,
    :func:`learn.monitor.two_modes.pair_cut`: each test's poles of two modes fall either side). In each
    cluster, the window ``+-CORE`` holding poles of the most tests (:func:`learn.densest_window.densest_window`;
    its centre then the median of the poles within :data:`CORE`, three fixed-point steps), then the same among the
    poles outside it, and so on, is a core while it holds poles of at
    least :data:`MIN_PRESENCE` of the tests and of at least :data:`MIN_COUNT` of them (half of them on a baseline
    of fewer than ``2 MIN_COUNT`` tests) beyond the background: the poles of the clusters held by fewer than half
    of the tests spread evenly over the poles' ``ln f`` span, as many as a window ``2 CORE`` wide holds. Two or
    more cores in a cluster are as many reference modes (each pole to the nearest); a cluster holding poles of
    half of the tests is one, centred on its core or else its median; a single core of a cluster held by fewer is
    one, its poles within ``CORE``: a mode found in a quarter of the tests among spurious poles is tracked as
    itself. A reference mode so found that is two modes is split in two
    (:func:`learn.monitor.two_modes.two_mode_groups`: a fair share of the tests hold two poles of it, or its parts
    either side of its widest gap differ by shape), then neighbouring ones that are one mode are merged
    (:func:`learn.monitor.one_mode.one_mode_groups`): a mode whose poles scatter across a gap the split falls in is
    tracked as itself, not as two modes each found in part of the tests (the rule and its chances of a wrong merge
    or split: there). A mode's frequency is the median of each test's pole nearest its centre; ``presence`` the
    share of the tests holding a pole in it.
    """
    tests = [t for t in tests if t is not None]
    n = len(tests)
    logf = np.concatenate([np.log(t.frequencies_hz) for t in tests]) if n else np.zeros(0)
    who = np.concatenate([np.full(t.frequencies_hz.size, i) for i, t in enumerate(tests)]) if n else np.zeros(0, int)
    col = np.concatenate([np.arange(t.frequencies_hz.size) for t in tests]) if n else np.zeros(0, int)
    order = np.argsort(logf)
    logf, who, col = logf[order], who[order], col[order]
    cuts = [0, *(np.flatnonzero(np.diff(logf) > math.log1p(CLUSTER_GAP)) + 1), logf.size]
    clusters = [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
    done = []
    least = max(MIN_PRESENCE * n, min(MIN_COUNT, 0.5 * n))    # the tests a reference mode needs, background aside
    while clusters:
        a, b = clusters.pop()
        tests_in = np.unique(who[a:b]).size
        if b - a >= 1.5 * tests_in and b - a > 1:
            k = a + pair_cut(logf[a:b], who[a:b], least)
            clusters += [(a, k), (k, b)]
        else:
            done.append((a, b))
    done.sort()
    sparse = sum(b - a for a, b in done if np.unique(who[a:b]).size < 0.5 * n)
    span = float(logf[-1] - logf[0]) if logf.size > 1 else 0.0
    background = sparse * 2 * CORE / span if span > 0 else 0.0     # poles of a window where no mode lies
    need = least + background
    groups = []                                 # (members, centre) of each reference mode
    for a, b in done:
        idx = np.arange(a, b)
        centres = _cores(logf[idx], who[idx], need)
        if len(centres) > 1:                    # modes a gap of less than CLUSTER_GAP joined: each pole to its nearest
            near = np.argmin(np.abs(logf[idx, None] - np.asarray(centres)[None]), axis=1)
            groups += [(idx[near == k], c) for k, c in enumerate(centres)]
        elif np.unique(who[idx]).size >= 0.5 * n:
            groups.append((idx, centres[0] if centres else float(np.median(logf[idx]))))
        elif centres:
            groups.append((idx[np.abs(logf[idx] - centres[0]) <= CORE], centres[0]))
    groups.sort(key=lambda g: g[1])
    dofs = tests[0].dofs if n else ()
    zeta = np.concatenate([t.damping_ratios for t in tests])[order] if n else np.zeros(0)
    groups = two_mode_groups(groups, logf, who, col, tests, dofs, need, CORE, APART_MAC)
    groups = one_mode_groups(groups, logf, who, col, zeta, tests, dofs, n)
    freqs, stds, extremes, presence, shapes = [], [], [], [], []
    for members, centre in groups:
        pick = picks(members, centre, logf, who)
        v = logf[list(pick.values())]
        freqs.append(float(np.exp(np.median(v))))
        stds.append(robust_std(v))
        extremes.append(float(np.max(np.abs(v - np.median(v)))) * (1 + 1e-9))   # its own reading inside, roundoff
        presence.append(len(pick) / n)
        shapes.append(dominant_shape(pick, col, tests, dofs))
    f = np.asarray(freqs, float)
    s = np.asarray(stds, float)
    tol = np.maximum(np.maximum(TOLERANCE_SIGMAS * s, MIN_TOLERANCE), np.asarray(extremes, float))
    with_shapes = bool(shapes) and all(x is not None for x in shapes)
    S = np.stack(shapes, axis=1) if with_shapes else None
    by_frequency = np.minimum(tol, _neighbour_cap(f))
    tol = np.minimum(tol, _neighbour_cap(f, _told_apart(S)))
    return ReferenceModes(f, s, tol, S, tuple(dofs) if with_shapes else (), np.asarray(presence, float),
                          None if np.array_equal(tol, by_frequency) else by_frequency)


def _cores(logf, who, need: float) -> list:
    """Centres of the dense windows ``+-CORE`` of sorted ``logf`` holding poles of at least ``need`` tests (``who``:
    each pole's test), densest first: the window of :func:`learn.densest_window.densest_window` centred on the
    median of its poles (:func:`_core_centre`), then the same among the poles left outside it, while one holds
    enough tests."""
    left = np.arange(logf.size)
    centres = []
    while left.size:
        x = logf[left]
        centre = _core_centre(x, densest_window(x, who[left], CORE))
        inside = np.abs(x - centre) <= CORE
        if np.unique(who[left[inside]]).size < need:
            break
        centres.append(centre)
        left = left[~inside]
    return centres


def _core_centre(logf, centre: float) -> float:
    """The centre of the densest part of sorted ``logf`` near ``centre``: three times the median of the values
    within :data:`CORE` of the last centre. A core's window then holds a mode's scattered poles evenly on both
    sides, so the poles left outside it are too few to make a second core."""
    for _ in range(3):
        near = logf[np.abs(logf - centre) <= CORE]
        if near.size == 0:
            break
        centre = float(np.median(near))
    return centre


def _told_apart(shapes) -> np.ndarray | None:
    """Shape (m, m) bool: the pairs of reference modes told apart by shape (MAC of their reference shapes below
    :data:`APART_MAC`), None without shapes."""
    return None if shapes is None else mac(shapes, shapes) < APART_MAC


def admissible(ref: ReferenceModes, frequencies_hz, macs=None) -> np.ndarray:
    """Shape (k, m) bool: which of the poles (``frequencies_hz`` (k,), ``macs`` (k, m) with the reference shapes,
    None without shapes of 2 or more sensors) may be each reference mode's reading: within its tracking band
    (``tolerance``) and, with shapes, MAC >= :data:`MAC_MIN`; beyond its band by frequency alone (a band widened
    past a neighbour told apart by shape, :data:`APART_MAC`), besides, MAC below :data:`MAC_MIN` with each such
    neighbour whose cap the band passes."""
    d = np.abs(np.log(np.asarray(frequencies_hz, float))[:, None] - np.log(ref.frequencies_hz)[None])
    ok = d <= ref.tolerance[None]
    return ok if macs is None else ok & _shape_ok(ref, d, macs)


def _shape_ok(ref: ReferenceModes, d, macs) -> np.ndarray:
    """Shape (k, m) bool: :func:`admissible`'s conditions on the shapes, ``d`` (k, m) the poles' ``|ln(f /
    f_ref)|`` and ``macs`` (k, m) their MAC with the reference shapes."""
    like = macs >= MAC_MIN
    if ref.frequency_tolerance is None:
        return like
    lnf = np.log(ref.frequencies_hz)
    passed = _told_apart(ref.shapes) & (NEIGHBOUR_SHARE * np.abs(lnf[None] - lnf[:, None])
                                         < ref.tolerance[:, None])                   # (m, m): mode i's band passes j
    like_passed = like.astype(float) @ passed.T.astype(float) > 0                   # (k, m): like a neighbour passed
    return like & ~((d > ref.frequency_tolerance[None]) & like_passed)


def track_modes(tests: list, ref: ReferenceModes):
    """Each test's poles assigned to the reference modes: ``(frequencies (n, m), damping (n, m), mac (n, m),
    column (n, m))``, NaN (column -1) where a test holds no pole admissible as the mode's reading
    (:func:`admissible`: within its tolerance and, with shapes of 2 or more sensors, MAC >= :data:`MAC_MIN`).
    Poles and modes are paired one to one, minimising the sum of ``(ln(f / f_ref) / tolerance)^2 + (1 - MAC) /
    (1 - MAC_MIN)``; a pole beyond every tolerance is never assigned."""
    from scipy.optimize import linear_sum_assignment

    n, m = len(tests), ref.frequencies_hz.size
    F, Z, M = np.full((n, m), np.nan), np.full((n, m), np.nan), np.full((n, m), np.nan)
    cols = np.full((n, m), -1)
    ln_ref = np.log(ref.frequencies_hz)
    for i, t in enumerate(tests):
        if t is None or t.frequencies_hz.size == 0 or m == 0:
            continue
        d = (np.log(t.frequencies_hz)[:, None] - ln_ref[None]) / ref.tolerance[None]      # (k, m)
        cost = d**2
        S = shapes_at(t, ref.dofs) if ref.shapes is not None else None
        macs = mac(S, ref.shapes) if S is not None else None
        if macs is not None:
            cost = cost + (1 - macs) / (1 - MAC_MIN)
        ok = admissible(ref, t.frequencies_hz, macs)
        cost = np.where(ok, cost, 1e9)
        r, c = linear_sum_assignment(cost)
        keep = ok[r, c]
        r, c = r[keep], c[keep]
        F[i, c], Z[i, c], cols[i, c] = t.frequencies_hz[r], t.damping_ratios[r], r
        if macs is not None:
            M[i, c] = macs[r, c]
    return F, Z, M, cols


def _neighbour_cap(frequencies_hz, apart=None) -> np.ndarray:
    """``NEIGHBOUR_SHARE`` of each mode's log gap to its nearest neighbour, shape (m,) (inf for a lone mode): how
    far in ``ln f`` a mode's tracking or search band may reach; with ``apart`` ((m, m) bool, :func:`_told_apart`),
    to its nearest neighbour not told apart by shape."""
    lnf = np.log(np.asarray(frequencies_hz, float))
    gaps = np.abs(lnf[None] - lnf[:, None])
    np.fill_diagonal(gaps, np.inf)
    if apart is not None:
        gaps[apart] = np.inf
    return NEIGHBOUR_SHARE * gaps.min(axis=1, initial=np.inf)


def narrow_bands_hz(ref: ReferenceModes, by_frequency: bool = False) -> np.ndarray:
    """Each reference mode's tracking band ``f_ref exp(-+tolerance)`` (Hz), shape (m, 2): where a pole is a reading
    of the mode in place; ``by_frequency``: the band by frequency alone (:attr:`ReferenceModes.frequency_tolerance`),
    where a reading without a shape (an FFT peak) is."""
    tol = ref.by_frequency if by_frequency else ref.tolerance
    return ref.frequencies_hz[:, None] * np.exp(np.outer(tol, [-1.0, 1.0]))


def search_bands_hz(ref: ReferenceModes) -> np.ndarray:
    """Each reference mode's search band (Hz), shape (m, 2): the band of its narrow-band re-identification,
    ``f_ref exp(-+max(frequency_tolerance, SEARCH_MIN))``, never beyond ``NEIGHBOUR_SHARE`` of the log gap to the
    next reference mode; it holds the tracking band by frequency alone (:func:`narrow_bands_hz`). A close pair told
    apart by shape keeps its search bands apart: over both modes an output-only identification of a short record
    finds the stronger one where over the weaker one's own band it finds that one."""
    f = ref.frequencies_hz
    tol = ref.by_frequency
    half = np.maximum(np.minimum(np.maximum(tol, SEARCH_MIN), _neighbour_cap(f)), tol)
    return f[:, None] * np.exp(np.outer(half, [-1.0, 1.0]))


def refit_missing(tests: list, files: list, ref: ReferenceModes, settings: IdentificationSettings, cache_dir=None,
                  pending: list | None = None) -> list:
    """``tests`` with the modes the identification over the series' band missed found again around them.

    For each test of FRFs or response records (modal data are read as they are) and each reference mode
    :func:`track_modes` leaves untracked there, the file is identified again over the mode's search band alone
    (:func:`search_bands_hz`, within the file's lines; the same method, every mode found there:
    :func:`learn.monitor.identification.identify_test`, cached like the first identification); the pole of that
    identification nearest the mode within its tracking band (and, with shapes of 2 or more sensors, MAC >=
    :data:`MAC_MIN`) is added to the test (its ``narrow_band_hz`` says so), by
    :func:`learn.pairs.measured.refit_missing_modes`. A spurious pole of the first pass never took the mode's place (the
    assignment is one to one and stops at the tolerance), so a mode missed there is looked for where it lies, not
    filled from elsewhere.
    """
    F = track_modes(tests, ref)[0]
    out = list(tests)
    for i, t in enumerate(tests):
        if t is None or t.kind == "modal":
            continue
        for _, found, k, _, _ in refit_missing_modes(np.flatnonzero(np.isnan(F[i])), ref.frequencies_hz,
                                                     ref.tolerance, search_bands_hz(ref), t.band_hz,
                                                     narrow_identifier(files[i], settings, cache_dir, pending),
                                                     partial(shape_accepts, ref)):
            out[i] = with_narrow_band_poles(out[i], found, [k])
    return out


def narrow_identifier(path, settings: IdentificationSettings, cache_dir=None, pending: list | None = None):
    """``identify(lo, hi)`` -> ``(found, frequencies Hz)`` or None: the file's narrow-band re-identification over
    ``lo``-``hi`` Hz (:func:`learn.monitor.identification.cached_identification`, ``pending`` as there), the form
    :func:`learn.pairs.measured.refit_missing_modes` takes."""

    def identify(lo, hi):
        found = cached_identification(path, settings, cache_dir, pending, (lo, hi))[0]
        return None if found is None else (found, found.frequencies_hz)

    return identify


def shape_accepts(ref: ReferenceModes, found, r: int):
    """True, or per pole of ``found`` whether its shape makes it reference mode ``r``'s reading (with shapes of 2 or
    more sensors: :func:`admissible` but for the band, MAC >= :data:`MAC_MIN` with the mode and, beyond its band by
    frequency alone, below it with the neighbours told apart by shape that the band passes)."""
    S = shapes_at(found, ref.dofs) if ref.shapes is not None else None
    if S is None:
        return True
    d = np.abs(np.log(found.frequencies_hz)[:, None] - np.log(ref.frequencies_hz)[None])
    return _shape_ok(ref, d, mac(S, ref.shapes))[:, r]


def identified_by(tests: list, cols) -> list:
    """Per test, per reference mode, how its tracked pole was found (:meth:`IdentifiedModes.identified_by`), None
    where the mode is missing; ``cols`` the poles' columns from :func:`track_modes`."""
    return [[None if t is None or c < 0 else t.identified_by(int(c)) for c in row] for t, row in zip(tests, cols)]


def reach_bands_hz(ref: ReferenceModes, by_shape: bool = False, open_factor: bool = True) -> np.ndarray:
    """Each reference mode's reach (Hz), shape (m, 2): where a pole that no other mode claims is that mode moved
    beyond its band: up to half the log gap to the neighbouring reference mode on each side, never beyond
    :data:`REACH_FACTOR` (the open side of the lowest and highest mode, where no neighbour's pole can lie, and a lone
    mode's either side: that factor). A neighbour's band (at most ``NEIGHBOUR_SHARE`` of the gap) never reaches
    into it. ``open_factor=False``: the open side mirrors the other side's half gap (an FFT peak's reach: the
    highest local maximum of a window as wide as the factor is often a stronger mode's leakage).

    ``by_shape``: with reference shapes, a neighbour told apart by shape (:data:`APART_MAC`) bounds no reach, as it
    bounds no tracking band (:func:`reference_modes`): a pole is the mode moved only when its MAC reaches
    :data:`MAC_MIN` with the mode (:func:`learn.monitor.beyond_band.beyond_bands`), which a pole of that neighbour
    does not, so the reach runs to half the gap to the nearest neighbour not told apart (a side without one: open).
    A close pair's band passes the neighbour (e.g. +-4 % for modes 1.7 % apart); the reach by frequency alone, half
    the gap, lies inside that band and holds no pole beyond it. Without shapes the reach by frequency (a reading
    without a shape: an FFT peak)."""
    f = ref.frequencies_hz
    cap = math.log(REACH_FACTOR)
    m = f.size
    if m == 0:
        return np.zeros((0, 2))
    lnf = np.log(f)
    apart = _told_apart(ref.shapes) if by_shape else None
    bound = ~apart if apart is not None else np.ones((m, m), bool)        # (m, m): j bounds i's reach
    np.fill_diagonal(bound, False)
    below = np.where(bound & (lnf[None] < lnf[:, None]), lnf[:, None] - lnf[None], np.inf).min(axis=1)
    above = np.where(bound & (lnf[None] > lnf[:, None]), lnf[None] - lnf[:, None], np.inf).min(axis=1)
    if not open_factor:                                                 # an open side: the other side's gap
        below, above = np.where(np.isfinite(below), below, above), np.where(np.isfinite(above), above, below)
    half = np.minimum(0.5 * np.c_[below, above], cap)                   # an open side: the factor
    return f[:, None] * np.exp(half * [-1.0, 1.0])
