"""Where baseline poles are two modes: the cut of a cluster at its widest gap or, where that chips a tail off, the
cut that the most tests hold poles on both sides of (:func:`pair_cut`), and a candidate reference mode that many
baseline tests hold two poles of, or whose parts either side of its widest gap differ by shape, split in two
(:func:`two_mode_groups`), the reverse of :func:`learn.monitor.one_mode.one_mode_groups`."""

from __future__ import annotations

import numpy as np

from learn.monitor.one_mode import dominant_shape, picks
from physics.modal import mac

__all__ = ["pair_cut", "pairs_in", "two_mode_groups"]


def pair_cut(logf, who, least: float) -> int:
    """Where a cluster of baseline poles that is several modes is cut in two: ``k``, the poles ``[:k]`` of sorted
    ``logf`` (shape (p,), ``who`` their tests) below. At the widest gap between consecutive poles, unless a side
    holds poles of fewer than ``least`` tests (fewer than a reference mode needs: a tail of a mode chipped off) and
    some cut has poles of at least ``least`` tests on both sides; then the cut that the most tests hold poles on both
    sides of, among those the widest gap. A test holds one pole of each mode it finds: two modes' poles lie either
    side of that cut however much their scatters overlap, where the widest gap may fall in a mode's sparse tail, the
    rest of the two modes then one cluster and one core. A cut fewer tests straddle shows no two modes found
    together (one mode among spurious poles)."""
    gap = np.diff(logf)
    k = 1 + int(np.argmax(gap))
    if min(np.unique(who[:k]).size, np.unique(who[k:]).size) >= least:
        return k
    j = np.arange(logf.size)
    _, t = np.unique(who, return_inverse=True)
    first = np.full(t.max() + 1, logf.size)
    last = np.full(t.max() + 1, -1)
    np.minimum.at(first, t, j)
    np.maximum.at(last, t, j)
    span = np.zeros(logf.size + 1)
    np.add.at(span, first + 1, 1)                   # cut k (between poles k - 1 and k) lies within (first, last]
    np.add.at(span, last + 1, -1)
    both = np.cumsum(span)[1:logf.size]             # tests with poles on both sides of cut k = 1 .. p - 1
    if both.max() < least:                          # too few tests hold poles either side to show two modes
        return k
    best = np.flatnonzero(both == both.max())
    return 1 + int(best[np.argmax(gap[best])])


def pairs_in(members, logf, who) -> np.ndarray:
    """The tests holding two or more poles among ``members`` (indices into the pooled baseline poles' sorted
    ``logf``; ``who`` their tests), each test's lowest and highest: shape (k, 2) indices into ``logf``, a row per
    test."""
    members = np.asarray(members, int)
    if members.size == 0:
        return np.zeros((0, 2), int)
    o = np.lexsort((logf[members], who[members]))           # by test, then by ln f
    m, t = members[o], who[members][o]
    new = np.r_[True, t[1:] != t[:-1]]                      # each test's first pole, then its last
    lo, hi = m[new], m[np.r_[new[1:], True]]
    return np.c_[lo, hi][lo != hi]


