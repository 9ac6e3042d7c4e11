"""Classify measured pairs of a beam with a trained model (the library behind ``classify``)."""

from __future__ import annotations

import functools

import numpy as np

from learn.classical import FREQUENCY_METHODS, run_classical
from learn.features import feature_names, frf_features, frequency_features, map_frf_to_grid, modal_features
from learn.hypotheses import NO_EXPLANATION, explain_many
from learn.measured import (IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, frf_rows, identification_band_hz,
                            identify_modes, modal_pair, mode_checks, nominal_ratio_range)
from learn.model_dir import TrainedModel
from learn.verdict import (IN_DISTRIBUTION_PERCENTILE, classical_answer, classical_verdict, equivalent_depth,
                           modes_text, network_answer, network_output, ood_percentile)
from physics.errors import BeamDamageError
from physics.identification import METHODS
from physics.layout import SYMMETRIC_SUPPORTS
from physics.io import MeasuredFRF
from physics.modal import modal_parameters

__all__ = ["DISTANCE_TERMS", "classify", "classify_many", "distance_terms", "distance_text", "identification_warning"]


def classify(model: TrainedModel, baseline, current) -> dict:
    """Verdict for one measured pair: :func:`classify_many` with one current input."""
    return classify_many(model, baseline, [current])[0]


def classify_many(model: TrainedModel, baseline, currents: list, names: list[str] | None = None,
                  methods: list | None = None) -> list[dict]:
    """Verdicts for tests of one beam against the same baseline (one network call for all pairs).

    Parameters
    ----------
    baseline : :class:`physics.io.ModalData` or :class:`physics.io.MeasuredFRF`
        The undamaged state, on the model's DOFs (:func:`on_model_dofs`).
    currents : list of the same kind as ``baseline``
    names : list of str, optional
        Names of the inputs (baseline first) for messages.
    methods : list of (str or None), optional
        The identification method of :data:`physics.identification.METHODS` that produced each modal-data input
        (baseline first; ``"ssi"`` in a ``modal.json`` of ``identify`` on response records), None where unknown:
        an input identified otherwise than the training data's modal noise describes gets one warning
        (:func:`identification_warning`).

    FRF files are identified by :data:`IDENTIFICATION` (LSCF/LSFD, the path the training data's modal noise
    describes); the modal-route network and every classical method read those modes. A model on an FRF route
    reads the FRFs themselves (any frequency lines, mapped onto its grid).

    A pair whose tests do not both hold modes 1-4 (a band that stops below mode 4, a mode lost in the noise
    floor) is classified on the modes both hold (:func:`modal_pair`) by every classical method; the modal
    network, trained on 4 modes, gives no answer for it (``network`` None). Fewer than 2 common modes are refused
    when the modal network would have to read them.

    Returns
    -------
    list of dict, one verdict per current input. The verdict keys (``damaged``, ``location_*``,
    ``hinge_flexibility*``...) are the network's answer when the pair lies inside the training data
    (``in_distribution``: its Mahalanobis distance within the :data:`IN_DISTRIBUTION_PERCENTILE` percentile of
    the training pairs', its modes 1-4 all present, in their training ranges and paired), else the classical
    method's (``verdict_from``); ``network`` and ``classical`` hold both answers, ``classical_methods`` every
    method's.
    """
    names = list(names) if names else ["baseline"] + [f"measured {k + 1}" for k in range(len(currents))]
    warnings: list[str] = []
    sens = model.sensitivity
    base_md, cur_md, identified, pairs = _measured_pairs(model, baseline, currents, names, sens, warnings)
    route, X, rows = _network_inputs(model, baseline, currents, pairs, identified, warnings, methods)
    if route in ("modal", "frequency"):
        _require_common_modes(pairs, names, model.beam)
    depth = functools.partial(equivalent_depth, preset=model.config.get("truth_beam") or model.beam.name,
                              width_m=model.config["reference_width_m"])
    nets, dist, pct, where, terms = _network_answers(model, route, X, rows, sens, len(currents), depth)
    answers, mode_reasons, mode_sens = _classical_answers(model, pairs, len(currents), sens)
    for i in range(len(currents)):
        if mirrored(model.beam, pairs[i] if pairs else None):
            nets[i] = nets[i] and fold_to_half(nets[i], model.beam, where[i])
            answers[i] = [fold_to_half(a, model.beam) for a in answers[i]]
    known = [i for i in range(len(currents)) if pairs and pairs[i] is not None]
    explained = [None] * len(currents)
    for i, e in zip(known, explain_many(model, [pairs[i] for i in known])):
        explained[i] = e
    results = []
    for i, net in enumerate(nets):
        cl = next((a for a in answers[i] if a["method"] == model.config["best_classical"]),
                  answers[i][0] if answers[i] else None)
        p = pairs[i] if pairs else None
        reasons = list(mode_reasons[i])
        if net is None:
            reasons.append("; ".join(p.missing) + f": the network needs modes {modes_text(model.beam.modes)}")
        elif pct[i] > IN_DISTRIBUTION_PERCENTILE:
            reasons.insert(0, f"Mahalanobis distance {dist[i]:.3g} from the training data, beyond "
                              f"{pct[i]:.2f}% of training pairs"
                              + (f"; largest terms: {distance_text(terms[i])}" if terms[i] else ""))
        verdict, from_network, w = _chosen_verdict(net, cl, p, reasons, warnings, mode_sens[i], depth, model.beam)
        results.append({
            "measured": names[i + 1], **verdict, "location_ambiguity": location_ambiguity(model.beam, verdict, p),
            "verdict_from": "network" if from_network else "classical",
            "in_distribution": not reasons, "out_of_distribution_reasons": reasons,
            "mahalanobis_distance": dist[i], "training_percentile": pct[i], "distance_terms": terms[i],
            "network": net, "classical": cl,
            "classical_methods": answers[i],
            "identification": _identification(p, base_md, cur_md[i] if cur_md else None, identified, model.beam),
            **(explained[i] or NO_EXPLANATION),
            "input_route": route, "warnings": w,
            "_extra": {"location_distribution": where[i]},
        })
    return results


