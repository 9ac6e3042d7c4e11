"""Sessions within the baseline period: runs of consecutive tests that share a level of the frequencies, separated
by jumps far beyond the scatter from one test to the next (a set-up re-mounted, a sensor re-glued, a day's
temperature). A baseline of ``k`` sessions holds ``k`` values of that variation, not one per test: held out one
test at a time, each test's session-mates stay in the model and the statistics of the environment read every new
session as beyond the baseline (of ``k`` sessions drawn alike, a new one lies beyond their range with probability
``2 / (k + 1)``). ``monitor``'s held-out statistics then leave out a whole session at a time
(:func:`learn.monitor.statistics.held_out_statistics`), and ``classify`` with several baselines judges a test
against the sessions' levels (:meth:`learn.pairs.normal_variation.NormalVariation.prediction`).

:func:`baseline_sessions` reads them from the baseline's log frequencies in test order: each mode scaled by its
scatter from one test to the next (``1.4826 MAD`` of the successive differences over ``sqrt 2``), the leading
principal direction of the scaled tests (the common course of the modes), and a jump wherever two successive tests
differ along it by more than :data:`JUMP_SIGMAS` of that scatter (Gaussian noise: ``2e-9`` per pair). Sessions are
reported only when every run holds at least :data:`MIN_SESSION` tests; a shorter run between two runs at one
level (a test off the level, an identification outlier: two jumps about it) belongs to them; a smooth drift has no
jump.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["JUMP_SIGMAS", "MIN_SESSION", "Sessions", "baseline_sessions"]

#: A jump between two successive tests: this many of their scatter along the modes' common course.
JUMP_SIGMAS = 6.0
#: Fewest tests of a session (a shorter run between jumps is an outlier, and the baseline is read as one session).
MIN_SESSION = 3


@dataclass(frozen=True)
class Sessions:
    """Runs of consecutive baseline tests at one level.

    Attributes
    ----------
    starts : tuple of int      position of each session's first test in the baseline (0-based, ascending)
    sizes : tuple of int       tests per session
    jump_sigmas : tuple        each jump (from session ``j`` to ``j + 1``) in scatters of successive tests
    explained : float          share of the tests' variance along the common course between the sessions' means
    """

    starts: tuple
    sizes: tuple
    jump_sigmas: tuple
    explained: float

    def folds(self) -> list:
        """The baseline positions of each session, one array per session."""
        return [np.arange(s, s + k) for s, k in zip(self.starts, self.sizes)]

    def to_dict(self, files=None) -> dict:
        first = [files[s] if files is not None else s for s in self.starts]
        names = ", ".join(Path(str(f)).name for f in first)
        text = (f"The baseline period holds {len(self.sizes)} sessions of {'/'.join(map(str, self.sizes))} tests "
                f"(from {names}; the levels jump by {min(self.jump_sigmas):.0f}-{max(self.jump_sigmas):.0f} times "
                f"the scatter between successive tests): held out a session at a time, its environment judged as "
                f"{len(self.sizes)} values, so a later session is an alarm of the environment only far beyond "
                f"them; more sessions in the baseline sharpen it"
                + ("; the residual and the per-mode statistic held out one test at a time (a model of one session "
                   "holds none of their variation), which takes later sessions to move the modes as these two differ: "
                   "a later session that moves them in another pattern alarms" if len(self.sizes) == 2 else ""))
        return {"count": len(self.sizes), "sizes": list(self.sizes), "first_tests": first,
                "jump_sigmas": [round(float(j), 1) for j in self.jump_sigmas], "explained": self.explained,
                "text": text}


def _scatter(D) -> np.ndarray:
    """Per column of ``D`` (n, p), the scatter of a test about the next: ``1.4826 MAD`` of the successive
    differences over ``sqrt 2``."""
    d = np.diff(D, axis=0)
    return 1.4826 * np.median(np.abs(d - np.median(d, axis=0)), axis=0) / np.sqrt(2.0)


def baseline_sessions(X, min_training: int = 0) -> Sessions | None:
    """The sessions of the baseline ``X`` (n, p) (log frequencies in test order; the modes every test holds), or
    None when it is one session: fewer than two runs between jumps, a run shorter than
    :data:`MIN_SESSION`, or a session so large that the others hold fewer than ``min_training`` tests (the
    tests a model held out without it is fitted on)."""
    X = np.asarray(X, float)
    n = len(X)
    if n < 2 * MIN_SESSION or X.ndim != 2:
        return None
    whole = np.isfinite(X).all(axis=0)                  # the modes every baseline test holds
    sc = np.zeros(X.shape[1])
    sc[whole] = _scatter(X[:, whole])
    keep = whole & (sc > 0)
    if not keep.any():
        return None
    D = (X[:, keep] - X[:, keep].mean(axis=0)) / sc[keep]
    s = D @ np.linalg.svd(D, full_matrices=False)[2][0]
    unit = np.sqrt(2.0) * _scatter(s[:, None])[0]
    if not unit > 0:                         # most successive tests alike (readings on a grid of lines)
        return None
    step = np.abs(np.diff(s)) / unit
    edges = [0, *(np.flatnonzero(step > JUMP_SIGMAS) + 1), n]
    k = 1
    while k < len(edges) - 2:                # a short run between two runs at one level: an excursion
        a, b = edges[k], edges[k + 1]
        if b - a < MIN_SESSION and abs(s[b] - s[a - 1]) <= JUMP_SIGMAS * unit:
            del edges[k:k + 2]
        else:
            k += 1
    edges = np.asarray(edges)
    jumps = edges[1:-1]
    sizes = np.diff(edges)
    if sizes.size < 2 or sizes.min() < MIN_SESSION or n - sizes.max() < min_training:
        return None
    within = sum(float(((s[a:b] - s[a:b].mean()) ** 2).sum()) for a, b in zip(edges[:-1], edges[1:]))
    return Sessions(tuple(int(v) for v in edges[:-1]), tuple(int(v) for v in sizes),
                    tuple(float(v) for v in step[jumps - 1]), round(1.0 - within / float((s**2).sum()), 4))

