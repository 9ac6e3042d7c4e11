"""Events of a monitored series: consecutive flagged tests after the baseline period (alarms, tests beyond the
baseline's conditions, tests whose modes could not be identified, tests whose mode moved or was lost beyond its
band) grouped into one event each, with what
changed (the modes that moved, their mean size and direction); and whether the tests that could not be identified
are more than the baseline period's share says (a binomial test): a change after which tests stop being identifiable
is a change, not "no alarm"."""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from learn.monitor.alarms import EXTRAPOLATED
from learn.monitor.tracking import MODE_LOST, MODE_MOVED
from physics.io import finite_or_none, floats_or_nan

__all__ = ["AGAINST", "FLAGGED", "MAX_GAP", "SPLIT_P", "STEP_BEFORE", "Z_MOVED", "Event", "group_events",
           "identification_change", "lost_modes_change", "unidentified_p_value"]

#: Tests without a flag (judged, no alarm) an event may hold between two flagged tests: an index running along
#: the threshold alarms on some of its tests, one event all the same.
MAX_GAP = 2
#: Chance that a test of the event's state starts a new event: an alarm whose change (its z-scores, with the
#: baseline's correlation between modes) lies beyond the chi-square quantile ``1 - SPLIT_P`` about the event's mean
#: change starts a new event (a graded damage: one event per state) when the event's next alarm confirms it (lies
#: beyond that quantile too, and within it about the new alarm); the event's last alarm needs no confirmation. An
#: alarm that no next alarm confirms stays in the event, left out of the mean that later alarms are judged against.
SPLIT_P = 1e-3
#: A mode moved in an event when its mean z-score (baseline standard deviations) reaches this.
Z_MOVED = 3.0
#: Tests without an alarm before an event (before the series' first change, for the events after it) that its
#: step is measured against.
STEP_BEFORE = 10
#: What an event's change is measured against: the normal model's prediction for each alarm (its residual: the
#: conditions' prediction of a regression), or the tests without an alarm just before the event (a latent model's
#: residual is blind along the environment's factors, which absorb the part of a damage along them: a slit that
#: lowers three modes by 0.7-0.85 % reads as mode 2 +0.6 % after removing a factor that moves every mode alike).
AGAINST = ("residual", "before")

#: The statuses an event gathers: alarms, tests beyond the baseline's conditions (alarmed by the environment's
#: statistics alone), tests not identified, tests whose mode moved or was lost beyond its band.
FLAGGED = ("alarm", EXTRAPOLATED, "not identified", MODE_MOVED, MODE_LOST)


@dataclass(frozen=True)
class Event:
    """Consecutive flagged tests after the baseline period.

    Attributes
    ----------
    first, last : int             row indices of its first and last flagged test
    first_file, last_file : str
    first_time, last_time         as the series gives them
    n_tests : int                 judged or not-identified tests from first to last
    n_alarms, n_not_identified, n_extrapolated : int
    n_beyond : int                tests of status ``mode moved`` or ``mode lost`` (not alarmed)
    modes : list of dict          per mode: ``mode`` (1-based), ``change_pct`` and ``z`` (means over the alarms,
                                  ``against`` what), ``step_pct`` (the alarms' mean against the ``n_before`` tests
                                  without an alarm before the event), ``moved`` (``|z| >=`` :data:`Z_MOVED`)
    moved : list of int           the modes that moved, farthest first, then those moved beyond their bands
    size_pct : float or None      root mean square over the modes of the event's mean change (%): one magnitude
                                  comparable between events, whichever modes moved
    size_first_pct, size_last_pct : float or None    the same of its first and last alarm alone
    direction : str               ``down``, ``up``, ``mixed`` (the moved modes' signs) or ``none``
    unidentified_p_value : float or None     P(as many tests not identified | the baseline period's share)
    change : bool                 alarms, a mode moved or lost beyond its band (flagged), or more tests not
                                  identified than the false-alarm rate allows
    text : str
    against : str                 what the change is measured against
    n_before : int                tests without an alarm before the event its ``step_pct`` is measured against
    members : tuple of int        row indices of its flagged tests
    before : tuple of int         row indices of the tests its change is measured against (empty: the normal
                                  model's prediction)
    verdict : dict or None        the explanations and the network's verdict (with a trained model)
    beyond_band : list of dict    per mode flagged beyond its band in the event's tests: ``mode``, ``moved`` (how
                                  many tests), ``change_pct`` (their median, against the reference frequency),
                                  ``lost`` (how many tests)
    """

    first: int
    last: int
    first_file: str
    last_file: str
    first_time: object
    last_time: object
    n_tests: int
    n_alarms: int
    n_not_identified: int
    n_extrapolated: int
    modes: list
    moved: list
    size_pct: float | None
    size_first_pct: float | None
    size_last_pct: float | None
    direction: str
    unidentified_p_value: float | None
    change: bool
    text: str
    against: str = ""
    n_before: int = 0
    members: tuple = ()
    before: tuple = ()
    verdict: dict | None = None
    n_beyond: int = 0
    beyond_band: list = field(default_factory=list)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["members"] = list(self.members)
        d["before"] = list(self.before)
        return d


