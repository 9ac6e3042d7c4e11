"""The mirror ambiguity of a symmetric beam: where natural frequencies alone cannot tell ``x`` from ``L - x``.

On a beam whose supports are symmetric (:attr:`physics.supports.Support.symmetric`), a damage at ``x`` and at
``L - x`` change every natural frequency alike; shapes at two or more sensors tell them apart. A verdict read on
frequencies alone is located on the half ``x <= L / 2`` and says so.
"""

from __future__ import annotations

import numpy as np

from learn.network.intervals import level_intervals

__all__ = ["fold_to_half", "location_ambiguity", "mirrored"]


def mirrored(beam, pair) -> bool:
    """Whether a pair leaves the mirror ambiguity: a symmetric beam (:attr:`physics.supports.Support.symmetric`)
    read on natural frequencies only (no shapes, or one sensor), where a damage at ``x`` and at ``L - x`` change
    every frequency alike."""
    test = beam.test
    return (test is not None and test.support.symmetric
            and (test.n_sensors == 1 or (pair is not None and pair.frequency_only)))


def fold_to_half(answer: dict, beam, distributions=None) -> dict:
    """An answer located on the half ``x <= L / 2`` (the mirror ambiguity, :func:`mirrored`): the network's
    distributions (level -> (B,), :attr:`learn.network.estimator.DamagePrediction.level_distributions`) folded onto it
    (mean and std of ``min(x, L - x)`` from the 68 % one, each interval from its own), a classical ``x`` mirrored
    there."""
    L = beam.length_m
    out = dict(answer)
    if distributions is not None:
        p = np.asarray(distributions["68"], float)
        c = (np.arange(p.size) + 0.5) / p.size
        c = np.minimum(c, 1 - c)
        mean = float(p @ c)
        out["location_std_m"] = float(np.sqrt(max(p @ c**2 - mean**2, 0.0) + 1 / (12 * p.size**2)) * L)
        for k, iv in level_intervals(distributions, fold=True).items():
            if f"x_m_{k}" in out:
                out[f"x_m_{k}"] = [float(v) * L for v in iv[0]]
    else:
        mean = min(answer["location_x_over_L"], 1 - answer["location_x_over_L"])
    out["location_x_over_L"], out["location_x_m"] = mean, mean * L
    z = int(beam.zone_of_x_over_L(mean))
    out["location_zone"] = z
    if out.get("location_element") is not None:
        out["location_element"] = z
    return out


def location_ambiguity(beam, verdict: dict, pair) -> str | None:
    """What frequencies alone cannot tell (:func:`mirrored`): the mirror image of the located damage, or None (also
    for a verdict whose place is undetermined: its text names the mirror zones)."""
    if not verdict.get("damaged") or verdict.get("place_determined") is False or not mirrored(beam, pair):
        return None
    x, L = verdict["location_x_m"], beam.length_m
    return (f"natural frequencies alone cannot tell x = {x:.3f} m from its mirror image L - x = {L - x:.3f} m on "
            f"this symmetric {beam.test.bc} beam: both places fit the data equally")
