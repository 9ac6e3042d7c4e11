"""Damage models: one module per kind of damage, one registry row each (:data:`DAMAGE_MODELS`).

A damage model turns its section of the configuration (``damage``, selected by
``damage.kind``) into random damages on the truth mesh and describes them:

* ``validate(d, cfg)`` normalises its keys of ``d = cfg["damage"]`` in place
  (raises :class:`physics.errors.ConfigError` naming the key);
* ``check_beam(d, preset, section, added_masses)`` refuses damage the specimen cannot hold
  (e.g. a slit deeper than the beam, a mass lost beyond what the beam carries), once the truth beam
  is known (``added_masses``: the ``(x_m, mass_kg)`` of its added masses);
* ``draw(rng, n, cfg, setup)`` draws ``n`` samples: ``n_damages`` (n,), centres
  ``x_m`` (n, S) and the model's parameters (n, S), NaN where a sample has fewer
  than ``S`` damages;
* ``corrections(params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements,
  shear_phi)`` gives the element corrections ``(dM, dK, dC)`` of the current
  state, each (B, n_elements, 4, 4) or ``None`` where the model changes nothing;
* ``size(params, x_m, ei_Nm2, mass_per_length_kg_m, length_m)`` is the
  non-dimensional size (B, S) the network learns (``damage{k}_size``) and
  ``size_meaning`` says what it is;
* ``damage_at(d, beam, x_m, size, extent, mass_per_length_kg_m, length_m)`` is the
  inverse of ``size``: the parameters (B, S) of damages of that size centred at ``x_m`` on
  the nominal beam ``beam`` (as ``size_range`` takes it) of that mass per length and length,
  their spread at ``extent`` in [0, 1] through the range section ``d`` draws (0: its
  smallest); ``corrections`` of them is the damage the competing explanation's exact
  refinement re-analyses (:mod:`learn.explanations.refine`);
* ``columns(...)`` (same arguments) gives the model's own stored columns:
  per sample ``{name: (B,)}`` and per damage ``{suffix: (B, S)}`` stored as
  ``damage{k}_{suffix}``; ``sample_units`` and ``units`` give their units;
* ``size_transform`` is how the network's size head learns the size: ``"log"`` (a positive size)
  or ``"asinh:<scale>"`` (a signed size, ``asinh(size / scale)``), read by
  :class:`learn.network.estimator.DamageClassifier`;
* ``size_label`` names the size in tables and the verdict (e.g. ``"hinge flexibility"``);
* ``label`` names the kind in the verdict's prose (e.g. ``"a mass change"``);
* ``perturbs`` ("stiffness" or "mass") says which element matrix a unit size
  changes to first order, for the classical methods' sensitivities
  (:func:`learn.explanations.sensitivity.beam_sensitivity`) and the competing explanations' frequency map
  (:mod:`learn.explanations.hypotheses`). A stiffness kind's size is the hinge flexibility
  ``EI / (k_theta L)`` its local rigidity loss amounts to, a mass kind's the signed mass ratio
  ``m_k / (m L)``: the first-order relative frequency change per unit size is then the same
  curvature-squared (displacement-squared) sensitivity for every kind of that ``perturbs``;
* ``size_range(d, beam)`` is the ``(lo, hi)`` of the sizes a dataset of section ``d`` draws on the
  truth beam ``beam`` (a preset name, or the truth beam's mapping, which may carry the config's
  ``section`` keys): the flat prior of the kind's competing explanation;
* ``spread_m(d, length_m)`` is the typical length (m) such a damage spreads over: the explanation
  averages the point sensitivities over a window of that length;
* ``sections`` names the beam sections the kind exists on (``physics.beam`` section kinds:
  ``("sandwich",)`` for a face-core debond), None for every section: a dataset of the kind on
  another section is refused, and its competing explanation is not offered there
  (:func:`applies_to`);
* ``separates`` says, for another explanation (``"intact"``, ``"global_stiffness"``,
  ``"support_change"`` or another kind), what measurement tells this kind from it when the
  frequencies of the measured modes cannot;
* ``describe(x_m, size, preset, section=None)`` is the verdict's prose for a
  damage of that size at ``x_m`` (no place for ``x_m`` None) on a beam (``preset``: a preset name or the
  truth beam's fields; ``section``: the config's section keys).

Generic keys of the section: ``kind``, ``intact_fraction`` (share of samples
without damage) and ``position_fraction`` (``x / L`` range of the centres);
each model adds its own (:attr:`DamageModel.defaults`).

Adding a kind: one module holding a class that satisfies :class:`DamageModel`
and one row in :data:`DAMAGE_MODELS` (see docs/datasets.md).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from datagen.damage.debond import Debond
from datagen.damage.mass_change import MassChange
from datagen.damage.slit import Slit
from physics.beam import beam_from_dict
from physics.errors import ConfigError

__all__ = ["DAMAGE_MODELS", "DEFAULT_KIND", "DamageModel", "GENERIC_DEFAULTS", "applies_to", "beam_section",
           "damage_defaults", "damage_model", "element4_index"]


class DamageModel(Protocol):
    """What a kind of damage provides to the generator, the store and the verdicts (see the module docstring)."""

    kind: str
    defaults: dict
    units: dict
    sample_units: dict
    size_meaning: str
    size_label: str
    label: str
    size_transform: str
    perturbs: str
    separates: dict
    sections: tuple | None

    def size_range(self, d: dict, beam) -> tuple[float, float]: ...

    def spread_m(self, d: dict, length_m: float) -> float: ...

    def validate(self, d: dict, cfg: dict) -> None: ...

    def check_beam(self, d: dict, preset, section: dict, added_masses=()) -> None: ...

    def draw(self, rng: np.random.Generator, n: int, cfg: dict, setup) -> dict: ...

    def corrections(self, params: dict, x_m, ei_Nm2, mass_per_length_kg_m, length_m: float, n_elements: int,
                    shear_phi=0.0) -> tuple: ...

    def size(self, params: dict, x_m, ei_Nm2, mass_per_length_kg_m, length_m: float) -> np.ndarray: ...

    def damage_at(self, d: dict, beam, x_m, size, extent, mass_per_length_kg_m: float, length_m: float) -> dict: ...

    def columns(self, params: dict, x_m, ei_Nm2, mass_per_length_kg_m, length_m: float) -> tuple[dict, dict]: ...

    def describe(self, x_m: float, size: float, preset, section: dict | None = None) -> str: ...


#: The damage kinds ``damage.kind`` may name.
DAMAGE_MODELS: dict[str, DamageModel] = {
    "slit": Slit(),
    "mass_change": MassChange(),
    "debond": Debond(),
}

DEFAULT_KIND = "slit"

#: Keys of the ``damage`` section shared by every kind.
GENERIC_DEFAULTS = {
    "kind": DEFAULT_KIND,
    "intact_fraction": 0.0,              # share of samples without damage
    "position_fraction": [0.03, 0.97],   # x / L range of the damage centres
}


def damage_model(kind) -> DamageModel:
    """The registered model of ``kind`` (raises :class:`ConfigError` naming ``damage.kind`` otherwise)."""
    if not isinstance(kind, str) or kind not in DAMAGE_MODELS:
        raise ConfigError(f"config key 'damage.kind' must be one of {sorted(DAMAGE_MODELS)}, got {kind!r}")
    return DAMAGE_MODELS[kind]


def beam_section(beam_mapping) -> str:
    """The section kind of a config's truth beam (``cfg["beam"]``, a beam file's mapping; None or empty: a thesis
    preset, a sandwich)."""
    if not beam_mapping:
        return "sandwich"
    return beam_from_dict(dict(beam_mapping), "config key 'beam'").section


def applies_to(kind, section: str) -> bool:
    """Whether damage kind ``kind`` exists on a beam of section kind ``section`` (its ``sections``)."""
    sections = damage_model(kind).sections
    return sections is None or section in sections


def damage_defaults(kind) -> dict:
    """Full default ``damage`` section of ``kind``: the generic keys then the model's."""
    return {**GENERIC_DEFAULTS, "kind": kind, **damage_model(kind).defaults}


def element4_index(x_m, length_m):
    """1-based element of the thesis's 4-element grid holding ``x`` (0 where ``x`` is NaN)."""
    x = np.asarray(x_m, float)
    idx = np.clip(np.floor(np.nan_to_num(x, nan=-1.0) / (length_m / 4)).astype(int) + 1, 1, 4)
    return np.where(np.isfinite(x), idx, 0)
