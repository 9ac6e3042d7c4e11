"""Fits of one candidate model: whitened residuals by data block, bounded multi-start least squares, LOMO.

Parameter uncertainties come from the Jacobian of the whitened residuals at
the optimum, ``cov = s^2 (J^T J)^-1`` with ``s^2 = max(1, chi^2 / dof)``
(the given noise, inflated when the fit is worse than the noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from physics import effects as fx
from physics.beam import Beam
from physics.discrepancy.candidates import Param, effect_params, has_position, shear_in_section_terms
from physics.discrepancy.measurement import Measurement, has_complex_shapes
from physics.discrepancy.model import (
    ModeResiduals,
    Prediction,
    aligned,
    dashpot_damping_per_c,
    mode_residuals,
    predict,
    rayleigh_fit,
)
from physics.frf import magnitude_db

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult

__all__ = ["BLOCKS", "Fit", "MAX_JOINT_INSTANCES", "Problem", "as_fit", "candidate_fit", "fit_model", "lomo_error",
           "model_params", "with_rayleigh"]


@dataclass(frozen=True)
class Fit:
    """One fitted model: the effects it contains and how well it explains the data.

    Attributes
    ----------
    effect : str
        The effect tested in this fit (``"none"`` for the globals-only model).
    effects : tuple of str
        Every effect in the model (previously named ones, then ``effect``).
    beam : Beam
        The calibrated beam (global parameters and effects written in; with
        damping ratios, Rayleigh damping least-squares fitted to them, because
        a beam file has no per-mode damping).
    parameters, parameter_std : dict
        Fitted values and standard deviations, keys ``"EI_Nm2"``,
        ``"mass_per_length_kg_m"``, ``"<effect>.<parameter>"``, the shear rigidity in the section's terms
        (:func:`physics.discrepancy.candidates.shear_in_section_terms`: a sandwich's ``G_core_pa``, a solid
        section's ``G_pa`` and ``k``). A std of 0 marks a value held fixed
        (the mass without FRFs), NaN a position chosen among the measured points.
    chi2 : float
        Sum of squared whitened residuals.
    n_obs, n_params : int
    bic : float
        ``chi2 + n_params ln n_obs``.
    lomo : float
        Leave-one-mode-out prediction error in noise units (:func:`lomo_error`), NaN if not computed.
    residuals : ModeResiduals
    chi2_blocks : dict
        ``chi2`` split by data block (:data:`BLOCKS`).
    whitened : dict
        Data block -> its whitened residual vector (FRF: raveled ``(n_resp, n_ref, n_lines)``).
    """

    effect: str
    effects: tuple
    beam: Beam
    parameters: dict
    parameter_std: dict
    chi2: float
    n_obs: int
    n_params: int
    bic: float
    lomo: float
    residuals: ModeResiduals
    chi2_blocks: dict = field(default_factory=dict)
    whitened: dict = field(default_factory=dict)

    @property
    def block_dof(self) -> dict:
        """Degrees of freedom of each block's chi^2: observations less what the fit takes from them.

        Frequencies lose the model's parameters, shapes one scale per mode
        (real part; the imaginary part a second), the FRF band levels the mass scale.
        """
        return _block_dof(self.whitened, self.n_params)

    @property
    def dof(self) -> int:
        """Degrees of freedom of ``chi2``: ``n_obs - n_params`` less the scale of each compared shape (2 per mode
        for complex shapes, 1 for real); the sum of :attr:`block_dof`."""
        return sum(self.block_dof.values())


def _block_dof(whitened: dict, n_params: int) -> dict:
    """:attr:`Fit.block_dof` of whitened residual blocks (every mode compared) and ``n_params`` parameters."""
    n = {k: v.size for k, v in whitened.items()}
    n_modes = n["frequencies"]     # one per measured mode
    out = {"frequencies": n["frequencies"] - n_params + (1 if "FRF" in n else 0)}
    if "mode shapes" in n:
        out["mode shapes"] = n["mode shapes"] - n_modes
    if "complex shapes" in n:
        out["complex shapes"] = n["complex shapes"] - n_modes
    if "FRF" in n:
        out["FRF"] = n["FRF"] - 1
    return out


#: Data blocks of the residual: what the evidence for an effect can come from.
BLOCKS = ("frequencies", "mode shapes", "complex shapes", "FRF")


def _band_mean_db(meas: Measurement, err_db: np.ndarray) -> np.ndarray:
    """Mean dB error over each measured mode's band (between the geometric means of neighbouring frequencies).

    Returns ``(n_resp, n_ref, n_modes)``; a band without lines counts 0. The FRF's levels
    (its absolute scale, hence the mass) enter the fit as these band means, one
    observation per band: the lines of a band share the model's and the
    identification's errors, and the modes' frequencies, damping and shapes come from
    the identified modal data.
    """
    onehot = meas.frf_band_onehot                                                 # (n_lines, n_modes)
    count = np.maximum(onehot.sum(axis=0), 1.0)
    return (err_db @ onehot) / count


class Problem:
    """Residual function of one candidate model.

    With damping ratios the damping is modal: every paired model mode gets its
    measured ratio, the others the Rayleigh least-squares extension
    (:func:`rayleigh_fit`); a dashpot only adds its non-proportional coupling.
    """

    def __init__(self, beam, meas, noise, fixed_effects, params, position, n_elements, pairs, fit_mass):
        self.beam, self.meas, self.noise = beam, meas, noise
        self.fixed = {k: dict(v) for k, v in fixed_effects.items()}
        self.position = position          # {effect: x_m} for discrete positions
        self.params = params
        self.n_elements, self.pairs = n_elements, pairs
        self.fit_mass = fit_mass
        self.mask = np.ones(meas.n_modes, dtype=bool)
        self.modal_zeta = None
        if meas.damping_ratios is not None:
            a, b = rayleigh_fit(2 * np.pi * meas.frequencies_hz, meas.damping_ratios)
            z_meas, p = meas.damping_ratios, np.asarray(pairs)

            def modal_zeta(w):
                z = np.maximum(a / (2 * np.maximum(w, 1e-12)) + b * w / 2, np.min(z_meas))
                z[p] = z_meas
                return z

            self.modal_zeta = modal_zeta

    def beam_at(self, u) -> tuple[Beam, float, float]:
        eff = {k: dict(v) for k, v in self.fixed.items()}
        ei_s = ms = 1.0
        for p, ui in zip(self.params, u):
            v = p.to_phys(ui)
            if p.key == "EI_scale":
                ei_s = v
            elif p.key == "mass_scale":
                ms = v
            else:
                name, key = p.key.split(".")
                eff.setdefault(name, {})[key] = v
        for name, x in self.position.items():
            if name in eff:
                eff[name]["x_m"] = x
        nb = replace(self.beam, effects=eff, EI_Nm2=self.beam.EI_Nm2 * ei_s,
                     mass_per_length_kg_m=self.beam.mass_per_length_kg_m * ms)
        return nb, ei_s, ms

    def predict(self, nb: Beam) -> Prediction:
        return predict(nb, self.meas, self.n_elements, modal_zeta=self.modal_zeta)

    def residual(self, u):
        return np.concatenate(list(self.blocks(self.predict(self.beam_at(u)[0])).values()))

    def blocks(self, pred) -> dict:
        """Whitened residuals by data block (:data:`BLOCKS`; only the blocks measured)."""
        meas, noise, p = self.meas, self.noise, self.pairs
        sf = np.broadcast_to(np.asarray(noise.frequency, dtype=float), (meas.n_modes,))
        out = {"frequencies": ((pred.frequencies_hz[p] / meas.frequencies_hz - 1) / sf)[self.mask]}
        if meas.shapes is not None:
            diff = [aligned(meas.shapes[:, j], pred.shapes[:, pj]) / noise.shape
                    for j, pj in enumerate(p) if self.mask[j]]
            out["mode shapes"] = np.concatenate([d.real for d in diff])
            if has_complex_shapes(meas):
                out["complex shapes"] = np.concatenate([d.imag for d in diff])
        if meas.frf is not None:
            err_db = _band_mean_db(meas, magnitude_db(pred.frf) - meas.frf_db)
            out["FRF"] = (err_db / noise.frf_db)[..., self.mask].ravel()
        return out


def model_params(beam, meas, effects, positions, fit_mass) -> list[Param]:
    """Fitted parameters: the global EI (and mass) scale, then each effect's (its ``x_m`` too when the data carry
    shapes or FRFs and ``positions`` does not fix it)."""
    position_free = meas.shapes is not None or meas.frf is not None
    params = [Param("EI_scale", 0.3, 3.0)] + ([Param("mass_scale", 0.3, 3.0)] if fit_mass else [])
    for e in effects:
        params += effect_params(e, beam, meas, position_free and e not in positions)
    return params


def fit_model(beam, meas, noise, effect, fixed_effects, n_elements, pairs, *, fit_mass, n_starts=4, seed=0,
         position=None, with_lomo=True, named=(), start=None) -> tuple[Fit, Problem, np.ndarray]:
    """Bounded multi-start least squares of the globals, the ``named`` effects and ``effect``.

    ``effect = "none"`` fits the globals (and the named effects) only. Named
    effects start from their values in ``start`` (``{effect: {param: value}}``);
    the new effect starts weak, then at random points within its bounds.
    ``position`` fixes ``x_m`` of position-bearing effects (``{effect: x_m}``).
    """
    position = dict(position or {})
    start = start or {}
    params = model_params(beam, meas, [*named, *([effect] if effect != "none" else [])], position, fit_mass)
    prob = Problem(beam, meas, noise, fixed_effects, params, position, n_elements, pairs, fit_mass)
    lo = [p.bounds()[0] for p in params]
    hi = [p.bounds()[1] for p in params]
    rng = np.random.default_rng(seed)
    best = None
    for s in range(n_starts):
        u0 = []
        for p in params:
            a, b = p.bounds()
            name, _, key = p.key.partition(".")
            if p.key in ("EI_scale", "mass_scale"):
                u0.append(0.0)
            elif key in start.get(name, {}) and (name in named or s == 0):
                v = start[name][key]
                u0.append(math.log(v) if p.log else v)
            elif s == 0:
                u0.append(a + 0.75 * (b - a) if p.log else 0.5 * (a + b))  # weak effect first
            else:
                u0.append(rng.uniform(a, b))
        res = _solve(prob.residual, np.clip(u0, lo, hi), lo, hi, max_nfev=400)
        if best is None or res.cost < best.cost:
            best = res
        if effect == "none" and not named:
            break
    fit = as_fit(prob, best, effect, meas)
    lomo = lomo_error(prob, best.x) if with_lomo else float("nan")
    return replace(fit, lomo=lomo), prob, best.x


#: Forward-difference step of the fits' Jacobians, relative to ``max(1, |u|)`` of each (log-)parameter ``u``.
#: scipy's relative step falls back to ``sqrt(eps)`` at a parameter of exactly 0 (the globals' start), below the
#: eigensolver's resolution of the frequencies (~1e-8 relative): such a Jacobian is noise, and the fit's path
#: then turns on rounding.
JACOBIAN_STEP = 1e-6


def _solve(fun, u0, lo, hi, max_nfev):
    """Bounded least squares of ``fun`` from ``u0`` with forward differences of step :data:`JACOBIAN_STEP`
    times ``max(1, |u|)``."""
    from scipy.optimize import least_squares  # scipy.optimize: 0.4 s to import, only where a model is fitted

    last = {}

    def f(u):
        last["u"], last["f"] = np.array(u), fun(u)
        return last["f"]

    def jac(u):
        f0 = last["f"] if "u" in last and np.array_equal(last["u"], u) else fun(u)
        cols = []
        for k in range(u.size):
            h = JACOBIAN_STEP * max(1.0, abs(u[k]))
            h = h if u[k] + h <= hi[k] else -h                                       # stay within the bounds
            v = np.array(u, dtype=float)
            v[k] += h
            cols.append((fun(v) - f0) / h)
        return np.stack(cols, axis=1)

    return least_squares(f, u0, jac=jac, bounds=(lo, hi), x_scale=1.0, max_nfev=max_nfev)


def lomo_error(prob: Problem, x0) -> float:
    """Leave-one-mode-out prediction error: RMS over modes of the held-out mode's whitened residuals.

    Each measured mode (its frequency, its shape and its FRF band levels, as
    measured) is predicted by a fit on the other modes; 1 means "predicted to
    within the noise".
    """
    meas = prob.meas
    if meas.n_modes - 1 < len(prob.params) and meas.shapes is None and meas.frf is None:
        return float("nan")
    lo, hi = zip(*[p.bounds() for p in prob.params])
    z2 = []
    for j in range(meas.n_modes):
        prob.mask = np.arange(meas.n_modes) != j
        res = _solve(prob.residual, x0, lo, hi, max_nfev=200)
        prob.mask = np.arange(meas.n_modes) == j
        held = np.concatenate(list(prob.blocks(prob.predict(prob.beam_at(res.x)[0])).values()))
        z2.append(np.mean(held**2))
    prob.mask = np.ones(meas.n_modes, dtype=bool)
    return float(np.sqrt(np.mean(z2)))


def with_rayleigh(nb: Beam, meas: Measurement) -> Beam:
    """``nb`` with Rayleigh damping fitted to the measured ratios less a dashpot's share (beam file only)."""
    w = 2 * np.pi * meas.frequencies_hz
    z = np.array(meas.damping_ratios, dtype=float)
    dashpots = fx.instances(nb.effects, "local_damping")
    if dashpots:
        per_c = dashpot_damping_per_c(nb, [d.get("x_m", nb.length_m) for d in dashpots], meas.n_modes, 24)
        z = np.maximum(z - np.array([d["c_Ns_m"] for d in dashpots]) @ per_c, 0.05 * z)
    a, b = rayleigh_fit(w, z)
    return nb.with_effects({**nb.effects_dict(), "proportional_damping": {"alpha_1_s": a, "beta_s": b}})


