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
``slit``            ``a + sqrt(1 + 2 theta F_r(x)) - 1``: the slit sensitivities  ``x`` on the grid, ``theta``
                    ``F`` (:mod:`learn.sensitivity`, curvature squared at ``x``)  in 0..theta_max
                    in the Rayleigh quotient of the nominal shapes
``mass_change``     ``a + (1 - 2 mu G_r(x))^-1/2 - 1``: a mass ``mu m L`` added   ``x`` on the grid, ``mu`` in
                    (``mu > 0``) or lost (``mu < 0``) at ``x`` (``G``:            +-10 % of the beam's mass
                    displacement squared there)
=================== ============================================================ ==========================

``a`` (the temperature nuisance, within the training's ``temperature_stiffness_change``: ``a = dEI / (2 EI)``)
enters every explanation but ``global_stiffness``. The likelihood is Gaussian with a relative standard deviation
``sigma`` per mode (default :data:`FREQUENCY_CHANGE_STD`) plus :data:`MODEL_ERROR` of each predicted change
(the sizes' intervals also hold :data:`SIZE_SCALE_STD`); each explanation's evidence is its likelihood averaged
over its prior (a grid), so a more flexible explanation pays for the predictions it could have made. With equal
prior probabilities (:data:`PRIOR`), the probabilities are the normalised evidences.

Shapes, where both tests hold them: the change of the real unit-norm shapes at the sensors
(:func:`learn.features.real_shapes`, the current shape's sign following the baseline's) enters the same
likelihood with a standard deviation :data:`SHAPE_CHANGE_STD` per entry. A slit or a mass predicts the first-order
shape change of its size at its place (the shape sensitivities of :mod:`learn.sensitivity`), a support change the
exact change of the nominal shapes (:func:`support_curve`), the day-to-day changes and a global stiffness change
none. Damping changes are not weighed: the repeatability of damping ratios (5-30 % between tests) is larger than
what a slit changes.

An explanation whose predicted change misses a mode's measured change by more than :data:`FIT_LIMIT` standard
deviations (the noise and the model error) does not fit: the summary says so when the most likely does not, and a
slit that does not fit reports no intervals.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from datagen.damage.slit import hinge_flexibility
from learn.features import real_shapes, sign_aligned
from learn.model_dir import sensitivity_of
from physics.effects import hermite_row
from physics.errors import BeamDamageError
from physics.fem import beam_model
from physics.modal import undamped_modes
from physics.properties import beam_preset
from physics.supports import THESIS_SUPPORT, add_springs, changed_springs, support

__all__ = ["FIT_LIMIT", "FREQUENCY_CHANGE_STD", "HYPOTHESES", "MODEL_ERROR", "NO_EXPLANATION", "PRIOR", "SEPARATE",
           "SHAPE_CHANGE_STD", "SIZE_SCALE_STD", "Hypothesis", "explain", "explain_many", "shape_changes", "summary",
           "support_curve", "weigh", "weigh_many"]

#: Relative standard deviation of a mode's frequency change between two tests (0.1 %): modal tests repeated on
#: the same specimen and mounting scatter 0.05-0.5 % in frequency; the training's frequency scatter and modal
#: noise put most pairs between 0.03 and 0.2 %.
FREQUENCY_CHANGE_STD = 1e-3

#: The explanations, in the order reported.
HYPOTHESES = ("intact", "global_stiffness", "support_change", "slit", "mass_change")

#: Prior probability of each explanation (equal: the verdict states it).
PRIOR = {h: 1.0 / len(HYPOTHESES) for h in HYPOTHESES}

#: Relative error of each predicted change, mode by mode (3 %): the sensitivities are those of the nominal shapes.
MODEL_ERROR = 0.03

#: Standard deviation of each entry of a real unit-norm shape's change between two tests (0.03): the top of the
#: repeatability of mode shapes (3 % of the largest entry per test, docs/datasets.md). Smaller values trust the
#: first-order shape predictions too much on noisier shapes (bench_hypotheses --shape-noise 0.03: slits 58 % right
#: with 0.01 against 71 % with 0.03).
SHAPE_CHANGE_STD = 0.03

#: Relative standard deviation of a size for a given change (10 %): the nominal beam's sensitivities stand for a
#: specimen whose EI, mass and clamp differ from it by several percent; it widens the size intervals.
SIZE_SCALE_STD = 0.1

#: Largest misfit of a mode's change, in its standard deviations, of an explanation that fits (3: a chance of
#: about 1 % over 4 modes).
FIT_LIMIT = 3.0

#: Grids of the parameters.
N_SIZE, N_GLOBAL, N_SUPPORT = 200, 401, 121
GLOBAL_RANGE, MASS_RANGE, SUPPORT_LN_RANGE = 0.05, 0.10, np.log(10.0)


@dataclass(frozen=True)
class Hypothesis:
    """One weighed explanation.

    Attributes
    ----------
    name : str
    probability : float                      posterior probability (the five sum to 1)
    log_evidence : float                     log of the prior-averaged likelihood (up to a common constant)
    parameters : dict                        the most likely parameters, and for ``slit`` the 68 %/95 % intervals
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


def _interval(values: np.ndarray, weights: np.ndarray, level: float, half_width: float = 0.0) -> list:
    """Equal-tailed interval of a discrete distribution, widened by ``half_width`` on each side (the half-width of
    a grid cell: a location grid's elements)."""
    order = np.argsort(values, kind="stable")
    values, weights = np.asarray(values)[order], np.asarray(weights)[order]
    c = np.cumsum(weights) / np.sum(weights)
    lo = values[min(np.searchsorted(c, (1 - level) / 2), values.size - 1)]
    hi = values[min(np.searchsorted(c, 1 - (1 - level) / 2), values.size - 1)]
    return [float(lo - half_width), float(hi + half_width)]


def _scaled(sizes: np.ndarray, weights: np.ndarray):
    """The size distribution times a factor ``N(1, SIZE_SCALE_STD)`` (9 points): values and weights, flattened."""
    c = 1 + SIZE_SCALE_STD * np.linspace(-2.5, 2.5, 9)
    w = np.exp(-0.5 * ((c - 1) / SIZE_SCALE_STD) ** 2)
    return (sizes[:, None] * c[None]).ravel(), (weights[:, None] * w[None]).ravel()


def support_curve(beam, EI_Nm2: float, mass_per_length_kg_m: float, root_spring_relative, ln_factors,
                  mode_index, n_elements: int = 40) -> tuple[np.ndarray, np.ndarray, str]:
    """Relative frequency changes (G, m) of the modes ``mode_index`` (0-based bending modes) when the beam's
    support springs change (module docstring), the changes of their real unit-norm shapes at the sensors
    (G, S m; sensor-major as :attr:`learn.sensitivity.Sensitivity.shape`), and what the parameter means.

    ``ln_factors`` (G,): the parameter of :func:`physics.supports.changed_springs` for the test's support:
    ``ln(k / k_0)`` of the clamp springs or the suspension; for pinned ends ``log10`` of the bearing spring
    ``k L / EI`` added to none. An unknown support is refused in one line.
    """
    test = beam.test
    sup = support(THESIS_SUPPORT if test is None else test.bc, "the model's test")
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
    sensors = np.arange(1, 5) * L / 4 if test is None else sorted(test.sensors_x_m)
    T = np.array([hermite_row(float(x), node_x)[0][keep] for x in sensors])          # (S, n)
    u = real_shapes((T @ phi[..., idx]).astype(complex))                               # (G + 1, S, m)
    du = sign_aligned(u[1:], u[:1]) - u[:1]
    return f[1:] / f[:1] - 1.0, du.reshape(du.shape[0], -1), what


def _loglik(g, y, s, half: float, model_error: float):
    """Log-likelihood of ``a + g`` averaged over the temperature nuisance ``a`` (uniform in +-``half``; a Gaussian
    integral in closed form), and the most likely ``a``: shapes (n, ...) for every pair's measured changes ``y``
    (n, m) and every predicted change ``g`` (..., m), relative std ``s`` (m,) and the model error on ``g``.
    ``half = 0``: no nuisance."""
    from scipy.special import log_ndtr  # scipy.special: 0.2 s to import, only where explanations are weighed

    var = s**2 + (model_error * g) ** 2                                  # (..., m)
    r = g - y.reshape(y.shape[:1] + (1,) * (g.ndim - 1) + y.shape[-1:])  # (n, ..., m)
    s0, s1, s2 = np.sum(r**2 / var, -1), np.sum(r / var, -1), np.sum(1.0 / var, -1)
    logdet = -0.5 * np.sum(np.log(var / s**2), -1)
    centre = -s1 / s2                                                    # the a that fits best
    a_best = np.clip(centre, -half, half)
    if half == 0:
        return -0.5 * s0 + logdet, a_best
    root = np.sqrt(s2)
    lo, hi = (-half - centre) * root, (half - centre) * root
    # log P(lo < z < hi), from the tail the interval lies in (no cancellation of two values near 1)
    right = lo > 0
    big = np.where(right, log_ndtr(-lo), log_ndtr(hi))
    small = np.where(right, log_ndtr(-hi), log_ndtr(lo))
    mass = big + np.log(-np.expm1(np.minimum(small - big, -1e-300)))
    return (-0.5 * (s0 - s1**2 / s2) + logdet + 0.5 * np.log(2 * np.pi) - np.log(root) + mass
            - np.log(2 * half)), a_best


#: Pairs weighed in one array operation (memory: about 2 MB per pair and mode).
CHUNK_PAIRS = 32


def weigh(shifts, sens, mass_sens, support: tuple, temperature_range=(-0.004, 0.004), theta_max: float = 0.2,
          sigma=FREQUENCY_CHANGE_STD, length_m: float = 1.0, model_error: float = MODEL_ERROR, shapes=None,
          support_shapes=None, shape_sigma: float = SHAPE_CHANGE_STD) -> list[Hypothesis]:
    """Weigh the explanations of one pair's relative frequency changes (and shape changes ``shapes`` (S m,)), see
    the module docstring and :func:`weigh_many`."""
    y = np.asarray(shifts, float)
    if y.ndim != 1:
        raise BeamDamageError(f"frequency changes must be a finite 1-D array, got {y!r}")
    return weigh_many(y[None], sens, mass_sens, support, temperature_range, theta_max, sigma, length_m,
                      model_error, None if shapes is None else np.asarray(shapes, float)[None], support_shapes,
                      shape_sigma)[0]


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


def weigh_many(shifts, sens, mass_sens, support: tuple, temperature_range=(-0.004, 0.004), theta_max: float = 0.2,
               sigma=FREQUENCY_CHANGE_STD, length_m: float = 1.0, model_error: float = MODEL_ERROR, shapes=None,
               support_shapes=None, shape_sigma: float = SHAPE_CHANGE_STD) -> list[list[Hypothesis]]:
    """Weigh the explanations of measured relative frequency changes of pairs holding the same modes, batched.

    Parameters
    ----------
    shifts : array, shape (n, m)        measured ``f_current / f_baseline - 1`` of the modes both tests hold
    sens : learn.sensitivity.Sensitivity          slit sensitivities of those modes (``frequency`` (m, E))
    mass_sens : learn.sensitivity.Sensitivity     mass-change sensitivities of those modes
    support : (ln_grid (G,), curve (G, m), what, reclamp_curve (R, m) or None)   from :func:`support_curve`
    temperature_range : (lo, hi)        relative EI change between test days (the training's)
    theta_max : float                   largest slit hinge flexibility of the prior
    sigma : float or array (m,)         relative std of each mode's change
    length_m : float
    model_error : float                 relative std of each predicted change (:data:`MODEL_ERROR`)
    shapes : array, shape (n, S m), optional   measured changes of the real unit-norm shapes at the sensors
                                        (:func:`shape_changes`; sensor-major as ``sens.shape``); without them
                                        frequencies alone are weighed
    support_shapes : array, shape (G, S m), optional   the support grid's shape changes (:func:`support_curve`)
    shape_sigma : float or array (S m,)  std of each shape entry's change (:data:`SHAPE_CHANGE_STD`)

    Returns
    -------
    per pair, a list of :class:`Hypothesis`, most probable first.
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
    th = np.linspace(0.0, theta_max, N_SIZE)
    # Rayleigh quotient with the nominal shapes: f^2 scales by 1 + 2 theta F (F = d ln f / d theta < 0)
    F = np.asarray(sens.frequency, float)                                # (m, E)
    grids["slit"] = np.sqrt(np.maximum(1 + 2 * th[:, None, None] * F.T[None], 1e-6)) - 1          # (T, E, m)
    mu = np.linspace(-MASS_RANGE, MASS_RANGE, N_SIZE + 1)
    G = np.asarray(mass_sens.frequency, float)                           # (m, E) per unit mass ratio added
    grids["mass_change"] = 1 / np.sqrt(np.maximum(1 - 2 * mu[:, None, None] * G.T[None], 1e-6)) - 1
    x_m = np.asarray(sens.x_over_L) * length_m
    x_mass_m = np.asarray(mass_sens.x_over_L) * length_m                # the mass sensitivities' own grid
    h = 0.5 * length_m / x_m.size                                        # half an element of the grid
    out = []
    if shapes is not None:
        shapes = np.asarray(shapes, float)
        if shapes.shape != (Y.shape[0], np.asarray(sens.shape).shape[0]) or not np.all(np.isfinite(shapes)):
            raise BeamDamageError(f"shape changes must be a finite (pairs, sensors x modes) array of shape "
                                  f"{(Y.shape[0], np.asarray(sens.shape).shape[0])}, got {shapes.shape}")
        # whitened by each entry's std: the shape terms then take a unit std
        ss = np.broadcast_to(np.asarray(shape_sigma, float), shapes.shape[1:])
        shapes = shapes / ss
        grid_shapes = {"intact": None, "global_stiffness": None,
                       "support_change": None if support_shapes is None else np.asarray(support_shapes, float) / ss,
                       "slit": (th, np.asarray(sens.shape, float) / ss[:, None]),
                       "mass_change": (mu, np.asarray(mass_sens.shape, float) / ss[:, None])}
    for start in range(0, Y.shape[0], CHUNK_PAIRS):
        y = Y[start:start + CHUNK_PAIRS]
        ll = {name: _loglik(g, y, s, 0.0 if name == "global_stiffness" else half, model_error)
              for name, g in grids.items()}
        if shapes is not None:
            extra = _shape_loglik(shapes[start:start + CHUNK_PAIRS], grid_shapes, 1.0)
            ll = {name: (v[0] + extra[name], v[1]) for name, v in ll.items()}
        for i in range(y.shape[0]):
            fits = {}
            for name, g in grids.items():
                li, ai = ll[name][0][i], ll[name][1][i]
                j = np.unravel_index(np.argmax(li), li.shape)
                fits[name] = (_log_mean_exp(li), j, (0.0 if name == "global_stiffness" else ai[j]) + g[j], li)
            params = {
                "intact": {"temperature_frequency_change": float(ll["intact"][1][i][fits["intact"][1]])},
                "global_stiffness": {"frequency_change": float(grids["global_stiffness"][fits["global_stiffness"][1]
                                                                                        ][0])},
                "support_change": {"parameter": what, "value": float(ln_grid[fits["support_change"][1][0]]),
                                   "temperature_frequency_change":
                                       float(ll["support_change"][1][i][fits["support_change"][1]])},
                "slit": _slit_parameters(fits["slit"], th, x_m, sens, h),
                "mass_change": {"x_m": float(x_mass_m[fits["mass_change"][1][1]]),
                                "mass_ratio": float(mu[fits["mass_change"][1][0]])},
            }
            g_best = params["global_stiffness"]["frequency_change"]
            params["global_stiffness"]["EI_change"] = float((1 + g_best) ** 2 - 1)
            logz = np.array([fits[n][0] + np.log(PRIOR[n]) for n in HYPOTHESES])
            p = np.exp(logz - logz.max())
            p /= p.sum()
            miss = {n: float(np.max(np.abs(fits[n][2] - y[i]) / np.sqrt(s**2 + (model_error * fits[n][2]) ** 2)))
                    for n in HYPOTHESES}
            if miss["slit"] > FIT_LIMIT:          # a slit that does not fit: no interval rather than a narrow one
                params["slit"].update({k: None for k in ("x_m_68", "x_m_95", "hinge_flexibility_68",
                                                         "hinge_flexibility_95")})
            rows = [Hypothesis(n, float(p[k]), float(fits[n][0]), params[n], np.asarray(fits[n][2], float),
                               float(100 * np.max(np.abs(fits[n][2] - y[i]))), miss[n])
                    for k, n in enumerate(HYPOTHESES)]
            out.append(sorted(rows, key=lambda r: -r.probability))
    return out


def _slit_parameters(fit: tuple, th, x_m, sens, h: float) -> dict:
    """The slit's most likely place and size and their 68 % / 95 % intervals from its likelihood grid (T, E)."""
    _, (t, e), _, ll = fit
    post = np.exp(ll - ll.max())
    px, pt = post.sum(axis=0), post.sum(axis=1)
    return {"x_m": float(x_m[e]), "x_over_L": float(sens.x_over_L[e]), "hinge_flexibility": float(th[t]),
            "x_m_68": _interval(x_m, px, 0.68, h), "x_m_95": _interval(x_m, px, 0.95, h),
            "hinge_flexibility_68": _interval(*_scaled(th, pt), 0.68),
            "hinge_flexibility_95": _interval(*_scaled(th, pt), 0.95)}


#: What would tell two explanations apart that the frequencies of these modes cannot.
SEPARATE = {
    frozenset({"slit", "support_change"}): "mode shapes near the support (a support change bends the beam "
                                           "differently there, a slit changes the curvature at the slit) or a "
                                           "higher mode",
    frozenset({"slit", "mass_change"}): "a higher mode (a slit follows the curvature squared, a mass the "
                                        "displacement squared) or mode shapes around the place",
    frozenset({"support_change", "mass_change"}): "mode shapes near the support or a higher mode",
}
SEPARATE_DEFAULT = {"intact": "a second baseline day (the day-to-day scatter of these frequencies) or a higher mode",
                    "global_stiffness": "the temperature of both test days, or a higher mode"}


def summary(rows: list[Hypothesis], modes) -> str:
    """The most likely explanation in words, and whether the next one can be told apart (Bayes factor < 3) and,
    if not, what measurement would separate them (:data:`SEPARATE`)."""
    best, second = rows[0], rows[1]
    text = (f"most likely explanation: {best.name} (probability {best.probability:.2f}, largest frequency misfit "
            f"{best.max_abs_frequency_error_pct:.2f} %)")
    if not best.fits:
        text = (f"no explanation fits the change within its noise (the most likely, {best.name}, misses a mode by "
                f"{best.max_misfit_std:.1f} standard deviations, {best.max_abs_frequency_error_pct:.2f} %: a change "
                f"none of them describes, or a noisier test than weighed); " + text)
    if second.probability > best.probability / 3:
        gap = np.abs(best.predicted - second.predicted)
        pair = frozenset({best.name, second.name})
        how = SEPARATE.get(pair) or next((SEPARATE_DEFAULT[h] for h in (best.name, second.name)
                                          if h in SEPARATE_DEFAULT), "a higher mode or mode shapes")
        text += (f"; {second.name} ({second.probability:.2f}) cannot be told apart from it on modes "
                 f"{', '.join(map(str, modes))} (their predicted changes differ by at most {100 * gap.max():.2f} %): "
                 f"{how} would separate them")
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


def shape_changes(eigenvectors) -> np.ndarray:
    """Changes of the real unit-norm shapes between the two tests, the current shape's sign following the
    baseline's (as the modal features take them): ``eigenvectors`` (n, 2, S, m) complex -> (n, S m), sensor-major
    as :attr:`learn.sensitivity.Sensitivity.shape`."""
    u = real_shapes(np.asarray(eigenvectors, complex))                   # (n, 2, S, m)
    return (sign_aligned(u[:, 1], u[:, 0]) - u[:, 0]).reshape(u.shape[0], -1)


#: The verdict keys of :func:`explain`, all None for a pair without explanations.
NO_EXPLANATION = {"hypotheses": None, "hypotheses_summary": None, "frequency_change_std": None,
                  "shape_change_std": None}


def explain(model, pair, sigma=FREQUENCY_CHANGE_STD) -> dict:
    """The explanations of one classified pair (a :class:`learn.measured.ModalPair`) on the model's beam:
    ``{"hypotheses": [row, ...], "hypotheses_summary": str, "frequency_change_std": sigma}``."""
    return explain_many(model, [pair], sigma)[0]


def explain_many(model, pairs: list, sigma=FREQUENCY_CHANGE_STD, shape_sigma=SHAPE_CHANGE_STD) -> list[dict]:
    """:func:`explain` of every pair, the pairs holding the same modes weighed in one batch.

    ``sigma``: the relative std of a frequency change, one for every mode or one per model mode (m,);
    ``shape_sigma``: the std of a unit-norm shape entry's change, one or per sensor and model mode (S, m) (a
    normal variation measured on several baselines). ``frequency_change_std`` and ``shape_change_std`` of each
    result are then lists over the pair's modes (and sensors)."""
    beam, cfg = model.beam, model.config
    truth = cfg.get("truth_beam") or {}
    if "EI_Nm2" in truth:
        EI, m = float(truth["EI_Nm2"]), float(truth["mass_per_length_kg_m"])
    else:
        p = beam_preset(beam.name)
        EI, m = p.EI_Nm2, p.mass_per_length_kg_m
    gen = cfg.get("generator_config") or {}
    mass_all = sensitivity_of(beam, cfg.get("root_spring_relative"), truth, {**gen, "damage": {"kind": "mass_change"}})
    days = cfg.get("day_changes") or {}
    clamp = beam.test is None or beam.test.bc in ("clamped-free", "clamped-clamped")
    grid, curve_all, what, reclamp_all, shapes_all = _support_curves(
        beam, EI, m, cfg.get("root_spring_relative"), tuple(days.get("root_spring_change") or ()) if clamp else ())
    damage = gen.get("damage") or {}
    theta_max = 0.2
    if damage.get("kind", "slit") == "slit" and "ei_loss" in damage and "width_m" in damage:
        theta_max = float(hinge_flexibility(max(damage["ei_loss"]), max(damage["width_m"]), beam.length_m))
    out = [None] * len(pairs)
    groups: dict = {}
    for i, pair in enumerate(pairs):
        groups.setdefault((tuple(int(j) for j in pair.modes), bool(pair.frequency_only)), []).append(i)
    n_all = len(beam.modes)
    for (key, frequency_only), members in groups.items():
        k = np.asarray(key, int)
        f = np.abs(np.stack([np.asarray(pairs[i].eigenvalues) for i in members]))         # (n, 2, m)
        support = (grid, curve_all[:, k], what, None if reclamp_all is None else reclamp_all[:, k])
        sens = model.sensitivity.modes(k)
        cols = (np.arange(shapes_all.shape[1] // n_all)[:, None] * n_all + k[None]).ravel()   # sensor-major
        shapes = None
        if not frequency_only and np.asarray(sens.shape).shape[0] == cols.size:
            shapes = shape_changes(np.stack([np.asarray(pairs[i].eigenvectors) for i in members]))
        s = sigma if np.ndim(sigma) == 0 else np.asarray(sigma, float)[k]
        ss = shape_sigma if np.ndim(shape_sigma) == 0 else np.asarray(shape_sigma, float)[:, k].ravel()
        ranked = weigh_many(f[:, 1] / f[:, 0] - 1.0, sens, mass_all.modes(k), support,
                            days.get("temperature_stiffness_change", (-0.004, 0.004)), theta_max=theta_max,
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
