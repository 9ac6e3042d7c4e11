"""Model discrepancy: where a beam model misses measured data, and which physical effect it lacks.

Workflow (:func:`analyse`)
--------------------------
1. Pair measured and model modes (MAC when shapes exist, else frequency) and
   form residuals: frequency error (%), damping ratio error, MAC, and FRF error
   per band (dB) when FRFs are given (:func:`mode_residuals`).
2. Recalibrate the global parameters first: ``EI`` always, the mass per length
   when FRFs fix the absolute scale, Rayleigh damping ``alpha, beta`` when
   damping ratios exist. From frequencies alone ``EI/m`` scales every frequency
   by one factor, so only frequency *ratios* (and shapes, damping, FRF shapes)
   carry information about a missing effect; an effect is named only when it
   explains what this recalibration cannot.
3. For each candidate of :data:`physics.effects.CANDIDATES`, a bounded,
   multi-start least-squares fit of its parameters together with the global
   ones on every residual present, each whitened by its noise level
   (:class:`Noise`). Score: ``BIC = chi^2 + k ln n`` with the noise given
   (Schwarz 1978; ``chi^2`` is ``-2 ln L`` up to a constant for Gaussian
   errors of known variance), and a leave-one-mode-out (LOMO) prediction
   error of the frequencies.
4. The best candidate is named when its BIC is at least
   :data:`BIC_SIGNIFICANT` below the current model's ("strong evidence",
   Kass & Raftery 1995) and its LOMO error is not worse; else ``"none"``.
   Other significant candidates whose ``chi^2`` lies within
   :data:`BIC_INDISTINGUISHABLE` of the winner's (likelihood ratio below
   ``e``) are reported as indistinguishable, with the measurement that separates them most
   (a higher mode, mode shapes, or the driving-point antiresonances,
   predicted by the two fitted models).
5. The named effect joins the model and the search repeats (at most
   ``max_effects`` effects); it stops when nothing significant remains.

Parameter uncertainties come from the Jacobian of the whitened residuals at
the optimum, ``cov = s^2 (J^T J)^-1`` with ``s^2 = max(1, chi^2 / (n - k))``
(the given noise, inflated when the fit is worse than the noise).

Core shear modulus
------------------
For a sandwich of two faces of thickness ``t_f`` on a core of thickness
``c = h - 2 t_f``, the shear rigidity is ``kGA = G_c b d^2 / c`` with
``d = c + t_f`` the distance between face centroids (Allen, *Analysis and
Design of Structural Sandwich Panels*, 1969, ch. 2; Zenkert, *An Introduction
to Sandwich Construction*, 1995), so ``G_c = kGA c / (b d^2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import OptimizeResult, least_squares, linear_sum_assignment

from physics import effects as fx
from physics.beam import Beam
from physics.errors import BeamDamageError, ShapeError
from physics.modal import mac, undamped_modes

try:  # installed with scikit-learn; only a speed-up
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover
    from contextlib import nullcontext

    def threadpool_limits(_):
        return nullcontext()

#: BIC drop that counts as significant ("strong evidence", Kass & Raftery 1995).
BIC_SIGNIFICANT = 6.0
#: Significant candidates whose chi^2 lies within this of the winner's are indistinguishable.
BIC_INDISTINGUISHABLE = 2.0


@dataclass(frozen=True)
class Noise:
    """Measurement noise (standard deviations) that whitens the residuals.

    Attributes
    ----------
    frequency : float or ndarray, shape (n_modes,)
        Relative std of the natural frequencies (0.003 = 0.3 %).
    damping : float
        Relative std of the damping ratios.
    shape : float
        Std of mode-shape entries relative to the largest entry of the mode.
    frf_db : float
        Std of FRF magnitudes (dB).
    """

    frequency: object = 0.003
    damping: float = 0.1
    shape: float = 0.02
    frf_db: float = 1.0


@dataclass(frozen=True)
class Measurement:
    """Measured modal data (and optionally FRFs) on a beam.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
    damping_ratios : ndarray, shape (n_modes,) or None
    shapes : ndarray, complex, shape (n_points, n_modes) or None
        Mode shapes at ``shape_x_m``.
    shape_x_m : tuple of float
        Positions (m) of the shape rows.
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines) or None
    frf_frequency_hz : ndarray, shape (n_lines,) or None
    frf_response_x_m, frf_reference_x_m : tuple of float
        Positions of the FRF rows and columns (m).
    frf_kind : {"receptance", "mobility", "accelerance"}
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray | None = None
    shapes: np.ndarray | None = None
    shape_x_m: tuple = ()
    frf: np.ndarray | None = None
    frf_frequency_hz: np.ndarray | None = None
    frf_response_x_m: tuple = ()
    frf_reference_x_m: tuple = ()
    frf_kind: str = "receptance"

    def __post_init__(self):
        f = np.asarray(self.frequencies_hz, dtype=float)
        if f.ndim != 1 or f.size < 2 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise ShapeError("measured frequencies_hz must be a 1-D array of at least 2 positive finite values")
        object.__setattr__(self, "frequencies_hz", f)
        if self.damping_ratios is not None:
            z = np.asarray(self.damping_ratios, dtype=float)
            if z.shape != f.shape or not np.all(np.isfinite(z)) or np.any(z <= 0) or np.any(z >= 1):
                raise ShapeError("measured damping_ratios must be in (0, 1), one per frequency")
            object.__setattr__(self, "damping_ratios", z)
        if self.shapes is not None:
            s = np.asarray(self.shapes, dtype=complex)
            if s.ndim != 2 or s.shape[1] != f.size or s.shape[0] != len(self.shape_x_m) or s.shape[0] < 2:
                raise ShapeError(f"measured shapes must be (n_points >= 2, n_modes = {f.size}) with one "
                                 "position per row")
            object.__setattr__(self, "shapes", s)
        if self.frf is not None:
            h = np.asarray(self.frf, dtype=complex)
            if h.shape != (len(self.frf_response_x_m), len(self.frf_reference_x_m), len(self.frf_frequency_hz)):
                raise ShapeError("measured FRF must be (n_resp, n_ref, n_lines) matching its positions and lines")
            object.__setattr__(self, "frf", h)
            object.__setattr__(self, "frf_frequency_hz", np.asarray(self.frf_frequency_hz, dtype=float))

    @property
    def n_modes(self) -> int:
        return self.frequencies_hz.size


