"""The verdicts of a classified pair: the network's and the classical methods' answers, which one is the verdict,
and the verdict as a reader sees it."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from datagen.damage import DAMAGE_MODELS, DEFAULT_KIND, damage_model
from learn.explanations.classical import MethodOutput
from learn.network.evaluate import MIN_DROP
from learn.network.intervals import LEVELS
from physics.io import dof_positions_text

if TYPE_CHECKING:  # torch: the network is loaded only where one runs
    from learn.network.estimator import DamageClassifier

__all__ = ["BASE_LABELS", "IN_DISTRIBUTION_PERCENTILE", "PLACE_MASS", "PLACE_PEAK", "DamageWords", "Verdict",
           "agreement", "classical_answer", "classical_verdict", "detectability_threshold", "explanation_label",
           "network_answer", "network_output", "noise_text", "normal_variation_text", "place_keys", "verdict_text"]

#: How the prose names the explanations that are no damage kind (a damage kind's ``label`` names it).
BASE_LABELS = {"intact": "intact", "global_stiffness": "a stiffness change of the whole beam",
               "support_change": "a support change"}


def explanation_label(name: str) -> str:
    """An explanation's name in prose: ``"a mass change"`` for ``"mass_change"``, ``"a stiffness change of the whole
    beam"`` for ``"global_stiffness"`` (:data:`BASE_LABELS`)."""
    return DAMAGE_MODELS[name].label if name in DAMAGE_MODELS else BASE_LABELS[name]


#: Training percentile of the Mahalanobis distance above which a pair counts as outside the training data.
IN_DISTRIBUTION_PERCENTILE = 99.9


def detectability_threshold() -> float:
    """Largest first-order frequency change below which a damage counts as not detectable (0.2 %)."""
    return MIN_DROP


def network_output(est: DamageClassifier, X, sens, name="network") -> tuple[MethodOutput, object]:
    """Network answers as a :class:`MethodOutput` plus the full :class:`learn.network.estimator.DamagePrediction`."""
    d = est.predict_details(X)
    detectable = sens.largest_drop(d.x_over_L, d.size) >= detectability_threshold()
    out = MethodOutput(name, d.probability_damaged, d.probability_damaged >= d.threshold, d.x_over_L,
                       d.size,
                       probability=d.probability_damaged, x_std_over_L=d.x_std_over_L,
                       size_std=d.size_std, detectable=detectable)
    return out, d


#: The network's zone probabilities hold a place when its best zone and that zone's neighbours hold this share of
#: them (with its mirror zones on a beam read on frequencies alone) ...
PLACE_MASS = 0.5
#: ... and its best zone at least this many times the share of a uniform spread.
PLACE_PEAK = 2.0


def _zone_span(edges, z: int) -> str:
    return f"zone {z} of {len(edges) - 1}, {edges[z - 1]:.3g}-{edges[z]:.3g} m"


def place_keys(answer: dict, beam, mirror: bool = False) -> dict:
    """Whether an answer's zone probabilities hold one place (:data:`PLACE_MASS`, :data:`PLACE_PEAK`), and its
    zone read from its ``x`` so that the two always agree.

    Returns ``{"place_determined", "place_text", "location_zone"[, "location_element"]}``: ``place_text`` says why
    the place is undetermined (a flat spread, or two separate peaks: "zone 1 ... or zone 6 ..., its mirror"), None
    when it is determined or the answer carries no probabilities (a classical method's). ``mirror``: the beam is
    read on frequencies alone where ``x`` and ``L - x`` fit alike (:func:`learn.explanations.mirror.mirrored`): a zone
    and its mirror count as one place.
    """
    edges = np.asarray(beam.zone_edges_m, float)
    z = int(beam.zone_of_x_over_L(answer["location_x_over_L"]))
    out = {"place_determined": True, "place_text": None, "location_zone": z}
    if answer.get("location_element") is not None:
        out["location_element"] = z
    p = answer.get("zone_probabilities")
    if not answer.get("damaged") or p is None:
        return out
    p = np.asarray(p, float)
    n = p.size
    near = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :]) <= 1          # (n, n) a zone and its neighbours
    L = beam.length_m
    centres = 0.5 * (edges[:-1] + edges[1:])
    twin = np.argmin(np.abs(centres[None, :] - (L - centres)[:, None]), axis=1)   # each zone's mirror zone
    held = near | (near[twin] if mirror else False)
    best = int(np.argmax(p))
    if p[held[best]].sum() >= PLACE_MASS and p[best] >= PLACE_PEAK / n:
        return out
    far = ~near[best]
    other = int(np.argmax(np.where(far, p, -1.0))) if far.any() else best
    head = f"{_zone_span(edges, best + 1)} ({p[best]:.2f})"
    if other != best and p[other] >= 1.0 / n and p[other] >= 0.5 * p[best]:
        text = f"{head} or {_zone_span(edges, other + 1)} ({p[other]:.2f})" + (
            ", its mirror" if twin[best] == other else "")
    else:
        text = f"the zone probabilities are flat (largest {head}, against {1 / n:.2f} each if uniform)"
    out.update(place_determined=False, place_text="place undetermined: " + text)
    return out


