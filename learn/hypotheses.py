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

Only frequencies enter: damping changes and shape changes are not weighed here.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.special import log_ndtr

from physics.errors import BeamDamageError

__all__ = ["FREQUENCY_CHANGE_STD", "HYPOTHESES", "MODEL_ERROR", "PRIOR", "SEPARATE", "SIZE_SCALE_STD", "Hypothesis",
           "explain", "summary", "support_curve", "weigh"]

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

#: Relative standard deviation of a size for a given change (10 %): the nominal beam's sensitivities stand for a
#: specimen whose EI, mass and clamp differ from it by several percent; it widens the size intervals.
SIZE_SCALE_STD = 0.1

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
    """

    name: str
    probability: float
    log_evidence: float
    parameters: dict
    predicted: np.ndarray
    max_abs_frequency_error_pct: float

    def row(self) -> dict:
        return {"name": self.name, "probability": self.probability, "parameters": self.parameters,
                "max_abs_frequency_error_pct": self.max_abs_frequency_error_pct,
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
                  mode_index, n_elements: int = 40) -> tuple[np.ndarray, str]:
    """Relative frequency changes (G, m) of the modes ``mode_index`` (0-based bending modes) when the beam's
    support springs change (module docstring), and what the parameter means.

    ``ln_factors`` (G,): ``ln(k / k_0)`` of the clamp springs or the suspension; for pinned ends ``log10`` of the
    bearing spring ``k L / EI`` added to none.
    """
    from physics.fem import beam_model
    from physics.layout import RIGID_BODY_MODES
    from physics.modal import undamped_modes

    test = beam.test
    bc = "clamped-free" if test is None else test.bc
    L = beam.length_m
    g = np.asarray(ln_factors, float)
    kr0 = (1e4 if root_spring_relative is None else float(root_spring_relative)) * EI_Nm2 / L
    base = beam_model(n_elements, L, EI_Nm2, mass_per_length_kg_m, bc="pinned-pinned" if bc == "clamped-clamped"
                      else bc, root_spring=kr0 if bc == "clamped-free" else None)
    K0, M = np.array(base.K), np.array(base.M)
    names = list(base.dofs)
    last = n_elements + 1
    K = np.repeat(K0[None], g.size + 1, axis=0)                  # row 0: the nominal support
    scale = np.concatenate([[0.0], g])
    if bc == "clamped-free":
        what = "ln(k / k0) of the clamp's rotational spring"
        K[:, names.index("1:rz"), names.index("1:rz")] += kr0 * (np.exp(scale) - 1.0)
    elif bc == "clamped-clamped":
        what = "ln(k / k0) of both clamps' rotational springs"
        for d in ("1:rz", f"{last}:rz"):
            K[:, names.index(d), names.index(d)] += kr0 * np.exp(scale)
    elif bc == "pinned-pinned":
        what = "log10(k L / EI) of the bearing rotational springs added at both pins"
        for d in ("1:rz", f"{last}:rz"):
            K[1:, names.index(d), names.index(d)] += 10.0 ** g * EI_Nm2 / L
    else:
        what = "ln(k / k0) of the suspension springs at both ends"
        ks = 0.5 * mass_per_length_kg_m * L * (0.05 * 22.3733 / L**2) ** 2 * EI_Nm2 / mass_per_length_kg_m
        for d in ("1:y", f"{last}:y"):
            K[:, names.index(d), names.index(d)] += ks * np.exp(scale)
    w, _ = undamped_modes(np.repeat(M[None], K.shape[0], axis=0), K)
    idx = RIGID_BODY_MODES[bc] + np.asarray(mode_index, int)
    f = w[:, idx]
    return f[1:] / f[:1] - 1.0, what


def _loglik(g, y, s, half: float, model_error: float):
    """Log-likelihood of ``a + g`` averaged over the temperature nuisance ``a`` (uniform in +-``half``; a Gaussian
    integral in closed form), and the most likely ``a``, for every change ``g`` (..., m): measured ``y`` (m,) with
    relative std ``s`` (m,) and the model error on ``g``. ``half = 0``: no nuisance."""
    var = s**2 + (model_error * g) ** 2
    r = g - y
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


def _slit(loglik, sens, theta_max: float, length_m: float) -> tuple:
    """Evidence, parameters (place, size, their intervals) and prediction of the slit explanation."""
    F = np.asarray(sens.frequency, float)                                # (m, E)
    th = np.linspace(0.0, theta_max, N_SIZE)
    # Rayleigh quotient with the nominal shapes: f^2 scales by 1 + 2 theta F (F = d ln f / d theta < 0)
    g = np.sqrt(np.maximum(1 + 2 * th[:, None, None] * F.T[None], 1e-6)) - 1          # (T, E, m)
    ll, ab = loglik(g)                                                   # (T, E)
    post = np.exp(ll - ll.max())
    t, e = np.unravel_index(np.argmax(ll), ll.shape)
    px, pt = post.sum(axis=0), post.sum(axis=1)
    x_m = np.asarray(sens.x_over_L) * length_m
    h = 0.5 * length_m / x_m.size                                        # half an element of the grid
    return _log_mean_exp(ll), {
        "x_m": float(x_m[e]), "x_over_L": float(sens.x_over_L[e]), "hinge_flexibility": float(th[t]),
        "x_m_68": _interval(x_m, px, 0.68, h), "x_m_95": _interval(x_m, px, 0.95, h),
        "hinge_flexibility_68": _interval(*_scaled(th, pt), 0.68),
        "hinge_flexibility_95": _interval(*_scaled(th, pt), 0.95)}, ab[t, e] + g[t, e]


def weigh(shifts, sens, mass_sens, support: tuple, temperature_range=(-0.004, 0.004), theta_max: float = 0.2,
          sigma=FREQUENCY_CHANGE_STD, length_m: float = 1.0, model_error: float = MODEL_ERROR) -> list[Hypothesis]:
    """Weigh the explanations of measured relative frequency changes (module docstring).

    Parameters
    ----------
    shifts : array, shape (m,)          measured ``f_current / f_baseline - 1`` of the modes both tests hold
    sens : learn.sensitivity.Sensitivity          slit sensitivities of those modes (``frequency`` (m, E))
    mass_sens : learn.sensitivity.Sensitivity     mass-change sensitivities of those modes
    support : (ln_grid (G,), curve (G, m), what, reclamp_curve (R, m) or None)   from :func:`support_curve`
    temperature_range : (lo, hi)        relative EI change between test days (the training's)
    theta_max : float                   largest slit hinge flexibility of the prior
    sigma : float or array (m,)         relative std of each mode's change
    length_m : float
    model_error : float                 relative std of each predicted change (:data:`MODEL_ERROR`)

    Returns
    -------
    list of :class:`Hypothesis`, most probable first.
    """
    y = np.asarray(shifts, float)
    if y.ndim != 1 or y.size < 1 or not np.all(np.isfinite(y)):
        raise BeamDamageError(f"frequency changes must be a finite 1-D array, got {y!r}")
    s = np.broadcast_to(np.asarray(sigma, float), y.shape)
    half = max((abs(float(v)) for v in temperature_range), default=0.0) / 2   # the temperature nuisance: +-half

    def loglik(g, nuisance=half):
        return _loglik(g, y, s, nuisance, model_error)

    out = {}
    ln_grid, curve, what, reclamp = support
    rc = np.zeros((1, y.size)) if reclamp is None else reclamp          # intact: temperature and re-clamping
    ll, ab = loglik(rc)
    j = int(np.argmax(ll))
    out["intact"] = (_log_mean_exp(ll), {"temperature_frequency_change": float(ab[j])}, ab[j] + rc[j])
    gl = np.linspace(-GLOBAL_RANGE, GLOBAL_RANGE, N_GLOBAL)            # no temperature nuisance: it is one
    g = np.broadcast_to(gl[:, None], (gl.size, y.size))
    ll, _ = loglik(g, 0.0)
    k = int(np.argmax(ll))
    out["global_stiffness"] = (_log_mean_exp(ll), {"frequency_change": float(gl[k]),
                                                   "EI_change": float((1 + gl[k]) ** 2 - 1)}, g[k])
    ll, ab = loglik(curve)
    j = int(np.argmax(ll))
    out["support_change"] = (_log_mean_exp(ll), {"parameter": what, "value": float(ln_grid[j]),
                                                 "temperature_frequency_change": float(ab[j])}, ab[j] + curve[j])
    out["slit"] = _slit(loglik, sens, theta_max, length_m)
    G = np.asarray(mass_sens.frequency, float)                           # (m, E) per unit mass ratio added
    mu = np.linspace(-MASS_RANGE, MASS_RANGE, N_SIZE + 1)
    g = 1 / np.sqrt(np.maximum(1 - 2 * mu[:, None, None] * G.T[None], 1e-6)) - 1      # (T, E, m)
    ll, ab = loglik(g)
    t, e = np.unravel_index(np.argmax(ll), ll.shape)
    out["mass_change"] = (_log_mean_exp(ll), {"x_m": float(sens.x_over_L[e] * length_m), "mass_ratio": float(mu[t])},
                          ab[t, e] + g[t, e])
    logz = np.array([out[h][0] + np.log(PRIOR[h]) for h in HYPOTHESES])
    p = np.exp(logz - logz.max())
    p /= p.sum()
    rows = [Hypothesis(h, float(p[k]), float(out[h][0]), out[h][1], np.asarray(out[h][2], float),
                       float(100 * np.max(np.abs(out[h][2] - y)))) for k, h in enumerate(HYPOTHESES)]
    return sorted(rows, key=lambda r: -r.probability)


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
    """The support grid, its curve over all the model's modes, what it means, and the re-clamping curve (or None)
    of a model's beam (cached: one model classifies many pairs)."""
    number = [r - 1 for r in beam.modes]
    pinned = beam.test is not None and beam.test.bc == "pinned-pinned"
    grid = (np.linspace(-2.0, 2.0, N_SUPPORT) if pinned
            else np.linspace(-SUPPORT_LN_RANGE, SUPPORT_LN_RANGE, N_SUPPORT))
    curve, what = support_curve(beam, EI_Nm2, mass_per_length_kg_m, root_spring_relative, grid, number)
    reclamp = None
    if reclamp_range:
        reclamp = support_curve(beam, EI_Nm2, mass_per_length_kg_m, root_spring_relative,
                                np.log1p(np.linspace(reclamp_range[0], reclamp_range[1], 9)), number)[0]
    return grid, curve, what, reclamp


def explain(model, pair, sigma=FREQUENCY_CHANGE_STD) -> dict:
    """The explanations of one classified pair (a :class:`learn.measured.ModalPair`) on the model's beam:
    ``{"hypotheses": [row, ...], "hypotheses_summary": str, "frequency_change_std": sigma}``."""
    from datagen.damage.slit import hinge_flexibility
    from learn.model_dir import sensitivity_of
    from physics.properties import beam_preset

    beam, cfg = model.beam, model.config
    truth = cfg.get("truth_beam") or {}
    if "EI_Nm2" in truth:
        EI, m = float(truth["EI_Nm2"]), float(truth["mass_per_length_kg_m"])
    else:
        p = beam_preset(beam.name)
        EI, m = p.EI_Nm2, p.mass_per_length_kg_m
    gen = cfg.get("generator_config") or {}
    mass_sens = sensitivity_of(beam, cfg.get("root_spring_relative"), truth,
                               {**gen, "damage": {"kind": "mass_change"}}).modes(pair.modes)
    sens = model.sensitivity.modes(pair.modes)
    days = cfg.get("day_changes") or {}
    clamp = beam.test is None or beam.test.bc in ("clamped-free", "clamped-clamped")
    grid, curve, what, reclamp = _support_curves(beam, EI, m, cfg.get("root_spring_relative"),
                                                 tuple(days.get("root_spring_change") or ()) if clamp else ())
    k = np.asarray(pair.modes, int)
    curve, reclamp = curve[:, k], None if reclamp is None else reclamp[:, k]
    damage = gen.get("damage") or {}
    theta_max = 0.2
    if damage.get("kind", "slit") == "slit" and "ei_loss" in damage and "width_m" in damage:
        theta_max = float(hinge_flexibility(max(damage["ei_loss"]), max(damage["width_m"]), beam.length_m))
    f = np.abs(np.asarray(pair.eigenvalues))
    rows = weigh(f[1] / f[0] - 1.0, sens, mass_sens, (grid, curve, what, reclamp),
                 days.get("temperature_stiffness_change", (-0.004, 0.004)), theta_max=theta_max, sigma=sigma,
                 length_m=beam.length_m)
    modes = [beam.modes[j] for j in pair.modes]
    return {"hypotheses": [r.row() for r in rows], "hypotheses_summary": summary(rows, modes),
            "frequency_change_std": float(sigma)}
