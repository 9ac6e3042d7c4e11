"""The verdicts of a series' alarms: with a trained model, the competing explanations weighed with the measured
per-mode scatter and the network's verdict against the baseline period."""

from __future__ import annotations

import warnings

import numpy as np

from learn.pairs.classify import classify_many
from learn.explanations.hypotheses import FREQUENCY_CHANGE_STD, explain_many
from learn.pairs.measured import modal_pair, on_model_dofs, pair_modes_by_frequency
from learn.monitor.alarms import SeriesResult, changed_text, what_changed
from learn.monitor.tracking import MODE_LOST, MODE_MOVED, shapes_at, track_modes
from physics.errors import BeamDamageError
from physics.io import ModalData
from physics.io import floats_or_nan
from physics.modal import eigenvalues_from_modal

__all__ = ["BEYOND", "alarm_verdicts", "baseline_nearest_median", "event_verdicts"]

#: The statuses of a test flagged for a mode beyond its band.
BEYOND = (MODE_MOVED, MODE_LOST)


def _modal_data(freqs_hz, damping, shapes, dofs):

    keep = np.isfinite(freqs_hz)
    z = np.where(np.isfinite(damping), damping, 0.01)[keep]
    return ModalData(eigenvalues_from_modal(np.asarray(freqs_hz)[keep], z),
                     None if shapes is None else np.asarray(shapes)[:, keep], tuple(dofs) if shapes is not None else ())


def _test_shapes(result: SeriesResult, i: int, cols) -> np.ndarray | None:
    ref = result.reference
    t = result.tests[i]
    S = shapes_at(t, ref.dofs) if (t is not None and ref.shapes is not None) else None
    if S is None:
        return None
    out = np.full((S.shape[0], cols.size), np.nan + 0j)
    have = cols >= 0
    out[:, have] = S[:, cols[have]]
    return out


def baseline_nearest_median(result: SeriesResult) -> int:
    """The baseline test whose frequencies lie nearest the baseline's (smallest sum of squared z-scores among those
    holding every reference mode; else the one holding most)."""
    best, key = None, None
    for i, r in enumerate(result.rows):
        if not (r["baseline"] and r["identified"]):
            continue
        z = np.array([np.nan if v is None else v for v in r["mode_z_scores"]], float)
        k = (-int(np.isfinite(z).sum()), float(np.nansum(z**2)))
        if key is None or k < key:
            best, key = i, k
    return best


def alarm_verdicts(result: SeriesResult, model=None, beam_x_m=None) -> dict:
    """Per alarmed test after the baseline period, and per test whose mode moved or was lost beyond its band
    (status :data:`~learn.monitor.tracking.MODE_MOVED` or :data:`~learn.monitor.tracking.MODE_LOST`) (row index ->
    dict): what changed mode by mode against the baseline population (``what_changed``, ``summary``, which names
    the flagged modes beyond their bands too: ``beyond_band``), and for the alarms, with a trained model, the
    competing explanations weighed with the measured per-mode scatter (``hypotheses``, ``hypotheses_summary``,
    ``frequency_change_std``) and the network's verdict against the baseline period (``network``,
    :func:`_network_verdicts`)."""
    rows = result.rows
    alarms = [i for i, r in enumerate(rows) if r["alarm"] and not r["baseline"]]
    flagged = [i for i, r in enumerate(rows) if not r["baseline"] and (r["alarm"] or r["status"] in BEYOND)]
    changed = {i: what_changed(rows[i], result.sigma) for i in flagged}
    out = {i: {"what_changed": changed[i], "summary": _summary(changed[i], rows[i]), "hypotheses": None,
               "hypotheses_summary": None, "frequency_change_std": None, "network": None,
               "network_baselines": None, "network_baseline": None, "network_error": None,
               "beyond_band": [d for d in rows[i].get("beyond_band", []) if d["flagged"]]} for i in flagged}
    if model is None or not alarms:
        return out

    items = [(i, result.frequencies_hz[i] * result.reference.frequencies_hz / result.expected_hz[i],
              floats_or_nan(result.rows[i]["damping_ratios"]), i) for i in alarms]
    _explain(result, model, beam_x_m, items, out)
    out = _network_verdicts(result, model, beam_x_m, alarms, out)
    return out


def _summary(changed: list, row: dict) -> str:
    """:func:`changed_text` of the modes within their bands (and those missing, unflagged), then the modes flagged
    beyond them (``beyond_band_text``)."""
    flagged = {d["mode"] for d in row.get("beyond_band", []) if d["flagged"]}
    text = changed_text([d for d in changed if d["mode"] not in flagged])
    return "; ".join(t for t in (text, row.get("beyond_band_text") or "") if t)