def zone_keys(beam, zone: int, probabilities=None) -> dict:
    """``location_zone``, ``zone_edges_m`` (and ``zone_probabilities``) of a verdict; ``location_element`` and
    ``element_probabilities`` are the zone's on the thesis's test (its 4 elements), None on another."""
    thesis = beam.test is None
    p = None if probabilities is None else [float(v) for v in probabilities]
    return {"location_zone": int(zone), "zone_edges_m": [float(v) for v in beam.zone_edges_m],
            "zone_probabilities": p, "location_element": int(zone) if thesis else None,
            "element_probabilities": p if thesis else None}


def network_answer(d, i, out, beam) -> dict:
    L = beam.length_m
    return {"damaged": bool(out.damaged[i]), "probability_damaged": float(d.probability_damaged[i]),
            "location_x_over_L": float(d.x_over_L[i]), "location_x_m": float(d.x_over_L[i] * L),
            "location_std_m": float(d.x_std_over_L[i] * L),
            **zone_keys(beam, d.element[i], d.element_probabilities[i]),
            "size": float(d.size[i]),
            "size_std": float(d.size_std[i]), **interval_keys(d.intervals, i, L),
            "detectable": bool(out.detectable[i]), "decision_threshold": float(d.threshold[i]),
            **support_answer(d, i)}


def interval_keys(intervals: dict, i: int, length_m: float) -> dict:
    """``x_m_68``, ``x_m_95``, ``size_68``, ``size_95`` of pair ``i`` (:mod:`learn.network.intervals`), as
    ``[lo, hi]``."""
    out = {}
    for k in LEVELS:
        out[f"x_m_{k}"] = [float(v) * length_m for v in intervals[f"x_over_L_{k}"][i]]
        out[f"size_{k}"] = [float(v) for v in intervals[f"size_{k}"][i]]
    return out


def support_answer(d, i) -> dict:
    """``probability_support_change`` and ``support_changed`` (above one half) of pair ``i``; None for a model not
    trained on support changes."""
    p = float(d.probability_support_change[i])
    if not np.isfinite(p):
        return {"probability_support_change": None, "support_changed": None}
    return {"probability_support_change": p, "support_changed": p >= 0.5}


def classical_answer(o: MethodOutput, i, beam) -> dict:
    zone = zone_keys(beam, beam.zone_of_x_over_L(o.x_over_L[i]))
    zone = {k: v for k, v in zone.items() if "probabilities" not in k}
    return {"method": o.name, "damaged": bool(o.damaged[i]), "location_x_over_L": float(o.x_over_L[i]),
            "location_x_m": float(o.x_over_L[i] * beam.length_m), **zone,
            "size": float(o.size[i]), "score": float(o.score[i])}


@dataclass(frozen=True)
class Verdict:
    """A classified pair's verdict: the network's answer (:func:`network_answer` with :func:`place_keys`) or the
    classical method's (:func:`classical_verdict`: no probabilities, spreads or intervals, None there). Lengths in
    m; ``size`` of the model's damage kind; ``zone_edges_m`` (z + 1,), ``*_probabilities`` (z,) or None,
    ``x_m_68`` ... ``size_95`` ``[lo, hi]`` or None."""

    damaged: bool
    probability_damaged: float | None
    decision_threshold: float | None
    location_x_over_L: float
    location_x_m: float
    location_std_m: float | None
    location_zone: int
    zone_edges_m: list
    zone_probabilities: list | None
    place_determined: bool
    place_text: str | None
    location_element: int | None
    element_probabilities: list | None
    size: float
    size_std: float | None
    x_m_68: list | None
    x_m_95: list | None
    size_68: list | None
    size_95: list | None
    detectable: bool
    probability_support_change: float | None
    support_changed: bool | None

    @classmethod
    def of(cls, answer: dict) -> "Verdict":
        """The verdict of an answer holding every field (the network's)."""
        return cls(**{f.name: answer[f.name] for f in fields(cls)})


