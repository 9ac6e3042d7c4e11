"""Classify measured pairs of a beam with a trained model (the library behind ``classify``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from datagen.damage import damage_model
from learn.classical import FREQUENCY_METHODS, run_classical
from learn.features import (feature_names, frf_features, frequency_features, map_frf_to_grid, modal_features,
                            with_missing_modes)
from learn.hypotheses import FREQUENCY_CHANGE_STD, NO_EXPLANATION, SHAPE_CHANGE_STD, explain_many
from learn.measured import (IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, frf_rows, identification_band_hz,
                            identify_modes, identify_test, modal_pair, mode_checks, nominal_ratio_range,
                            refit_missing_modes)
from learn.mirror import fold_to_half, location_ambiguity, mirrored
from learn.model_dir import TrainedModel
from learn.mode_count import mode_count_problem
from learn.normal_variation import measure, model_modes
from learn.shapes import real_shapes, sign_aligned
from learn.verdict import (IN_DISTRIBUTION_PERCENTILE, agreement, classical_answer, classical_verdict,
                           modes_text, network_answer, network_output, ood_percentile, place_keys)
from physics.errors import BeamDamageError
from physics.identification import METHODS
from physics.io import MeasuredFRF
from physics.modal import modal_parameters

__all__ = ["DEFAULT_FALSE_ALARM_RATE", "DISTANCE_TERMS", "MIN_PAIRING_MAC", "classify", "classify_many",
           "distance_terms", "distance_text", "identification_warning", "network_reads", "shape_pairing_reasons"]


#: False-alarm rate of the test against a measured normal variation (``classify --false-alarm-rate``).
DEFAULT_FALSE_ALARM_RATE = 0.01

def classify(model: TrainedModel, baseline, current) -> dict:
    """Verdict for one measured pair: :func:`classify_many` with one current input."""
    return classify_many(model, baseline, [current])[0]


def classify_many(model: TrainedModel, baseline, currents: list, names: list[str] | None = None,
                  methods: list | None = None, false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE) -> list[dict]:
    """Verdicts for tests of one beam against the same baseline (one network call for all pairs).

    Parameters
    ----------
    baseline : :class:`physics.io.ModalData` or :class:`physics.io.MeasuredFRF`, or a list of them
        The undamaged state, on the model's DOFs (:func:`on_model_dofs`). Several baseline tests measure the
        normal variation between tests (:mod:`learn.normal_variation`): it decides whether a change is more than
        that variation, and it replaces the assumed noise in the competing explanations and the distance check;
        the pair methods compare each test with the baseline nearest the baselines' centre.
    currents : list of the same kind as ``baseline``
    names : list of str, optional
        Names of the inputs (the baselines first) for messages.
    methods : list of (str or None), optional
        The identification method of :data:`physics.identification.METHODS` that produced each modal-data input
        (baselines first; ``"ssi"`` in a ``modal.json`` of ``identify`` on response records), None where unknown:
        an input identified otherwise than the training data's modal noise describes gets one warning
        (:func:`identification_warning`).
    false_alarm_rate : float
        Of the test against the measured normal variation (several baselines).

    FRF files are identified by :data:`IDENTIFICATION` (LSCF/LSFD, the path the training data's modal noise
    describes); the modal-route network and every classical method read those modes. A model on an FRF route
    reads the FRFs themselves (any frequency lines, mapped onto its grid).

    A pair whose tests do not both hold every mode of the model (a band that stops below the last, a mode at a
    node of the reference DOF or the sensors, a mode lost in the noise floor) is classified on the modes both hold
    (:func:`modal_pair`) by every classical method and by the modal or frequency network, which answers on any
    2 or more of its modes (the missing ones' features NaN: :func:`learn.features.with_missing_modes`); a network
    of a format-3 model needs every mode and gives no answer for it (``network`` None). Fewer than 2 common modes
    are refused when a modal or frequency network would have to read them.

    Returns
    -------
    list of dict, one verdict per current input. The verdict keys (``damaged``, ``location_*``, ``size*``...;
    ``size`` of the model's ``damage_kind``, as ``size_meaning`` says) are the network's answer when the pair lies
    inside the training data (``in_distribution``: its Mahalanobis distance on the features it holds within the
    :data:`IN_DISTRIBUTION_PERCENTILE` percentile of the training pairs' on the same features, its modes in their
    training ranges and paired), else the classical method's (``verdict_from``); ``network`` and ``classical`` hold
    both answers, ``classical_methods`` every method's.
    """
    baselines = list(baseline) if isinstance(baseline, (list, tuple)) else [baseline]
    nb = len(baselines)
    names = (list(names) if names else
             (["baseline"] if nb == 1 else [f"baseline {k + 1}" for k in range(nb)])
             + [f"measured {k + 1}" for k in range(len(currents))])
    warnings: list[str] = []
    sens = model.sensitivity
    base_md, cur_md, identified, pairs, nv, base_mds = _measured_pairs(model, baselines, currents, names, sens,
                                                                       warnings)
    ref = 0 if nv is None else nv.reference
    names = [names[ref], *names[nb:]]
    route, X, rows = _network_inputs(model, baselines[ref], currents, pairs, identified, warnings, methods)
    if route in ("modal", "frequency"):
        _require_common_modes(pairs, names, model.beam)
    nets, dist, pct, where, terms = _network_answers(model, route, X, rows, sens, len(currents))
    normal = _normal_variation(model, route, nv, base_mds, warnings)
    answers, mode_reasons, mode_sens = _classical_answers(model, pairs, len(currents), sens)
    for i in range(len(currents)):
        mirror = mirrored(model.beam, pairs[i] if pairs else None)
        if mirror:
            nets[i] = nets[i] and fold_to_half(nets[i], model.beam, where[i])
            answers[i] = [fold_to_half(a, model.beam) for a in answers[i]]
        nets[i] = nets[i] and {**nets[i], **place_keys(nets[i], model.beam, mirror)}
    known = [i for i in range(len(currents)) if pairs and pairs[i] is not None]
    explained = [None] * len(currents)
    for i, e in zip(known, _explanations(model, [pairs[i] for i in known], nv)):
        explained[i] = e
    kind = damage_model(model.damage_kind)
    size_keys = {"damage_kind": kind.kind, "size_meaning": kind.size_meaning}
    results = []
    for i, net in enumerate(nets):
        cl = next((a for a in answers[i] if a["method"] == model.config["best_classical"]),
                  answers[i][0] if answers[i] else None)
        p = pairs[i] if pairs else None
        reasons = list(mode_reasons[i])
        if net is None:
            reasons.append("; ".join(p.missing) + f": the network needs modes {modes_text(model.beam.modes)}")
        elif p is not None and not p.complete:
            reasons += shape_pairing_reasons(p, model.beam)
        if net is not None and pct[i] > IN_DISTRIBUTION_PERCENTILE and not _like_baseline_pairs(dist[i], normal):
            reasons.insert(0, f"Mahalanobis distance {dist[i]:.3g} from the training data, beyond "
                              f"{pct[i]:.2f}% of training pairs"
                              + (f" and the baseline tests' own pairs (at most "
                                 f"{normal['baseline_pairs_distance_max']:.3g})" if nv is not None else "")
                              + (f"; largest terms: {distance_text(terms[i])}" if terms[i] else ""))
        verdict, from_network, w = _chosen_verdict(net, cl, p, reasons, warnings, mode_sens[i], model.beam)
        nv_i = dict(normal)
        if nv is not None and cur_md is not None:
            target_hz, band = nv.targets
            nv_i.update(nv.test(model_modes(cur_md[i], model.beam, target_hz, names[i + 1], band)[0],
                                false_alarm_rate), false_alarm_rate=false_alarm_rate)
            verdict, w = _within_normal_variation(verdict, nv_i, w, "network" if from_network else cl and cl["method"])
        results.append({
            "measured": names[i + 1], **verdict, **size_keys,
            "location_ambiguity": location_ambiguity(model.beam, verdict, p),
            "verdict_from": "network" if from_network else "classical",
            "in_distribution": not reasons, "out_of_distribution_reasons": reasons,
            "mahalanobis_distance": dist[i], "training_percentile": pct[i], "distance_terms": terms[i],
            "network": net, "classical": cl,
            "classical_methods": answers[i],
            "identification": _identification(p, base_md, cur_md[i] if cur_md else None, identified, model.beam),
            **(explained[i] or NO_EXPLANATION),
            "input_route": route, "normal_variation": nv_i,
            "agreement": agreement(verdict, net, cl, (explained[i] or NO_EXPLANATION)["hypotheses"],
                                   "network" if from_network else "classical"),
            "warnings": w,
            "_extra": {"location_distribution": where[i] and where[i]["68"],
                       "frequency_change_pct": _change_pct(p, nv_i),
                       "modes": [] if p is None else [model.beam.modes[j] for j in p.mode_index]},
        })
    return results


def _change_pct(pair, normal: dict):
    """Each classified mode's frequency change (%) as the explanations weigh it: against the baselines' mean when
    several baselines were measured, else against the baseline; None without a pair."""
    if pair is None:
        return None
    if "frequency_change_pct" in normal:
        return np.array([normal["frequency_change_pct"][j] for j in pair.mode_index], float)
    return 100 * (np.abs(pair.eigenvalues[1]) / np.abs(pair.eigenvalues[0]) - 1)


def _measured_pairs(model: TrainedModel, baselines: list, currents: list, names: list[str], sens, warnings: list):
    """Modal data of the inputs and the modes each (baseline, current) pair holds: ``(baseline ModalData, list of
    current ModalData, identified, list of ModalPair, NormalVariation or None, list of baseline ModalData)``, the
    modal data and pairs None when the FRFs could not be identified (an FRF-input model then reads the FRFs
    alone). With several baselines the pairs compare with the reference baseline of their normal variation."""
    nb = len(baselines)
    mds, identified, found = _modal_inputs(model, [*baselines, *currents], names, sens)
    if mds is None:
        if nb > 1:
            raise BeamDamageError("several baseline tests need their modes, and LSCF/LSFD identification failed")
        warnings.append("LSCF/LSFD identification failed: no classical answer; the FRF-route network alone")
        return None, None, identified, None, None, None
    found = found or [None] * len(names)
    nv = measure(mds[:nb], model.beam, sens.frequencies_hz, names[:nb]) if nb > 1 else None
    if nv is not None and identified:          # a mode of the baselines missed: identified again over its band
        target_hz, band = nv.targets
        again = [refit_missing_modes(d, md, target_hz, band, nv.counts > 0, n)
                 for d, md, n in zip([*baselines, *currents], mds, names)]
        if any(t for _, t in again):
            mds = [md for md, _ in again]
            found = [f if not t else f"{f}; " + ", ".join(f"mode {model.beam.modes[j]} at {hz:.5g} Hz by LSCF over "
                                                          f"{lo:.5g}-{hi:.5g} Hz" for j, hz, lo, hi in t)
                     for f, (_, t) in zip(found, again)]
            nv = measure(mds[:nb], model.beam, sens.frequencies_hz, names[:nb])
    r = 0 if nv is None else nv.reference
    base_md = mds[r]
    target_hz, band = (sens.frequencies_hz, None) if nv is None else nv.targets
    pairs = [modal_pair(base_md, c, model.beam, target_hz, (names[r], n), (found[r], f), band)
             for c, n, f in zip(mds[nb:], names[nb:], found[nb:])]
    warnings += list(dict.fromkeys(w for p in pairs for w in p.warnings))
    w = damping_warning(model, pairs)
    if w:
        warnings.append(w)
    return base_md, mds[nb:], identified, pairs, nv, mds[:nb]


def _normal_variation(model: TrainedModel, route: str, nv, base_mds, warnings: list) -> dict:
    """The verdicts' ``normal_variation`` shared by all pairs: assumed (one baseline) or measured, with the
    Mahalanobis distances of the baseline tests' own pairs (reference against each other baseline) from the
    training data; one warning when most of those pairs lie outside it."""
    if nv is None:
        return {"n_baselines": 1, "measured": False, "frequency_std_pct": 100 * FREQUENCY_CHANGE_STD,
                "baseline_pairs_distance_max": None, "baseline_pairs_training_percentile": None}
    out = {**nv.summary(), "baseline_pairs_distance_max": None, "baseline_pairs_training_percentile": None}
    if route not in ("modal", "frequency"):
        return out
    others = [k for k in range(nv.n_baselines) if k != nv.reference]
    target_hz, band = nv.targets
    pairs = [modal_pair(base_mds[nv.reference], base_mds[k], model.beam, target_hz, tolerance=band) for k in others]
    full = [i for i, p in enumerate(pairs) if p.complete and (route == "frequency" or not p.frequency_only)]
    if not full:
        return out
    dist, pct = ood_percentile(model.networks[route], _mode_features(model, route, pairs, full))
    out["baseline_pairs_distance_max"] = float(dist.max())
    out["baseline_pairs_training_percentile"] = [float(v) for v in pct]
    outside = int(np.sum(pct > IN_DISTRIBUTION_PERCENTILE))
    if 2 * outside > len(full):
        scatter = max(v for v in out["frequency_std_pct"] if v is not None)
        warnings.append(f"{outside} of the {len(full)} pairs of baseline tests lie outside the training data (beyond "
                        f"{IN_DISTRIBUTION_PERCENTILE}% of its pairs; measured frequency scatter up to {scatter:.2g} % "
                        "per mode): the network was trained for a smaller variation between tests; the verdict "
                        "rests on the measured variation, and a model trained with measurement.frequency_scatter "
                        "covering it would answer better")
    return out


def _like_baseline_pairs(distance: float, normal: dict) -> bool:
    """Whether a pair lies no farther from the training data than the baseline tests' own pairs."""
    top = normal.get("baseline_pairs_distance_max")
    return top is not None and distance <= top


def _explanations(model: TrainedModel, pairs: list, nv) -> list[dict]:
    """The competing explanations of the pairs: with the assumed noise, or with the normal variation measured on
    several baselines (each frequency against the baselines' mean, std ``s sqrt(1 + 1/n)``; each shape entry
    against the reference baseline's, std ``s sqrt(2)``)."""
    if nv is None or not pairs:
        return explain_many(model, pairs)
    mean_hz, counts = nv.frequency_mean_hz, nv.counts
    sigma = np.where(counts >= 2, nv.frequency_std_rel * np.sqrt(1 + 1 / np.maximum(counts, 1)),
                     FREQUENCY_CHANGE_STD)
    centred = []
    for p in pairs:                       # the baseline's frequencies moved to the baselines' mean
        lam = np.array(p.eigenvalues)
        f = np.abs(lam[0]) / (2 * np.pi)
        lam[0] = lam[0] * np.where(np.isfinite(mean_hz[p.mode_index]), mean_hz[p.mode_index] / f, 1.0)
        centred.append(replace(p, eigenvalues=lam))
    shape = nv.shape_std
    shape_sigma = SHAPE_CHANGE_STD if shape is None else np.where(np.isfinite(shape), shape * np.sqrt(2),
                                                                   SHAPE_CHANGE_STD)
    return explain_many(model, centred, sigma, shape_sigma)


def _within_normal_variation(verdict: dict, normal: dict, warnings: list, source) -> tuple[dict, list]:
    """The verdict after the test against the measured normal variation: a damage called inside it is withdrawn
    (said in a warning); a change beyond it that the verdict's source calls undamaged is said."""
    w = list(warnings)
    n, p, alpha = normal["n_baselines"], normal["p_value"], normal["false_alarm_rate"]
    test = (f"{'Hotelling T2' if normal['test'] == 'hotelling' else 'largest |z|'} {normal['statistic']:.3g} "
            f"against {normal['threshold']:.3g}, p = {p:.2g}")
    if verdict["damaged"] and not normal["beyond"]:
        verdict = {**verdict, "damaged": False}
        w.append(f"the {source} calls the pair damaged, but its natural frequencies lie within the normal variation "
                 f"measured on {n} baseline tests ({test} >= {alpha:g}): no damage detected")
    elif normal["beyond"] and not verdict["damaged"]:
        w.append(f"the natural frequencies lie beyond the normal variation measured on {n} baseline tests ({test} < "
                 f"{alpha:g}), though the {source} finds no damage: see the competing explanations")
    return verdict, w


#: How far outside the training's damping ratios a baseline may lie before :func:`damping_warning` speaks (factor).
DAMPING_RANGE_FACTOR = 2.0


def damping_warning(model: TrainedModel, pairs: list) -> str | None:
    """One line when the baseline's damping ratios lie beyond :data:`DAMPING_RANGE_FACTOR` times the training pairs'
    range (``damping_ratio_range`` of the model: the central 99 % of the training's measured baseline ratios),
    else None: the modal noise the model was trained with depends on the damping (an output-only identification's
    frequency scatter grows with its square root)."""
    trained = model.config.get("damping_ratio_range")
    pair = next((p for p in pairs if p is not None and p.mode_index.size), None)
    if pair is None or not trained:
        return None

    lo, hi = np.asarray(trained, float)[pair.mode_index].T
    zeta = modal_parameters(pair.eigenvalues[0])[1]
    given = np.isfinite(zeta) & (zeta > 0)                                # frequencies alone carry no damping
    out = given & ((zeta < lo / DAMPING_RANGE_FACTOR) | (zeta > hi * DAMPING_RANGE_FACTOR))
    if not out.any():
        return None
    modes = [model.beam.modes[j] for j in pair.mode_index[out]]
    return (f"the baseline's damping ratios of mode(s) {', '.join(map(str, modes))} ("
            + ", ".join(f"{100 * z:.3g} %" for z in zeta[out]) + ") lie beyond twice the training's ("
            + ", ".join(f"{100 * a:.3g}-{100 * b:.3g} %" for a, b in zip(lo[out], hi[out]))
            + "): the modal noise the model was trained with depends on the damping; generate with "
              "specimen.damping_ratios set to the test's")


def _require_common_modes(pairs: list, names: list[str], beam) -> None:
    """Refuse a pair with fewer modes both tests hold than :func:`learn.mode_count.mode_count_problem` asks (the
    modal network reads modes)."""
    for p, n in zip(pairs, names[1:]):
        found = f"{n}: {p.mode_index.size} of modes {modes_text(beam.modes)} found in both it and {names[0]} ("
        problem = mode_count_problem(p.mode_index.size, found + "; ".join(p.missing) + ")")
        if problem:
            raise BeamDamageError(problem)


def _network_answers(model: TrainedModel, route: str, X, rows: list, sens, n: int):
    """Per input (lists of ``n``): the network's answer (None for a pair it does not read), the Mahalanobis
    distance from the training data, its training percentile, and the network's location distributions (level ->
    (B,))."""
    nets, dist, pct, where, terms = [None] * n, [None] * n, [None] * n, [None] * n, [None] * n
    if not rows:
        return nets, dist, pct, where, terms
    est = model.networks[route]
    out, d = network_output(est, X, sens)
    distance, percentile = ood_percentile(est, X)
    named = distance_terms(est, X, route, model.beam) if route in ("modal", "frequency") else [None] * len(rows)
    for r, i in enumerate(rows):
        nets[i] = network_answer(d, r, out, model.beam)
        dist[i], pct[i] = float(distance[r]), float(percentile[r])
        where[i] = {k: v[r] for k, v in d.level_distributions.items()}
        terms[i] = named[r]
    return nets, dist, pct, where, terms


#: Features listed in ``distance_terms`` of a verdict (the largest terms of the squared distance).
DISTANCE_TERMS = 6


def distance_terms(est, X, route: str, beam, top: int = DISTANCE_TERMS) -> list[list[dict]]:
    """Per row of ``X``: the features that make up most of its squared Mahalanobis distance, largest first.

    Each entry (features of a missing mode left out): ``feature`` (:func:`learn.features.feature_names`),
    ``value`` (the pair's feature),
    ``training_std`` (how many training standard deviations it lies from the training mean) and ``share``
    (its term ``z_i (P z)_i`` over the squared distance; the shares of all features sum to 1).
    """
    terms, Z = est.distance_terms(X)
    names = feature_names(route, beam)
    total = np.maximum(np.nansum(terms, axis=1), 1e-300)
    out = []
    for r in range(terms.shape[0]):
        held = np.flatnonzero(np.isfinite(terms[r]))                      # a missing mode's features have no term
        order = held[np.argsort(-terms[r, held])][:top]
        out.append([{"feature": names[j], "value": float(np.asarray(X)[r, j]), "training_std": float(Z[r, j]),
                     "share": float(terms[r, j] / total[r])} for j in order])
    return out


def distance_text(terms: list[dict], n: int = 3) -> str:
    """The largest terms in words, e.g. ``df1 (%) -7.1 sd (62 %), dphi 2:y m1 +3.0 sd (12 %)``."""
    return ", ".join(f"{t['feature']} {t['training_std']:+.1f} sd ({t['share']:.0%})" for t in terms[:n])


def _chosen_verdict(net, cl, p, reasons: list, warnings: list, sens, beam):
    """The verdict keys (the network's inside the training data, else the classical method's), whether they are
    the network's, and the pair's warnings: ``(dict, bool, list)``."""
    w = list(warnings)
    inside = not reasons
    found = ", ".join(str(beam.modes[j]) for j in p.mode_index) if p is not None else ""
    if net is None:
        w.append(f"the network gives no answer for this pair (it needs modes {modes_text(beam.modes)}): the verdict "
                 f"is the classical method's ({cl['method']}) on modes {found}")
        return classical_verdict(cl, sens, beam), False, w
    if p is not None and not p.complete:
        w.append("; ".join(p.missing) + f": the network and the classical methods answer on modes {found}")
    if inside or cl is None:
        if not inside:
            w.append("the pair lies outside the training data (" + "; ".join(reasons) + ") and no classical "
                     "answer is available: treat the network's verdict with caution")
        return dict(net), True, w
    w.append("the pair lies outside the training data (" + "; ".join(reasons) + "): the verdict is the "
             f"classical method's ({cl['method']}"
             + ("" if p is None or p.complete else f" on modes {found}")
             + "); the network's answer is shown beside it")
    return classical_verdict(cl, sens, beam), False, w


def _identification(p, base_md, cur_md, identified: bool, beam) -> dict:
    """The verdict's ``identification``: how the modes were found (``as``: the ``identify`` command that finds the
    same modes), the baseline and measured natural frequencies (Hz; every mode found when the pair is not complete),
    the 1-based modes classified, and every pole found in each test with the model's mode it was paired with
    (``baseline_poles``, ``measured_poles``: ``{"frequency_hz", "mode"}``, mode None for a pole left unpaired)."""
    if p is None:
        freqs, modes = ([], []), []
    elif p.complete:
        freqs, modes = np.abs(p.eigenvalues) / (2 * np.pi), list(beam.modes)
    else:
        freqs = [np.sort(np.abs(md.eigenvalues)) / (2 * np.pi) for md in (base_md, cur_md)]
        modes = [beam.modes[int(j)] for j in p.mode_index]
    poles = p.poles if p is not None and p.poles else ([], [])
    return {**IDENTIFICATION, "n_modes": beam.n_modes, "modes_model": list(beam.modes),
            "source": "identified from FRFs" if identified else "modal data",
            **({"as": "identify --band " + " ".join(f"{b:g}" for b in beam.test.band_hz)}
               if identified and beam.test is not None else {}),
            "baseline_frequencies_hz": [float(x) for x in freqs[0]],
            "measured_frequencies_hz": [float(x) for x in freqs[1]], "modes_classified": modes,
            "baseline_poles": list(poles[0]), "measured_poles": list(poles[1])}



def _modal_inputs(model: TrainedModel, inputs: list, names: list[str], sens):
    """Modal data of every input: ``(list of ModalData, identified, found)``, ``found`` one text per input on the
    modes it holds (e.g. "LSCF/LSFD found 2 modes in 2-500 Hz")."""
    kinds = {isinstance(d, MeasuredFRF) for d in inputs}
    if len(kinds) > 1:
        raise BeamDamageError("BASELINE and MEASURED must all be FRF files or all modal data")
    if not kinds.pop():
        return list(inputs), False, None
    test = model.beam.test
    if test is None:
        fmax, fmin = IDENTIFICATION_BAND_FACTOR * float(sens.frequencies_hz[3]), 0.0
    else:
        fmin, fmax = test.band_hz
    try:  # the thesis's test: its 4 modes; another test: as 'identify --band' does, then paired by frequency
        ids = [identify_modes(d, fmax, n) if test is None else identify_test(d, test.band_hz, n)
               for d, n in zip(inputs, names)]
    except BeamDamageError:
        if model.route == "modal":
            raise
        return None, True, None                # an FRF-route model classifies the FRFs without modes
    found = []
    for d, md in zip(inputs, ids):
        k = md.eigenvalues.size
        lo, hi = identification_band_hz(d, fmax, fmin)
        found.append(f"LSCF/LSFD found {k} mode{'s' * (k != 1)} in {lo:.4g}-{hi:.4g} Hz")
    return ids, True, found


def _frf_route_features(model: TrainedModel, baseline, currents, warnings: list):
    """Grid features of the model's FRF route for (baseline, current) FRF pairs, or None if the files lack DOFs."""
    rows_b = frf_rows(baseline, model.beam)
    rows_c = [frf_rows(c, model.beam) for c in currents]
    if rows_b[0] is None or any(r[0] is None for r in rows_c):
        return None
    if model.route == "updated":
        warnings.append("the updated-model route is fed with the measured FRFs (no updating of measured FRFs here)")

    def grid(r):
        H, f = r
        w, g = f.omega_rad_s, model.beam.grid_rad_s
        if w[0] > g[0] * 1.001 or w[-1] < g[-1] * 0.999:
            msg = (f"FRF lines cover {w[0]:.4g}-{w[-1]:.4g} rad/s, the model's grid "
                   f"{g[0]:.4g}-{g[-1]:.4g} rad/s: nearest values used outside")
            if msg not in warnings:
                warnings.append(msg)
        return map_frf_to_grid(H, w, g)

    gb = grid(rows_b)
    return frf_features(np.stack([np.stack([gb, grid(r)]) for r in rows_c]))


def _classical_answers(model: TrainedModel, pairs, n: int, sens):
    """Every classical method's answers per pair, the reasons a complete pair's modes lie outside the training
    data, and the sensitivities of the modes each pair was classified on: three lists of ``n``.

    Complete pairs are classified in one call on modes 1-4; the others each on the modes both tests hold (the
    sensitivities of those modes alone), none below 2 common modes."""
    L = model.beam
    thresholds = model.config["classical_thresholds"]
    answers, reasons, mode_sens = [[] for _ in range(n)], [[] for _ in range(n)], [sens] * n
    if pairs is None:
        return answers, reasons, mode_sens
    full = [i for i, p in enumerate(pairs) if p.complete]
    if full:
        lam = np.stack([pairs[i].eigenvalues for i in full])
        vecs = np.stack([pairs[i].eigenvectors for i in full])
        outs, _ = run_classical(lam, vecs, sens, thresholds)
        for j, (i, why) in enumerate(zip(full, mode_checks(lam, vecs, nominal_ratio_range(sens)))):
            if pairs[i].frequency_only:  # no shapes: the frequency-only methods, no MAC check
                why = [r for r in why if "MAC" not in r]
            answers[i] = [classical_answer(o, j, L) for o in outs
                          if not pairs[i].frequency_only or o.name in FREQUENCY_METHODS]
            reasons[i] = why
    for i, p in enumerate(pairs):
        if not p.complete and p.mode_index.size >= 2:
            mode_sens[i] = sens.modes(p.mode_index)
            outs, _ = run_classical(p.eigenvalues[None], p.eigenvectors[None], mode_sens[i], thresholds)
            answers[i] = [classical_answer(o, 0, L) for o in outs
                          if not p.frequency_only or o.name in FREQUENCY_METHODS]
    return answers, reasons, mode_sens


def network_reads(est, pair) -> bool:
    """Whether the modal or frequency network ``est`` answers ``pair``: it holds every mode of the model, or the
    network answers missing modes (``est.answers_missing_modes``) and the pair holds ``est.min_modes`` or more."""
    return pair.complete or (est.answers_missing_modes and pair.mode_index.size >= est.min_modes)


def _mode_features(model: TrainedModel, route: str, pairs: list, rows: list):
    """The ``modal`` or ``frequency`` features of ``pairs[rows]`` on the model's modes (NaN in the columns of a mode
    a pair lacks), None for no rows."""
    if not rows:
        return None
    m = model.beam.n_modes
    lam, vecs = _on_model_modes(pairs, rows, m)
    return frequency_features(lam, m) if route == "frequency" else modal_features(lam, vecs, m, model.beam.test)


def _on_model_modes(pairs: list, rows: list, n_modes: int):
    """Eigen-data of ``pairs[rows]`` on the model's modes, NaN for those a pair lacks (stacked)."""
    parts = [with_missing_modes(pairs[i].eigenvalues[None], pairs[i].eigenvectors[None], pairs[i].mode_index, n_modes)
             for i in rows]
    return np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts])