def as_fit(prob: Problem, res: OptimizeResult, effect: str, meas: Measurement) -> Fit:
    nb, ei_s, ms = prob.beam_at(res.x)
    r = res.fun
    chi2 = float(r @ r)
    n_obs, n_par = r.size, res.x.size
    pred = prob.predict(nb)
    white = prob.blocks(pred)
    dof = sum(_block_dof(white, n_par).values())   # the result's Fit.dof
    s2 = max(1.0, chi2 / dof) if dof > 0 else 1.0
    J = res.jac
    try:
        cov = s2 * np.linalg.pinv(J.T @ J)
        std_u = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std_u = np.full(n_par, np.nan)
    params = {"EI_Nm2": nb.EI_Nm2, "mass_per_length_kg_m": nb.mass_per_length_kg_m}
    std = {"EI_Nm2": nb.EI_Nm2 * std_u[0],
           "mass_per_length_kg_m": nb.mass_per_length_kg_m * std_u[1] if prob.fit_mass else 0.0}
    for i, p in enumerate(prob.params):
        if p.key in ("EI_scale", "mass_scale"):
            continue
        v = p.to_phys(res.x[i])
        params[p.key] = v
        std[p.key] = v * std_u[i] if p.log else std_u[i]
    for name, x in prob.position.items():
        params[f"{name}.x_m"] = x
        std[f"{name}.x_m"] = float("nan")   # chosen among the measured points, not fitted
    if "shear_deformation.kGA_N" in params:
        for k, (v, sd) in shear_in_section_terms(params["shear_deformation.kGA_N"], std["shear_deformation.kGA_N"],
                                                  nb).items():
            params[k], std[k] = v, sd
    blocks = {b: float(v @ v) for b, v in white.items()}
    if meas.damping_ratios is not None:
        nb = with_rayleigh(nb, meas)
    return Fit(effect, tuple(nb.effects), nb, params, std, chi2, n_obs, n_par, chi2 + n_par * math.log(n_obs),
               float("nan"), mode_residuals(meas, pred, prob.pairs), blocks, white)