def classical_verdict(cl: dict, sens) -> Verdict:
    """The verdict from the classical method's answer ``cl`` (no probabilities or spreads)."""
    detectable = sens.largest_drop(np.array([cl["location_x_over_L"]]), np.array([cl["size"]]))[0]
    return Verdict.of({**dict.fromkeys(f.name for f in fields(Verdict)), **{k: cl[k] for k in (
        "damaged", "location_x_over_L", "location_x_m", "location_element", "location_zone", "zone_edges_m",
        "size")}, "place_determined": True, "detectable": bool(detectable >= detectability_threshold())})


@dataclass(frozen=True)
class DamageWords:
    """How a verdict speaks of a damage: the model's damage kind's prose (``describe``) on its truth beam
    (``preset``: a preset name or the truth beam's mapping; ``section``: the generator config's section keys)."""

    kind: str = DEFAULT_KIND
    preset: object = None
    section: dict | None = None

    @property
    def size_label(self) -> str:
        return damage_model(self.kind).size_label

    def what(self, a: dict) -> str:
        """The kind's description of the damage of answer ``a`` (its ``location_x_m`` and ``size``)."""
        return damage_model(self.kind).describe(a["location_x_m"], a["size"], self.preset, self.section)


def _network_sentence(a: dict, words: DamageWords) -> str:
    return _damage_sentence(a, words) + _support_sentence(a)


def _support_sentence(a: dict) -> str:
    if not a.get("support_changed"):
        return ""
    return (f"; the supports changed beyond re-clamping (probability {a['probability_support_change']:.1%}: "
            "a clamp, bearing or suspension stiffer or softer than on the baseline day)")


def _damage_sentence(a: dict, words: DamageWords) -> str:
    if not a["damaged"]:
        return f"no damage detected (probability of damage {a['probability_damaged']:.1%}{_threshold_text(a)})"
    if not a["detectable"]:
        return (f"possibly damaged (probability {a['probability_damaged']:.1%}), but not detectable here: a damage "
                f"like the one that would explain the data ({words.what(a)}) changes the natural frequencies by less "
                "than the measurement resolution")
    size_std = "" if a.get("size_std") is None else f"; {words.size_label} +- {a['size_std']:.2g}"
    if a.get("place_determined") is False:
        return (f"damaged (probability {a['probability_damaged']:.1%}{_threshold_text(a)}): "
                f"{words.what({**a, 'location_x_m': None})}; {a['place_text']}{size_std}")
    return (f"damaged (probability {a['probability_damaged']:.1%}{_threshold_text(a)}): {words.what(a)} (location +- "
            f"{a['location_std_m']:.3f} m, x/L = {a['location_x_over_L']:.2f}, {_zone_text(a)}{size_std})")


def _threshold_text(a: dict) -> str:
    """How the probability compares with the decision threshold (set on intact validation pairs for the network's
    false-alarm target), e.g. ``", below the 99.2% this model calls damage at"``."""
    t = a.get("decision_threshold")
    if t is None:
        return ""
    return f", {'below' if a['probability_damaged'] < t else 'at or above'} the {t:.1%} this model calls damage at"


def modes_text(modes) -> str:
    """``"1-4"`` for a run of 3 or more modes, else ``"1, 3, 5"``."""
    modes = list(modes)
    run = modes == list(range(modes[0], modes[-1] + 1))
    return f"{modes[0]}-{modes[-1]}" if run and len(modes) > 2 else ", ".join(map(str, modes))


def _zone_text(a: dict) -> str:
    edges, z = a.get("zone_edges_m"), a.get("location_zone")
    if a.get("location_element") is not None:
        return f"element {a['location_element']} of 4"
    return _zone_span(edges, z)


def _classical_sentence(c: dict, words: DamageWords) -> str:
    if not c["damaged"]:
        return f"{c['method']}: undamaged"
    model = damage_model(words.kind)
    if c["size"] < 0 and model.size_transform == "log":             # a kind of positive sizes only
        return (f"{c['method']}: changed, the natural frequencies rise, which {model.label} does not do: a stiffness "
                f"gained or a mass lost near x = {c['location_x_m']:.3g} m ({_zone_text(c)})")
    return f"{c['method']}: damaged, {words.what(c)} ({_zone_text(c)})"


def explained_text(res: dict) -> str:
    """What the competing explanations were weighed on: ``"frequency and shape changes"`` or
    ``"frequency changes"``."""
    return "frequency and shape changes" if res.get("shape_change_std") else "frequency changes"