#: Smallest MAC between a mode of the baseline and of the measured test for a pair the network reads
#: (:func:`learn.measured.mode_checks`).
MIN_PAIRING_MAC = 0.8


def shape_pairing_reasons(pair, beam) -> list[str]:
    """Reasons a pair with missing modes lies outside what the network was trained on: a mode whose baseline and
    measured shapes do not pair (MAC below :data:`MIN_PAIRING_MAC`; none without shapes). Its modes lie within the
    pairing tolerance of the nominal beam's by construction (:func:`learn.measured.modal_pair`)."""
    if pair.frequency_only or pair.eigenvectors.shape[1] < 2:
        return []
    u = real_shapes(pair.eigenvectors)
    m = np.sum(sign_aligned(u[1], u[0]) * u[0], axis=0) ** 2        # unit-norm real shapes: the MAC
    return [f"mode {beam.modes[j]} of the baseline and the measured test do not pair (MAC {v:.2f} < "
            f"{MIN_PAIRING_MAC})" for j, v in zip(pair.mode_index, m) if v < MIN_PAIRING_MAC]


def _network_inputs(model: TrainedModel, baseline, currents: list, pairs, identified: bool, warnings: list,
                    methods=None):
    """Route, feature rows and the pairs they belong to: ``(route, X, rows)``.

    ``X`` are the FRF-route features of every pair when the model reads FRFs and the inputs are FRF files, else
    the modal (or, without shapes, frequency) features of the pairs the network reads (:func:`network_reads`;
    NaN in the columns of a mode a pair lacks; ``rows``: their indices; ``X`` None when there are none).
    Warnings are appended to ``warnings``.
    """
    if identified and model.route in ("measured", "updated"):
        X = _frf_route_features(model, baseline, currents, warnings)
        if X is not None:
            return model.route, X, list(range(len(currents)))
    if pairs is None:
        raise BeamDamageError(f"the files hold neither the FRFs the model's {model.route} route reads "
                              "nor identifiable modes")
    if any(p.frequency_only for p in pairs):
        if "frequency" not in model.networks:
            raise BeamDamageError("natural frequencies without mode shapes need a model with a frequency-route "
                                  "network: re-create it with 'beam-damage train'")
        rows = [i for i, p in enumerate(pairs) if network_reads(model.networks["frequency"], p)]
        return "frequency", _mode_features(model, "frequency", pairs, rows), rows
    if "modal" not in model.networks:
        raise BeamDamageError("this model has no modal-route network; give FRF files holding receptances at "
                              f"{', '.join(model.beam.dofs)} driven at {model.beam.dofs[model.beam.drive_row]}")
    rows = [i for i, p in enumerate(pairs) if network_reads(model.networks["modal"], p)]
    X = _mode_features(model, "modal", pairs, rows)
    w = identification_warning(model, identified, methods)
    if w:
        warnings.append(w)
    return "modal", X, rows