def two_mode_groups(groups: list, logf, who, col, tests: list, dofs: tuple, need: float, window: float,
                    apart_mac: float) -> list:
    """``groups`` ((members, centre) in frequency order, as :func:`learn.monitor.one_mode.one_mode_groups` takes
    them; ``col`` each pole's column in its test) with each that is two modes split in two, each part's centre the
    median ``ln f`` of its poles (the others as they are).

    *Found together.* The baseline tests holding two poles of a group within ``window`` (``ln f``) of its centre
    (:func:`pairs_in`; a test counts only when it holds a pole of each other group whose centre lies within ``2
    window``, whose pole the pair may otherwise be) number at least ``need``, the tests a reference mode's core
    needs (``MIN_PRESENCE`` and ``MIN_COUNT`` of them beyond the background of spurious poles in a window as wide,
    :func:`learn.monitor.tracking.reference_modes`): the second mode is seen beside the first in a fair share of the
    baseline and is tracked as itself. The split falls at the median of those tests' midpoints between their two
    poles, where each test's two poles separate. Shapes do not enter: a mode the records resolve as two poles of one
    shape in a fair share of the tests is two modes, as :func:`~learn.monitor.one_mode.one_mode_groups` keeps two
    such candidates apart. The rule's statistics, the tests counted as independent draws: one mode whose pole a
    test's identification doubles with chance ``q`` is split with the binomial chance ``P(X >= need)``, ``X ~ B(n,
    q)``: on 40 tests (``need`` 7 without background) 5.5e-5 for ``q`` 1/40 (a doubled pole one test in 40), 3.4e-3
    for 0.05, 0.10 for 0.1; on 20 tests (``need`` 7) 3.6e-7 and 3.4e-5. Two modes found together in a share ``p``
    of the tests stay one with chance ``P(X < need)``, ``X ~ B(n, p)``: on 40 tests 0.096 for ``p`` 0.25, 5.9e-4
    for 0.4, 4.2e-6 for 0.5; on 20 tests 0.058 for 0.5, 1e-6 for 0.81. A pair so split is found together in
    ``need`` or more tests: :func:`~learn.monitor.one_mode.one_mode_groups` never merges it back (its chance of so
    many tests holding both, were they two parts of one mode, is near 1, never at most ``SAME_MODE_CHANCE``).

    *Apart by shape.* Otherwise, with shapes of 2 or more sensors, the group cut at its widest gap between
    consecutive poles among the cuts leaving poles of at least ``need`` tests on each side is two modes when the
    parts' dominant shapes (:func:`~learn.monitor.one_mode.dominant_shape`) have a MAC below ``apart_mac``: two
    modes a test finds one or the other of (one pole found between them), told apart by shape, which
    ``one_mode_groups`` keeps apart (it merges only parts alike, MAC >= ``SAME_MAC``), unless a part's shape is not
    so apart from a close group's (centre within ``2 window``): that group's poles scattered across the boundary."""
    out = []
    for g, (members, centre) in enumerate(groups):
        members = np.sort(np.asarray(members, int))
        rows = pairs_in(members[np.abs(logf[members] - centre) <= window], logf, who)
        close = [np.asarray(m, int) for h, (m, c) in enumerate(groups) if h != g and abs(c - centre) <= 2 * window]
        for other in close:
            rows = rows[np.isin(who[rows[:, 0]], who[other])]
        if rows.shape[0] >= max(need, 1):
            cut = float(np.median(0.5 * (logf[rows[:, 0]] + logf[rows[:, 1]])))
            parts = [members[logf[members] < cut], members[logf[members] >= cut]]
        else:
            shapes = [_shape(m, logf, who, col, tests, dofs) for m in close]
            parts = _apart_by_shape(members, logf, who, col, tests, dofs, need, apart_mac,
                                    [x for x in shapes if x is not None])
        if len(parts) == 1:
            out.append(groups[g])
        else:
            out += [(part, float(np.median(logf[part]))) for part in parts if part.size]
    return out


def _shape(members, logf, who, col, tests: list, dofs: tuple):
    """The dominant shape of ``members``' poles, each test's nearest their median ``ln f`` (None without shapes)."""
    return dominant_shape(picks(members, float(np.median(logf[members])), logf, who), col, tests, dofs)


def _apart_by_shape(members, logf, who, col, tests: list, dofs: tuple, need: float, apart_mac: float,
                    neighbours: list) -> list:
    """``members`` (sorted) cut at their widest gap in ``logf`` among the cuts leaving poles of ``need`` tests or
    more on each side, when the parts' dominant shapes' MAC lies below ``apart_mac`` and each part's shape is apart
    so from the ``neighbours``' (dominant shapes of the close groups), else ``[members]`` (:func:`two_mode_groups`)."""
    t = who[members]
    _, first = np.unique(t, return_index=True)
    _, from_end = np.unique(t[::-1], return_index=True)
    k = np.arange(1, members.size)                                  # cut k: members[:k] below
    left = np.searchsorted(np.sort(first), k)                       # tests with a pole below the cut
    right = np.sum((members.size - 1 - from_end)[:, None] >= k[None], axis=0)     # with a pole above it
    ok = (left >= max(need, 1)) & (right >= max(need, 1))
    if not ok.any():
        return [members]
    k = int(k[ok][np.argmax(np.diff(logf[members])[ok])])
    parts = [members[:k], members[k:]]
    shapes = [_shape(p, logf, who, col, tests, dofs) for p in parts]
    if any(x is None for x in shapes):
        return [members]
    S = np.stack(shapes + neighbours, axis=1)
    apart = mac(S[:, :2], S) < apart_mac                            # (2, 2 + neighbours)
    return parts if apart[0, 1] and apart[:, 2:].all() else [members]
