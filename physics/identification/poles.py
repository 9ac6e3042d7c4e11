"""Stabilisation diagrams of poles over model orders and the automatic selection of physical poles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConvergenceError
from physics.modal import eigenvalues_from_modal

__all__ = ["MAX_DAMPING", "MISSED_SHARE", "NO_STABLE_POLE", "STABILITY_CODES", "MissedModes", "SelectedPoles",
           "StabilisationDiagram", "damping_resolution", "missed_clusters", "missed_modes", "select_known_mode",
           "select_poles", "stability_status", "steadiest_text", "unresolved"]

#: Largest damping ratio of a physical pole (LSCF and SSI-cov poles, peaks of peak picking and the circle fit): a
#: broader one is a computational pole or a bump of the noise floor.
MAX_DAMPING = 0.2


#: The refusal of a selection that found no pole, with what a user can change (the options of ``identify`` that set
#: the highest model order and the band; ``max_order`` and ``band_hz`` in Python).
NO_STABLE_POLE = ("no pole is stable over enough model orders: raise the highest model order or widen the band "
                  "(beam-damage identify --max-order N --band FMIN FMAX)")
#: Stability codes of poles in a stabilisation diagram.
STABILITY_CODES = {0: "new", 1: "stable frequency", 2: "stable frequency and damping",
                   3: "stable frequency and vector", 4: "stable"}


def damping_resolution(natural_frequencies_hz, duration_s):
    """The least damping ratio a record of ``duration_s`` seconds resolves at each frequency (Hz):
    ``1 / (2 pi f T)``, the damping whose envelope ``exp(-zeta 2 pi f t)`` falls by a factor e over the record.
    A lighter damping decays too little within the record for its value to be measured, so the record cannot tell
    it from zero; an infinite duration resolves every damping (0)."""
    f = np.asarray(natural_frequencies_hz, float)
    return np.zeros_like(f) if not np.isfinite(duration_s) else 1.0 / (2 * np.pi * f * float(duration_s))


def unresolved(zeta_a, zeta_b, resolution):
    """Whether two damping ratios both lie within ``+-resolution`` (:func:`damping_resolution`, finite for a record
    of known duration): a record resolves neither from zero, so they are the same damping whatever their
    difference (poles of a mode lighter than the record resolves, its damping estimated about zero from one model
    order to the next). False where the resolution is 0 (an infinite duration)."""
    r = np.asarray(resolution, float)
    return (np.abs(zeta_a) <= r) & (np.abs(zeta_b) <= r) & (r > 0)


@dataclass(frozen=True)
class StabilisationDiagram:
    """Poles of LSCF models of increasing order (one row per pole).

    Attributes
    ----------
    order : ndarray of int, shape (n_poles,)
    eigenvalues : ndarray, complex, shape (n_poles,)  (rad/s, Im > 0)
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_poles,)
    participation : ndarray, complex, shape (n_poles, n_ref)
        Modal participation vectors (unit norm).
    status : ndarray of int, shape (n_poles,)
        See :data:`STABILITY_CODES`; compared with the previous order.
    band_hz : (float, float)
    duration_s : float
        Duration of the record the poles come from (s; infinite where unknown): a damping change is judged against
        at least :func:`damping_resolution` of it, by the status and by the selection's clusters.
    """

    order: np.ndarray
    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    participation: np.ndarray
    status: np.ndarray
    band_hz: tuple
    duration_s: float = float("inf")

def stability_status(order, natural_frequencies_hz, damping_ratios, participation, freq_tol=0.01, damping_tol=0.05,
                     mpf_tol=0.98, duration_s=float("inf")):
    """Stability code (:data:`STABILITY_CODES`) of each pole against the nearest pole of the previous order.

    Parameters
    ----------
    order : ndarray of int, shape (n_poles,)
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_poles,)
    participation : ndarray, complex, shape (n_poles, n_ref)
        Unit-norm participation vectors.
    freq_tol, damping_tol : float
        Relative change of frequency / damping below which they are stable; the damping's change relative to the
        larger of the damping and the record's :func:`damping_resolution` at the pole's frequency; two dampings both
        within the resolution (:func:`unresolved`) are stable whatever their change.
    mpf_tol : float
        MAC between participation vectors above which the vector is stable (always with one reference).
    duration_s : float
        Duration of the record (s); infinite: the damping's change relative to the damping alone.

    Returns
    -------
    ndarray of int, shape (n_poles,)
        0 for the poles of the lowest order and of an order whose previous order holds none.
    """
    fn, zeta, mpf = natural_frequencies_hz, damping_ratios, participation
    floor = damping_resolution(fn, duration_s)
    status = np.zeros(fn.size, int)
    for p in np.unique(order)[1:]:
        cur = np.nonzero(order == p)[0]
        prev = np.nonzero(order == p - 1)[0]
        if prev.size == 0 or cur.size == 0:
            continue
        d = np.abs(fn[cur][:, None] - fn[prev][None, :])
        near = prev[np.argmin(d, axis=1)]
        f_ok = np.abs(fn[cur] - fn[near]) <= freq_tol * fn[cur]
        d_ok = (np.abs(zeta[cur] - zeta[near]) <= damping_tol * np.maximum(zeta[cur], floor[cur])) \
            | unresolved(zeta[cur], zeta[near], floor[cur])
        v_ok = (np.abs(np.sum(mpf[cur].conj() * mpf[near], axis=1)) ** 2 >= mpf_tol) if mpf.shape[1] > 1 \
            else np.ones(cur.size, bool)
        status[cur] = np.where(f_ok, np.where(d_ok & v_ok, 4, np.where(v_ok, 3, np.where(d_ok, 2, 1))), 0)
    return status


@dataclass(frozen=True)
class SelectedPoles:
    """Physical poles picked from a stabilisation diagram.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
    natural_frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
        Medians over the upper half (by model order) of the cluster of stable poles (a damping below zero, within
        the record's resolution, reads 0).
    frequency_std_hz, damping_std : ndarray, shape (n_modes,)
        Standard deviation over those poles (spread across model orders, a
        measure of the estimate's sensitivity to model order, not a
        statistical confidence interval).
    count : ndarray of int, shape (n_modes,)
        Orders (upper half of the cluster) in which the pole was found stable.
    participation : ndarray, complex, shape (n_modes, n_ref)
    weakly_stable : ndarray of bool, shape (n_modes,)
        Stable over fewer orders than the selection asks, kept because a clear spectral peak lies at its frequency.
    """

    eigenvalues: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    count: np.ndarray
    participation: np.ndarray
    weakly_stable: np.ndarray


def select_poles(diagram: StabilisationDiagram, n_modes=None, min_status=4, freq_tol=0.01,
                 damping_tol=0.25, min_count=None, seed_orders=0.25, peaks_hz=(), peak_tol_hz=None,
                 weak_min_count=3):
    """Automatic pole selection from a stabilisation diagram (no GUI; rules are parameters).

    1. Candidate poles have ``status >= min_status`` (4 = stable in frequency,
       damping and participation vector).
    2. Seeds are the candidates of the highest ``seed_orders`` fraction of orders.
       For each seed, every order contributes its candidate nearest in frequency
       if within ``freq_tol`` (relative) and ``damping_tol`` (relative) of the seed.
    3. Clusters are taken largest first; a seed already in a taken cluster is
       skipped and poles already taken are removed from later clusters, which
       are dropped below ``min_count`` members (default: a third of the orders
       that hold any pole).
    4. A cluster left with fewer members but at least ``weak_min_count``, within ``peak_tol_hz`` of one of
       ``peaks_hz`` (clear spectral peaks) and ``freq_tol`` of no cluster taken, is kept *weakly stable*.
    5. With ``n_modes``, the ``n_modes`` largest clusters are kept (weakly stable ones last).

    The clusters these rules leave are :func:`missed_clusters`.

    Parameters
    ----------
    diagram : StabilisationDiagram
    n_modes : int, optional
    min_status : int
    freq_tol, damping_tol : float
    min_count : int, optional
    seed_orders : float in (0, 1]
    peaks_hz : sequence of float
        Frequencies of clear spectral peaks (Hz).
    peak_tol_hz : sequence of float, optional
        Largest distance of a weakly stable cluster's median frequency from each peak (default ``freq_tol`` f).
    weak_min_count : int

    Returns
    -------
    SelectedPoles
        Sorted by frequency.

    Raises
    ------
    ConvergenceError
        If no pole is stable enough.
    """
    chosen, weak, _, _ = _selection(diagram, min_status, freq_tol, damping_tol, min_count, seed_orders, peaks_hz,
                                    peak_tol_hz, weak_min_count)
    flags = [False] * len(chosen) + [True] * len(weak)
    chosen = (chosen + weak)[:n_modes]
    if not chosen:
        raise ConvergenceError(NO_STABLE_POLE)
    return _summarise_clusters(diagram, chosen, flags[:len(chosen)])


def select_known_mode(diagram: StabilisationDiagram, peaks_hz=(), peak_tol_hz=None) -> SelectedPoles:
    """:func:`select_poles` in a band known to hold a mode (a series' reference mode identified again in its own
    band); where it finds no pole stable enough, the one cluster of poles steady in frequency and shape (status >=
    3), seeded at any model order: a weak mode's damping wanders from one order to the next, and its pole splits at
    the high orders (noise modelled), where :func:`select_poles` seeds, so that only the low orders hold it. Two or
    more such clusters are no reading of the one mode (the band's noise modelled at several frequencies).

    Raises :class:`ConvergenceError` when neither finds a pole, or the second finds several."""
    try:
        return select_poles(diagram, peaks_hz=peaks_hz, peak_tol_hz=peak_tol_hz)
    except ConvergenceError:
        sel = select_poles(diagram, min_status=3, seed_orders=1.0, peaks_hz=peaks_hz, peak_tol_hz=peak_tol_hz)
    if sel.natural_frequencies_hz.size != 1:
        raise ConvergenceError(NO_STABLE_POLE)
    return sel


def _selection(d: StabilisationDiagram, min_status, freq_tol, damping_tol, min_count, seed_orders, peaks_hz,
               peak_tol_hz, weak_min_count):
    """The rules of :func:`select_poles` (before ``n_modes``): the clusters chosen, those kept weakly stable and
    those left with at least ``weak_min_count`` members, ``freq_tol`` from every cluster kept (member index arrays),
    and ``min_count``."""
    cand = np.nonzero(d.status >= min_status)[0]
    cand = cand[np.argsort(d.order[cand], kind="stable")]
    orders = np.unique(d.order)
    if min_count is None:
        min_count = max(2, int(np.ceil(orders.size / 3)))
    top = orders[int(np.floor((1 - seed_orders) * (orders.size - 1))):] if orders.size else orders
    seeds = cand[np.isin(d.order[cand], top)]
    clusters = _seed_clusters(d, cand, seeds, freq_tol, damping_tol)
    used = set()
    chosen = _take_clusters(clusters, min_count, used)
    peaks = np.asarray(peaks_hz, float)
    tol = freq_tol * peaks if peak_tol_hz is None else np.asarray(peak_tol_hz, float)
    taken_hz = [np.median(d.natural_frequencies_hz[m]) for m in chosen]

    def apart(mem, at_peak=False):
        f = np.median(d.natural_frequencies_hz[mem])
        ok = (not at_peak or np.any(np.abs(peaks - f) <= tol)) and all(abs(f - g) > freq_tol * g for g in taken_hz)
        if ok:
            taken_hz.append(f)
        return ok

    weak = _take_clusters(clusters, weak_min_count, used, lambda m: apart(m, True)) if peaks.size else []
    left = _take_clusters(clusters, weak_min_count, used, apart)
    return chosen, weak, left, min_count


#: A cluster left out is named when stable over at least this share of the orders a cluster needs.
MISSED_SHARE = 1 / 3


@dataclass(frozen=True)
class MissedModes:
    """Clusters of stable poles the selection leaves out (:func:`missed_clusters`), by frequency.

    Attributes
    ----------
    frequency_hz : ndarray, shape (n,)
        Median frequency of each cluster.
    counts, n_orders, min_count : ndarray of int, shape (n,)
        Orders the cluster is stable in, orders of its diagram, orders its selection asked for.
    """

    frequency_hz: np.ndarray
    counts: np.ndarray
    n_orders: np.ndarray
    min_count: np.ndarray

    def text(self, heights_db=None) -> str:
        """``"1.23 Hz (12 of 40 orders, 7.1 dB above the floor), ..."`` (heights: one per mode, optional)."""
        h = [None] * self.frequency_hz.size if heights_db is None else heights_db
        return ", ".join(f"{f:.4g} Hz ({c} of {n} orders"
                         + ("" if x is None else f", {x if abs(x) >= 5e-3 else 0.0:.3g} dB above the floor")
                         + ")" for f, c, n, x in zip(self.frequency_hz, self.counts, self.n_orders, h))


def missed_clusters(diagram: StabilisationDiagram, peaks_hz=(), peak_tol_hz=None, share=MISSED_SHARE, min_status=4,
                    freq_tol=0.01, damping_tol=0.25, min_count=None, seed_orders=0.25,
                    weak_min_count=3) -> MissedModes:
    """The clusters the rules of :func:`select_poles` (same parameters) leave out that the stabilisation diagram
    still shows: stable over at least ``weak_min_count`` orders and ``share`` of ``min_count``, without a clear
    peak, farther than ``freq_tol`` from every cluster kept."""
    d = diagram
    _, _, left, need = _selection(d, min_status, freq_tol, damping_tol, min_count, seed_orders, peaks_hz,
                                  peak_tol_hz, weak_min_count)
    left = [m for m in left if m.size >= share * need]
    f = np.array([np.median(d.natural_frequencies_hz[m]) for m in left])
    o = np.argsort(f)
    n = np.unique(d.order).size
    return MissedModes(f[o], np.array([m.size for m in left], int)[o], np.full(f.size, n), np.full(f.size, need))


def missed_modes(parts, kept_hz, freq_tol=0.01) -> MissedModes:
    """The missed clusters of one or more passes (:class:`MissedModes`) that no mode kept explains.

    A cluster within ``freq_tol`` (relative) of a frequency of ``kept_hz`` is dropped; of clusters within
    ``2 freq_tol`` of each other (passes seeing one mode), the one of most orders is kept.

    Parameters
    ----------
    parts : sequence of MissedModes
    kept_hz : array_like
        Frequencies of the modes finally kept (Hz).
    """
    rows = [r for p in parts for r in zip(p.frequency_hz, p.counts, p.n_orders, p.min_count)]
    kept = np.asarray(kept_hz, float)
    rows = [r for r in rows if not np.any(np.abs(kept - r[0]) <= freq_tol * r[0])]
    out = []
    for r in sorted(rows, key=lambda r: (-r[1], r[0])):
        if all(abs(r[0] - o[0]) > 2 * freq_tol * r[0] for o in out):
            out.append(r)
    cols = np.array(sorted(out), float).reshape(-1, 4).T
    return MissedModes(cols[0], *(c.astype(int) for c in cols[1:]))


def _seed_clusters(d: StabilisationDiagram, cand, seeds, freq_tol, damping_tol):
    """For each seed, each order's candidate nearest in frequency within the tolerances of the seed.

    ``cand`` (pole indices) is sorted by ascending order. Returns ``[(seed, members), ...]``,
    largest cluster first (ties: the seed of the higher order first).
    """
    # candidates by order, padded to a (n_orders, width) table (-1 = none)
    c_orders, c_group = np.unique(d.order[cand], return_inverse=True)
    slot = np.arange(cand.size) - np.searchsorted(c_group, c_group)  # cand is grouped by ascending order
    by_order = np.full((c_orders.size, max(1, np.bincount(c_group).max(initial=0))), -1)
    by_order[c_group, slot] = cand
    f_tab = np.where(by_order >= 0, d.natural_frequencies_hz[by_order], np.inf)
    dist = np.abs(f_tab[None] - d.natural_frequencies_hz[seeds][:, None, None])  # (n_seeds, n_orders, width)
    near = by_order[np.arange(c_orders.size)[None, :], np.argmin(dist, axis=2)]  # (n_seeds, n_orders)
    fs, zs = d.natural_frequencies_hz[seeds][:, None], d.damping_ratios[seeds][:, None]
    zr = np.maximum(zs, damping_resolution(fs, d.duration_s))           # at least the damping the record resolves
    ok = (np.abs(d.natural_frequencies_hz[near] - fs) <= freq_tol * fs) \
        & ((np.abs(d.damping_ratios[near] - zs) <= damping_tol * zr)
           | unresolved(d.damping_ratios[near], zs, damping_resolution(fs, d.duration_s)))
    clusters = [(sd, near[k][ok[k]]) for k, sd in enumerate(seeds)]
    clusters.sort(key=lambda c: (-c[1].size, -d.order[c[0]]))
    return clusters


def _take_clusters(clusters, min_count, used, accept=None):
    """Clusters in turn, skipping a seed already taken and poles already taken (``used``, updated); those left
    with fewer than ``min_count`` members, or that ``accept(members)`` refuses, are dropped. Returns the member
    index arrays taken."""
    chosen = []
    for sd, mem in clusters:
        if sd in used:
            continue
        mem = np.array([j for j in mem if j not in used], int)
        if mem.size < min_count or (accept is not None and not accept(mem)):
            continue
        chosen.append(mem)
        used.update(mem.tolist())
        used.add(sd)
    return chosen


def _summarise_clusters(d: StabilisationDiagram, chosen, weak) -> SelectedPoles:
    """Medians and spreads over the upper half (by order) of each cluster, sorted by frequency.

    Low orders are biased (the z-domain model converges with order), hence the upper half.
    """
    chosen = [m[d.order[m] >= np.median(d.order[m])] for m in chosen]
    fn = np.array([np.median(d.natural_frequencies_hz[m]) for m in chosen])
    zeta = np.maximum([np.median(d.damping_ratios[m]) for m in chosen], 0.0)   # unresolved below 0: zero
    f_std = np.array([np.std(d.natural_frequencies_hz[m], ddof=1) for m in chosen])
    z_std = np.array([np.std(d.damping_ratios[m], ddof=1) for m in chosen])
    count = np.array([m.size for m in chosen])
    mpf = np.array([d.participation[m[np.argmax(d.order[m])]] for m in chosen])
    o = np.argsort(fn)
    lam = eigenvalues_from_modal(fn[o], zeta[o])
    return SelectedPoles(lam, fn[o], zeta[o], f_std[o], z_std[o], count[o], mpf[o], np.asarray(weak, bool)[o])


def steadiest_text(diagram: StabilisationDiagram, n: int = 3) -> str:
    """What a failed selection saw: the ``n`` frequencies whose poles kept their frequency and shape (status >= 3)
    over the most model orders, and what to try; empty without such poles."""
    d = diagram
    ok = d.status >= 3
    if not ok.any():
        return ""
    key = np.round(np.log(d.natural_frequencies_hz[ok]) / np.log1p(0.01)).astype(int)    # 1 % bins
    bins, inverse = np.unique(key, return_inverse=True)
    orders = np.array([np.unique(d.order[ok][inverse == b]).size for b in range(bins.size)])
    top = np.argsort(-orders, kind="stable")[:n]
    total = np.unique(d.order).size
    seen = ", ".join(f"{np.median(d.natural_frequencies_hz[ok][inverse == b]):.4g} Hz ({orders[b]} of {total} "
                     "orders)" for b in top)
    return (f"; the steadiest poles (frequency and shape): {seen}; try --band around one of them, or --method fdd "
            "(peaks of the spectra)")