def _explain(result: SeriesResult, model, beam_x_m, items: list, out: dict) -> None:
    """``out[key]`` updated with the competing explanations (:func:`learn.explanations.hypotheses.explain_many`, the
    measured per-mode scatter as each mode's standard deviation) of each item ``(key, frequencies at the baseline's
    conditions (m,), damping ratios (m,), row whose shapes to use)`` against the baseline medians."""
    ref = result.reference
    sens = model.sensitivity
    n_all = len(model.beam.modes)
    which = pair_modes_by_frequency(ref.frequencies_hz, sens.frequencies_hz[:n_all])
    sigma_model = np.full(n_all, FREQUENCY_CHANGE_STD)
    sigma_model[which[which >= 0]] = result.sigma[which >= 0]
    _, _, _, cols = track_modes(result.tests, ref)
    Zb = np.array([floats_or_nan(r["damping_ratios"]) for r in result.rows if r["baseline"] and r["identified"]], float)
    base = _modal_data(ref.frequencies_hz, np.nanmedian(Zb, axis=0), ref.shapes, ref.dofs)
    try:
        base_m = on_model_dofs(base, model.beam, beam_x_m, "the baseline median")[0]
        pairs, keys = [], []
        for key, f, zeta, row in items:
            name = result.rows[row]["file"]
            cur = _modal_data(f, zeta, _test_shapes(result, row, cols[row]) if ref.shapes is not None else None,
                              ref.dofs)
            cur_m = on_model_dofs(cur, model.beam, beam_x_m, name)[0]
            pairs.append(modal_pair(base_m, cur_m, model.beam, sens.frequencies_hz, ("baseline median", name)))
            keys.append(key)
        for key, e in zip(keys, explain_many(model, pairs, sigma_model)):
            out[key].update(e)
    except BeamDamageError as exc:
        for key, *_ in items:
            out[key]["hypotheses_summary"] = f"no explanations: {exc}"


def event_verdicts(result: SeriesResult, events: list, model, beam_x_m=None) -> list:
    """Per event with alarms (:func:`learn.monitor.events.group_events`; None for the others): the competing
    explanations of the event's change, weighed with the measured per-mode scatter: its alarms' mean frequencies
    brought to the baseline's conditions against the baseline medians, or, for an event measured against the tests
    before it (a latent model, whose expected frequencies hold the part of a damage along the removed factors),
    its alarms' mean step from those tests, applied to the baseline medians (a uniform part of it is what every
    explanation's temperature nuisance takes); the shapes and damping of its ``representative`` alarm, the one
    whose change lies nearest the event's mean; and the network's verdict of the
    representative alarm against the baseline period (:func:`_network_verdicts`). One explanation per event, not
    per alarm: an event's alarms are one state, their mean the better measure of it."""
    empty = {"representative": None, "hypotheses": None, "hypotheses_summary": None, "frequency_change_std": None,
             "network": None, "network_baselines": None, "network_baseline": None, "network_error": None}
    reps, items = {}, []
    for k, ev in enumerate(events):
        alarms = [i for i in ev.members if result.rows[i]["status"] == "alarm"]
        if not alarms:
            continue
        Z = np.array([floats_or_nan(result.rows[i]["mode_z_scores"]) for i in alarms])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)        # a mode missing in every alarm stays NaN
            mean = np.nanmean(Z, axis=0)
            rep = alarms[int(np.argmin(np.nansum((Z - mean) ** 2, axis=1) - 1e3 * np.isfinite(Z).sum(axis=1)))]
            if ev.before:      # against the tests before: the raw step (its uniform part the explanations' nuisance)
                lnf = np.log(result.frequencies_hz)
                f = result.reference.frequencies_hz * np.exp(np.nanmean(lnf[alarms], axis=0)
                                                             - np.nanmean(lnf[list(ev.before)], axis=0))
            else:
                at_base = (result.frequencies_hz[alarms] * result.reference.frequencies_hz
                           / result.expected_hz[alarms])
                f = np.nanmean(at_base, axis=0)
        reps[k] = rep
        items.append((rep, f, floats_or_nan(result.rows[rep]["damping_ratios"]), rep))
    by_rep = {rep: {**empty, "representative": result.rows[rep]["file"]} for rep in reps.values()}
    if model is not None and items:
        _explain(result, model, beam_x_m, items, by_rep)
        by_rep = _network_verdicts(result, model, beam_x_m, list(by_rep), by_rep)
    return [by_rep[reps[k]] if k in reps else None for k in range(len(events))]


def _network_verdicts(result: SeriesResult, model, beam_x_m, alarms: list, out: dict) -> dict:
    """The network's verdicts of the alarms (``network``) by :func:`learn.pairs.classify.classify_many` against the
    whole baseline period (its scatter the normal variation; ``network_baselines``: how many tests), else, when
    classify refuses that, against the baseline test nearest the baseline median (``network_baseline``)."""

    base = [i for i, r in enumerate(result.rows) if r["baseline"] and r["identified"]]
    nearest = baseline_nearest_median(result)
    if not base:
        return out

    def md(i):
        t = result.tests[i]
        return on_model_dofs(_modal_data(t.frequencies_hz, t.damping_ratios, t.shapes, t.dofs), model.beam, beam_x_m,
                             result.rows[i]["file"])[0]

    keys = ("damaged", "probability_damaged", "location_x_m", "location_zone", "size",
            "verdict_from", "in_distribution", "out_of_distribution_reasons", "hypotheses_summary", "warnings")
    methods = [None if t is None else t.method if t.method in ("lscf", "ssi") else None for t in result.tests]
    rate = result.threshold.rate

    def run(group, baselines):
        names = [result.rows[i]["file"] for i in (*baselines, *group)]
        vs = classify_many(model, [md(i) for i in baselines], [md(i) for i in group], names=names,
                           methods=[methods[i] for i in (*baselines, *group)], false_alarm_rate=rate)
        for i, v in zip(group, vs):
            out[i].update(network={k: v.get(k) for k in keys}, network_baselines=len(baselines),
                          network_baseline=result.rows[baselines[0]]["file"] if len(baselines) == 1 else None)

    for baselines in (base, [nearest]):
        try:
            run(alarms, baselines)                           # one network call for every alarm
            return out
        except BeamDamageError:
            pass
    for i in alarms:                                         # one alarm's error apart
        try:
            run([i], [nearest])
        except BeamDamageError as exc:
            out[i].update(network_error=str(exc), network_baseline=result.rows[nearest]["file"])
    return out