def agreement(damaged: bool, net, cl, hypotheses, source: str) -> dict:
    """Whether the network, the classical method and the competing explanations tell one story about damage:
    ``{"network", "classical", "explanations", "agree", "text"}`` (None for an answer not given; the
    explanations' answer is the most likely one's name, a damage when it is a damage kind of
    :data:`datagen.damage.DAMAGE_MODELS`)."""
    best = hypotheses[0] if hypotheses else None
    votes = {"network": None if net is None else bool(net["damaged"]),
             "classical": None if cl is None else bool(cl["damaged"]),
             "explanations": None if best is None else best["name"] in DAMAGE_MODELS}
    given = {k: v for k, v in votes.items() if v is not None}
    agree = len(set(given.values())) <= 1
    said = {"network": f"the network {'calls it damaged' if votes['network'] else 'finds no damage'}",
            "classical": f"{cl['method'] if cl else ''} {'calls it damaged' if votes['classical'] else 'finds none'}",
            "explanations": (f"the most likely explanation is {explanation_label(best['name'])} "
                             f"({best['probability']:.2f}"
                             + ("" if best.get("fits", True) else ", not fitting") + ")") if best else ""}
    parts = [said[k] for k in given]
    if agree and given and set(given.values()) != {bool(damaged)}:    # the verdict withdrawn by the baselines
        agree = False
        text = ("; ".join(parts)[:1].upper() + "; ".join(parts)[1:] + f", but the verdict is "
                f"{'damaged' if damaged else 'no damage detected'}: the natural frequencies lie within the normal "
                "variation the baseline tests measured.")
    elif agree:
        text = "One story: " + "; ".join(parts) + "."
    else:
        text = (f"They disagree: {'; '.join(parts)}. The verdict ({'damaged' if damaged else 'undamaged'}) "
                f"is the {source}'s")
        if best is not None and votes["explanations"] != bool(damaged):
            text += (": the explanations find the change within the noise they weigh" if best["name"] == "intact"
                     else ": the explanations weigh the change against its noise and find "
                          f"{explanation_label(best['name'])} more probable")
        text += "."
    return {**votes, "agree": agree, "text": text}


def verdict_text(res: dict, words: DamageWords = DamageWords()) -> str:
    """The verdict as a reader sees it: the answer, where it comes from, both methods, the caveats; the damage in
    the words of the model's damage kind (``words``)."""
    net, cl = res["network"], res["classical"]
    modes = res["identification"].get("modes_classified") or []
    partial = bool(modes) and len(modes) < res["identification"].get("n_modes", 4)
    on = f" on modes {', '.join(map(str, modes))}" if partial else ""
    nv = res.get("normal_variation") or {}
    answer = net if res["verdict_from"] == "network" else res["classical"]
    if answer is not None and answer["damaged"] and not res["damaged"] and nv.get("beyond") is False:
        source = "network" if res["verdict_from"] == "network" else res["classical"]["method"]
        head = (f"Verdict ({source}{on}, against the normal variation of {nv['n_baselines']} baseline tests): no "
                f"damage detected: the natural frequencies lie within it (p = {nv['p_value']:.2g}), though the "
                f"{source} alone calls it damaged")
        head += f" (probability {net['probability_damaged']:.1%})." if source == "network" else "."
    elif res["verdict_from"] == "network":
        head = f"Verdict (network{on}): " + _network_sentence(net, words) + "."
    elif net is None:
        need = modes_text(res["identification"].get("modes_model", [1, 2, 3, 4]))
        head = (f"Verdict (classical method on modes {', '.join(map(str, modes))}, the network needs modes {need}): "
                + _classical_sentence(cl, words) + ".")
    else:
        head = ("Verdict (classical method, the pair lies outside the training data): " + _classical_sentence(cl, words)
                + ".")
    lines = [head[:1].upper() + head[1:]]
    if net is None:
        lines.append("Why: " + "; ".join(res["out_of_distribution_reasons"]) + ".")
        lines.append(f"Network: no answer (trained on modes "
                     f"{modes_text(res['identification'].get('modes_model', [1, 2, 3, 4]))}).")
    else:
        if net["damaged"]:
            what = "Element" if net.get("location_element") is not None else "Zone"
            lines.append(f"{what} probabilities (network): " + ", ".join(f"{k + 1}: {v:.2f}" for k, v in
                                                                         enumerate(net["zone_probabilities"])))
        lines.append(f"Network: {_network_sentence(net, words)}.")
    lines.append(f"Classical ({cl['method']}, the best on the training data): {_classical_sentence(cl, words)}."
                 if cl else "Classical: no answer (fewer than 2 modes identified in both tests).")
    if net is None:
        lines.append(f"Input route: {res['input_route']}; in distribution: no.")
    else:
        lines.append(f"Input route: {res['input_route']}; distance from the training data: Mahalanobis "
                     f"{res['mahalanobis_distance']:.3g} (beyond {res['training_percentile']:.1f}% of training pairs); "
                     f"in distribution: {'yes' if res['in_distribution'] else 'no'}.")
    ident = res["identification"]
    lines.append(f"Natural frequencies (Hz, {ident['source']}): baseline "
                 + ", ".join(f"{x:.2f}" for x in ident["baseline_frequencies_hz"]) + "; measured "
                 + ", ".join(f"{x:.2f}" for x in ident["measured_frequencies_hz"])
                 + (f"; modes classified: {', '.join(map(str, modes))}"
                    if modes and len(modes) < ident.get("n_modes", 4) else ""))
    for name in ("baseline", "measured"):
        poles = ident.get(f"{name}_poles")
        if poles:
            lines.append(f"{name.capitalize()} poles -> the model's modes: "
                         + ", ".join(f"{p['frequency_hz']:.2f} Hz -> "
                                     + (f"mode {p['mode']}" if p["mode"] is not None else "none (unpaired)")
                                     + (f" ({p['choice']})" if p.get("choice") else "")
                                     for p in poles))
    for name, d in (res.get("dof_positions") or {}).items():
        lines.append(f"{name}: " + (dof_positions_text(d) if d else "modal data without DOF labels: rows taken as "
                                                                  "the model's DOFs"))
    if res.get("location_ambiguity"):
        lines.append(f"Location: {res['location_ambiguity']}.")
    if res.get("normal_variation"):
        lines.append(normal_variation_text(res["normal_variation"]))
    if res.get("agreement"):
        lines.append(res["agreement"]["text"])
    if res.get("hypotheses"):
        lines.append(f"Explanations of the {explained_text(res)} (equal priors, {noise_text(res)}): "
                     + ", ".join(f"{explanation_label(h['name'])} {h['probability']:.2f}" for h in res["hypotheses"])
                     + f"; {res['hypotheses_summary']}.")
    lines += [f"warning: {w}" for w in res["warnings"]]
    return "\n".join(lines)