def mirrored(beam, pair) -> bool:
    """Whether a pair leaves the mirror ambiguity: a symmetric beam (:data:`physics.layout.SYMMETRIC_SUPPORTS`)
    read on natural frequencies only (no shapes, or one sensor), where a damage at ``x`` and at ``L - x`` change
    every frequency alike."""
    test = beam.test
    return (test is not None and test.bc in SYMMETRIC_SUPPORTS
            and (test.n_sensors == 1 or (pair is not None and pair.frequency_only)))


def fold_to_half(answer: dict, beam, distribution=None) -> dict:
    """An answer located on the half ``x <= L / 2`` (the mirror ambiguity, :func:`mirrored`): the network's
    distribution folded onto it (mean and std of ``min(x, L - x)``), a classical ``x`` mirrored there."""
    L = beam.length_m
    out = dict(answer)
    if distribution is not None:
        p = np.asarray(distribution, float)
        c = (np.arange(p.size) + 0.5) / p.size
        c = np.minimum(c, 1 - c)
        mean = float(p @ c)
        out["location_std_m"] = float(np.sqrt(max(p @ c**2 - mean**2, 0.0) + 1 / (12 * p.size**2)) * L)
    else:
        mean = min(answer["location_x_over_L"], 1 - answer["location_x_over_L"])
    out["location_x_over_L"], out["location_x_m"] = mean, mean * L
    z = int(beam.zone_of(mean))
    out["location_zone"] = z
    if out.get("location_element") is not None:
        out["location_element"] = z
    return out


def location_ambiguity(beam, verdict: dict, pair) -> str | None:
    """What frequencies alone cannot tell (:func:`mirrored`): the mirror image of the located damage, or None."""
    if not verdict.get("damaged") or not mirrored(beam, pair):
        return None
    x, L = verdict["location_x_m"], beam.length_m
    return (f"natural frequencies alone cannot tell x = {x:.3f} m from its mirror image L - x = {L - x:.3f} m on "
            f"this symmetric {beam.test.bc} beam: both places fit the data equally")


def _measured_pairs(model: TrainedModel, baseline, currents: list, names: list[str], sens, warnings: list):
    """Modal data of the inputs and the modes each (baseline, current) pair holds:
    ``(baseline ModalData, list of current ModalData, identified, list of ModalPair)``, the last three None when
    the FRFs could not be identified (an FRF-input model then reads the FRFs alone)."""
    base_md, cur_md, identified, found = _modal_inputs(model, baseline, currents, names, sens)
    if base_md is None:
        warnings.append("LSCF/LSFD identification failed: no classical answer; the FRF-route network alone")
        return None, None, identified, None
    found = found or [None] * len(names)
    pairs = [modal_pair(base_md, c, model.beam, sens.frequencies_hz, (names[0], n), (found[0], f))
             for c, n, f in zip(cur_md, names[1:], found[1:])]
    warnings += list(dict.fromkeys(w for p in pairs for w in p.warnings))
    w = damping_warning(model, pairs)
    if w:
        warnings.append(w)
    return base_md, cur_md, identified, pairs


#: How far outside the training's damping ratios a baseline may lie before :func:`damping_warning` speaks (factor).
DAMPING_RANGE_FACTOR = 2.0