#: Most point masses of a repeatable effect fitted together as one candidate (each with its mass and position).
MAX_JOINT_INSTANCES = 2


def candidate_fit(beam, meas, noise, name, fixed, n_elements, pairs, fit_mass, n_starts, seed, named, start,
                   positions):
    """Fit one candidate on top of the named effects; returns ``(fit, positions used)``.

    A repeatable point effect (``added_mass``) with shapes or FRFs is also fitted as up to
    :data:`MAX_JOINT_INSTANCES` instances at once, each at its own fitted position (bolted masses along a beam: no
    single point mass fits them, several together do); the candidate is the set of lowest BIC, its
    :attr:`Fit.effects` naming every instance.
    """
    f, pos = _candidate_fit(beam, meas, noise, name, fixed, n_elements, pairs, fit_mass, n_starts, seed, named,
                            start, positions)
    position_free = meas.shapes is not None or meas.frf is not None
    if not (fx.EFFECTS[fx.effect_of(name)].repeatable and position_free):
        return f, pos
    base = fx.effect_of(name)
    held = {**fixed, **dict.fromkeys(named, {})}
    keys = [name]
    for _ in range(MAX_JOINT_INSTANCES - 1):
        held[keys[-1]] = {}
        keys.append(fx.next_instance(held, base))
        if 2 * len(keys) + 1 + len(named) >= f.n_obs:
            break
        g, _, _ = fit_model(beam, meas, noise, keys[-1], fixed, n_elements, pairs, n_starts=n_starts,
                            position=positions, fit_mass=fit_mass, seed=seed, named=(*named, *keys[:-1]),
                            start=start)
        if g.bic < f.bic:
            f, pos = g, positions
    return f, pos


