"""Classify measured pairs of a beam with a trained model (the library behind ``classify``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from datagen.damage import damage_model
from learn.explanations.classical import FREQUENCY_METHODS, run_classical
from learn.network.features import feature_names
from learn.explanations.hypotheses import FREQUENCY_CHANGE_STD, NO_EXPLANATION, SHAPE_CHANGE_STD, explain_many
from learn.pairs.measured import IDENTIFICATION, mode_checks, nominal_ratio_range
from learn.explanations.mirror import fold_to_half, location_ambiguity, mirrored
from learn.network.model_dir import TrainedModel
from learn.pairs.normal_variation import model_modes
from learn.pairs.inputs import PairInputs, pair_inputs
from learn.explanations.shapes import real_shapes, sign_aligned
from learn.pairs.verdict import (IN_DISTRIBUTION_PERCENTILE, Verdict, agreement, classical_answer, classical_verdict,
                                 modes_text, network_answer, network_output, place_keys)

__all__ = ["DEFAULT_FALSE_ALARM_RATE", "DISTANCE_TERMS", "KEYS", "MIN_PAIRING_MAC", "Answers", "ClassifiedPair",
           "classify_many", "classify_pairs", "distance_terms", "pair_answers",
           "shape_pairing_reasons"]


#: False-alarm rate of the test against a measured normal variation (``classify --false-alarm-rate``).
DEFAULT_FALSE_ALARM_RATE = 0.01

#: The keys of a classified pair's serialised form (:meth:`ClassifiedPair.to_dict`, ``classify --json``), in order.
KEYS = ("measured", "damaged", "probability_damaged", "decision_threshold", "location_x_over_L", "location_x_m",
        "location_std_m", "location_zone", "zone_edges_m", "zone_probabilities", "place_determined", "place_text",
        "location_ambiguity", "location_element", "element_probabilities", "damage_kind", "size", "size_std",
        "x_m_68", "x_m_95", "size_68", "size_95", "size_meaning", "detectable", "probability_support_change",
        "support_changed", "verdict_from", "in_distribution", "out_of_distribution_reasons", "mahalanobis_distance",
        "training_percentile", "distance_terms", "hypotheses", "hypotheses_summary", "frequency_change_std",
        "shape_change_std", "normal_variation", "agreement", "network", "classical", "classical_methods",
        "identification", "input_route", "warnings", "dof_positions")


@dataclass(frozen=True)
class Answers:
    """The second stage, per pair: the network's answer (None for a pair it does not read) with the pair's
    Mahalanobis distance from the training data, its training percentile, the distance's largest terms and the
    network's location distributions (level -> (B,)); every classical method's answer and the best one on the
    training data (``classical``); why a complete pair's modes lie outside the training data; the sensitivities of
    the modes classified."""

    network: dict | None = None
    mahalanobis_distance: float | None = None
    training_percentile: float | None = None
    distance_terms: list | None = None
    location_distributions: dict | None = None
    classical: dict | None = None
    classical_methods: list | tuple = ()
    mode_reasons: tuple = ()
    sensitivity: object = None


@dataclass(frozen=True)
class ClassifiedPair:
    """The last stage: one pair's verdict, the answers it was chosen from, the competing explanations
    (``explanations``: ``hypotheses``, ``hypotheses_summary``, ``frequency_change_std``, ``shape_change_std``) and
    what the figure of ``classify`` draws besides (``modes``: 1-based modes classified, ``frequency_change_pct``:
    their changes as the explanations weigh them)."""

    measured: str
    verdict: Verdict
    damage_kind: str
    size_meaning: str
    location_ambiguity: str | None
    verdict_from: str
    in_distribution: bool
    out_of_distribution_reasons: list
    answers: Answers
    identification: dict
    explanations: dict
    input_route: str
    normal_variation: dict
    agreement: dict
    warnings: list
    modes: list
    frequency_change_pct: object = None
    dof_positions: dict | None = None

    def to_dict(self) -> dict:
        """The pair as ``classify --json`` prints it (:data:`KEYS`)."""
        d = {**asdict(self.answers), **asdict(self), **asdict(self.verdict), **self.explanations}
        return {k: d[k] for k in KEYS}


def classify_many(model: TrainedModel, baseline, currents: list, names: list[str] | None = None,
                  methods: list | None = None, false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE) -> list[dict]:
    """:func:`classify_pairs`, each pair serialised (:meth:`ClassifiedPair.to_dict`)."""
    return [c.to_dict() for c in classify_pairs(model, baseline, currents, names, methods, false_alarm_rate)]


def classify_pairs(model: TrainedModel, baseline, currents: list, names: list[str] | None = None,
                   methods: list | None = None,
                   false_alarm_rate: float = DEFAULT_FALSE_ALARM_RATE) -> list[ClassifiedPair]:
    """Verdicts for tests of one beam against the same baseline (one network call for all pairs), in stages:
    :func:`pair_inputs` -> :func:`pair_answers` -> the competing explanations -> the verdicts.

    Parameters
    ----------
    baseline : :class:`physics.io.ModalData` or :class:`physics.io.MeasuredFRF`, or a list of them
        The undamaged state, on the model's DOFs (:func:`on_model_dofs`). Several baseline tests measure the
        normal variation between tests (:mod:`learn.pairs.normal_variation`): it decides whether a change is more than
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
    2 or more of its modes (the missing ones' features NaN: :func:`learn.network.features.with_missing_modes`); a
    network of a format-3 model needs every mode and gives no answer for it (``network`` None). Fewer than 2 common
    modes are refused when a modal or frequency network would have to read them.

    Returns
    -------
    list of :class:`ClassifiedPair`, one per current input. Its verdict (``damaged``, ``location_*``, ``size*``...;
    ``size`` of the model's ``damage_kind``, as ``size_meaning`` says) is the network's answer when the pair lies
    inside the training data (``in_distribution``: its Mahalanobis distance on the features it holds within the
    :data:`IN_DISTRIBUTION_PERCENTILE` percentile of the training pairs' on the same features, its modes in their
    training ranges and paired), else the classical method's (``verdict_from``); ``network`` and ``classical`` hold
    both answers, ``classical_methods`` every method's.
    """
    inputs = pair_inputs(model, baseline, currents, names, methods)
    answers = pair_answers(model, inputs)
    warnings = list(inputs.warnings)
    normal = _normal_variation(model, inputs, warnings)
    explained = _explanations(model, inputs)
    return [_classified(model, inputs, i, a, e, normal, warnings, false_alarm_rate)
            for i, (a, e) in enumerate(zip(answers, explained))]


def pair_answers(model: TrainedModel, inputs: PairInputs) -> tuple:
    """The second stage of :func:`classify_pairs`: the network's and every classical method's answers per pair
    (:class:`Answers`), located on the half beam where frequencies alone leave the mirror ambiguity
    (:func:`learn.explanations.mirror.mirrored`)."""
    out = []
    for i, a in enumerate(_classical_answers(model, inputs.pairs, _network_answers(model, inputs))):
        net, methods = a.network, list(a.classical_methods)
        mirror = mirrored(model.beam, inputs.pair(i))
        if mirror:
            net = net and fold_to_half(net, model.beam, a.location_distributions)
            methods = [fold_to_half(c, model.beam) for c in methods]
        net = net and {**net, **place_keys(net, model.beam, mirror)}
        best = next((c for c in methods if c["method"] == model.config["best_classical"]),
                    methods[0] if methods else None)
        out.append(replace(a, network=net, classical=best, classical_methods=methods))
    return tuple(out)


def _classified(model: TrainedModel, inputs: PairInputs, i: int, a: Answers, explained: dict, normal: dict,
                warnings: list, false_alarm_rate: float) -> ClassifiedPair:
    """The last stage of :func:`classify_pairs` for pair ``i``: which answer is the verdict, tested against the
    measured normal variation (several baselines)."""
    beam, net, cl, p, nv = model.beam, a.network, a.classical, inputs.pair(i), inputs.normal_variation
    reasons = list(a.mode_reasons)
    if net is None:
        reasons.append("; ".join(p.missing) + f": the network needs modes {modes_text(beam.modes)}")
    elif p is not None and not p.complete:
        reasons += shape_pairing_reasons(p, beam)
    dist, pct, terms = a.mahalanobis_distance, a.training_percentile, a.distance_terms
    top = normal.get("baseline_pairs_distance_max")            # the baseline tests' own pairs lie as far
    if net is not None and pct > IN_DISTRIBUTION_PERCENTILE and not (top is not None and dist <= top):
        reasons.insert(0, f"Mahalanobis distance {dist:.3g} from the training data, beyond {pct:.2f}% of training "
                          "pairs" + (f" and the baseline tests' own pairs (at most "
                                     f"{normal['baseline_pairs_distance_max']:.3g})" if nv is not None else "")
                       + ("; largest terms: " + ", ".join(f"{t['feature']} {t['training_std']:+.1f} sd "
                                                          f"({t['share']:.0%})" for t in terms[:3]) if terms else ""))
    verdict, from_network, w = _chosen_verdict(net, cl, p, reasons, warnings, a.sensitivity, beam)
    nv_i = dict(normal)
    if nv is not None and inputs.currents is not None:
        target_hz, band = nv.targets
        nv_i.update(nv.test(model_modes(inputs.currents[i], beam, target_hz, inputs.names[i + 1], band)[0],
                            false_alarm_rate), false_alarm_rate=false_alarm_rate)
        verdict, w = _within_normal_variation(verdict, nv_i, w, "network" if from_network else cl and cl["method"])
    source = "network" if from_network else "classical"
    kind = damage_model(model.recorded.kind)
    return ClassifiedPair(
        inputs.names[i + 1], verdict, kind.kind, kind.size_meaning, location_ambiguity(beam, asdict(verdict), p),
        source, not reasons, reasons, a,
        _identification(p, inputs.baseline, inputs.currents[i] if inputs.currents else None, inputs.identified, beam),
        explained, inputs.route, nv_i, agreement(verdict.damaged, net, cl, explained["hypotheses"], source), w,
        [] if p is None else [beam.modes[j] for j in p.mode_index], _change_pct(p, nv_i))


def _change_pct(pair, normal: dict):
    """Each classified mode's frequency change (%) as the explanations weigh it: against the baselines' mean when
    several baselines were measured, else against the baseline; None without a pair."""
    if pair is None:
        return None
    if "frequency_change_pct" in normal:
        return np.array([normal["frequency_change_pct"][j] for j in pair.mode_index], float)
    return 100 * (np.abs(pair.eigenvalues[1]) / np.abs(pair.eigenvalues[0]) - 1)


def _normal_variation(model: TrainedModel, inputs: PairInputs, warnings: list) -> dict:
    """The verdicts' ``normal_variation`` shared by all pairs: assumed (one baseline) or measured, with the
    Mahalanobis distances of the baseline tests' own pairs (reference against each other baseline) from the
    training data (:attr:`learn.pairs.inputs.PairInputs.baseline_features`); one warning when most of those pairs
    lie outside it."""
    nv, route = inputs.normal_variation, inputs.route
    if nv is None:
        return {"n_baselines": 1, "measured": False, "frequency_std_pct": 100 * FREQUENCY_CHANGE_STD,
                "baseline_pairs_distance_max": None, "baseline_pairs_training_percentile": None}
    out = {**nv.summary(), "baseline_pairs_distance_max": None, "baseline_pairs_training_percentile": None}
    if inputs.baseline_features is None:
        return out
    dist, pct = model.networks[route].training_percentile(inputs.baseline_features)
    out["baseline_pairs_distance_max"] = float(dist.max())
    out["baseline_pairs_training_percentile"] = [float(v) for v in pct]
    outside = int(np.sum(pct > IN_DISTRIBUTION_PERCENTILE))
    if 2 * outside > len(pct):
        scatter = max(v for v in out["frequency_std_pct"] if v is not None)
        warnings.append(f"{outside} of the {len(pct)} pairs of baseline tests lie outside the training data (beyond "
                        f"{IN_DISTRIBUTION_PERCENTILE}% of its pairs; measured frequency scatter up to {scatter:.2g} % "
                        "per mode): the network was trained for a smaller variation between tests; the verdict "
                        "rests on the measured variation, and a model trained with measurement.frequency_scatter "
                        "covering it would answer better")
    return out


def _explanations(model: TrainedModel, inputs: PairInputs) -> list[dict]:
    """The third stage of :func:`classify_pairs`: the competing explanations of each pair (:data:`NO_EXPLANATION`
    without one): with the assumed noise, or with the normal variation measured on several baselines (each
    frequency against the baselines' mean, with the standard deviation of a later test about it,
    :meth:`learn.pairs.normal_variation.NormalVariation.prediction`: ``s sqrt(1 + 1/n)``, or that of a new session;
    each shape entry against the reference baseline's, std ``s sqrt(2)``)."""
    out, nv = [NO_EXPLANATION] * (len(inputs.names) - 1), inputs.normal_variation
    known = [i for i in range(len(out)) if inputs.pair(i) is not None]
    pairs, noise = [inputs.pairs[i] for i in known], ()
    if nv is not None and pairs:
        mean_hz, spread, shape = nv.frequency_mean_hz, nv.prediction()[1], nv.shape_std
        noise = (np.where(np.isfinite(spread), spread, FREQUENCY_CHANGE_STD),
                 SHAPE_CHANGE_STD if shape is None else np.where(np.isfinite(shape), shape * np.sqrt(2),
                                                                 SHAPE_CHANGE_STD))
        for k, p in enumerate(pairs):                  # the baseline's frequencies moved to the baselines' mean
            lam = np.array(p.eigenvalues)
            f = np.abs(lam[0]) / (2 * np.pi)
            lam[0] = lam[0] * np.where(np.isfinite(mean_hz[p.mode_index]), mean_hz[p.mode_index] / f, 1.0)
            pairs[k] = replace(p, eigenvalues=lam)
    for i, e in zip(known, explain_many(model, pairs, *noise)):
        out[i] = e
    return out


def _within_normal_variation(verdict: Verdict, normal: dict, warnings: list, source) -> tuple[Verdict, list]:
    """The verdict after the test against the measured normal variation: a damage called inside it is withdrawn
    (said in a warning); a change beyond it that the verdict's source calls undamaged is said."""
    w = list(warnings)
    n, p, alpha = normal["n_baselines"], normal["p_value"], normal["false_alarm_rate"]
    test = (f"{'Hotelling T2' if normal['test'] == 'hotelling' else 'largest |z|'} {normal['statistic']:.3g} "
            f"against {normal['threshold']:.3g}, p = {p:.2g}")
    if verdict.damaged and not normal["beyond"]:
        verdict = replace(verdict, damaged=False)
        w.append(f"the {source} calls the pair damaged, but its natural frequencies lie within the normal variation "
                 f"measured on {n} baseline tests ({test} >= {alpha:g}): no damage detected")
    elif normal["beyond"] and not verdict.damaged:
        w.append(f"the natural frequencies lie beyond the normal variation measured on {n} baseline tests ({test} < "
                 f"{alpha:g}), though the {source} finds no damage: see the competing explanations")
    return verdict, w


def _network_answers(model: TrainedModel, inputs: PairInputs) -> list[Answers]:
    """Per input: the network's part of its :class:`Answers` (empty for a pair the network does not read)."""
    out = [Answers()] * (len(inputs.names) - 1)
    route, X, rows = inputs.route, inputs.features, inputs.rows
    if not rows:
        return out
    est = model.networks[route]
    o, d = network_output(est, X, model.sensitivity)
    distance, percentile = est.training_percentile(X)     # Mahalanobis distances, training percentiles
    named = distance_terms(est, X, route, model.beam) if route in ("modal", "frequency") else [None] * len(rows)
    for r, i in enumerate(rows):
        out[i] = Answers(network_answer(d, r, o, model.beam), float(distance[r]), float(percentile[r]), named[r],
                         {k: v[r] for k, v in d.level_distributions.items()})
    return out


#: Features listed in ``distance_terms`` of a verdict (the largest terms of the squared distance).
DISTANCE_TERMS = 6


def distance_terms(est, X, route: str, beam, top: int = DISTANCE_TERMS) -> list[list[dict]]:
    """Per row of ``X``: the features that make up most of its squared Mahalanobis distance, largest first.

    Each entry (features of a missing mode left out): ``feature`` (:func:`learn.network.features.feature_names`),
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


def _chosen_verdict(net, cl, p, reasons: list, warnings: list, sens, beam):
    """The verdict (the network's inside the training data, else the classical method's), whether it is the
    network's, and the pair's warnings: ``(Verdict, bool, list)``."""
    w = list(warnings)
    inside = not reasons
    found = ", ".join(str(beam.modes[j]) for j in p.mode_index) if p is not None else ""
    if net is None:
        w.append(f"the network gives no answer for this pair (it needs modes {modes_text(beam.modes)}): the verdict "
                 f"is the classical method's ({cl['method']}) on modes {found}")
        return classical_verdict(cl, sens), False, w
    if p is not None and not p.complete:
        w.append("; ".join(p.missing) + f": the network and the classical methods answer on modes {found}")
    if inside or cl is None:
        if not inside:
            w.append("the pair lies outside the training data (" + "; ".join(reasons) + ") and no classical "
                     "answer is available: treat the network's verdict with caution")
        return Verdict.of(net), True, w
    w.append("the pair lies outside the training data (" + "; ".join(reasons) + "): the verdict is the "
             f"classical method's ({cl['method']}"
             + ("" if p is None or p.complete else f" on modes {found}")
             + "); the network's answer is shown beside it")
    return classical_verdict(cl, sens), False, w


def _identification(p, base_md, cur_md, identified: bool, beam) -> dict:
    """The verdict's ``identification``: how the modes were found (``as``: the ``identify`` command that finds the
    same modes), the baseline and measured natural frequencies (Hz; every mode found when the pair is not complete),
    the 1-based modes classified, and every pole found in each test with the model's mode it was paired with
    (``baseline_poles``, ``measured_poles``: ``{"frequency_hz", "mode"}``, mode None for a pole left unpaired;
    ``"choice"`` on one paired among several poles in its mode's band, why it)."""
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


def _classical_answers(model: TrainedModel, pairs, parts: list[Answers]) -> list[Answers]:
    """``parts`` with every classical method's answers per pair, the reasons a complete pair's modes lie outside
    the training data, and the sensitivities of the modes each pair was classified on.

    Complete pairs are classified in one call on modes 1-4; the others each on the modes both tests hold (the
    sensitivities of those modes alone), none below 2 common modes."""
    L, sens, n = model.beam, model.sensitivity, len(parts)
    thresholds = model.config["classical_thresholds"]
    answers, reasons, mode_sens = [[] for _ in range(n)], [[] for _ in range(n)], [sens] * n
    if pairs is None:
        return [replace(a, sensitivity=sens) for a in parts]
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
    return [replace(a, classical_methods=tuple(c), mode_reasons=tuple(r), sensitivity=s)
            for a, c, r, s in zip(parts, answers, reasons, mode_sens)]


#: Smallest MAC between a mode of the baseline and of the measured test for a pair the network reads
#: (:func:`learn.pairs.measured.mode_checks`).
MIN_PAIRING_MAC = 0.8


def shape_pairing_reasons(pair, beam) -> list[str]:
    """Reasons a pair with missing modes lies outside what the network was trained on: a mode whose baseline and
    measured shapes do not pair (MAC below :data:`MIN_PAIRING_MAC`; none without shapes). Its modes lie within the
    pairing tolerance of the nominal beam's by construction (:func:`learn.pairs.measured.modal_pair`)."""
    if pair.frequency_only or pair.eigenvectors.shape[1] < 2:
        return []
    u = real_shapes(pair.eigenvectors)
    m = np.sum(sign_aligned(u[1], u[0]) * u[0], axis=0) ** 2        # unit-norm real shapes: the MAC
    return [f"mode {beam.modes[j]} of the baseline and the measured test do not pair (MAC {v:.2f} < "
            f"{MIN_PAIRING_MAC})" for j, v in zip(pair.mode_index, m) if v < MIN_PAIRING_MAC]


