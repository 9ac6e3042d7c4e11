"""The baseline period's modes (clustered poles, their median frequencies and dominant shapes) and each test's
poles assigned to them by frequency and, with 2 or more sensors, MAC."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from learn.monitor.identification import IdentifiedModes
from learn.noise_calibration import robust_std
from physics.modal import mac

__all__ = ["CLUSTER_GAP", "MAC_MIN", "MIN_PRESENCE", "ReferenceModes", "reference_modes", "shapes_at",
           "track_modes"]

#: A reference mode is a cluster of baseline poles found in at least this share of the baseline tests.
MIN_PRESENCE = 0.5
#: Baseline poles closer than this (relative) in frequency fall into one cluster.
CLUSTER_GAP = 0.05
#: A pole is assigned to a reference mode within ``max(TOLERANCE_SIGMAS * std, MIN_TOLERANCE)`` of it in log
#: frequency (std: the baseline's robust scatter of the mode), never beyond ``NEIGHBOUR_SHARE`` of the log gap to
#: the next reference mode.
TOLERANCE_SIGMAS, MIN_TOLERANCE, NEIGHBOUR_SHARE = 10.0, math.log(1.15), 0.45
#: With 2 or more sensors, a pole is assigned only when its shape's MAC with the reference shape reaches this.
MAC_MIN = 0.6


@dataclass(frozen=True)
class ReferenceModes:
    """The baseline period's modes.

    Attributes
    ----------
    frequencies_hz : ndarray (m,)     median over the baseline tests
    log_std : ndarray (m,)            robust std of ``ln f`` over the baseline tests (1.4826 MAD)
    tolerance : ndarray (m,)          largest ``|ln(f / f_ref)|`` of an assigned pole
    shapes : ndarray complex (s, m) or None    dominant shape over the baseline tests (unit norm)
    dofs : tuple of str               rows of ``shapes``
    presence : ndarray (m,)           share of the baseline tests holding the mode
    """

    frequencies_hz: np.ndarray
    log_std: np.ndarray
    tolerance: np.ndarray
    shapes: np.ndarray | None
    dofs: tuple
    presence: np.ndarray


def shapes_at(t: IdentifiedModes, dofs: tuple):
    """``t.shapes`` with rows in the order ``dofs`` (None without shapes or with fewer than 2 sensors)."""
    if t.shapes is None or len(dofs) < 2 or set(t.dofs) != set(dofs):
        return None
    return t.shapes[[t.dofs.index(d) for d in dofs]]


def reference_modes(tests: list) -> ReferenceModes:
    """Reference modes from the baseline tests (identified ones; None entries skipped).

    The baseline poles' ``ln f`` are pooled and split where consecutive ones lie more than :data:`CLUSTER_GAP`
    apart (a cluster holding on average 1.5 poles per test or more is split again at its widest gap); a cluster
    found in at least :data:`MIN_PRESENCE` of the tests is a reference mode, its frequency the median of each
    test's pole nearest the cluster's median.
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
    while clusters:
        a, b = clusters.pop()
        tests_in = np.unique(who[a:b]).size
        if b - a >= 1.5 * tests_in and b - a > 1:
            k = a + 1 + int(np.argmax(np.diff(logf[a:b])))
            clusters += [(a, k), (k, b)]
        else:
            done.append((a, b))
    done.sort()
    dofs = tests[0].dofs if n else ()
    freqs, stds, presence, shapes = [], [], [], []
    for a, b in done:
        centre = np.median(logf[a:b])
        pick = {}
        for j in range(a, b):
            i = int(who[j])
            if i not in pick or abs(logf[j] - centre) < abs(logf[pick[i]] - centre):
                pick[i] = j
        if len(pick) < MIN_PRESENCE * n:
            continue
        v = logf[list(pick.values())]
        freqs.append(float(np.exp(np.median(v))))
        stds.append(robust_std(v))
        presence.append(len(pick) / n)
        rows = [shapes_at(tests[i], dofs) for i in pick]
        if all(r is not None for r in rows):
            S = np.stack([r[:, col[j]] for r, (i, j) in zip(rows, pick.items())], axis=1)   # (s, n_picked)
            S = S / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
            shapes.append(np.linalg.svd(S, full_matrices=False)[0][:, 0])
        else:
            shapes.append(None)
    f = np.asarray(freqs, float)
    s = np.asarray(stds, float)
    tol = np.maximum(TOLERANCE_SIGMAS * s, MIN_TOLERANCE)
    if f.size > 1:
        gaps = np.diff(np.log(f))
        neighbour = np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf])
        tol = np.minimum(tol, NEIGHBOUR_SHARE * neighbour)
    with_shapes = bool(shapes) and all(x is not None for x in shapes)
    return ReferenceModes(f, s, tol, np.stack(shapes, axis=1) if with_shapes else None,
                          tuple(dofs) if with_shapes else (), np.asarray(presence, float))


def track_modes(tests: list, ref: ReferenceModes):
    """Each test's poles assigned to the reference modes: ``(frequencies (n, m), damping (n, m), mac (n, m),
    column (n, m))``, NaN (column -1) where a test holds no pole within the mode's tolerance (and, with shapes of 2
    or more sensors, MAC >= :data:`MAC_MIN`). Poles and modes are paired one to one, minimising the sum of
    ``(ln(f / f_ref) / tolerance)^2 + (1 - MAC) / (1 - MAC_MIN)``; a pole beyond every tolerance is never
    assigned."""
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
        ok = np.abs(d) <= 1.0
        S = shapes_at(t, ref.dofs) if ref.shapes is not None else None
        macs = mac(S, ref.shapes) if S is not None else None
        if macs is not None:
            cost = cost + (1 - macs) / (1 - MAC_MIN)
            ok &= macs >= MAC_MIN
        cost = np.where(ok, cost, 1e9)
        r, c = linear_sum_assignment(cost)
        keep = ok[r, c]
        r, c = r[keep], c[keep]
        F[i, c], Z[i, c], cols[i, c] = t.frequencies_hz[r], t.damping_ratios[r], r
        if macs is not None:
            M[i, c] = macs[r, c]
    return F, Z, M, cols