def damping_warning(model: TrainedModel, pairs: list) -> str | None:
    """One line when the baseline's damping ratios lie beyond :data:`DAMPING_RANGE_FACTOR` times the training pairs'
    range (``damping_ratio_range`` of the model: the central 99 % of the training's measured baseline ratios),
    else None: the modal noise the model was trained with depends on the damping (an output-only identification's
    frequency scatter grows with its square root)."""
    trained = model.config.get("damping_ratio_range")
    pair = next((p for p in pairs if p is not None and p.modes.size), None)
    if pair is None or not trained:
        return None

    lo, hi = np.asarray(trained, float)[pair.modes].T
    zeta = modal_parameters(pair.eigenvalues[0])[1]
    given = np.isfinite(zeta) & (zeta > 0)                                # frequencies alone carry no damping
    out = given & ((zeta < lo / DAMPING_RANGE_FACTOR) | (zeta > hi * DAMPING_RANGE_FACTOR))
    if not out.any():
        return None
    modes = [model.beam.modes[j] for j in pair.modes[out]]
    return (f"the baseline's damping ratios of mode(s) {', '.join(map(str, modes))} ("
            + ", ".join(f"{100 * z:.3g} %" for z in zeta[out]) + ") lie beyond twice the training's ("
            + ", ".join(f"{100 * a:.3g}-{100 * b:.3g} %" for a, b in zip(lo[out], hi[out]))
            + "): the modal noise the model was trained with depends on the damping; generate with "
              "specimen.damping_ratios set to the test's")


def _require_common_modes(pairs: list, names: list[str], beam) -> None:
    """Refuse a pair with fewer than 2 modes both tests hold (the modal network reads modes)."""
    for p, n in zip(pairs, names[1:]):
        if p.modes.size < 2:
            raise BeamDamageError(f"{n}: {p.modes.size} of modes {modes_text(beam.modes)} found in both it and "
                                  f"{names[0]} ("
                                  + "; ".join(p.missing) + "); classify needs at least 2 common modes")


def _network_answers(model: TrainedModel, route: str, X, rows: list, sens, n: int, depth):
    """Per input (lists of ``n``): the network's answer (None for a pair it does not read), the Mahalanobis
    distance from the training data, its training percentile, and the network's location distribution."""
    nets, dist, pct, where, terms = [None] * n, [None] * n, [None] * n, [None] * n, [None] * n
    if not rows:
        return nets, dist, pct, where, terms
    est = model.networks[route]
    out, d = network_output(est, X, sens)
    distance, percentile = ood_percentile(est, X)
    named = distance_terms(est, X, route, model.beam) if route in ("modal", "frequency") else [None] * len(rows)
    for r, i in enumerate(rows):
        nets[i] = network_answer(d, r, out, model.beam, depth(float(d.hinge_flexibility[r])))
        dist[i], pct[i], where[i] = float(distance[r]), float(percentile[r]), d.location_distribution[r]
        terms[i] = named[r]
    return nets, dist, pct, where, terms


#: Features listed in ``distance_terms`` of a verdict (the largest terms of the squared distance).
DISTANCE_TERMS = 6


def distance_terms(est, X, route: str, beam, top: int = DISTANCE_TERMS) -> list[list[dict]]:
    """Per row of ``X``: the features that make up most of its squared Mahalanobis distance, largest first.

    Each entry: ``feature`` (:func:`learn.features.feature_names`), ``value`` (the pair's feature),
    ``training_std`` (how many training standard deviations it lies from the training mean) and ``share``
    (its term ``z_i (P z)_i`` over the squared distance; the shares of all features sum to 1).
    """
    terms, Z = est.distance_terms(X)
    names = feature_names(route, beam)
    total = np.maximum(terms.sum(axis=1), 1e-300)
    out = []
    for r in range(terms.shape[0]):
        order = np.argsort(-terms[r])[:top]
        out.append([{"feature": names[j], "value": float(np.asarray(X)[r, j]), "training_std": float(Z[r, j]),
                     "share": float(terms[r, j] / total[r])} for j in order])
    return out


def distance_text(terms: list[dict], n: int = 3) -> str:
    """The largest terms in words, e.g. ``df1 (%) -7.1 sd (62 %), dphi 2:y m1 +3.0 sd (12 %)``."""
    return ", ".join(f"{t['feature']} {t['training_std']:+.1f} sd ({t['share']:.0%})" for t in terms[:n])


def _chosen_verdict(net, cl, p, reasons: list, warnings: list, sens, depth, beam):
    """The verdict keys (the network's inside the training data, else the classical method's), whether they are
    the network's, and the pair's warnings: ``(dict, bool, list)``."""
    w = list(warnings)
    inside = not reasons
    found = ", ".join(str(beam.modes[j]) for j in p.modes) if p is not None else ""
    if net is None:
        w.append(f"the network gives no answer for this pair (it needs modes {modes_text(beam.modes)}): the verdict "
                 f"is the classical method's ({cl['method']}) on modes {found}")
        return classical_verdict(cl, sens, depth, beam), False, w
    if inside or cl is None:
        if not inside:
            w.append("the pair lies outside the training data (" + "; ".join(reasons) + ") and no classical "
                     "answer is available: treat the network's verdict with caution")
        return dict(net), True, w
    w.append("the pair lies outside the training data (" + "; ".join(reasons) + "): the verdict is the "
             f"classical method's ({cl['method']}"
             + ("" if p is None or p.complete else f" on modes {found}")
             + "); the network's answer is shown beside it")
    return classical_verdict(cl, sens, depth, beam), False, w