def _output_only(method) -> bool:
    return method in METHODS and METHODS[method].data == "records"


def identification_warning(model: TrainedModel, identified: bool, methods=None) -> str | None:
    """One line when the inputs' modes were identified otherwise than the training data's modal noise describes
    (``measurement.identification`` of its generator config), else None.

    FRF files (``identified``) are identified here by :data:`IDENTIFICATION`; modal data carry the ``methods``
    that produced them (None: unknown, nothing said). Output-only inputs (SSI-cov, FDD) against FRF-route or
    fixed modal noise, and FRF-route inputs against output-only modal noise, are named.
    """
    trained = (model.config.get("generator_config") or {}).get("measurement", {}).get("identification")
    trained_oo = _output_only((trained or {}).get("method"))
    used = sorted({m for m in (methods or ()) if m is not None})
    oo = [m for m in used if _output_only(m)]
    if oo and not trained_oo:
        what = "the FRF route's LSCF/LSFD" if trained else "fixed stds, not an identification"
        return (f"the training data's modal noise describes {what}, not the output-only identification of these "
                f"modes ({', '.join(oo)}): retrain on data from 'beam-damage generate --modal-noise output-only'")
    frf = identified or any(not _output_only(m) for m in used)
    if frf and trained_oo:
        return ("the training data's modal noise describes the output-only identification (SSI-cov), not the "
                "FRF route's of these modes: retrain on data from 'beam-damage generate' without "
                "--modal-noise output-only")
    if identified and trained != IDENTIFICATION:
        return ("the training data's modal noise was not calibrated against the identification run here: retrain "
                "on data from 'beam-damage generate --config training'")
    return None


