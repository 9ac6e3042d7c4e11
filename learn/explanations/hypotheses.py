"""Competing explanations of the change between two tests, weighed by their evidence on the frequency changes.

Every explanation predicts the relative natural-frequency changes ``y_r = f_r,current / f_r,baseline - 1`` of the
modes both tests hold, on the nominal beam of the model (its supports, modes and sensitivities):

=================== ============================================================ ==========================
explanation         predicted ``y`` (first order unless stated)                   parameters, flat priors
=================== ============================================================ ==========================
``intact``          day-to-day change only: ``a`` (temperature) plus, where a     ``a`` and the re-clamping
                    clamp is, the re-clamping change of the clamp spring (exact)  within the training's ranges
``global_stiffness`` ``g`` on every mode (temperature, moisture: ``EI`` changes   ``g`` in +-5 %
                    by ``2 g``)
``support_change``  ``a`` plus the exact change of the support springs by a       ``ln(k / k_0)`` in +-ln 10
                    factor: clamp springs (clamped ends), bearing rotation        (a pinned end: ``k L / EI``
                    springs (pinned ends), suspension (free-free)                 in 0.01-100 from none)
a damage kind       ``a + sqrt(1 + 2 s F_r(x)) - 1`` for a kind that perturbs    ``x`` on the grid, ``s``
(each row of        the stiffness (``s`` its hinge flexibility, ``F`` the        (its size) over the sizes
``DAMAGE_MODELS``)  curvature-squared sensitivities, :mod:`learn.explanations.sensitivity`);  its data draw
                    ``a + (1 - 2 s G_r(x))^-1/2 - 1`` for one that perturbs the  (``size_range`` of the
                    mass (``s`` its signed mass ratio, ``G`` displacement        model's generator config;
                    squared): the Rayleigh quotient of the nominal shapes, the   another kind's defaults)
                    sensitivities averaged over the kind's ``spread_m`` about x
=================== ============================================================ ==========================

``a`` (the temperature nuisance, within the training's ``temperature_stiffness_change``: ``a = dEI / (2 EI)``)
enters every explanation but ``global_stiffness``. The likelihood is Gaussian with a relative standard deviation
``sigma`` per mode (default :data:`FREQUENCY_CHANGE_STD`) plus :data:`MODEL_ERROR` of each predicted change
(the sizes' intervals also hold :data:`SIZE_SCALE_STD`); each explanation's evidence is its likelihood averaged
over its prior (a grid), so a more flexible explanation pays for the predictions it could have made. With equal
prior probabilities, the probabilities are the normalised evidences.

Shapes, where both tests hold them: the change of the real unit-norm shapes at the sensors
(:func:`learn.explanations.shapes.real_shapes`, the current shape's sign following the baseline's) enters the same
likelihood with a standard deviation :data:`SHAPE_CHANGE_STD` per entry. A damage kind predicts the first-order
shape change of its size at its place (the shape sensitivities of :mod:`learn.explanations.sensitivity`), a support
change the exact change of the nominal shapes (:func:`support_curve`), the day-to-day changes and a global stiffness
change none. Damping changes are not weighed: the repeatability of damping ratios (5-30 % between tests) is larger than
what a slit changes.

A damage kind's grid is the first pass (every pair and kind in one array operation; the evidence): each pair's three
best places of each kind are refined on the kind's exact model, the nominal FE beam re-analysed with the kind's own
damage (:mod:`learn.explanations.refine`), and its misfit, most likely place and size and their intervals are read there
(a local exact grid about the refined fit, its likelihood tempered by the Birge ratio: a fit beyond the noise widens
its intervals); its evidence moves by the exact fit's best likelihood over the grid's.

An explanation whose predicted change misses a mode's measured change by more than :data:`FIT_LIMIT` standard
deviations (the noise and the model error) does not fit: the summary says so when the most likely does not, and a
damage kind that does not fit reports no intervals. Every damage kind reports its most likely ``x_m`` and ``size``
(its ``size_label``) and their 68 % / 95 % intervals. What tells two explanations apart (:func:`separate`) comes from
the kinds' ``separates``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from datagen.damage import DAMAGE_MODELS, damage_defaults
from learn.explanations.likelihood import nuisance_loglik
from learn.explanations.refine import (SIZE_SCALE_STD, ExactKind, birge_ratio, kind_parameters, refined_fits)
from learn.explanations.sensitivity import Sensitivity
from learn.explanations.shapes import real_shapes, shape_changes, sign_aligned
from learn.pairs.verdict import explanation_label
from physics.effects import hermite_row
from physics.errors import BeamDamageError
from physics.fem import beam_model
from physics.modal import undamped_modes
from physics.supports import add_springs, changed_springs

__all__ = ["BASE_HYPOTHESES", "FIT_LIMIT", "FREQUENCY_CHANGE_STD", "KindExplanation",
           "MODEL_ERROR", "NO_EXPLANATION", "SEPARATE_BASE", "SHAPE_CHANGE_STD", "SIZE_SCALE_STD", "Hypothesis",
           "explain_many", "kind_explanation", "kind_explanations", "separate",
           "summary", "support_curve", "weigh",
           "weigh_many", "window_averaged"]

#: Relative standard deviation of a mode's frequency change between two tests (0.1 %): modal tests repeated on
#: the same specimen and mounting scatter 0.05-0.5 % in frequency; the training's frequency scatter and modal
#: noise put most pairs between 0.03 and 0.2 %.
FREQUENCY_CHANGE_STD = 1e-3

#: The explanations that are no damage kind.
BASE_HYPOTHESES = ("intact", "global_stiffness", "support_change")

#: Relative error of each predicted change, mode by mode (3 %): the sensitivities are those of the nominal shapes.
MODEL_ERROR = 0.03

#: Standard deviation of each entry of a real unit-norm shape's change between two tests (0.03): the top of the
#: repeatability of mode shapes (3 % of the largest entry per test, docs/datasets.md). Smaller values trust the
#: first-order shape predictions too much on noisier shapes (bench_hypotheses --shape-noise 0.03: slits 58 % right
#: with 0.01 against 71 % with 0.03).
SHAPE_CHANGE_STD = 0.03

#: Largest misfit of a mode's change, in its standard deviations, of an explanation that fits (3: a chance of
#: about 1 % over 4 modes).
FIT_LIMIT = 3.0

#: Grids of the parameters (a size grid of odd length holds 0 when its range is symmetric).
N_SIZE, N_GLOBAL, N_SUPPORT = 201, 401, 121
GLOBAL_RANGE, SUPPORT_LN_RANGE = 0.05, np.log(10.0)


@dataclass(frozen=True)
class KindExplanation:
    """A damage kind's explanation on one beam: its size grid (the flat prior) and its sensitivities.

    Attributes
    ----------
    name : str                  the kind (:data:`datagen.damage.DAMAGE_MODELS`)
    perturbs : str              "stiffness" or "mass": the frequency map (module docstring)
    sizes : ndarray, shape (K,)  the size grid over the kind's ``size_range``
    sens : learn.explanations.sensitivity.Sensitivity   sensitivities per unit size, averaged over the kind's spread
    size_label : str
    exact : learn.explanations.refine.ExactKind or None   the kind's exact model on the nominal beam: the grid's best
                                candidates refined on it (:func:`learn.explanations.refine.refined_fits`); None: the
                                grid alone
    """

    name: str
    perturbs: str
    sizes: np.ndarray
    sens: Sensitivity
    size_label: str = "size"
    exact: ExactKind | None = None

    def modes(self, indices) -> "KindExplanation":
        """The explanation on the nominal modes ``indices`` (0-based) alone."""
        exact = None if self.exact is None else self.exact.modes(indices)
        return replace(self, sens=self.sens.modes(indices), exact=exact)

    def frequency_grid(self) -> np.ndarray:
        """Relative frequency changes (K, E, m) over the size grid and the places (the Rayleigh quotient of the
        nominal shapes: the stiffness or the mass scaled by ``1 + 2 s F`` or ``1 - 2 s G``)."""
        F = np.asarray(self.sens.frequency, float).T[None]              # (1, E, m), d ln f per unit size
        s = self.sizes[:, None, None]
        if self.perturbs == "stiffness":
            return np.sqrt(np.maximum(1 + 2 * s * F, 1e-6)) - 1
        return 1 / np.sqrt(np.maximum(1 - 2 * s * F, 1e-6)) - 1


def window_averaged(sens: Sensitivity, spread_m: float) -> Sensitivity:
    """``sens`` with each place's sensitivities averaged over a window ``spread_m`` long centred there (clipped to
    the beam, each element weighed by its overlap); below one element the point values."""
    E = sens.n_elements
    le = sens.length_m / E
    if not spread_m > le:
        return sens
    centres = (np.arange(E) + 0.5) * le
    a = np.clip(centres - spread_m / 2, 0.0, sens.length_m)[:, None]   # (E centres, 1)
    b = np.clip(centres + spread_m / 2, 0.0, sens.length_m)[:, None]
    starts = np.arange(E)[None] * le                                    # (1, E elements)
    W = np.clip(np.minimum(b, starts + le) - np.maximum(a, starts), 0.0, None)
    W /= W.sum(axis=1, keepdims=True)
    return replace(sens, frequency=np.asarray(sens.frequency) @ W.T, shape=np.asarray(sens.shape) @ W.T)


@dataclass(frozen=True)
class Hypothesis:
    """One weighed explanation.

    Attributes
    ----------
    name : str
    probability : float                      posterior probability (the explanations' sum to 1)
    log_evidence : float                     log of the prior-averaged likelihood (up to a common constant)
    parameters : dict                        the most likely parameters, and for a damage kind the 68 %/95 %
                                             intervals of ``x_m`` and ``size``
    predicted : ndarray, shape (m,)          relative frequency changes at the most likely parameters
    max_abs_frequency_error_pct : float      largest |measured - predicted| change there (%)
    max_misfit_std : float                   largest |measured - predicted| change over its std (the noise and
                                             the model error of the prediction); beyond :data:`FIT_LIMIT` the
                                             explanation does not fit
    """

    name: str
    probability: float
    log_evidence: float
    parameters: dict
    predicted: np.ndarray
    max_abs_frequency_error_pct: float
    max_misfit_std: float = 0.0

    @property
    def fits(self) -> bool:
        """Whether every predicted change lies within :data:`FIT_LIMIT` standard deviations of the measured one."""
        return self.max_misfit_std <= FIT_LIMIT

    def row(self) -> dict:
        return {"name": self.name, "probability": self.probability, "parameters": self.parameters,
                "max_abs_frequency_error_pct": self.max_abs_frequency_error_pct,
                "max_misfit_std": self.max_misfit_std, "fits": self.fits,
                "predicted_change_pct": [float(v) for v in 100 * self.predicted]}


def _log_mean_exp(v: np.ndarray) -> float:
    top = float(np.max(v))
    return top + float(np.log(np.mean(np.exp(v - top))))


def support_curve(beam, EI_Nm2: float, mass_per_length_kg_m: float, root_spring_relative, ln_factors,
                  mode_index, n_elements: int = 40) -> tuple[np.ndarray, np.ndarray, str]:
    """Relative frequency changes (G, m) of the modes ``mode_index`` (0-based bending modes) when the beam's
    support springs change (module docstring), the changes of their real unit-norm shapes at the sensors
    (G, S m; sensor-major as :attr:`learn.explanations.sensitivity.Sensitivity.shape`), and what the parameter means.

    ``ln_factors`` (G,): the parameter of :func:`physics.supports.changed_springs` for the test's support:
    ``ln(k / k_0)`` of the clamp springs or the suspension; for pinned ends ``log10`` of the bearing spring
    ``k L / EI`` added to none. An unknown support is refused in one line.
    """
    sup = beam.support
    L = beam.length_m
    g = np.asarray(ln_factors, float)
    kr0 = (1e4 if root_spring_relative is None else float(root_spring_relative)) * EI_Nm2 / L
    base = beam_model(n_elements, L, EI_Nm2, mass_per_length_kg_m, bc=sup.name,
                      root_spring=kr0 if sup.clamped else None)
    last = n_elements + 1
    own = sup.spring_dofs(last)                                  # the support's springs (module physics.supports)
    nominal = sup.nominal_unit_stiffness(L) * EI_Nm2             # a suspension (the clamps': kr0, in base)
    K0 = add_springs(base.K, base.dofs, own, nominal)
    k0 = kr0 if sup.clamped else nominal
    dk = np.concatenate([[0.0], changed_springs(sup, k0, EI_Nm2, L, g)])   # row 0: the nominal support
    K = add_springs(np.repeat(K0[None], g.size + 1, axis=0), base.dofs, own, dk)
    M, names, what = np.array(base.M), list(base.dofs), sup.change_meaning
    w, phi = undamped_modes(np.repeat(M[None], K.shape[0], axis=0), K)
    idx = sup.rigid_body_modes + np.asarray(mode_index, int)
    f = w[:, idx]
    all_dofs = [f"{n}:{d}" for n in range(1, last + 1) for d in ("y", "rz")]
    keep = [all_dofs.index(d) for d in names]
    node_x = np.linspace(0.0, L, last)
    T = np.array([hermite_row(float(x), node_x)[0][keep] for x in beam.sensors_x_m])          # (S, n)
    u = real_shapes((T @ phi[..., idx]).astype(complex))                               # (G + 1, S, m)
    du = sign_aligned(u[1:], u[:1]) - u[:1]
    return f[1:] / f[:1] - 1.0, du.reshape(du.shape[0], -1), what


#: Pairs weighed in one array operation (memory: about 2 MB per pair and mode).
CHUNK_PAIRS = 32


def weigh(shifts, kinds: dict, support: tuple, temperature_range=(-0.004, 0.004), sigma=FREQUENCY_CHANGE_STD,
          length_m: float = 1.0, model_error: float = MODEL_ERROR, shapes=None, support_shapes=None,
          shape_sigma: float = SHAPE_CHANGE_STD) -> list[Hypothesis]:
    """Weigh the explanations of one pair's relative frequency changes (and shape changes ``shapes`` (S m,)), see
    the module docstring and :func:`weigh_many`."""
    y = np.asarray(shifts, float)
    if y.ndim != 1:
        raise BeamDamageError(f"frequency changes must be a finite 1-D array, got {y!r}")
    return weigh_many(y[None], kinds, support, temperature_range, sigma, length_m, model_error,
                      None if shapes is None else np.asarray(shapes, float)[None], support_shapes, shape_sigma)[0]


def _shape_loglik(shapes, grids_shapes: dict, sigma: float) -> dict:
    """Shape terms of the log-likelihood, ``(p . y - |p|^2 / 2) / sigma^2`` for each explanation's predicted shape
    changes ``p`` and the measured ``y`` (n, D) (the ``|y|^2`` term is common to all and left out): arrays of the
    shapes of the frequency terms, (n, grid...). ``grids_shapes``: name -> (scale (K,), sensitivity (D, E)) for a
    change linear in a size, or (G, D) predictions, or None for no shape change."""
    out = {}
    for name, g in grids_shapes.items():
        if g is None:
            out[name] = 0.0
        elif isinstance(g, tuple):
            scale, S = g                                                    # (K,), (D, E)
            dot = (shapes @ S)[:, None, :] * scale[None, :, None]           # (n, K, E)
            sq = scale[:, None] ** 2 * np.sum(S**2, axis=0)[None, :]        # (K, E)
            out[name] = (dot - 0.5 * sq[None]) / sigma**2
        else:
            out[name] = (shapes @ g.T - 0.5 * np.sum(g**2, axis=1)[None]) / sigma**2   # (n, G)
    return out


def weigh_many(shifts, kinds: dict, support: tuple, temperature_range=(-0.004, 0.004), sigma=FREQUENCY_CHANGE_STD,
               length_m: float = 1.0, model_error: float = MODEL_ERROR, shapes=None, support_shapes=None,
               shape_sigma: float = SHAPE_CHANGE_STD) -> list[list[Hypothesis]]:
    """Weigh the explanations of measured relative frequency changes of pairs holding the same modes, batched.

    Parameters
    ----------
    shifts : array, shape (n, m)        measured ``f_current / f_baseline - 1`` of the modes both tests hold
    kinds : dict name -> KindExplanation   the damage kinds' explanations on those modes (:func:`kind_explanations`)
    support : (ln_grid (G,), curve (G, m), what, reclamp_curve (R, m) or None)   from :func:`support_curve`
    temperature_range : (lo, hi)        relative EI change between test days (the training's)
    sigma : float or array (m,)         relative std of each mode's change
    length_m : float
    model_error : float                 relative std of each predicted change (:data:`MODEL_ERROR`)
    shapes : array, shape (n, S m), optional   measured changes of the real unit-norm shapes at the sensors
                                        (:func:`learn.explanations.shapes.shape_changes`; sensor-major as the kinds'
                                        ``sens.shape``); without them frequencies alone are weighed
    support_shapes : array, shape (G, S m), optional   the support grid's shape changes (:func:`support_curve`)
    shape_sigma : float or array (S m,)  std of each shape entry's change (:data:`SHAPE_CHANGE_STD`)

    Returns
    -------
    per pair, a list of :class:`Hypothesis`, most probable first (equal prior probabilities).
    """
    Y = np.asarray(shifts, float)
    if Y.ndim != 2 or Y.shape[1] < 1 or not np.all(np.isfinite(Y)):
        raise BeamDamageError(f"frequency changes must be a finite (pairs, modes) array, got {Y!r}")
    s = np.broadcast_to(np.asarray(sigma, float), Y.shape[1:])
    half = max((abs(float(v)) for v in temperature_range), default=0.0) / 2   # the temperature nuisance: +-half
    ln_grid, curve, what, reclamp = support
    grids = {
        "intact": np.zeros((1, Y.shape[1])) if reclamp is None else reclamp,          # temperature, re-clamping
        "global_stiffness": np.broadcast_to(np.linspace(-GLOBAL_RANGE, GLOBAL_RANGE, N_GLOBAL)[:, None],
                                            (N_GLOBAL, Y.shape[1])),
        "support_change": curve,
    }
    for name, k in kinds.items():
        grids[name] = k.frequency_grid()                                  # (K, E, m)
    names = list(grids)
    log_prior = -np.log(len(names))
    out, ss = [], 1.0
    if shapes is not None:
        n_shape = {np.asarray(k.sens.shape).shape[0] for k in kinds.values()}
        shapes = np.asarray(shapes, float)
        if len(n_shape) != 1 or shapes.shape != (Y.shape[0], *n_shape) or not np.all(np.isfinite(shapes)):
            raise BeamDamageError(f"shape changes must be a finite (pairs, sensors x modes) array matching the "
                                  f"kinds' shape sensitivities {sorted(n_shape)}, got {shapes.shape}")
        # whitened by each entry's std: the shape terms then take a unit std
        ss = np.broadcast_to(np.asarray(shape_sigma, float), shapes.shape[1:])
        shapes = shapes / ss
        grid_shapes = {"intact": None, "global_stiffness": None,
                       "support_change": None if support_shapes is None else np.asarray(support_shapes, float) / ss,
                       **{name: (k.sizes, np.asarray(k.sens.shape, float) / ss[:, None]) for name, k in kinds.items()}}
    for start in range(0, Y.shape[0], CHUNK_PAIRS):
        y = Y[start:start + CHUNK_PAIRS]
        ll = {name: nuisance_loglik(g, y, s, 0.0 if name == "global_stiffness" else half, model_error)
              for name, g in grids.items()}
        if shapes is not None:
            extra = _shape_loglik(shapes[start:start + CHUNK_PAIRS], grid_shapes, 1.0)
            ll = {name: (v[0] + extra[name], v[1]) for name, v in ll.items()}
        ys = None if shapes is None else shapes[start:start + CHUNK_PAIRS]
        refined = {name: refined_fits(k, y, s, half, model_error, ll[name][0], ys, ss)
                   for name, k in kinds.items() if k.exact is not None}
        for i in range(y.shape[0]):
            fits = {}
            for name, g in grids.items():
                li, ai = ll[name][0][i], ll[name][1][i]
                j = np.unravel_index(np.argmax(li), li.shape)
                fits[name] = (_log_mean_exp(li), j, (0.0 if name == "global_stiffness" else ai[j]) + g[j], li)
                if name in refined:     # the exact model's optimum; the evidence shifted by its best likelihood
                    r = refined[name][i]
                    fits[name] = (fits[name][0] + r["gain"], j, r["predicted"], li)
            g_best = float(grids["global_stiffness"][fits["global_stiffness"][1]][0])
            params = {
                "intact": {"temperature_frequency_change": float(ll["intact"][1][i][fits["intact"][1]])},
                "global_stiffness": {"frequency_change": g_best, "EI_change": float((1 + g_best) ** 2 - 1)},
                "support_change": {"parameter": what, "value": float(ln_grid[fits["support_change"][1][0]]),
                                   "temperature_frequency_change":
                                       float(ll["support_change"][1][i][fits["support_change"][1]])},
            }
            z = {n: (fits[n][2] - y[i]) / np.sqrt(s**2 + (model_error * fits[n][2]) ** 2) for n in names}
            miss = {n: float(np.max(np.abs(v))) for n, v in z.items()}
            for name, k in kinds.items():
                if name in refined:
                    r = refined[name][i]
                    params[name] = kind_parameters(r["x_m"], r["size"], length_m, k.size_label, r["x_values"],
                                                   r["size_values"], r["loglik"], r["half_width_m"],
                                                   miss[name] <= FIT_LIMIT, r["birge"], r["log_area"])
                    continue
                (t, e), li = fits[name][1], fits[name][3]
                x_m = np.asarray(k.sens.x_over_L) * length_m
                params[name] = kind_parameters(x_m[e], k.sizes[t], length_m, k.size_label,
                                               np.broadcast_to(x_m[None], li.shape),
                                               np.broadcast_to(k.sizes[:, None], li.shape), li,
                                               0.5 * length_m / x_m.size, miss[name] <= FIT_LIMIT,
                                               float(birge_ratio(np.sum(z[name] ** 2), y.shape[1])))
            logz = np.array([fits[n][0] + log_prior for n in names])
            p = np.exp(logz - logz.max())
            p /= p.sum()
            rows = [Hypothesis(n, float(p[j]), float(fits[n][0]), params[n], np.asarray(fits[n][2], float),
                               float(100 * np.max(np.abs(fits[n][2] - y[i]))), miss[n])
                    for j, n in enumerate(names)]
            out.append(sorted(rows, key=lambda r: -r.probability))
    return out


#: What tells an explanation that is no damage kind from any other (the damage kinds' own ``separates`` say what
#: tells them from the others: :func:`separate`).
SEPARATE_BASE = {"intact": "a second baseline day (the day-to-day scatter of these frequencies) or a higher mode",
                 "global_stiffness": "the temperature of both test days, or a higher mode"}


def separate(first: str, second: str) -> str:
    """What measurement would tell two explanations apart that the frequencies of the measured modes cannot: a
    damage kind's ``separates`` entry for the other (either kind's, for two kinds), else the base text of either."""
    for a, b in ((first, second), (second, first)):
        if a in DAMAGE_MODELS and b in DAMAGE_MODELS[a].separates:
            return DAMAGE_MODELS[a].separates[b]
    return next((SEPARATE_BASE[h] for h in (first, second) if h in SEPARATE_BASE), "a higher mode or mode shapes")


def summary(rows: list[Hypothesis], modes) -> str:
    """The most likely explanation in words (that it does not fit, or that it fits only beyond the noise and its
    intervals are widened), and whether the next one can be told apart (Bayes factor < 3) and, if not, what
    measurement would separate them (:func:`separate`)."""
    best, second = rows[0], rows[1]
    text = (f"most likely explanation: {explanation_label(best.name)} (probability {best.probability:.2f}, largest "
            f"frequency misfit {best.max_abs_frequency_error_pct:.2f} %)")
    if not best.fits:
        text = (f"no explanation fits the change within its noise (the most likely, {explanation_label(best.name)}, "
                f"misses a mode by {best.max_misfit_std:.1f} standard deviations, "
                f"{best.max_abs_frequency_error_pct:.2f} %: a change none of them describes, or a noisier test than "
                "weighed); " + text)
    elif best.parameters.get("birge_ratio", 1.0) > 1:
        text += (f"; it reproduces the change only beyond the noise (misfit {best.max_misfit_std:.1f} standard "
                 f"deviations, Birge ratio {best.parameters['birge_ratio']:.1f}): its intervals are widened by it")
    if second.probability > best.probability / 3:
        gap = np.abs(best.predicted - second.predicted)
        text += (f"; {explanation_label(second.name)} ({second.probability:.2f}) cannot be told apart from it on modes "
                 f"{', '.join(map(str, modes))} (their predicted changes differ by at most {100 * gap.max():.2f} %): "
                 f"{separate(best.name, second.name)} would separate them")
    return text


@lru_cache(maxsize=8)
def _support_curves(beam, EI_Nm2: float, mass_per_length_kg_m: float, root_spring_relative, reclamp_range: tuple):
    """The support grid, its curve over all the model's modes, what it means, the re-clamping curve (or None) and
    the support's shape changes (G, S m) of a model's beam (cached: one model classifies many pairs)."""
    number = [r - 1 for r in beam.modes]
    added = beam.test is not None and beam.test.support.change == "add"      # log10(k L / EI) of springs added
    grid = (np.linspace(-2.0, 2.0, N_SUPPORT) if added
            else np.linspace(-SUPPORT_LN_RANGE, SUPPORT_LN_RANGE, N_SUPPORT))
    curve, shapes, what = support_curve(beam, EI_Nm2, mass_per_length_kg_m, root_spring_relative, grid, number)
    reclamp = None
    if reclamp_range:
        reclamp = support_curve(beam, EI_Nm2, mass_per_length_kg_m, root_spring_relative,
                                np.log1p(np.linspace(reclamp_range[0], reclamp_range[1], 9)), number)[0]
    return grid, curve, what, reclamp, shapes


def kind_explanations(model) -> dict:
    """Each registered damage kind's explanation on the model's beam (the kinds its section holds:
    :attr:`learn.network.model_dir.TrainedModel.kind_sensitivities`): its sizes over ``size_range`` and its
    sensitivities averaged over ``spread_m``, both of the model's generator config for the model's own kind and of
    the kind's defaults for the others; fitted exactly on the model's nominal beam."""
    recorded, mapping, nominal = model.recorded, model.truth, model.nominal
    out = {}
    for name, sens in model.kind_sensitivities.items():
        d = recorded.damage if recorded.damage.get("kind") == name else damage_defaults(name)
        exact = ExactKind(name, d, mapping, nominal, np.arange(sens.frequency.shape[0]))
        out[name] = kind_explanation(name, d, mapping, sens, exact=exact)
    return out


def kind_explanation(name: str, d: dict, beam, sens: Sensitivity, sizes=None, exact=None) -> KindExplanation:
    """The explanation of damage kind ``name`` of config section ``d`` on the truth beam ``beam`` (a preset name or
    its mapping): ``sizes`` (default: :data:`N_SIZE` over the kind's ``size_range``) and the point sensitivities
    ``sens`` (:func:`learn.explanations.sensitivity.beam_sensitivity` of that kind) averaged over its ``spread_m``."""
    kind = DAMAGE_MODELS[name]
    sizes = np.linspace(*kind.size_range(d, beam), N_SIZE) if sizes is None else np.asarray(sizes, float)
    return KindExplanation(name, kind.perturbs, sizes, window_averaged(sens, kind.spread_m(d, sens.length_m)),
                           kind.size_label, exact)


#: The verdict keys of :func:`explain_many`, all None for a pair without explanations.
NO_EXPLANATION = {"hypotheses": None, "hypotheses_summary": None, "frequency_change_std": None,
                  "shape_change_std": None}


def explain_many(model, pairs: list, sigma=FREQUENCY_CHANGE_STD, shape_sigma=SHAPE_CHANGE_STD) -> list[dict]:
    """The explanations of each classified pair (a :class:`learn.pairs.measured.ModalPair`) on the model's beam,
    ``{"hypotheses": [row, ...], "hypotheses_summary": str, "frequency_change_std": sigma, "shape_change_std"}``,
    the pairs holding the same modes weighed in one batch.

    ``sigma``: the relative std of a frequency change, one for every mode or one per model mode (m,);
    ``shape_sigma``: the std of a unit-norm shape entry's change, one or per sensor and model mode (S, m) (a
    normal variation measured on several baselines). ``frequency_change_std`` and ``shape_change_std`` of each
    result are then lists over the pair's modes (and sensors)."""
    beam, cfg, truth = model.beam, model.config, model.truth
    EI, m = float(truth["EI_Nm2"]), float(truth["mass_per_length_kg_m"])
    kinds_all = kind_explanations(model)
    days = cfg.get("day_changes") or {}
    grid, curve_all, what, reclamp_all, shapes_all = _support_curves(
        beam, EI, m, cfg.get("root_spring_relative"),
        tuple(days.get("root_spring_change") or ()) if model.beam.support.clamped else ())
    out = [None] * len(pairs)
    groups: dict = {}
    for i, pair in enumerate(pairs):
        groups.setdefault((tuple(int(j) for j in pair.mode_index), bool(pair.frequency_only)), []).append(i)
    n_all = len(beam.modes)
    for (key, frequency_only), members in groups.items():
        k = np.asarray(key, int)
        f = np.abs(np.stack([np.asarray(pairs[i].eigenvalues) for i in members]))         # (n, 2, m)
        support_grid = (grid, curve_all[:, k], what, None if reclamp_all is None else reclamp_all[:, k])
        kinds = {name: kind.modes(k) for name, kind in kinds_all.items()}
        cols = (np.arange(shapes_all.shape[1] // n_all)[:, None] * n_all + k[None]).ravel()   # sensor-major
        shapes = None
        if not frequency_only and all(np.asarray(v.sens.shape).shape[0] == cols.size for v in kinds.values()):
            shapes = shape_changes(np.stack([np.asarray(pairs[i].eigenvectors) for i in members]))
        s = sigma if np.ndim(sigma) == 0 else np.asarray(sigma, float)[k]
        ss = shape_sigma if np.ndim(shape_sigma) == 0 else np.asarray(shape_sigma, float)[:, k].ravel()
        ranked = weigh_many(f[:, 1] / f[:, 0] - 1.0, kinds, support_grid,
                            days.get("temperature_stiffness_change", (-0.004, 0.004)),
                            sigma=s, length_m=beam.length_m, shapes=shapes,
                            support_shapes=shapes_all[:, cols], shape_sigma=ss)
        modes = [beam.modes[j] for j in key]
        for i, rows in zip(members, ranked):
            out[i] = {"hypotheses": [r.row() for r in rows], "hypotheses_summary": summary(rows, modes),
                      "frequency_change_std": _listed(s),
                      "shape_change_std": None if shapes is None else _listed(ss)}
    return out


def _listed(v):
    """A float, or a list of floats."""
    return float(v) if np.ndim(v) == 0 else [float(a) for a in np.ravel(v)]