def _candidate_fit(beam, meas, noise, name, fixed, n_elements, pairs, fit_mass, n_starts, seed, named, start,
                   positions):
    position_free = meas.shapes is not None or meas.frf is not None
    kw = dict(fit_mass=fit_mass, seed=seed, named=named, start=start)
    if has_position(name):
        # scan the measured points for the position; with shapes or FRFs then refine it continuously
        options = []
        for x in beam.measured_x_m:
            pos = {**positions, name: x}
            f, prob, x_opt = fit_model(beam, meas, noise, name, fixed, n_elements, pairs,
                                       n_starts=max(2, n_starts // 2), position=pos, with_lomo=False, **kw)
            options.append((f.bic, f, prob, x_opt, pos))
        _, f, prob, x_opt, pos = min(options, key=lambda t: t[0])
        if position_free:
            refined, _, _ = fit_model(beam, meas, noise, name, fixed, n_elements, pairs, n_starts=1,
                                      position=positions, fit_mass=fit_mass, seed=seed, named=named,
                                      start={**start, name: f.beam.effects_dict()[name]})
            if refined.chi2 <= f.chi2:
                return refined, positions
            # the local search from the best measured point went astray: keep that point
        # the discrete position counts as a parameter
        return replace(f, n_params=f.n_params + 1, bic=f.bic + math.log(f.n_obs), lomo=lomo_error(prob, x_opt)), pos
    f, _, _ = fit_model(beam, meas, noise, name, fixed, n_elements, pairs, n_starts=n_starts, position=positions, **kw)
    return f, positions