# ---------------------------------------------------------------------------
# Model evaluation
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Prediction:
    """Model modes at the measured points (``n`` lowest modes, ascending)."""

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray          # complex, (n_points, n)
    frf: np.ndarray | None      # like Measurement.frf


def predict(beam: Beam, meas: Measurement, n_elements: int = 40, n_modes: int | None = None,
            *, EI_scale=1.0, mass_scale=1.0) -> Prediction:
    """Modes of ``beam`` (every effect applied) at the measured points.

    Damped modes come from the lowest ``n_modes + 6`` undamped modes (modal
    projection, exact for proportional damping, accurate for light local damping).
    """
    n = n_modes or meas.n_modes + 2
    model = beam.fe_model(n_elements, EI_scale=EI_scale, mass_scale=mass_scale)
    n_proj = min(n + 6, len(model.dofs))
    w2, phi = eigh(model.K, model.M, subset_by_index=[0, n_proj - 1])   # phi^T M phi = I
    w = np.sqrt(np.clip(w2, 0.0, None))
    c_r = phi.T @ model.C @ phi
    xs = meas.shape_x_m if meas.shapes is not None else ()
    if np.any(c_r):
        a = np.block([[np.zeros((n_proj, n_proj)), np.eye(n_proj)], [-np.diag(w**2), -c_r]])
        lam, vec = np.linalg.eig(a)
        keep = lam.imag > 0
        lam, vec = lam[keep], vec[:n_proj, keep]
        order = np.argsort(lam.imag)
        lam, q = lam[order], vec[:, order]
        q = q / np.sqrt(np.sum(q * (2 * lam * q + c_r @ q), axis=0))   # eq. 1.10 (M_r = I)
        wn = np.abs(lam)
        zeta = -lam.real / wn
    else:
        lam = 1j * w
        q = np.eye(n_proj, dtype=complex) / np.sqrt(2j * w)           # eq. 1.10 with C = 0
        wn, zeta = w, np.zeros_like(w)
    shapes = np.zeros((len(xs), n), dtype=complex)
    if len(xs):
        shapes = fx.interpolation_matrix(model, xs) @ phi @ q[:, :n]
    frf = None
    if meas.frf is not None:
        tr = fx.interpolation_matrix(model, meas.frf_response_x_m) @ phi @ q
        tf = fx.interpolation_matrix(model, meas.frf_reference_x_m) @ phi @ q
        s = 2j * np.pi * meas.frf_frequency_hz
        pole = 1 / (s[:, None] - lam[None, :])
        pole_c = 1 / (s[:, None] - np.conj(lam)[None, :])
        frf = (np.einsum("sj,rj,fj->srf", tr, tf, pole) + np.einsum("sj,rj,fj->srf", np.conj(tr), np.conj(tf), pole_c))
        frf = frf * s ** {"receptance": 0, "mobility": 1, "accelerance": 2}[meas.frf_kind]
    return Prediction(wn[:n] / (2 * np.pi), zeta[:n], shapes, frf)