def _judged(rows, baseline: bool) -> list:
    """The rows of the baseline period (or of the later tests) that say something of the structure: judged, and
    not a test whose record is not usable (``record_problem``: unreadable, NaN samples, a dead or clipped channel)."""
    return [r for r in rows if r["baseline"] == baseline and r["status"] != "not judged"
            and not r.get("record_problem")]


def _baseline_counts(rows) -> tuple[int, int]:
    """``(tests not identified, tests of the series)`` in the baseline period."""
    base = _judged(rows, True)
    return sum(r["status"] == "not identified" for r in base), len(base)


def unidentified_p_value(k: int, n: int, u_base: int, n_base: int) -> float:
    """P(X >= k) for X ~ Binomial(n, p0), ``p0 = (u_base + 1) / (n_base + 2)`` (the baseline period's share of
    tests not identified, Laplace's rule: a baseline that identified all its tests still allows a few failures)."""
    if k <= 0:
        return 1.0
    p0 = (u_base + 1) / (n_base + 2)
    from scipy import stats  # scipy.stats: heavy, only where a series lost its identification

    return float(stats.binom.sf(k - 1, n, p0))


def identification_change(rows: list, false_alarm_rate: float) -> dict:
    """The tests not identified after the baseline period against the baseline period's share (binomial test):
    ``baseline`` / ``later`` (``not_identified``, ``tests``), ``p_value``, ``change`` (``p_value <
    false_alarm_rate``) and ``text``."""
    ub, nb = _baseline_counts(rows)
    later = _judged(rows, False)
    u = sum(r["status"] == "not identified" for r in later)
    p = unidentified_p_value(u, len(later), ub, nb)
    change = bool(u and p < false_alarm_rate)
    unusable = sum(bool(r.get("record_problem")) for r in rows if r["status"] != "not judged")
    text = (f"{u} of {len(later)} later tests not identified against {ub} of {nb} in the baseline period "
            f"(binomial p = {p:.2g})" + (": identification lost, reported as a change" if change else "")
            + (f"; {unusable} test{'s' if unusable != 1 else ''} with no usable record (unreadable, NaN samples, "
               "a dead or clipped channel) not counted" if unusable else ""))
    return {"baseline": {"not_identified": ub, "tests": nb}, "later": {"not_identified": u, "tests": len(later)},
            "unusable_records": unusable, "p_value": p, "change": change, "text": text}


def _lacks(row, r: int) -> bool:
    """Whether a row lacks reference mode ``r`` (0-based) in its band: not identified, or the mode missing."""
    return row["status"] == "not identified" or (r + 1) in (row.get("missing_modes") or [])


def lost_modes_change(rows: list, false_alarm_rate: float) -> dict:
    """Per reference mode, the later tests where it was lost (no pole in its band or within its reach beyond it:
    ``beyond_band`` readings ``lost``, flagged or not) against the baseline period's share lacking it (tests not
    identified included), by the binomial test of :func:`unidentified_p_value`; a mode whose p-value lies below
    ``false_alarm_rate / m`` is a change (a run of losses a short baseline could not judge one by one). Returns
    ``modes`` (per mode: ``mode``, ``baseline`` and ``later`` counts, ``p_value``, ``change``), ``change`` and
    ``text``."""
    base, later = _judged(rows, True), _judged(rows, False)
    m = len(rows[0]["mode_z_scores"]) if rows else 0
    modes = []
    for r in range(m):
        ub = sum(_lacks(row, r) for row in base)
        k = sum(any(d["mode"] == r + 1 and d["reading"] == "lost" for d in (row.get("beyond_band") or []))
                for row in later)
        p = unidentified_p_value(k, len(later), ub, len(base))
        modes.append({"mode": r + 1, "baseline": {"lacking": ub, "tests": len(base)},
                      "later": {"lost": k, "tests": len(later)}, "p_value": p,
                      "change": bool(k and p < false_alarm_rate / max(m, 1))})
    lost = [d for d in modes if d["later"]["lost"]]
    text = "; ".join(f"mode {d['mode']} lost in {d['later']['lost']} of {d['later']['tests']} later tests against "
                     f"{d['baseline']['lacking']} of {d['baseline']['tests']} lacking it in the baseline period "
                     f"(binomial p = {d['p_value']:.2g})" + (": reported as a change" if d["change"] else "")
                     for d in lost) or "no mode lost in a later test"
    return {"modes": modes, "change": any(d["change"] for d in modes), "text": text}


