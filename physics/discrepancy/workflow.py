"""The discrepancy search (:func:`analyse`): rounds of candidate fits, named effects, detection limits."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from physics import effects as fx
from physics.beam import Beam
from physics.errors import BeamDamageError
from physics.discrepancy.fitting import Fit, candidate_fit, fit_model
from physics.discrepancy.limits import detection_limits
from physics.discrepancy.measurement import Measurement, Noise, has_complex_shapes
from physics.discrepancy.model import ModeResiduals, mode_residuals, predict
from physics.discrepancy.pairing import Pairing, PairingRule, implausible_pairing, pair_measured
from physics.discrepancy.selection import NoiseCheck, decide, estimate_noise_scale, noise_check

__all__ = ["DiscrepancyResult", "analyse", "check_candidates"]

@dataclass(frozen=True)
class DiscrepancyResult:
    """Outcome of :func:`analyse`.

    Attributes
    ----------
    nominal : ModeResiduals
        The beam as given (before any recalibration).
    steps : tuple of Step
    final : Fit
        The model with every named effect (globals recalibrated).
    named_effects : tuple of str
    noise : Noise
    untestable : dict
        Candidate -> why it could not be tested on this data.
    evidence : dict
        Named effect -> the data block (:data:`BLOCKS`) whose chi^2 fell most when it was named.
    evidence_chi2_drop : dict
        Named effect -> {block: chi^2 drop / c_b}.
    noise_check : NoiseCheck
        Of the final model, against the noise given.
    detection_limits : dict
        Candidate not named -> :class:`DetectionLimit` (with the noise used for the selection).
    noise_scale : float
        Factor on the given noise stds used for the selection: 1, or with
        ``estimate_noise`` ``sqrt(chi^2/dof)`` of round 1's best-fitting model
        when below 1 (:func:`analyse`).
    noise_scale_dof : int
        Degrees of freedom of that estimate (0: not estimated).
    noise_scale_from : str
        The model the estimate comes from, or why there is none.
    pairing : Pairing or None
        The measured modes paired with the nominal model's (:func:`physics.discrepancy.pairing.pair_measured`).
    """

    nominal: ModeResiduals
    steps: tuple
    final: Fit
    named_effects: tuple
    noise: Noise
    untestable: dict = field(default_factory=dict)
    evidence: dict = field(default_factory=dict)
    evidence_chi2_drop: dict = field(default_factory=dict)
    noise_check: NoiseCheck | None = None
    detection_limits: dict = field(default_factory=dict)
    noise_scale: float = 1.0
    noise_scale_dof: int = 0
    noise_scale_from: str = ""
    pairing: Pairing | None = None


def analyse(beam: Beam, meas: Measurement, noise: Noise | None = None, *, candidates=None,
            max_effects: int = 2, n_elements: int = 40, n_starts: int = 4, seed: int = 0,
            estimate_noise: bool = False, progress=None, pairing: PairingRule | None = None,
            band_hz=None) -> DiscrepancyResult:
    """Name the effects ``beam`` lacks to explain ``meas`` (module docstring).

    Parameters
    ----------
    beam : Beam
        Nominal model (its own effects are kept and refitted as globals are).
    meas : Measurement
    noise : Noise, optional
    candidates : sequence of str, optional
        Effects to test (default: every candidate of the beam's supports,
        :func:`physics.effects.candidates_for` ``beam.bc``); one that does not fit them is refused.
    max_effects : int
        Most effects to name.
    n_elements : int
        Mesh of the fitted models (converged: 40 cubic elements).
    n_starts : int
        Starts of each bounded least-squares fit (the first at a weak effect,
        the others uniform in the bounds).
    seed : int
        Seed of the random starts.
    estimate_noise : bool
        For a ``noise`` that is only assumed: scale it by ``s = sqrt(chi^2/dof)``
        of round 1's best-fitting model (the lowest chi^2 among the globals-only
        model and every one-effect candidate; Mallows' Cp with ``sigma^2`` from
        the richest model fitted) when that model has at least
        :data:`NOISE_DOF_MIN` degrees of freedom and the chi^2 test rejects the
        assumed noise as too large (level ``P_NOISE``, two-sided), as the
        inflation of a block needs it rejected as too small. One factor for
        every block, held for every round; a block whose residual exceeds the
        scaled noise is inflated as usual.
    progress : callable, optional
        Called with a short text before each candidate fit.
    pairing : callable, optional
        The rule that pairs the measured modes with the nominal model's (:data:`physics.discrepancy.pairing.
        PairingRule`; ``beam-damage discrepancy`` passes ``classify``'s); None: largest MAC, else nearest frequency
        after the median ratio, every measured mode paired.
    band_hz : (lo, hi), optional
        The band the modes were measured in (Hz), to name a model mode below it.

    Returns
    -------
    DiscrepancyResult

    Raises
    ------
    ImplausibleTest
        Before any fit, when a measured mode pairs with no model mode under ``pairing`` or fewer than 2 pair
        (:func:`physics.discrepancy.pairing.pair_measured`): one line naming the causes.
    """
    with threadpool_limits(1):   # small dense eigenproblems: one BLAS thread is fastest
        names = check_candidates(candidates, beam.bc, beam.section)
        nominal_pred = predict(beam, meas, n_elements)
        paired = pair_measured(meas, nominal_pred, pairing, band_hz)
        if not paired.plausible:
            raise implausible_pairing(paired)
        return _analyse(beam, meas, noise or Noise(), names, max_effects, n_elements, n_starts, seed, estimate_noise,
                        progress, nominal_pred, paired)


def check_candidates(candidates, bc: str, section: str | None = None) -> tuple[str, ...]:
    """``candidates`` checked against the supports of a ``bc`` beam and its section kind (None: all of
    :func:`physics.effects.candidates_for` ``bc, section``).

    Raises
    ------
    BeamDamageError
        One line naming the unknown effect, or the effect, the bc (and section) and the candidates that fit it.
    """
    fits = fx.candidates_for(bc, section)
    if candidates is None:
        return fits
    unknown = [c for c in candidates if c not in fx.CANDIDATES]
    if unknown:
        raise BeamDamageError(f"unknown candidate effect(s) {unknown}; expected some of {list(fx.CANDIDATES)}")
    for c in candidates:
        if c not in fits:
            where = f"{section} section" if c in fx.candidates_for(bc) else f"{bc} beam"
            raise BeamDamageError(f"candidate effect '{c}' does not fit a {where}; its candidates are "
                                  f"{', '.join(fits)}")
    return tuple(candidates)


def _untestable(names: list, meas: Measurement, beam: Beam, noise: Noise, n_elements: int) -> dict:
    """Candidates these data cannot test, removed from ``names``: ``{effect: why}``."""
    out = {}
    if "local_damping" in names and meas.frf is None and not has_complex_shapes(meas):
        names.remove("local_damping")
        out["local_damping"] = ("modal damping (one ratio per mode) fits any damping ratios; a dashpot needs "
                                "complex mode shapes or FRFs")
    solid = beam.solid
    if "shear_deformation" in names and solid is not None and "shear_deformation" not in beam.effects:
        shift = _solid_shear_shift(beam, meas, n_elements)
        sf = float(np.min(noise.frequency))
        if shift < sf:
            names.remove("shear_deformation")
            out["shear_deformation"] = (f"the {beam.section} section's own shear rigidity kGA = {solid.kGA_N:.3g} N "
                                        f"(k = {solid.shear_coefficient:.3f}, G = {solid.shear_modulus_pa:.3g} Pa) "
                                        f"shifts the measured modes by at most {100 * shift:.2g} %, below the "
                                        f"frequency noise {100 * sf:.2g} %")
    return out


def _solid_shear_shift(beam: Beam, meas: Measurement, n_elements: int) -> float:
    """Largest relative frequency change over the measured modes that a solid section's own ``k G A`` (with its
    rotary inertia) makes."""
    base = predict(beam, meas, n_elements)
    shear = beam.with_effects({**beam.effects_dict(), "shear_deformation": {"kGA_N": beam.solid.kGA_N}})
    f = predict(shear, meas, n_elements)
    n = meas.n_modes
    return float(np.max(np.abs(f.frequencies_hz[:n] / base.frequencies_hz[:n] - 1)))


def _analyse(beam, meas, noise, candidates, max_effects, n_elements, n_starts, seed, estimate_noise, progress,
             nominal_pred, pairing):
    fit_mass = meas.frf is not None
    names = list(candidates)
    untestable = _untestable(names, meas, beam, noise, n_elements)
    pairs = pairing.model_index
    fixed = {k: dict(v) for k, v in beam.effects.items() if k != "proportional_damping"}
    say = progress or (lambda s: None)
    say("globals only")
    base, _, _ = fit_model(beam, meas, noise, "none", fixed, n_elements, pairs, fit_mass=fit_mass,
                           n_starts=n_starts, seed=seed)
    ctx = dict(beam=beam, meas=meas, noise=noise, fixed=fixed, n_elements=n_elements, pairs=pairs,
               fit_mass=fit_mass, n_starts=n_starts, seed=seed, say=say)
    steps, named, positions, evidence, drops = [], [], {}, {}, {}
    scale = (1.0, 0, "not estimated: the noise was given" if meas.frf is None else
             "not estimated: an FRF's noise is never rescaled")
    while len(named) < max_effects:
        todo = _todo(names, named, fixed)
        if not todo:
            break
        fits, used = _fit_candidates(ctx, todo, named, base, positions)
        if not steps and estimate_noise:
            scale = estimate_noise_scale(base, fits)
        step = decide(ctx, base, fits, scale[0])
        steps.append(step)
        if step.named == "none":
            break
        best = step.candidates[0]
        drops[best.effect] = {b: (base.chi2_blocks[b] - best.chi2_blocks[b]) / step.c_hat.get(b, 1.0)
                              for b in best.chi2_blocks}
        evidence[best.effect] = max(drops[best.effect], key=drops[best.effect].get)
        # the candidate's every new effect key (several point masses fitted together)
        named += [k for k in best.effects if k not in fixed and k not in named and k != "proportional_damping"]
        positions = used[best.effect]
        base = best
    c_last = steps[-1].c_hat if steps else {}
    rest = [c for c in names if c not in named and c not in fixed]
    say("detection limits")
    limits = detection_limits(beam, meas, noise, base, c_last, rest, fixed=fixed, named=tuple(named),
                              positions=positions, n_elements=n_elements, pairs=pairs)
    return DiscrepancyResult(mode_residuals(meas, nominal_pred, pairs), tuple(steps), base, tuple(named), noise,
                             untestable, evidence, drops, noise_check(base), limits, math.sqrt(scale[0]),
                             scale[1], scale[2], pairing)


def _todo(names, named, fixed) -> list:
    """The candidates of a round: each effect the model lacks, and a further instance of each repeatable point
    effect (:attr:`physics.effects.Effect.repeatable`: one more point mass at its own position) it holds."""
    held = {**fixed, **dict.fromkeys(named, {})}
    return [fx.next_instance(held, c) if fx.EFFECTS[c].repeatable else c for c in names
            if fx.EFFECTS[c].repeatable or (c not in named and c not in fixed)]


def _fit_candidates(ctx: dict, todo, named, base: Fit, positions) -> tuple[list, dict]:
    """Every candidate of ``todo`` fitted on top of the ``named`` effects; ``(fits, positions used by each)``."""
    fits, used = [], {}
    start = base.beam.effects_dict()
    for c in todo:
        ctx["say"](c if not named else f"{' + '.join(named)} + {c}")
        f, pos = candidate_fit(ctx["beam"], ctx["meas"], ctx["noise"], c, ctx["fixed"], ctx["n_elements"],
                               ctx["pairs"], ctx["fit_mass"], ctx["n_starts"], ctx["seed"], tuple(named), start,
                               positions)
        fits.append(f)
        used[f.effect] = pos
    return fits, used
