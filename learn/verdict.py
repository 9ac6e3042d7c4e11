"""The verdicts of a classified pair: the network's and the classical methods' answers, which one is the verdict,
and the verdict as a reader sees it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from datagen.config import DEFAULTS
from datagen.damage.slit import equivalent_depth as slit_depth
from learn.classical import MethodOutput
from learn.evaluate import MIN_DROP
from learn.features import as_spec
from physics.io import dof_positions_text

if TYPE_CHECKING:  # torch: the network is loaded only where one runs
    from learn.estimator import DamageClassifier

__all__ = ["IN_DISTRIBUTION_PERCENTILE", "classical_answer", "classical_verdict", "detectability_threshold",
           "equivalent_depth", "network_answer", "network_output", "ood_percentile", "verdict_text"]

#: Training percentile of the Mahalanobis distance above which a pair counts as outside the training data.
IN_DISTRIBUTION_PERCENTILE = 99.9


def detectability_threshold() -> float:
    """Largest first-order frequency drop below which a slit counts as not detectable (0.2 %)."""
    return MIN_DROP


def network_output(est: DamageClassifier, X, sens, name="network") -> tuple[MethodOutput, object]:
    """Network answers as a :class:`MethodOutput` plus the full :class:`learn.estimator.DamagePrediction`."""
    d = est.predict_details(X)
    detectable = sens.largest_drop(d.x_over_L, d.hinge_flexibility) >= detectability_threshold()
    out = MethodOutput(name, d.probability_damaged, d.probability_damaged >= est.threshold_, d.x_over_L,
                       d.hinge_flexibility,
                       probability=d.probability_damaged, x_std_over_L=d.x_std_over_L,
                       hinge_flexibility_std=d.hinge_flexibility_std, detectable=detectable)
    return out, d



def ood_percentile(est: DamageClassifier, X) -> tuple[np.ndarray, np.ndarray]:
    """Mahalanobis distances of feature rows to the training features, and the percentage of training pairs
    at or below each distance: arrays of shape (n,)."""
    d = est.mahalanobis(X)
    return d, np.searchsorted(est.reference_distances_, d, side="right") / est.reference_distances_.size * 100



def zone_keys(beam, zone: int, probabilities=None) -> dict:
    """``location_zone``, ``zone_edges_m`` (and ``zone_probabilities``) of a verdict; ``location_element`` and
    ``element_probabilities`` are the zone's on the thesis's test (its 4 elements), None on another."""
    thesis = beam.test is None
    p = None if probabilities is None else [float(v) for v in probabilities]
    return {"location_zone": int(zone), "zone_edges_m": [float(v) for v in beam.zone_edges_m],
            "zone_probabilities": p, "location_element": int(zone) if thesis else None,
            "element_probabilities": p if thesis else None}


def network_answer(d, i, out, beam, depth) -> dict:
    beam = as_spec(beam)
    L = beam.length_m
    return {"damaged": bool(out.damaged[i]), "probability_damaged": float(d.probability_damaged[i]),
            "location_x_over_L": float(d.x_over_L[i]), "location_x_m": float(d.x_over_L[i] * L),
            "location_std_m": float(d.x_std_over_L[i] * L),
            **zone_keys(beam, d.element[i], d.element_probabilities[i]),
            "hinge_flexibility": float(d.hinge_flexibility[i]),
            "hinge_flexibility_std": float(d.hinge_flexibility_std[i]),
            "depth_m": depth, "detectable": bool(out.detectable[i]), **support_answer(d, i)}


def support_answer(d, i) -> dict:
    """``probability_support_change`` and ``support_changed`` (above one half) of pair ``i``; None for a model not
    trained on support changes."""
    p = float(d.probability_support_change[i])
    if not np.isfinite(p):
        return {"probability_support_change": None, "support_changed": None}
    return {"probability_support_change": p, "support_changed": p >= 0.5}


def classical_answer(o: MethodOutput, i, beam) -> dict:
    beam = as_spec(beam)
    zone = {k: v for k, v in zone_keys(beam, beam.zone_of(o.x_over_L[i])).items() if "probabilities" not in k}
    return {"method": o.name, "damaged": bool(o.damaged[i]), "location_x_over_L": float(o.x_over_L[i]),
            "location_x_m": float(o.x_over_L[i] * beam.length_m), **zone,
            "hinge_flexibility": float(o.hinge_flexibility[i]), "score": float(o.score[i])}



def classical_verdict(cl: dict, sens, depth, beam=None) -> dict:
    """The verdict keys from the classical method's answer ``cl`` (no probabilities or spreads)."""
    detectable = sens.largest_drop(np.array([cl["location_x_over_L"]]), np.array([cl["hinge_flexibility"]]))[0]
    return {"damaged": cl["damaged"], "probability_damaged": None,
            "location_x_over_L": cl["location_x_over_L"], "location_x_m": cl["location_x_m"],
            "location_std_m": None, "location_element": cl["location_element"],
            "location_zone": cl["location_zone"], "zone_edges_m": cl["zone_edges_m"], "zone_probabilities": None,
            "element_probabilities": None, "hinge_flexibility": cl["hinge_flexibility"],
            "hinge_flexibility_std": None, "depth_m": depth(cl["hinge_flexibility"]),
            "detectable": bool(detectable >= detectability_threshold()),
            "probability_support_change": None, "support_changed": None}