def _pattern(rows, baseline):
    """Inverse covariance of the baseline tests' z-scores (modes correlate: one environment moves several)."""
    Z = np.array([floats_or_nan(rows[i]["mode_z_scores"]) for i in baseline], float)
    Z = Z[np.isfinite(Z).all(axis=1)] if len(Z) else Z
    if len(Z) < 3:
        return None
    return np.cov(Z, rowvar=False).reshape(Z.shape[1], Z.shape[1])


def _jumps(cov, zs: list, z) -> bool:
    """Whether the alarm ``z`` lies beyond the chi-square quantile ``1 - SPLIT_P`` about the mean of ``zs`` (the
    event's alarms so far): a new state."""
    if cov is None or not zs:
        return False
    Z = np.array(zs, float)
    n = np.isfinite(Z).sum(axis=0)
    mean = np.where(n > 0, np.nansum(Z, axis=0) / np.maximum(n, 1), np.nan)     # a mode missing in every alarm: NaN
    keep = np.isfinite(mean) & np.isfinite(z)
    if not keep.any():
        return False
    S = cov[np.ix_(keep, keep)] * (1 + 1 / len(zs))
    dof = max(int(np.linalg.matrix_rank(S, tol=1e-9 * max(np.abs(S).max(), 1e-300))), 1)
    r = (z - mean)[keep]
    d2 = float(r @ np.linalg.pinv(S, rcond=1e-9) @ r)
    from scipy import stats  # scipy.stats: heavy, only where alarms are grouped

    return d2 > stats.chi2.ppf(1 - SPLIT_P, dof)


def _size(change):
    """Root mean square over the modes of a change (%): one magnitude that compares events whatever modes moved."""
    change = np.asarray(change, float)
    return float(np.sqrt(np.nanmean(change**2))) if np.isfinite(change).any() else None