def _span(v, scale: float = 1.0, unit: str = "") -> str:
    """``"0.1 %"`` for one value, ``"0.05-0.8 %"`` for the range of a list."""
    if not isinstance(v, (list, tuple)):
        return f"{scale * v:.2g}{unit}"
    v = [scale * a for a in v if a is not None]
    lo, hi = min(v), max(v)
    return f"{lo:.2g}{unit}" if f"{lo:.2g}" == f"{hi:.2g}" else f"{lo:.2g}-{hi:.2g}{unit}"


def noise_text(res: dict) -> str:
    """The noise the explanations were weighed with, e.g. ``"0.1 % noise per mode, 0.03 per shape entry"``."""
    what = "measured" if isinstance(res["frequency_change_std"], list) else "assumed"
    return (f"{what} noise {_span(res['frequency_change_std'], 100, ' %')} per mode"
            + (f", {_span(res['shape_change_std'])} per shape entry" if res.get("shape_change_std") else ""))


def normal_variation_text(nv: dict) -> str:
    """The normal variation between tests in one line: assumed, or measured on several baselines with the test
    of this pair against it."""
    if not nv["measured"]:
        return (f"Normal variation between tests: assumed ({nv['frequency_std_pct']:.2g} % per mode in the "
                "explanations, the training's ranges in the network), not measured: give several baseline tests "
                "(--baseline repeated) to measure it.")
    text = (f"Normal variation measured on {nv['n_baselines']} baseline tests (reference {nv['reference_baseline']}):"
            f" frequency scatter {_span(nv['frequency_std_pct'], 1, ' %')} per mode"
            + (f", shapes {_span(nv['shape_std'])} per entry" if nv.get("shape_std") else "")
            + (f", damping {_span(nv['damping_std_pct'], 1, ' points')}"
               if any(v is not None for v in nv["damping_std_pct"]) else "")
            + (f"; {nv['sessions']['text']}" if nv.get("sessions") else ""))
    if "beyond" in nv:
        change = ", ".join(f"{c:+.3g} %" for c in nv["frequency_change_pct"] if c is not None)
        text += (f"; this test's frequencies change by {change} from the baselines' mean, "
                 f"{'beyond' if nv['beyond'] else 'within'} that variation (p = {nv['p_value']:.2g}, false-alarm "
                 f"rate {nv['false_alarm_rate']:g})")
    return text + "."