def _real_shape(v):
    """Rotate a complex shape to be as real as possible; normalise to its largest entry."""
    v = np.asarray(v, dtype=complex)
    theta = 0.5 * np.angle(np.sum(v**2))
    r = v * np.exp(-1j * theta)
    return r / r[np.argmax(np.abs(r))]


def _aligned(a, b):
    """``a - c b`` with ``a`` made real (:func:`_real_shape`) and ``c`` the least-squares complex scale."""
    a = _real_shape(a)
    b = np.asarray(b, dtype=complex)
    return a - b * (np.vdot(b, a) / np.vdot(b, b))


def pair_modes(meas: Measurement, pred: Prediction) -> np.ndarray:
    """Model mode index paired with each measured mode (MAC with shapes, else log-frequency distance)."""
    if meas.shapes is not None:
        cost = -mac(meas.shapes, pred.shapes)
    else:
        ratio = np.median(meas.frequencies_hz / pred.frequencies_hz[:meas.n_modes])
        cost = np.abs(np.log(meas.frequencies_hz[:, None] / (ratio * pred.frequencies_hz[None, :])))
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(meas.n_modes, dtype=int)
    out[rows] = cols
    return out


@dataclass(frozen=True)
class ModeResiduals:
    """Residuals of one model against the measurement, per measured mode.

    Attributes
    ----------
    measured_hz, model_hz : ndarray, shape (n_modes,)
    frequency_error_pct : ndarray  ``100 (model - measured) / measured``
    measured_damping, model_damping : ndarray or None
    mac : ndarray or None   MAC of each paired mode (shapes given)
    frf_band_error_db : ndarray or None   RMS dB error per band around each measured mode
    frf_error_db : float or None   RMS dB error over all lines
    """

    measured_hz: np.ndarray
    model_hz: np.ndarray
    frequency_error_pct: np.ndarray
    measured_damping: np.ndarray | None
    model_damping: np.ndarray | None
    mac: np.ndarray | None
    frf_band_error_db: np.ndarray | None
    frf_error_db: float | None

    @property
    def max_abs_frequency_error_pct(self) -> float:
        return float(np.max(np.abs(self.frequency_error_pct)))

    @property
    def mean_abs_frequency_error_pct(self) -> float:
        return float(np.mean(np.abs(self.frequency_error_pct)))

    def gap(self) -> dict:
        return {"max_abs_frequency_error_pct": self.max_abs_frequency_error_pct,
                "mean_abs_frequency_error_pct": self.mean_abs_frequency_error_pct,
                "frf_error_db": self.frf_error_db}


def _db(h):
    return 20 * np.log10(np.maximum(np.abs(h), 1e-300))


def mode_residuals(meas: Measurement, pred: Prediction, pairs=None) -> ModeResiduals:
    """Per-mode residuals of ``pred`` against ``meas`` (modes paired by :func:`pair_modes`)."""
    pairs = pair_modes(meas, pred) if pairs is None else pairs
    f = pred.frequencies_hz[pairs]
    macs = None
    if meas.shapes is not None:
        macs = np.array([mac(meas.shapes[:, [j]], pred.shapes[:, [p]])[0, 0] for j, p in enumerate(pairs)])
    band = total = None
    if meas.frf is not None:
        err = _db(pred.frf) - _db(meas.frf)
        fm = meas.frequencies_hz
        edges = np.concatenate([[0.0], np.sqrt(fm[:-1] * fm[1:]), [np.inf]])
        lines = meas.frf_frequency_hz
        band = np.array([np.sqrt(np.mean(err[..., (lines >= lo) & (lines < hi)] ** 2))
                         if np.any((lines >= lo) & (lines < hi)) else np.nan for lo, hi in zip(edges[:-1], edges[1:])])
        total = float(np.sqrt(np.mean(err**2)))
    return ModeResiduals(meas.frequencies_hz, f, 100 * (f / meas.frequencies_hz - 1), meas.damping_ratios,
                         None if meas.damping_ratios is None else pred.damping_ratios[pairs], macs, band, total)