def _lnf(rows, idx) -> np.ndarray:
    F = np.array([floats_or_nan(rows[i]["frequencies_hz"]) for i in idx], float).reshape(len(idx), -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(F)


def _day_to_day(rows, baseline) -> np.ndarray:
    """Per mode, the standard deviation of ``ln f`` from one baseline test to the next, over sqrt 2 (the scatter of
    one test about its neighbours: a slow drift of the environment left out)."""
    X = _lnf(rows, baseline)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanstd(np.diff(X, axis=0), axis=0, ddof=1) / np.sqrt(2)


def _event(rows, members: list, ctx: dict) -> Event:
    ub, nb, false_alarm_rate = ctx["ub"], ctx["nb"], ctx["rate"]
    first, last = members[0], members[-1]
    span = [i for i in range(first, last + 1) if rows[i]["status"] != "not judged"]
    alarms = [i for i in members if rows[i]["status"] == "alarm"]
    u = sum(rows[i]["status"] == "not identified" and not rows[i].get("record_problem") for i in members)
    unusable = sum(bool(rows[i].get("record_problem")) for i in members)
    m = len(rows[first]["mode_z_scores"])
    end = first if ctx["first_change"] is None else min(first, ctx["first_change"])
    before = [i for i in range(end) if rows[i]["status"] == "no alarm"][-STEP_BEFORE:]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)         # a mode missing in every alarm: NaN, then None
        steps = _lnf(rows, alarms) - np.nanmean(_lnf(rows, before), axis=0) if alarms and before else None
        if not alarms:
            C = np.full((1, m), np.nan)
            c = z = np.full(m, np.nan)
        elif ctx["against"] == "before" and steps is not None:
            C = 100 * np.expm1(steps)
            c = 100 * np.expm1(np.nanmean(steps, axis=0))
            z = np.nanmean(steps, axis=0) / (ctx["day_sd"] * np.sqrt(1 / len(alarms) + 1 / len(before)))
        else:
            C = np.array([floats_or_nan(rows[i]["change_pct"]) for i in alarms])
            Z = np.array([floats_or_nan(rows[i]["mode_z_scores"]) for i in alarms])
            c, z = np.nanmean(C, axis=0), np.nanmean(Z, axis=0)
        step = None if steps is None else 100 * np.expm1(np.nanmean(steps, axis=0))
    stepped = ctx["against"] == "before" and steps is not None
    against = ((f"the {len(before)} tests without an alarm before "
                + ("it" if end == first else f"the first change (test {end + 1})")) if stepped
               else "the normal model's prediction")
    modes = [{"mode": r + 1, "change_pct": finite_or_none(c[r]), "z": finite_or_none(z[r]),
              "step_pct": None if step is None else finite_or_none(step[r]),
              "moved": bool(np.isfinite(z[r]) and abs(z[r]) >= Z_MOVED)} for r in range(m)]
    moved = [d["mode"] for d in sorted(modes, key=lambda d: -abs(d["z"]) if d["z"] is not None else 0.0)
             if d["moved"]]
    p = unidentified_p_value(u, len(span) - unusable, ub, nb) if u else None
    change = bool(alarms) or (p is not None and p < false_alarm_rate)
    size = _size(c) if alarms else None
    first_size = _size(C[0]) if alarms else None
    last_size = _size(C[-1]) if alarms else None
    n_ext = sum(bool(rows[i].get("extrapolated")) for i in members)
    unseen = sum(rows[i]["status"] == EXTRAPOLATED for i in members)
    n_beyond = sum(rows[i]["status"] in (MODE_MOVED, MODE_LOST) for i in members)
    beyond = _beyond(rows, members)
    change = change or bool(beyond)
    for d in beyond:                                # a mode moved beyond its band moved, whatever its z
        if d["moved"] and d["mode"] not in moved:
            moved.append(d["mode"])
            modes[d["mode"] - 1]["moved"] = True
    signs = {np.sign(c[k - 1]) for k in moved if np.isfinite(z[k - 1]) and abs(z[k - 1]) >= Z_MOVED}
    signs |= {np.sign(d["change_pct"]) for d in beyond if d["moved"] and d["change_pct"] is not None}
    direction = "none" if not moved else "down" if signs == {-1.0} else "up" if signs == {1.0} else "mixed"
    where = (f"test {first + 1}" if first == last else f"tests {first + 1}-{last + 1}")
    times = rows[first]["time"], rows[last]["time"]
    if times[0] is not None:
        where += f" ({times[0]}" + (f" to {times[1]})" if last != first else ")")
    parts = [f"{len(alarms)} alarm{'s' * (len(alarms) != 1)}"]
    if unseen:
        parts.append(f"{unseen} {EXTRAPOLATED} (alarmed by the environment's statistics alone)")
    if n_beyond:
        parts.append(f"{n_beyond} with a mode moved or lost beyond its band")
    if u:
        parts.append(f"{u} not identified (p = {p:.2g} at the baseline's share"
                     + ("; identification lost)" if p < false_alarm_rate else ")"))
    if unusable:
        parts.append(f"{unusable} with no usable record (not counted)")
    if len(span) > len(members):
        parts.append(f"{len(span) - len(members)} without an alarm between")
    what = ""
    z_moved = [k for k in moved if np.isfinite(z[k - 1]) and abs(z[k - 1]) >= Z_MOVED]
    if z_moved:
        what = (f"; modes {', '.join(map(str, z_moved))} {direction} ("
                + ", ".join(f"mode {k} {c[k - 1]:+.3g} %" for k in z_moved) + f"), size {size:.3g} % (rms over "
                f"the modes; against {against})")
    elif alarms:
        lead = int(np.argmax(np.abs(np.where(np.isfinite(z), z, 0.0)))) if np.isfinite(z).any() \
            else int(np.argmax(np.abs(np.where(np.isfinite(c), c, 0.0))))
        sd = f"{z[lead]:+.1f} sd" if np.isfinite(z[lead]) else "no baseline scatter to scale it by"
        what = (f"; no mode moved {Z_MOVED:g} standard deviations on average (the most: mode {lead + 1} "
                f"{c[lead]:+.3g} %, {sd}), size {size:.3g} % (rms over the modes; against {against})")
    if beyond:
        what += "; beyond their bands: " + ", ".join(
            ", ".join(([f"mode {d['mode']} moved in {d['moved']} (median {d['change_pct']:+.3g} %)"]
                       if d["moved"] else []) + ([f"mode {d['mode']} lost in {d['lost']}"] if d["lost"] else []))
            for d in beyond)
    ext = f"; {n_ext} of {len(members)} extrapolated beyond the baseline's conditions" if n_ext else ""
    verdict = "" if change else f"; {EXTRAPOLATED}" if unseen else "; not a change"
    text = f"{where}: " + ", ".join(parts) + what + ext + verdict
    return Event(first, last, rows[first]["file"], rows[last]["file"], times[0], times[1], len(span), len(alarms), u,
                 n_ext, modes, moved, size, first_size, last_size, direction, p, change, text, against,
                 len(before), tuple(members), tuple(before) if stepped else (), None, n_beyond, beyond)