def _identification(p, base_md, cur_md, identified: bool, beam) -> dict:
    """The verdict's ``identification``: how the modes were found, the baseline and measured natural frequencies
    (Hz; every mode found when the pair is not complete) and the 1-based modes classified."""
    if p is None:
        freqs, modes = ([], []), []
    elif p.complete:
        freqs, modes = np.abs(p.eigenvalues) / (2 * np.pi), list(beam.modes)
    else:
        freqs = [np.sort(np.abs(md.eigenvalues)) / (2 * np.pi) for md in (base_md, cur_md)]
        modes = [beam.modes[int(j)] for j in p.modes]
    return {**IDENTIFICATION, "n_modes": beam.n_modes, "modes_model": list(beam.modes),
            "source": "identified from FRFs" if identified else "modal data",
            "baseline_frequencies_hz": [float(x) for x in freqs[0]],
            "measured_frequencies_hz": [float(x) for x in freqs[1]], "modes_classified": modes}



def _modal_inputs(model: TrainedModel, baseline, currents: list, names: list[str], sens):
    """Modal data of the baseline and every current input: ``(ModalData, list of ModalData, identified, found)``,
    ``found`` one text per input on the modes it holds (e.g. "LSCF/LSFD found 2 modes in 2-500 Hz")."""
    inputs = [baseline, *currents]
    kinds = {isinstance(d, MeasuredFRF) for d in inputs}
    if len(kinds) > 1:
        raise BeamDamageError("BASELINE and MEASURED must all be FRF files or all modal data")
    if not kinds.pop():
        return baseline, list(currents), False, None
    test = model.beam.test
    if test is None:
        fmax, fmin = IDENTIFICATION_BAND_FACTOR * float(sens.frequencies_hz[3]), 0.0
    else:
        fmin, fmax = test.band_hz
    try:
        # another test: spare poles and a model order for wide noisy bands, then paired by frequency
        k = model.beam.n_modes + (0 if test is None else 2)
        order = 40 if test is None else max(40, 10 * k)
        ids = [identify_modes(d, fmax, n, k, fmin, order) for d, n in zip(inputs, names)]
    except BeamDamageError:
        if model.route == "modal":
            raise
        return None, None, True, None          # an FRF-route model classifies the FRFs without modes
    found = []
    for d, md in zip(inputs, ids):
        k = md.eigenvalues.size
        lo, hi = identification_band_hz(d, fmax, fmin)
        found.append(f"LSCF/LSFD found {k} mode{'s' * (k != 1)} in {lo:.4g}-{hi:.4g} Hz")
    return ids[0], ids[1:], True, found


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
        if not p.complete and p.modes.size >= 2:
            mode_sens[i] = sens.modes(p.modes)
            outs, _ = run_classical(p.eigenvalues[None], p.eigenvectors[None], mode_sens[i], thresholds)
            answers[i] = [classical_answer(o, 0, L) for o in outs
                          if not p.frequency_only or o.name in FREQUENCY_METHODS]
    return answers, reasons, mode_sens


def _network_inputs(model: TrainedModel, baseline, currents: list, pairs, identified: bool, warnings: list,
                    methods=None):
    """Route, feature rows and the pairs they belong to: ``(route, X, rows)``.

    ``X`` are the FRF-route features of every pair when the model reads FRFs and the inputs are FRF files, else
    the modal features of the pairs whose tests both hold modes 1-4 (``rows``: their indices; ``X`` None when
    there are none). Warnings are appended to ``warnings``.
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
        rows = [i for i, p in enumerate(pairs) if p.complete]
        X = frequency_features(np.stack([pairs[i].eigenvalues for i in rows]), model.beam.n_modes) if rows else None
        return "frequency", X, rows
    if "modal" not in model.networks:
        raise BeamDamageError("this model has no modal-route network; give FRF files holding receptances at "
                              f"{', '.join(model.beam.dofs)} driven at {model.beam.dofs[model.beam.drive_row]}")
    rows = [i for i, p in enumerate(pairs) if p.complete]
    X = None
    if rows:
        X = modal_features(np.stack([pairs[i].eigenvalues for i in rows]),
                           np.stack([pairs[i].eigenvectors for i in rows]), model.beam.n_modes, model.beam.test)
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