# ---------------------------------------------------------------------------
# Parameterisation of a fit
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class _Param:
    key: str            # "EI_scale", "mass_scale", "<effect>.<parameter>"
    lower: float
    upper: float
    log: bool = True

    def to_phys(self, u):
        return math.exp(u) if self.log else u

    def bounds(self):
        return (math.log(self.lower), math.log(self.upper)) if self.log else (self.lower, self.upper)


def _effect_params(effect: str, beam: Beam, meas: Measurement, position_free: bool) -> list[_Param]:
    """Free parameters of ``effect`` with physical bounds scaled on the beam."""
    L, EI, m = beam.length_m, beam.EI_Nm2, beam.mass_per_length_kg_m
    rho_i = m * beam.thickness_m**2 / 12
    w1 = 2 * np.pi * meas.frequencies_hz[0]
    table = {
        "shear_deformation": [_Param("shear_deformation.kGA_N", 1.0 * EI / L**2, 1e6 * EI / L**2)],
        # between a tenth of the uniform section's and all the mass in the faces (3 m h^2 / 12)
        "rotary_inertia": [_Param("rotary_inertia.rho_I_kg_m", 0.1 * rho_i, 3.0 * rho_i)],
        "root_flexibility": [_Param("root_flexibility.k_theta_Nm_rad", 0.1 * EI / L, 1e5 * EI / L)],
        "added_mass": [_Param("added_mass.mass_kg", 1e-4 * m * L, 2.0 * m * L)],
        "local_damping": [_Param("local_damping.c_Ns_m", 1e-7 * m * L * w1, 0.3 * m * L * w1)],
    }
    out = list(table[effect])
    if effect in ("added_mass", "local_damping") and position_free:
        out.append(_Param(f"{effect}.x_m", 0.02 * L, L, log=False))
    return out


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
        The calibrated beam (global parameters and effects written in).
    parameters, parameter_std : dict
        Fitted values and standard deviations, keys ``"EI_Nm2"``,
        ``"mass_per_length_kg_m"``, ``"<effect>.<parameter>"``, derived
        ``"shear_deformation.G_core_pa"``. A std of 0 marks a value held fixed
        (the mass without FRFs), NaN a position chosen among the measured points.
    chi2 : float
        Sum of squared whitened residuals.
    n_obs, n_params : int
    bic : float
        ``chi2 + n_params ln n_obs``.
    lomo : float
        Leave-one-mode-out prediction error in noise units (:func:`_lomo`), NaN if not computed.
    residuals : ModeResiduals
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


class _Problem:
    """Residual function of one candidate model."""

    def __init__(self, beam, meas, noise, fixed_effects, params, position, n_elements, pairs, fit_mass, damping):
        self.beam, self.meas, self.noise = beam, meas, noise
        self.fixed = {k: dict(v) for k, v in fixed_effects.items()}
        self.position = position          # {effect: x_m} for discrete positions
        self.params = params
        self.n_elements, self.pairs = n_elements, pairs
        self.fit_mass, self.damping = fit_mass, damping
        self.mask = np.ones(meas.n_modes, dtype=bool)

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
        if self.damping:
            a, b = self.rayleigh_ref
            eff.setdefault("proportional_damping", {})
            eff["proportional_damping"].update(alpha_1_s=a * self.rayleigh_u[0], beta_s=b * self.rayleigh_u[1])
        nb = replace(self.beam, effects=eff, EI_Nm2=self.beam.EI_Nm2 * ei_s,
                     mass_per_length_kg_m=self.beam.mass_per_length_kg_m * ms)
        return nb, ei_s, ms

    def residual(self, u_all):
        k = len(self.params)
        u, d = u_all[:k], u_all[k:]
        if self.damping:
            self.rayleigh_u = d
        nb, _, _ = self.beam_at(u)
        pred = predict(nb, self.meas, self.n_elements)
        return self._whiten(pred)

    def _whiten(self, pred):
        meas, noise, p = self.meas, self.noise, self.pairs
        sf = np.broadcast_to(np.asarray(noise.frequency, dtype=float), (meas.n_modes,))
        r = [((pred.frequencies_hz[p] / meas.frequencies_hz - 1) / sf)[self.mask]]
        if self.damping:
            r.append(((pred.damping_ratios[p] / meas.damping_ratios - 1) / noise.damping)[self.mask])
        if meas.shapes is not None:
            for j, pj in enumerate(p):
                if not self.mask[j]:
                    continue
                diff = _aligned(meas.shapes[:, j], pred.shapes[:, pj]) / noise.shape
                r.append(diff.real)
                if np.any(np.abs(meas.shapes.imag) > 0):
                    r.append(diff.imag)
        if meas.frf is not None:
            r.append(((_db(pred.frf) - _db(meas.frf)) / noise.frf_db).ravel())
        return np.concatenate(r)