def _beyond(rows, members: list) -> list:
    """Per mode flagged beyond its band in the members' rows (``beyond_band``): ``mode``, ``moved`` (tests),
    ``change_pct`` (their median), ``lost`` (tests)."""
    flagged = [d for i in members for d in (rows[i].get("beyond_band") or []) if d["flagged"]]
    out = []
    for k in sorted({d["mode"] for d in flagged}):
        moved = [d["change_pct"] for d in flagged if d["mode"] == k and d["reading"] == "moved"]
        out.append({"mode": k, "moved": len(moved), "change_pct": float(np.median(moved)) if moved else None,
                    "lost": sum(d["mode"] == k and d["reading"] == "lost" for d in flagged)})
    return out


def group_events(rows: list, false_alarm_rate: float = 0.01, max_gap: int = MAX_GAP, against: str = "residual"
                 ) -> list[Event]:
    """The events of a monitored series' rows (``status``, ``baseline``, ``mode_z_scores``, ``change_pct``,
    ``file``, ``time``; ``extrapolated`` and ``beyond_band`` if present), in time order.

    An event starts at a flagged test after the baseline period (``status`` ``alarm``, ``not identified``,
    ``mode moved`` or ``mode lost``: :data:`FLAGGED`) and
    takes every following flagged test until more than ``max_gap`` judged tests without an alarm pass, or until an
    alarm's change departs from the event's mean change beyond chance and the next alarm confirms it (:data:`SPLIT_P`:
    a new state). Tests that
    cannot be judged against the baseline (``not judged``) are skipped. An event whose tests were not identified
    is a change when so many failures are unlikely at the baseline period's share
    (:func:`unidentified_p_value` below ``false_alarm_rate``); one holding a mode moved or lost beyond its band
    (flagged in a row's ``beyond_band``) is a change, its ``beyond_band`` and text naming the modes. ``against``
    (:data:`AGAINST`): what the event's change, its modes that moved (``|z| >=`` :data:`Z_MOVED`, ``z`` in the
    baseline's day-to-day scatter for ``"before"``) and its size are measured against.
    """
    if against not in AGAINST:
        raise ValueError(f"against must be one of {', '.join(AGAINST)}, got {against!r}")
    ub, nb = _baseline_counts(rows)
    base = [i for i, r in enumerate(rows) if r["baseline"] and r["status"] in ("alarm", "no alarm")]
    cov = _pattern(rows, base)
    ctx = {"ub": ub, "nb": nb, "rate": false_alarm_rate, "against": against, "day_sd": _day_to_day(rows, base)}
    alarm_z = {i: floats_or_nan(r["mode_z_scores"]) for i, r in enumerate(rows)
               if not r["baseline"] and r["status"] == "alarm"}
    later = sorted(alarm_z)
    following = dict(zip(later, later[1:]))                 # each alarm's next alarm in the series

    def reading(i, zs):
        """Alarm ``i`` against the event's alarms ``zs``: ``"same"`` (within chance of their mean), ``"new"`` (beyond
        it, and so is the next alarm within the gap, within chance of ``i``; or no such next alarm) or ``"stray"``
        (beyond it alone: a member of the event that its mean change leaves out)."""
        if not _jumps(cov, zs, alarm_z[i]):
            return "same"
        j = following.get(i)
        quiet = 0 if j is None else sum(rows[k]["status"] not in FLAGGED and rows[k]["status"] != "not judged"
                                        for k in range(i + 1, j))
        if j is None or quiet > max_gap:
            return "new"
        return "new" if _jumps(cov, zs, alarm_z[j]) and not _jumps(cov, [alarm_z[i]], alarm_z[j]) else "stray"

    groups, members, zs, gap = [], [], [], 0
    for i, r in enumerate(rows):
        if r["baseline"] or r["status"] == "not judged":
            continue
        if r["status"] in FLAGGED:
            z = alarm_z.get(i)
            read = "same" if z is None or not members else reading(i, zs)
            if members and (gap > max_gap or read == "new"):
                groups.append(members)
                members, zs = [], []
            members.append(i)
            if z is not None and read != "stray":
                zs.append(z)
            gap = 0
        elif members:
            gap += 1
            if gap > max_gap:
                groups.append(members)
                members, zs = [], []
    if members:
        groups.append(members)
    events = []
    ctx["first_change"] = None
    for members in groups:
        events.append(_event(rows, members, ctx))
        if events[-1].change and ctx["first_change"] is None:
            ctx["first_change"] = members[0]
    return events
