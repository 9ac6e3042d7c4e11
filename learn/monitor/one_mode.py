"""Candidate reference modes that are one mode: their poles never both in a baseline test, alike by shape, within
the half-power half-width (:func:`one_mode_groups`), and the helpers a reference mode is summarised by."""

from __future__ import annotations

import numpy as np

from learn.monitor.identification import IdentifiedModes
from physics.modal import mac

__all__ = ["SAME_MAC", "SAME_MODE_CHANCE", "SAME_MODE_CHANCE_ALONE", "dominant_shape", "one_mode_groups", "picks",
           "same_mode_chance", "shapes_at"]

#: Two neighbouring candidate reference modes are one mode, their poles merged, when their frequencies lie within the
#: half-power half-width (the median damping ratio of their poles, in ``ln f``), with shapes of 2 or more sensors their
#: dominant shapes' MAC reaches ``SAME_MAC``, and the baseline tests holding both are so few that two modes found
#: independently would hold that few with a chance of at most ``SAME_MODE_CHANCE`` (``SAME_MODE_CHANCE_ALONE`` by
#: frequency alone: one sensor, or shapes missing): :func:`same_mode_chance`. One mode's poles, split in two clusters
#: where a gap between them falls, are never both in a test but for a doubled pole; two modes both resolved now and
#: then are, and two of different shapes stay apart whatever their tests.
SAME_MAC, SAME_MODE_CHANCE, SAME_MODE_CHANCE_ALONE = 0.9, 0.01, 1e-4


def shapes_at(t: IdentifiedModes, dofs: tuple):
    """``t.shapes`` with rows in the order ``dofs`` (None without shapes or with fewer than 2 sensors)."""
    if t.shapes is None or len(dofs) < 2 or set(t.dofs) != set(dofs):
        return None
    return t.shapes[[t.dofs.index(d) for d in dofs]]


def picks(members, centre: float, logf, who) -> dict:
    """Per test holding a pole among ``members`` (indices into ``logf``), the index of its pole nearest ``centre``
    in ``ln f``: ``{test: index}``."""
    pick = {}
    for j in members:
        i = int(who[j])
        if i not in pick or abs(logf[j] - centre) < abs(logf[pick[i]] - centre):
            pick[i] = int(j)
    return pick


def dominant_shape(pick: dict, col, tests: list, dofs: tuple):
    """The dominant shape (unit norm, shape (s,)) of the picked poles (:func:`picks`; ``col`` each pole's column in
    its test), the first left singular vector of their unit-norm shapes; None when a test lacks shapes of 2 or
    more sensors."""
    rows = [shapes_at(tests[i], dofs) for i in pick]
    if not rows or any(r is None for r in rows):
        return None
    S = np.stack([r[:, col[j]] for r, j in zip(rows, pick.values())], axis=1)   # (s, n_picked)
    S = S / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
    return np.linalg.svd(S, full_matrices=False)[0][:, 0]


def one_mode_groups(groups: list, logf, who, col, zeta, tests: list, dofs: tuple, n: int) -> list:
    """``groups`` ((members, centre) in frequency order; ``members`` indices into the pooled baseline poles' sorted
    ``logf``, ``who`` their tests, ``col`` their columns there, ``zeta`` their damping ratios; ``n`` tests) with
    neighbouring ones that are one mode merged (:data:`SAME_MODE_CHANCE`), the pair of smallest chance first, until
    no pair is; a merged group's centre the median ``ln f`` of its poles. A pair without damping ratios (NaN) is
    never merged.

    The rule's statistics (:func:`same_mode_chance`, the hypergeometric law of the tests holding both given how many
    hold each): two distinct modes whose detections are independent are merged with a chance of at most
    :data:`SAME_MODE_CHANCE` (1 %) when their shapes are alike (MAC >= :data:`SAME_MAC`) and they lie within the
    half-power half-width, at most :data:`SAME_MODE_CHANCE_ALONE` (0.01 %) by frequency alone. Two modes whose
    detections exclude each other (one pole found between them) are merged when their shapes cannot tell them apart
    (alike, or one sensor): the records then give one mode. One mode split in two clusters never found together
    (``both`` 0) stays split when its parts are too rare for the evidence: on 40 tests with shapes a part found in
    7 tests is merged with one found in 18 or more (4 with 27, 12 with 12), by frequency alone 7 with 27 (12 with
    19; a part of 3 never); on 20 tests with shapes 5 with 11; on 12 tests 3 with 9 (by frequency alone never). A
    doubled pole (two poles of the mode in one test) counts in ``both`` and weakens the evidence, e.g. 24 and 12 of
    40 with one test holding both: chance 1.9e-5.
    """
    groups = list(groups)
    while len(groups) > 1:
        chosen = [picks(m, c, logf, who) for m, c in groups]
        shapes = [dominant_shape(p, col, tests, dofs) for p in chosen]
        best, at = np.inf, -1
        for k in range(len(groups) - 1):
            a, b = chosen[k], chosen[k + 1]
            half_width = float(np.median(zeta[[*a.values(), *b.values()]]))
            if not abs(groups[k + 1][1] - groups[k][1]) <= half_width:   # beyond the half-power half-width
                continue
            with_shapes = shapes[k] is not None and shapes[k + 1] is not None
            if with_shapes and mac(shapes[k][:, None], shapes[k + 1][:, None])[0, 0] < SAME_MAC:
                continue
            chance = same_mode_chance(n, len(a), len(b), len(a.keys() & b.keys()))
            if chance <= (SAME_MODE_CHANCE if with_shapes else SAME_MODE_CHANCE_ALONE) and chance < best:
                best, at = chance, k
        if at < 0:
            break
        members = np.concatenate([groups[at][0], groups[at + 1][0]])
        groups[at:at + 2] = [(members, float(np.median(logf[members])))]
    return groups


def same_mode_chance(n: int, k1: int, k2: int, both: int) -> float:
    """The chance that two modes, found in ``k1`` and ``k2`` of ``n`` tests independently of each other, are both
    found in at most ``both`` tests: the hypergeometric law's ``P(X <= both)``, ``X`` the tests of the ``k2`` among
    the ``k1``. Small: the two are (nearly) never found together, as the poles of one mode split in two."""
    from scipy.stats import hypergeom

    return float(hypergeom.cdf(both, n, k1, k2))