def _rayleigh_refs(meas: Measurement) -> tuple[float, float]:
    w = 2 * np.pi * meas.frequencies_hz
    z = float(np.mean(meas.damping_ratios))
    return 2 * z * w[0], 2 * z / w[-1]


def _fit(beam, meas, noise, effect, fixed_effects, n_elements, pairs, *, fit_mass, n_starts=4, seed=0,
         position=None, with_lomo=True, named=(), start=None) -> tuple[Fit, _Problem, np.ndarray]:
    """Bounded multi-start least squares of the globals, the ``named`` effects and ``effect``.

    ``effect = "none"`` fits the globals (and the named effects) only. Named
    effects start from their values in ``start`` (``{effect: {param: value}}``);
    the new effect starts weak, then at random points within its bounds.
    ``position`` fixes ``x_m`` of position-bearing effects (``{effect: x_m}``).
    """
    damping = meas.damping_ratios is not None
    position_free = meas.shapes is not None or meas.frf is not None
    position = dict(position or {})
    start = start or {}
    params = [_Param("EI_scale", 0.3, 3.0)]
    if fit_mass:
        params.append(_Param("mass_scale", 0.3, 3.0))
    n_named = len(params)
    for e in named:
        params += _effect_params(e, beam, meas, position_free and e not in position)
    n_named = len(params) - n_named
    if effect != "none":
        params += _effect_params(effect, beam, meas, position_free and effect not in position)
    prob = _Problem(beam, meas, noise, fixed_effects, params, position, n_elements, pairs, fit_mass, damping)
    if damping:
        prob.rayleigh_ref = _rayleigh_refs(meas)
    lo = [p.bounds()[0] for p in params] + ([0.0, 0.0] if damping else [])
    hi = [p.bounds()[1] for p in params] + ([20.0, 20.0] if damping else [])
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
        if damping:
            u0 += [0.5, 0.5]
        res = least_squares(prob.residual, np.clip(u0, lo, hi), bounds=(lo, hi), x_scale=1.0,
                            diff_step=1e-6, max_nfev=400)
        if best is None or res.cost < best.cost:
            best = res
        if effect == "none" and not damping and not named:
            break
    fit = _as_fit(prob, best, effect, meas)
    lomo = _lomo(prob, best.x) if with_lomo else float("nan")
    return replace(fit, lomo=lomo), prob, best.x


def _lomo(prob: _Problem, x0) -> float:
    """Leave-one-mode-out prediction error: RMS over modes of the held-out mode's whitened residuals.

    Each measured mode (its frequency, and its damping ratio when given) is
    predicted by a fit on the other modes; the residuals are divided by their
    noise, so 1 means "predicted to within the noise".
    """
    meas = prob.meas
    n_par = len(prob.params) + (2 if prob.damping else 0)
    if meas.n_modes - 1 < len(prob.params) and meas.shapes is None and meas.frf is None:
        return float("nan")
    lo, hi = zip(*[p.bounds() for p in prob.params])
    lo = list(lo) + ([0.0, 0.0] if prob.damping else [])
    hi = list(hi) + ([20.0, 20.0] if prob.damping else [])
    sf = np.broadcast_to(np.asarray(prob.noise.frequency, dtype=float), (meas.n_modes,))
    z2 = []
    for j in range(meas.n_modes):
        prob.mask = np.arange(meas.n_modes) != j
        res = least_squares(prob.residual, x0, bounds=(lo, hi), diff_step=1e-6, max_nfev=200)
        if prob.damping:
            prob.rayleigh_u = res.x[len(prob.params):]
        nb, _, _ = prob.beam_at(res.x[:len(prob.params)])
        pred = predict(nb, meas, prob.n_elements)
        k = prob.pairs[j]
        r = [(pred.frequencies_hz[k] / meas.frequencies_hz[j] - 1) / sf[j]]
        if prob.damping and meas.n_modes - 1 >= n_par - len(prob.params) + 1:
            r.append((pred.damping_ratios[k] / meas.damping_ratios[j] - 1) / prob.noise.damping)
        z2.append(np.mean(np.square(r)))
    prob.mask = np.ones(meas.n_modes, dtype=bool)
    return float(np.sqrt(np.mean(z2)))