def equivalent_depth(hinge_flexibility: float, preset, width_m: float) -> float | None:
    """Depth (m) of a slit ``width_m`` wide of that hinge flexibility (:func:`datagen.damage.slit.equivalent_depth`)."""
    return slit_depth(hinge_flexibility, preset, width_m, DEFAULTS["section"])


def _network_sentence(a: dict) -> str:
    return _damage_sentence(a) + _support_sentence(a)


def _support_sentence(a: dict) -> str:
    if not a.get("support_changed"):
        return ""
    return (f"; the supports changed beyond re-clamping (probability {a['probability_support_change']:.1%}: "
            "a clamp, bearing or suspension stiffer or softer than on the baseline day)")


def _damage_sentence(a: dict) -> str:
    if not a["damaged"]:
        return f"no damage detected (probability of damage {a['probability_damaged']:.1%})"
    if not a["detectable"]:
        return (f"possibly damaged (probability {a['probability_damaged']:.1%}), but not detectable here: a slit like "
                f"the one that would explain the data, near x = {a['location_x_m']:.3f} m, changes the natural "
                "frequencies by less than the measurement resolution")
    depth = "" if a["depth_m"] is None else f", e.g. a slit {a['depth_m'] * 1000:.2f} mm deep over 5.5 mm"
    return (f"damaged (probability {a['probability_damaged']:.1%}): slit at x = {a['location_x_m']:.3f} m +- "
            f"{a['location_std_m']:.3f} m (x/L = {a['location_x_over_L']:.2f}, {_zone_text(a)}), hinge flexibility "
            f"EI/(k L) = {a['hinge_flexibility']:.3g} +- {a['hinge_flexibility_std']:.2g}"
            f"{depth}")


def modes_text(modes) -> str:
    """``"1-4"`` for a run of 3 or more modes, else ``"1, 3, 5"``."""
    modes = list(modes)
    run = modes == list(range(modes[0], modes[-1] + 1))
    return f"{modes[0]}-{modes[-1]}" if run and len(modes) > 2 else ", ".join(map(str, modes))


def _zone_text(a: dict) -> str:
    edges, z = a.get("zone_edges_m"), a.get("location_zone")
    if a.get("location_element") is not None:
        return f"element {a['location_element']} of 4"
    return f"zone {z} of {len(edges) - 1}, {edges[z - 1]:.3g}-{edges[z]:.3g} m"


def _classical_sentence(c: dict) -> str:
    if not c["damaged"]:
        return f"{c['method']}: undamaged"
    return (f"{c['method']}: damaged, x = {c['location_x_m']:.3f} m ({_zone_text(c)}), hinge "
            f"flexibility {c['hinge_flexibility']:.3g}")


def explained_text(res: dict) -> str:
    """What the competing explanations were weighed on: ``"frequency and shape changes"`` or
    ``"frequency changes"``."""
    return "frequency and shape changes" if res.get("shape_change_std") else "frequency changes"


def verdict_text(res: dict) -> str:
    """The verdict as a reader sees it: the answer, where it comes from, both methods, the caveats."""
    net, cl = res["network"], res["classical"]
    modes = res["identification"].get("modes_classified") or []
    if res["verdict_from"] == "network":
        head = "Verdict (network): " + _network_sentence(net) + "."
    elif net is None:
        need = modes_text(res["identification"].get("modes_model", [1, 2, 3, 4]))
        head = (f"Verdict (classical method on modes {', '.join(map(str, modes))}, the network needs modes {need}): "
                + _classical_sentence(cl) + ".")
    else:
        head = ("Verdict (classical method, the pair lies outside the training data): " + _classical_sentence(cl)
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
        lines.append(f"Network: {_network_sentence(net)}.")
    lines.append(f"Classical ({cl['method']}, the best on the training data): {_classical_sentence(cl)}." if cl else
                 "Classical: no answer (fewer than 2 modes identified in both tests).")
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
    for name, d in res["dof_positions"].items():
        lines.append(f"{name}: " + (dof_positions_text(d) if d else "modal data without DOF labels: rows taken as "
                                                                  "the model's DOFs"))
    if res.get("location_ambiguity"):
        lines.append(f"Location: {res['location_ambiguity']}.")
    if res.get("hypotheses"):
        lines.append(f"Explanations of the {explained_text(res)} (equal priors, "
                     f"{100 * res['frequency_change_std']:.2g} % noise per mode"
                     + (f", {res['shape_change_std']:.2g} per shape entry" if res.get("shape_change_std") else "")
                     + "): "
                     + ", ".join(f"{h['name']} {h['probability']:.2f}" for h in res["hypotheses"])
                     + f"; {res['hypotheses_summary']}.")
    lines += [f"warning: {w}" for w in res["warnings"]]
    return "\n".join(lines)