def g_core_pa(kGA_N: float, beam: Beam) -> float:
    """Equivalent core shear modulus ``G_c = kGA c / (b d^2)`` (module docstring; thin-face limit ``kGA/(b h)``)."""
    tf = beam.face_thickness_m or 0.0
    c = beam.thickness_m - 2 * tf
    d = c + tf
    return kGA_N * c / (beam.width_m * d**2)


def _as_fit(prob: _Problem, res: OptimizeResult, effect: str, meas: Measurement) -> Fit:
    k = len(prob.params)
    if prob.damping:
        prob.rayleigh_u = res.x[k:]
    nb, ei_s, ms = prob.beam_at(res.x[:k])
    r = res.fun
    chi2 = float(r @ r)
    n_obs, n_par = r.size, res.x.size
    s2 = max(1.0, chi2 / (n_obs - n_par)) if n_obs > n_par else 1.0
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
        params["shear_deformation.G_core_pa"] = g_core_pa(params["shear_deformation.kGA_N"], nb)
        std["shear_deformation.G_core_pa"] = g_core_pa(std["shear_deformation.kGA_N"], nb)
    if prob.damping:
        pd = nb.effects["proportional_damping"]
        for key, ref, i in (("alpha_1_s", prob.rayleigh_ref[0], k), ("beta_s", prob.rayleigh_ref[1], k + 1)):
            params[f"proportional_damping.{key}"] = pd[key]
            std[f"proportional_damping.{key}"] = ref * std_u[i]
    pred = predict(nb, meas, prob.n_elements)
    return Fit(effect, tuple(nb.effects), nb, params, std, chi2, n_obs, n_par,
               chi2 + n_par * math.log(n_obs), float("nan"), mode_residuals(meas, pred, prob.pairs))


# ---------------------------------------------------------------------------
# Selection
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Step:
    """One round of the search: the current model, every candidate fitted on top, the decision."""

    base: Fit
    candidates: tuple
    named: str
    indistinguishable_from: tuple
    separating_measurement: str


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
    """

    nominal: ModeResiduals
    steps: tuple
    final: Fit
    named_effects: tuple
    noise: Noise
    untestable: dict = field(default_factory=dict)


def _candidate_fit(beam, meas, noise, name, fixed, n_elements, pairs, fit_mass, n_starts, seed, named, start,
                   positions):
    """Fit one candidate on top of the named effects; returns ``(fit, positions used)``."""
    position_free = meas.shapes is not None or meas.frf is not None
    kw = dict(fit_mass=fit_mass, seed=seed, named=named, start=start)
    if name in ("added_mass", "local_damping"):
        # scan the measured points for the position; with shapes or FRFs then refine it continuously
        options = []
        for x in beam.measured_x_m:
            pos = {**positions, name: x}
            f, prob, x_opt = _fit(beam, meas, noise, name, fixed, n_elements, pairs, n_starts=max(2, n_starts // 2),
                                  position=pos, with_lomo=False, **kw)
            options.append((f.bic, f, prob, x_opt, pos))
        _, f, prob, x_opt, pos = min(options, key=lambda t: t[0])
        if position_free:
            refined, _, _ = _fit(beam, meas, noise, name, fixed, n_elements, pairs, n_starts=1, position=positions,
                                 fit_mass=fit_mass, seed=seed, named=named,
                                 start={**start, name: f.beam.effects_dict()[name]})
            return refined, positions
        # the discrete position counts as a parameter
        return replace(f, n_params=f.n_params + 1, bic=f.bic + math.log(f.n_obs), lomo=_lomo(prob, x_opt)), pos
    f, _, _ = _fit(beam, meas, noise, name, fixed, n_elements, pairs, n_starts=n_starts, position=positions, **kw)
    return f, positions


def _separating_measurement(a: Fit, b: Fit, meas: Measurement, noise: Noise, n_elements: int) -> str:
    """The measurement where the two fitted models differ most, relative to its noise."""
    n = meas.n_modes
    probe = replace(meas, shapes=np.zeros((len(a.beam.measured_x_m), n)), shape_x_m=a.beam.measured_x_m, frf=None,
                    frf_frequency_hz=None, frf_response_x_m=(), frf_reference_x_m=())
    pa = predict(a.beam, probe, n_elements, n + 1)
    pb = predict(b.beam, probe, n_elements, n + 1)
    sf = float(np.max(np.asarray(noise.frequency)))
    options = []
    dn = abs(pa.frequencies_hz[n] / pb.frequencies_hz[n] - 1)
    options.append((dn / sf, f"natural frequency of mode {n + 1} ({100 * dn:.2g} % apart: "
                             f"{pa.frequencies_hz[n]:.1f} vs {pb.frequencies_hz[n]:.1f} Hz)"))
    ds = max(np.max(np.abs(_aligned(pa.shapes[:, j], pb.shapes[:, j]))) for j in range(n))
    options.append((ds / noise.shape, f"mode shapes at the measured points (largest normalised difference "
                                      f"{ds:.2g})"))
    x_ref = a.beam.measured_x_m[0]
    anti = [_antiresonances_hz(f.beam, x_ref, n_elements, n - 1) for f in (a, b)]
    da = float(np.max(np.abs(anti[0] / anti[1] - 1)))
    options.append((da / sf, f"antiresonances of the driving-point FRF at x = {x_ref:.4g} m "
                             f"(up to {100 * da:.2g} % apart)"))
    return max(options)[1]


def _antiresonances_hz(beam: Beam, x_m: float, n_elements: int, n: int) -> np.ndarray:
    """Antiresonances of the driving-point receptance at ``x_m``: the frequencies with ``w(x_m)`` held at zero."""
    model = beam.fe_model(n_elements)
    t = fx.interpolation_matrix(model, [x_m])[0]
    # constrain t^T u = 0 by a null-space basis
    q, _ = np.linalg.qr(np.column_stack([t, np.eye(t.size)]))
    z = q[:, 1:]
    w, _ = undamped_modes(z.T @ model.M @ z, z.T @ model.K @ z)
    return w[:n] / (2 * np.pi)


def analyse(beam: Beam, meas: Measurement, noise: Noise | None = None, *, candidates=fx.CANDIDATES,
            max_effects: int = 2, n_elements: int = 40, n_starts: int = 4, seed: int = 0,
            progress=None) -> DiscrepancyResult:
    """Name the effects ``beam`` lacks to explain ``meas`` (module docstring).

    Parameters
    ----------
    beam : Beam
        Nominal model (its own effects are kept and refitted as globals are).
    meas : Measurement
    noise : Noise, optional
    candidates : sequence of str
        Effects to test (default all of :data:`physics.effects.CANDIDATES`).
    max_effects : int
        Most effects to name.
    n_elements : int
        Mesh of the fitted models (converged: 40 cubic elements).
    n_starts : int
        Starts of each bounded least-squares fit (the first at a weak effect,
        the others uniform in the bounds).
    seed : int
        Seed of the random starts.
    progress : callable, optional
        Called with a short text before each candidate fit.

    Returns
    -------
    DiscrepancyResult
    """
    with threadpool_limits(1):   # small dense eigenproblems: one BLAS thread is fastest
        return _analyse(beam, meas, noise or Noise(), candidates, max_effects, n_elements, n_starts, seed, progress)


def _analyse(beam, meas, noise, candidates, max_effects, n_elements, n_starts, seed, progress):
    unknown = [c for c in candidates if c not in fx.CANDIDATES]
    if unknown:
        raise BeamDamageError(f"unknown candidate effect(s) {unknown}; expected some of {list(fx.CANDIDATES)}")
    fit_mass = meas.frf is not None
    untestable = {}
    names = list(candidates)
    if meas.damping_ratios is None and "local_damping" in names:
        names.remove("local_damping")
        untestable["local_damping"] = "needs damping ratios (or FRFs)"
    nominal_pred = predict(beam, meas, n_elements)
    pairs = pair_modes(meas, nominal_pred)
    nominal = mode_residuals(meas, nominal_pred, pairs)
    fixed = {k: dict(v) for k, v in beam.effects.items() if k != "proportional_damping"}
    say = progress or (lambda s: None)
    say("globals only")
    base, _, _ = _fit(beam, meas, noise, "none", fixed, n_elements, pairs, fit_mass=fit_mass, n_starts=n_starts,
                      seed=seed)
    steps, named, positions = [], [], {}
    while len(named) < max_effects:
        todo = [c for c in names if c not in named and c not in fixed]
        if not todo:
            break
        fits, used = [], {}
        start = base.beam.effects_dict()
        for c in todo:
            say(c if not named else f"{' + '.join(named)} + {c}")
            f, pos = _candidate_fit(beam, meas, noise, c, fixed, n_elements, pairs, fit_mass, n_starts, seed,
                                    tuple(named), start, positions)
            fits.append(f)
            used[c] = pos
        fits.sort(key=lambda f: f.bic)
        best = fits[0]
        # an effect needs data left over to be tested: more observations than parameters and a held-out check
        testable = best.n_obs > best.n_params and np.isfinite(best.lomo)
        lomo_ok = testable and (not np.isfinite(base.lomo) or best.lomo <= base.lomo)
        significant = best.bic <= base.bic - BIC_SIGNIFICANT and lomo_ok
        if not significant:
            steps.append(Step(base, tuple(fits), "none", (), ""))
            break
        # explain the data equally well: also significant, and a likelihood within e^1 of the winner's
        # (chi^2, not BIC: a parameter more must not make two equal fits look different)
        ties = tuple(f.effect for f in fits[1:]
                     if f.bic <= base.bic - BIC_SIGNIFICANT and f.chi2 - best.chi2 < BIC_INDISTINGUISHABLE)
        sep = ""
        if ties:
            other = next(f for f in fits if f.effect == ties[0])
            sep = _separating_measurement(best, other, meas, noise, n_elements)
        steps.append(Step(base, tuple(fits), best.effect, ties, sep))
        named.append(best.effect)
        positions = used[best.effect]
        base = best
    return DiscrepancyResult(nominal, tuple(steps), base, tuple(named), noise, untestable)


def simulate_measurement(truth: Beam, n_modes: int = 4, noise: Noise | None = None, *, seed: int = 0,
                         n_elements: int = 80, shapes: bool = False, damping: bool = True,
                         frf_lines: int = 0, frf_band_hz=None) -> Measurement:
    """Noisy "measured" data of a truth beam (for tests and benchmarks of :func:`analyse`).

    Modes come from the truth's own model (its elements and effects) on an
    ``n_elements`` mesh, usually finer than the fitted one. Frequencies get
    relative Gaussian noise ``noise.frequency``, damping ratios relative noise
    ``noise.damping``, shapes complex noise ``noise.shape`` times the largest
    entry. With ``frf_lines > 0`` the receptance between the measured points
    (reference: the first) is computed by direct inversion of the truth's full
    ``(M, C, K)`` and gets log-normal magnitude noise of ``noise.frf_db``.
    """
    from physics.frf import receptance

    noise = noise or Noise(0.002, 0.05, 0.01, 0.5)
    rng = np.random.default_rng(seed)
    xs = truth.measured_x_m
    probe = Measurement(np.ones(n_modes), shapes=np.zeros((len(xs), n_modes)), shape_x_m=xs)
    pred = predict(truth, probe, n_elements, n_modes)
    sf = np.broadcast_to(np.asarray(noise.frequency, dtype=float), (n_modes,))
    f = pred.frequencies_hz * (1 + sf * rng.standard_normal(n_modes))
    z = None
    if damping:
        if not np.all(pred.damping_ratios > 0):
            raise BeamDamageError("the truth beam needs damping (effects.proportional_damping) to simulate "
                                  "damping ratios")
        z = pred.damping_ratios * (1 + noise.damping * rng.standard_normal(n_modes))
    sh = None
    if shapes:
        sh = pred.shapes / np.max(np.abs(pred.shapes), axis=0)
        sh = sh + noise.shape * (rng.standard_normal(sh.shape) + 1j * rng.standard_normal(sh.shape)) / np.sqrt(2)
    kw = {}
    if frf_lines:
        model = truth.fe_model(n_elements)
        lo, hi = frf_band_hz or (0.5 * pred.frequencies_hz[0], 1.15 * pred.frequencies_hz[-1])
        fl = np.linspace(lo, hi, frf_lines)
        t = fx.interpolation_matrix(model, xs)
        # receptance at all DOFs for a unit force at the first measured point, then interpolated
        h_full = receptance(model.M, model.C, model.K, 2 * np.pi * fl)           # (n, n, F)
        h = np.einsum("sa,abf,b->sf", t, h_full, t[0])[:, None, :]
        h = h * 10 ** (noise.frf_db * rng.standard_normal(h.shape) / 20)
        kw = dict(frf=h, frf_frequency_hz=fl, frf_response_x_m=xs, frf_reference_x_m=(xs[0],))
    return Measurement(f, z, sh, xs if shapes else (), **kw)
