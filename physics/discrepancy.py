"""Model discrepancy: where a beam model misses measured data, and which physical effect it lacks.

Workflow (:func:`analyse`)
--------------------------
1. Pair measured and model modes (MAC when shapes exist, else frequency) and
   form residuals: frequency error (%), damping ratio error, MAC, and FRF error
   per band (dB) when FRFs are given (:func:`mode_residuals`).
2. Recalibrate the global parameters first: ``EI`` always, the mass per length
   when FRFs fix the absolute scale. From frequencies alone ``EI/m`` scales
   every frequency by one factor, so only frequency *ratios* (and shapes, FRF
   shapes) carry information about a missing effect; an effect is named only
   when it explains what this recalibration cannot.
3. Damping is modal: every measured mode keeps its own measured damping ratio
   (the null model, one free ratio per mode, as in most real tests), so the
   ratios themselves never score a candidate. A local dashpot keeps only its
   non-proportional coupling (the off-diagonal modal damping), visible in the
   imaginary parts of complex mode shapes and in FRFs; without those it is
   not tested.
4. For each candidate of :data:`physics.effects.CANDIDATES`, a bounded,
   multi-start least-squares fit of its parameters together with the global
   ones on every residual present (frequencies, real and imaginary parts of
   shapes, FRF magnitudes), each whitened by its noise level (:class:`Noise`).
   FRFs enter as their mean level per mode band (:func:`_band_mean_db`; it
   fixes the mass), their modes as the identified modal data.
   Score: ``sum_b chi^2_b / c_b + k ln n``, the BIC with the noise given
   (Schwarz 1978; ``chi^2`` is ``-2 ln L`` up to a constant for Gaussian
   errors of known variance), with ``c_b`` the best fit's ``chi^2_b / dof_b``
   where a chi^2 test rejects block ``b``'s noise as too small
   (quasi-likelihood variance inflation, Burnham & Anderson 2002), else 1;
   and a leave-one-mode-out (LOMO) prediction error of each mode's data.
5. The best candidate is named when its score is at least
   :data:`BIC_SIGNIFICANT` below the current model's ("strong evidence",
   Kass & Raftery 1995) and its LOMO error is not worse; else ``"none"``.
   Other significant candidates whose fitted predictions of the measured
   quantities differ from the winner's by less than :data:`DISTINCT` (squared,
   in noise units) are reported as indistinguishable, with the measurement that
   separates them most (a higher mode, mode shapes, or the driving-point
   antiresonances, predicted by the two fitted models). The data block whose
   chi^2 fell most is the effect's evidence.
6. The named effect joins the model and the search repeats (at most
   ``max_effects`` effects); it stops when nothing significant remains.
7. The final model's chi^2 is tested against its degrees of freedom
   (:func:`noise_check`): is the residual consistent with the assumed noise?

Parameter uncertainties come from the Jacobian of the whitened residuals at
the optimum, ``cov = s^2 (J^T J)^-1`` with ``s^2 = max(1, chi^2 / dof)``
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

__all__ = ["BIC_SIGNIFICANT", "BLOCKS", "DISTINCT", "DiscrepancyResult", "Fit", "Measurement", "ModeResiduals",
           "Noise", "NoiseCheck", "P_NOISE", "Prediction", "Step", "analyse", "frf_scatter_db", "g_core_pa",
           "has_complex_shapes", "mode_residuals", "noise_check", "pair_modes", "predict", "rayleigh_fit",
           "simulate_measurement"]

try:  # installed with scikit-learn; only a speed-up
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover
    from contextlib import nullcontext

    def threadpool_limits(_):
        return nullcontext()

#: BIC drop that counts as significant ("strong evidence", Kass & Raftery 1995).
BIC_SIGNIFICANT = 6.0
#: Significant candidates whose fitted predictions differ from the winner's by less than this (sum of squared
#: differences in noise units, each block divided by the round's c_b) are indistinguishable: were one model true, the
#: other's expected chi^2 would exceed its own by about this much, so the data could not give strong evidence.
DISTINCT = BIC_SIGNIFICANT


@dataclass(frozen=True)
class Noise:
    """Measurement noise (standard deviations) that whitens the residuals.

    Attributes
    ----------
    frequency : float or ndarray, shape (n_modes,)
        Relative std of the natural frequencies (0.003 = 0.3 %).
    damping : float
        Relative std of simulated damping ratios (:func:`simulate_measurement`;
        the analysis takes measured ratios as modal damping, step 3).
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
            *, EI_scale=1.0, mass_scale=1.0, modal_zeta=None) -> Prediction:
    """Modes of ``beam`` (every effect applied) at the measured points.

    Damped modes come from the lowest ``n_modes + 6`` undamped modes (modal
    projection, exact for proportional damping, accurate for light local damping).

    Parameters
    ----------
    modal_zeta : callable, optional
        ``modal_zeta(w_rad_s) -> zeta`` (arrays of the projected undamped modes,
        ascending). Modal damping: the diagonal of the modal damping matrix
        becomes ``2 zeta_r w_r``; its off-diagonal part (the non-proportional
        coupling of a local dashpot) is kept.
    """
    n = n_modes or meas.n_modes + 2
    model = beam.fe_model(n_elements, EI_scale=EI_scale, mass_scale=mass_scale)
    n_proj = min(n + 6, len(model.dofs))
    w2, phi = eigh(model.K, model.M, subset_by_index=[0, n_proj - 1])   # phi^T M phi = I
    w = np.sqrt(np.clip(w2, 0.0, None))
    c_r = phi.T @ model.C @ phi
    if modal_zeta is not None:
        c_r = c_r - np.diag(np.diag(c_r)) + np.diag(2 * np.asarray(modal_zeta(w), dtype=float) * w)
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
        The calibrated beam (global parameters and effects written in; with
        damping ratios, Rayleigh damping least-squares fitted to them, because
        a beam file has no per-mode damping).
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
    dof : int
        Degrees of freedom of ``chi2``: ``n_obs - n_params`` less the scale
        of each compared shape (2 per mode for complex shapes, 1 for real).
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
    dof: int = 0
    chi2_blocks: dict = field(default_factory=dict)
    whitened: dict = field(default_factory=dict)

    def block_dof(self, meas: "Measurement") -> dict:
        """Degrees of freedom of each block's chi^2: observations less what the fit takes from them.

        Frequencies lose the model's parameters, shapes one scale per mode
        (real part; the imaginary part a second), the FRF band levels the mass scale.
        """
        n = {k: v.size for k, v in self.whitened.items()}
        n_modes = meas.n_modes
        out = {"frequencies": n["frequencies"] - self.n_params + (1 if "FRF" in n else 0)}
        if "mode shapes" in n:
            out["mode shapes"] = n["mode shapes"] - n_modes
        if "complex shapes" in n:
            out["complex shapes"] = n["complex shapes"] - n_modes
        if "FRF" in n:
            out["FRF"] = n["FRF"] - 1
        return out


#: Data blocks of the residual: what the evidence for an effect can come from.
BLOCKS = ("frequencies", "mode shapes", "complex shapes", "FRF")


def has_complex_shapes(meas: Measurement) -> bool:
    """Measured shapes with imaginary parts (non-proportional damping is visible in them)."""
    return meas.shapes is not None and bool(np.any(np.abs(meas.shapes.imag) > 0))


def rayleigh_fit(w_rad_s, zeta) -> tuple[float, float]:
    """Least-squares Rayleigh coefficients ``(alpha 1/s, beta s) >= 0`` of ``zeta = alpha/(2w) + beta w/2``.

    Relative residuals (each ratio weighted by ``1/zeta``); used to extend measured
    ratios to unmeasured modes and for the beam file, never to score an effect.
    """
    from scipy.optimize import nnls

    w, z = np.asarray(w_rad_s, dtype=float), np.asarray(zeta, dtype=float)
    a = np.column_stack([1 / (2 * w), w / 2]) / z[:, None]
    coef, _ = nnls(a, np.ones_like(z))
    return float(coef[0]), float(coef[1])


def _band_mean_db(meas: Measurement, err_db: np.ndarray) -> np.ndarray:
    """Mean dB error over each measured mode's band (between the geometric means of neighbouring frequencies).

    Returns ``(n_resp, n_ref, n_modes)``; a band without lines counts 0. The FRF's levels
    (its absolute scale, hence the mass) enter the fit as these band means, one
    observation per band: the lines of a band share the model's and the
    identification's errors, and the modes' frequencies, damping and shapes come from
    the identified modal data.
    """
    fm = meas.frequencies_hz
    edges = np.concatenate([[0.0], np.sqrt(fm[:-1] * fm[1:]), [np.inf]])
    band = np.searchsorted(edges, meas.frf_frequency_hz, side="right") - 1       # (n_lines,)
    onehot = (band[:, None] == np.arange(fm.size)[None, :]).astype(float)         # (n_lines, n_modes)
    count = np.maximum(onehot.sum(axis=0), 1.0)
    return (err_db @ onehot) / count


class _Problem:
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
            diff = [_aligned(meas.shapes[:, j], pred.shapes[:, pj]) / noise.shape
                    for j, pj in enumerate(p) if self.mask[j]]
            out["mode shapes"] = np.concatenate([d.real for d in diff])
            if has_complex_shapes(meas):
                out["complex shapes"] = np.concatenate([d.imag for d in diff])
        if meas.frf is not None:
            out["FRF"] = (_band_mean_db(meas, _db(pred.frf) - _db(meas.frf)) / noise.frf_db)[..., self.mask].ravel()
        return out


def _fit(beam, meas, noise, effect, fixed_effects, n_elements, pairs, *, fit_mass, n_starts=4, seed=0,
         position=None, with_lomo=True, named=(), start=None) -> tuple[Fit, _Problem, np.ndarray]:
    """Bounded multi-start least squares of the globals, the ``named`` effects and ``effect``.

    ``effect = "none"`` fits the globals (and the named effects) only. Named
    effects start from their values in ``start`` (``{effect: {param: value}}``);
    the new effect starts weak, then at random points within its bounds.
    ``position`` fixes ``x_m`` of position-bearing effects (``{effect: x_m}``).
    """
    position_free = meas.shapes is not None or meas.frf is not None
    position = dict(position or {})
    start = start or {}
    params = [_Param("EI_scale", 0.3, 3.0)]
    if fit_mass:
        params.append(_Param("mass_scale", 0.3, 3.0))
    for e in named:
        params += _effect_params(e, beam, meas, position_free and e not in position)
    if effect != "none":
        params += _effect_params(effect, beam, meas, position_free and effect not in position)
    prob = _Problem(beam, meas, noise, fixed_effects, params, position, n_elements, pairs, fit_mass)
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
        res = least_squares(prob.residual, np.clip(u0, lo, hi), bounds=(lo, hi), x_scale=1.0,
                            diff_step=1e-6, max_nfev=400)
        if best is None or res.cost < best.cost:
            best = res
        if effect == "none" and not named:
            break
    fit = _as_fit(prob, best, effect, meas)
    lomo = _lomo(prob, best.x) if with_lomo else float("nan")
    return replace(fit, lomo=lomo), prob, best.x


def _lomo(prob: _Problem, x0) -> float:
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
        res = least_squares(prob.residual, x0, bounds=(lo, hi), diff_step=1e-6, max_nfev=200)
        prob.mask = np.arange(meas.n_modes) == j
        held = np.concatenate(list(prob.blocks(prob.predict(prob.beam_at(res.x)[0])).values()))
        z2.append(np.mean(held**2))
    prob.mask = np.ones(meas.n_modes, dtype=bool)
    return float(np.sqrt(np.mean(z2)))


def g_core_pa(kGA_N: float, beam: Beam) -> float:
    """Equivalent core shear modulus ``G_c = kGA c / (b d^2)`` (module docstring; thin-face limit ``kGA/(b h)``)."""
    tf = beam.face_thickness_m or 0.0
    c = beam.thickness_m - 2 * tf
    d = c + tf
    return kGA_N * c / (beam.width_m * d**2)


def _with_rayleigh(nb: Beam, meas: Measurement) -> Beam:
    """``nb`` with Rayleigh damping fitted to the measured ratios less a dashpot's share (beam file only)."""
    w = 2 * np.pi * meas.frequencies_hz
    z = np.array(meas.damping_ratios, dtype=float)
    if "local_damping" in nb.effects:
        # a dashpot c at x adds c phi_r(x)^2 / (2 w_r) to mode r (mass-normalised phi)
        model = nb.fe_model(24)
        w2, phi = eigh(model.K, model.M, subset_by_index=[0, meas.n_modes - 1])
        d = nb.effects["local_damping"]
        t = fx.interpolation_matrix(model, [d.get("x_m", nb.length_m)])[0]
        z = np.maximum(z - d["c_Ns_m"] * (t @ phi) ** 2 / (2 * np.sqrt(w2)), 0.05 * z)
    a, b = rayleigh_fit(w, z)
    return nb.with_effects({**nb.effects_dict(), "proportional_damping": {"alpha_1_s": a, "beta_s": b}})


def _shape_dof(meas: Measurement, mask) -> int:
    if meas.shapes is None:
        return 0
    return (2 if has_complex_shapes(meas) else 1) * int(np.sum(mask))


def _as_fit(prob: _Problem, res: OptimizeResult, effect: str, meas: Measurement) -> Fit:
    nb, ei_s, ms = prob.beam_at(res.x)
    r = res.fun
    chi2 = float(r @ r)
    n_obs, n_par = r.size, res.x.size
    dof = n_obs - n_par - _shape_dof(meas, prob.mask)
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
        params["shear_deformation.G_core_pa"] = g_core_pa(params["shear_deformation.kGA_N"], nb)
        std["shear_deformation.G_core_pa"] = g_core_pa(std["shear_deformation.kGA_N"], nb)
    pred = prob.predict(nb)
    white = prob.blocks(pred)
    blocks = {b: float(v @ v) for b, v in white.items()}
    if meas.damping_ratios is not None:
        nb = _with_rayleigh(nb, meas)
    return Fit(effect, tuple(nb.effects), nb, params, std, chi2, n_obs, n_par, chi2 + n_par * math.log(n_obs),
               float("nan"), mode_residuals(meas, pred, prob.pairs), dof, blocks, white)


# ---------------------------------------------------------------------------
# Selection
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Step:
    """One round of the search: the current model, every candidate fitted on top, the decision.

    Attributes
    ----------
    base : Fit
    candidates : tuple of Fit   (ascending score)
    named : str
        The effect named in this round, ``"none"`` when nothing is significant.
    indistinguishable_from : tuple of str
        Significant candidates whose fitted predictions of the measured
        quantities lie within the noise of the named one's (:data:`DISTINCT`).
    separating_measurement : str
        The measurement predicted to separate the named effect from the first of them.
    c_hat : dict
        Variance inflation of each data block in the round (:func:`_round`):
        1 when the best fit's residual in the block is consistent with its
        noise, else its ``chi^2 / dof``.
    """

    base: Fit
    candidates: tuple
    named: str
    indistinguishable_from: tuple
    separating_measurement: str
    c_hat: dict = field(default_factory=dict)

    def score(self, fit: Fit) -> float:
        """``sum_b chi^2_b / c_b + k ln n`` (BIC with each block's noise inflated by ``c_b``; lower is better)."""
        chi2 = sum(v / self.c_hat.get(k, 1.0) for k, v in fit.chi2_blocks.items())
        return chi2 + fit.n_params * math.log(fit.n_obs)

    def distance(self, a: Fit, b: Fit) -> float:
        """Squared difference of two fits' whitened residuals (their predictions, in noise units), like chi^2."""
        return sum(float(np.sum((a.whitened[k] - b.whitened[k]) ** 2)) / self.c_hat.get(k, 1.0) for k in a.whitened)


@dataclass(frozen=True)
class NoiseCheck:
    """Is the residual of a fit consistent with the noise that whitened it?

    Attributes
    ----------
    chi2 : float
    dof : float   (FRF lines counted at their weight)
    chi2_per_dof : float
    p_value : float
        ``P(chi^2_dof >= chi2)``.
    consistent : bool
        ``P_LOW <= p_value <= 1 - P_LOW`` (two-sided, :data:`P_NOISE`).
    verdict : str
        ``"consistent"``, ``"residual larger than the noise"`` or ``"residual smaller than the noise"``.
    blocks : dict
        The same test per data block: ``{block: {"chi2", "dof", "chi2_per_dof", "p_value", "verdict"}}``.
    """

    chi2: float
    dof: int
    chi2_per_dof: float
    p_value: float
    consistent: bool
    verdict: str
    blocks: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"chi2": self.chi2, "dof": self.dof, "chi2_per_dof": self.chi2_per_dof, "p_value": self.p_value,
                "noise_consistent": self.consistent, "verdict": self.verdict, "blocks": self.blocks}


#: Two-sided level of the chi^2 test of the noise.
P_NOISE = 0.01


def frf_scatter_db(meas: Measurement) -> float:
    """Random noise (std, dB) of the measured FRF magnitudes from their line-to-line scatter.

    For independent noise of std ``s`` on each line the second difference along
    frequency has std ``sqrt(6) s``; the smooth FRF adds little between dense
    lines, and the median absolute deviation ignores the peaks. Floored at 0.01 dB.
    """
    x = _db(meas.frf).reshape(-1, meas.frf_frequency_hz.size)
    d2 = x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]
    mad = np.median(np.abs(d2 - np.median(d2, axis=1, keepdims=True)))
    return max(float(1.4826 * mad / math.sqrt(6)), 0.01)


def _chi2_test(chi2: float, dof: int) -> tuple[float, str]:
    from scipy.stats import chi2 as chi2_dist

    if dof <= 0:
        return float("nan"), "no degrees of freedom left"
    p = float(chi2_dist.sf(chi2, dof))
    return p, ("residual larger than the noise" if p < P_NOISE / 2 else
               "residual smaller than the noise" if p > 1 - P_NOISE / 2 else "consistent")


def noise_check(fit: Fit, meas: Measurement) -> NoiseCheck:
    """chi^2 test of ``fit``'s whitened residual against its degrees of freedom, overall and per block."""
    p, verdict = _chi2_test(fit.chi2, fit.dof)
    blocks = {}
    for k, dof in fit.block_dof(meas).items():
        pb, vb = _chi2_test(fit.chi2_blocks[k], dof)
        blocks[k] = {"chi2": fit.chi2_blocks[k], "dof": dof,
                     "chi2_per_dof": fit.chi2_blocks[k] / dof if dof > 0 else float("nan"), "p_value": pb,
                     "verdict": vb}
    consistent = verdict in ("consistent", "no degrees of freedom left")
    return NoiseCheck(fit.chi2, fit.dof, fit.chi2 / fit.dof if fit.dof > 0 else float("nan"), p, consistent,
                      verdict, blocks)


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
            if refined.chi2 <= f.chi2:
                return refined, positions
            # the local search from the best measured point went astray: keep that point
        # the discrete position counts as a parameter
        return replace(f, n_params=f.n_params + 1, bic=f.bic + math.log(f.n_obs), dof=f.dof - 1,
                       lomo=_lomo(prob, x_opt)), pos
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
            estimate_noise: bool = False, progress=None) -> DiscrepancyResult:
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
    estimate_noise : bool
        For a ``noise`` that is only assumed: scale it by ``s = sqrt(chi^2/dof)``
        of round 1's best-fitting model (the lowest chi^2 among the globals-only
        model and every one-effect candidate) when ``s < 1`` and that model has
        at least :data:`NOISE_DOF_MIN` degrees of freedom (Mallows' Cp with
        ``sigma^2`` from the richest model fitted), one factor for every block,
        held for every round. A block whose residual exceeds the scaled noise
        is inflated as usual (:func:`_round`).
    progress : callable, optional
        Called with a short text before each candidate fit.

    Returns
    -------
    DiscrepancyResult
    """
    with threadpool_limits(1):   # small dense eigenproblems: one BLAS thread is fastest
        return _analyse(beam, meas, noise or Noise(), candidates, max_effects, n_elements, n_starts, seed,
                        estimate_noise, progress)


#: Fewest degrees of freedom of the fit whose chi^2/dof estimates the noise scale (``estimate_noise``): with
#: 10 the estimate of the variance has a relative std of ``sqrt(2/10) = 0.45``.
NOISE_DOF_MIN = 10


def _round(base: Fit, fits, meas: Measurement, scale2: float = 1.0) -> "Step":
    """A round's variance inflation per data block, from its best-fitting model.

    ``c_b`` is that model's ``chi^2_b / dof_b`` where the chi^2 test rejects the
    block's residual as larger than its noise times ``sqrt(scale2)``
    (quasi-likelihood, Burnham & Anderson 2002), else ``scale2``: a block the
    models cannot fit to its noise weighs by its actual scatter.
    """
    best = min([base, *fits], key=lambda f: f.chi2)
    c_hat = {}
    for k, dof in best.block_dof(meas).items():
        _, verdict = _chi2_test(best.chi2_blocks[k] / scale2, dof)
        c_hat[k] = best.chi2_blocks[k] / dof if verdict == "residual larger than the noise" else scale2
    return Step(base, (), "none", (), "", c_hat)


def _noise_scale(base: Fit, fits) -> tuple[float, int, str]:
    """``(s^2, dof, source)``: the variance factor from round 1's best-fitting model (:func:`analyse`)."""
    best = min([base, *fits], key=lambda f: f.chi2)
    if best.dof < NOISE_DOF_MIN:
        return 1.0, 0, (f"not estimated: the best-fitting model ({best.effect}) has {best.dof} degrees of freedom, "
                        f"fewer than {NOISE_DOF_MIN}")
    s2 = best.chi2 / best.dof
    src = f"chi2/dof {s2:.3g} of round 1's best-fitting model ({best.effect}) on {best.dof} dof"
    return (min(s2, 1.0), best.dof, src if s2 < 1 else src + "; not below 1, the noise given is kept")


def _untestable(names: list, meas: Measurement) -> dict:
    if "local_damping" in names and meas.frf is None and not has_complex_shapes(meas):
        names.remove("local_damping")
        return {"local_damping": "modal damping (one ratio per mode) fits any damping ratios; a dashpot "
                                 "needs complex mode shapes or FRFs"}
    return {}


def _analyse(beam, meas, noise, candidates, max_effects, n_elements, n_starts, seed, estimate_noise, progress):
    unknown = [c for c in candidates if c not in fx.CANDIDATES]
    if unknown:
        raise BeamDamageError(f"unknown candidate effect(s) {unknown}; expected some of {list(fx.CANDIDATES)}")
    fit_mass = meas.frf is not None
    names = list(candidates)
    untestable = _untestable(names, meas)
    nominal_pred = predict(beam, meas, n_elements)
    pairs = pair_modes(meas, nominal_pred)
    fixed = {k: dict(v) for k, v in beam.effects.items() if k != "proportional_damping"}
    say = progress or (lambda s: None)
    say("globals only")
    base, _, _ = _fit(beam, meas, noise, "none", fixed, n_elements, pairs, fit_mass=fit_mass, n_starts=n_starts,
                      seed=seed)
    ctx = dict(beam=beam, meas=meas, noise=noise, fixed=fixed, n_elements=n_elements, pairs=pairs,
               fit_mass=fit_mass, n_starts=n_starts, seed=seed, say=say)
    steps, named, positions, evidence, drops = [], [], {}, {}, {}
    scale = (1.0, 0, "not estimated: the noise was given")
    while len(named) < max_effects:
        todo = [c for c in names if c not in named and c not in fixed]
        if not todo:
            break
        fits, used = _fit_candidates(ctx, todo, named, base, positions)
        if not steps and estimate_noise:
            scale = _noise_scale(base, fits)
        step = _decide(ctx, base, fits, scale[0])
        steps.append(step)
        if step.named == "none":
            break
        best = step.candidates[0]
        drops[best.effect] = {b: (base.chi2_blocks[b] - best.chi2_blocks[b]) / step.c_hat.get(b, 1.0)
                              for b in best.chi2_blocks}
        evidence[best.effect] = max(drops[best.effect], key=drops[best.effect].get)
        named.append(best.effect)
        positions = used[best.effect]
        base = best
    c_last = steps[-1].c_hat if steps else {}
    rest = [c for c in names if c not in named and c not in fixed]
    say("detection limits")
    limits = detection_limits(beam, meas, noise, base, c_last, rest, fixed=fixed, named=tuple(named),
                              positions=positions, n_elements=n_elements, pairs=pairs)
    return DiscrepancyResult(mode_residuals(meas, nominal_pred, pairs), tuple(steps), base, tuple(named), noise,
                             untestable, evidence, drops, noise_check(base, meas), limits, math.sqrt(scale[0]),
                             scale[1], scale[2])


def _fit_candidates(ctx: dict, todo, named, base: Fit, positions) -> tuple[list, dict]:
    """Every candidate of ``todo`` fitted on top of the ``named`` effects; ``(fits, positions used by each)``."""
    fits, used = [], {}
    start = base.beam.effects_dict()
    for c in todo:
        ctx["say"](c if not named else f"{' + '.join(named)} + {c}")
        f, pos = _candidate_fit(ctx["beam"], ctx["meas"], ctx["noise"], c, ctx["fixed"], ctx["n_elements"],
                                ctx["pairs"], ctx["fit_mass"], ctx["n_starts"], ctx["seed"], tuple(named), start,
                                positions)
        fits.append(f)
        used[c] = pos
    return fits, used


def _decide(ctx: dict, base: Fit, fits: list, scale2: float) -> "Step":
    """One round's decision: the best candidate named when significant, with its indistinguishable rivals."""
    probe = _round(base, fits, ctx["meas"], scale2)
    fits = sorted(fits, key=probe.score)
    best = fits[0]
    # an effect needs data left over to be tested: more observations than parameters and a held-out check
    testable = best.n_obs > best.n_params and np.isfinite(best.lomo)
    lomo_ok = testable and (not np.isfinite(base.lomo) or best.lomo <= base.lomo)
    significant = probe.score(best) <= probe.score(base) - BIC_SIGNIFICANT and lomo_ok
    if not significant:
        return replace(probe, candidates=tuple(fits))
    # indistinguishable: also significant, and predicting the measured quantities within the noise of the
    # winner's predictions (the data could not give strong evidence for one over the other)
    ties = tuple(f.effect for f in fits[1:]
                 if probe.score(f) <= probe.score(base) - BIC_SIGNIFICANT and probe.distance(f, best) < DISTINCT)
    sep = ""
    if ties:
        other = next(f for f in fits if f.effect == ties[0])
        sep = _separating_measurement(best, other, ctx["meas"], ctx["noise"], ctx["n_elements"])
    return replace(probe, candidates=tuple(fits), named=best.effect, indistinguishable_from=ties,
                   separating_measurement=sep)


# ---------------------------------------------------------------------------
# Detection limits
# ---------------------------------------------------------------------------

#: effect -> (dimensionless size reported, its parameter, True when a *smaller* value is the stronger effect).
SIZES = {
    "shear_deformation": ("kGA_L2_over_EI", "kGA_N", True),
    "rotary_inertia": ("rho_I_over_m_h2_12", "rho_I_kg_m", False),
    "root_flexibility": ("k_L_over_EI", "k_theta_Nm_rad", True),
    "added_mass": ("mass_fraction_of_m_L", "mass_kg", False),
    "local_damping": ("added_damping_ratio", "c_Ns_m", False),
}


@dataclass(frozen=True)
class DetectionLimit:
    """How large an effect that was not named would have to be to be named with these data and this noise.

    The limit is the size at which the effect's noise-free signature, after the
    refit of every other parameter of the final model (globals, named effects)
    has absorbed what it can (linearised), reaches the naming threshold
    ``BIC_SIGNIFICANT + k ln n`` in chi^2 (each block divided by the last
    round's ``c_b``): at that size the expected chi^2 drop equals the drop the
    score requires, so an effect there is named about half the time and a
    clearly larger one nearly always. The leave-one-mode-out check is not part of it.

    Attributes
    ----------
    effect : str
    quantity : str
        The dimensionless size (:data:`SIZES`): ``k_L_over_EI``, ``kGA_L2_over_EI``,
        ``mass_fraction_of_m_L``, ``rho_I_over_m_h2_12`` or ``added_damping_ratio``
        (a dashpot's first-order added damping ratio ``c phi_r(x)^2 / (2 w_r)``,
        largest over the measured modes, mass-normalised ``phi``).
    named_below : bool
        True when the effect is named for a size *below* the limit (a root
        spring or shear rigidity: softer is stronger), else above.
    limit : float or None
        At the most sensitive measured position for position-bearing effects;
        None when not detectable anywhere within the candidate's bounds.
    limit_by_x_m : dict
        Position (m) -> limit (None: not detectable there), for added mass and local damping.
    threshold_chi2 : float
        The chi^2 drop the score requires.
    """

    effect: str
    quantity: str
    named_below: bool
    limit: float | None
    limit_by_x_m: dict = field(default_factory=dict)
    threshold_chi2: float = float("nan")

    def below_limit(self, size: float, x_m: float | None = None) -> bool:
        """True when an effect of ``size`` (at ``x_m``, nearest measured position) is too weak to be named."""
        lim = self.limit
        if x_m is not None and self.limit_by_x_m:
            lim = self.limit_by_x_m[min(self.limit_by_x_m, key=lambda x: abs(x - x_m))]
        if lim is None:
            return True
        return size > lim if self.named_below else size < lim

    def text(self) -> str:
        side = "<=" if self.named_below else ">="
        if self.limit is None:
            return f"{self.effect}: not detectable within its bounds with these data and this noise"
        where = ""
        if self.limit_by_x_m:
            best = min((x for x, v in self.limit_by_x_m.items() if v is not None),
                       key=lambda x: self.limit_by_x_m[x] * (-1 if self.named_below else 1))
            others = ", ".join(f"{v:.3g} at {x:.3g} m" if v is not None else f"none at {x:.3g} m"
                               for x, v in self.limit_by_x_m.items() if x != best)
            where = f" at x = {best:.3g} m" + (f" ({others})" if others else "")
        return f"{self.effect}: named only for {self.quantity} {side} {self.limit:.3g}{where}"

    def to_dict(self) -> dict:
        return {"quantity": self.quantity, "named_when": "below" if self.named_below else "above",
                "limit": self.limit, "limit_by_x_m": {f"{x:.6g}": v for x, v in self.limit_by_x_m.items()},
                "threshold_chi2": self.threshold_chi2, "text": self.text()}


def _u_of(params: list, fit: Fit, beam: Beam) -> np.ndarray:
    """Optimisation vector of ``params`` at the values of ``fit``."""
    u = []
    for p in params:
        v = (fit.parameters["EI_Nm2"] / beam.EI_Nm2 if p.key == "EI_scale" else
             fit.parameters["mass_per_length_kg_m"] / beam.mass_per_length_kg_m if p.key == "mass_scale" else
             fit.parameters[p.key])
        u.append(math.log(v) if p.log else v)
    return np.asarray(u, dtype=float)


def _size_factor(effect: str, nb: Beam, meas: Measurement, x_m: float | None, n_elements: int) -> float:
    """Dimensionless size per unit of the effect's parameter on the calibrated beam ``nb`` (:data:`SIZES`)."""
    L, EI, m = nb.length_m, nb.EI_Nm2, nb.mass_per_length_kg_m
    if effect == "shear_deformation":
        return L**2 / EI
    if effect == "rotary_inertia":
        return 12 / (m * nb.thickness_m**2)
    if effect == "root_flexibility":
        return L / EI
    if effect == "added_mass":
        return 1 / (m * L)
    model = nb.fe_model(n_elements)
    w2, phi = eigh(model.K, model.M, subset_by_index=[0, meas.n_modes - 1])
    t = fx.interpolation_matrix(model, [x_m])[0]
    return float(np.max((t @ phi) ** 2 / (2 * np.sqrt(w2))))


def detection_limits(beam: Beam, meas: Measurement, noise: Noise, final: Fit, c_hat: dict, effects,
                     *, fixed=None, named=(), positions=None, n_elements: int = 40, pairs=None) -> dict:
    """:class:`DetectionLimit` of each of ``effects`` on top of the ``final`` model.

    Parameters
    ----------
    beam : Beam
        The nominal beam the fits started from.
    final : Fit
        The model with the named effects (its parameters are the linearisation point).
    c_hat : dict
        Variance inflation per data block of the last round (:class:`Step`).
    effects : sequence of str
        Candidates not named.
    fixed, named, positions, n_elements, pairs
        As in the search: the beam's own effects, the named effects, their
        discrete positions, the fitted mesh and the mode pairing.
    """
    fixed = {k: dict(v) for k, v in (fixed or {}).items()}
    positions = dict(positions or {})
    pairs = pair_modes(meas, predict(beam, meas, n_elements)) if pairs is None else pairs
    position_free = meas.shapes is not None or meas.frf is not None
    fit_mass = meas.frf is not None
    nuis = [_Param("EI_scale", 0.3, 3.0)] + ([_Param("mass_scale", 0.3, 3.0)] if fit_mass else [])
    for e in named:
        nuis += _effect_params(e, beam, meas, position_free and e not in positions)
    null = _Problem(beam, meas, noise, fixed, nuis, positions, n_elements, pairs, fit_mass)
    u_n = _u_of(nuis, final, beam)
    blocks0 = null.blocks(null.predict(null.beam_at(u_n)[0]))
    weight = np.concatenate([np.full(v.size, 1 / math.sqrt(c_hat.get(k, 1.0))) for k, v in blocks0.items()])
    r0 = np.concatenate(list(blocks0.values()))
    jac = np.empty((r0.size, u_n.size))
    for i in range(u_n.size):
        du = np.zeros_like(u_n)
        du[i] = 1e-6
        jac[:, i] = (null.residual(u_n + du) - null.residual(u_n - du)) / 2e-6
    q, sv, _ = np.linalg.svd(jac * weight[:, None], full_matrices=False)
    q = q[:, sv > 1e-9 * sv[0]] if sv.size and sv[0] > 0 else q[:, :0]
    out = {}
    for effect in effects:
        p = _effect_params(effect, beam, meas, False)[0]
        xs = list(beam.measured_x_m) if effect in ("added_mass", "local_damping") else [None]
        k_new = 1 + (xs[0] is not None)    # a position, continuous or among the measured points, counts as one
        thr = BIC_SIGNIFICANT + k_new * math.log(final.n_obs)
        by_x = {}
        for x in xs:
            pos = positions if x is None else {**positions, effect: x}
            prob = _Problem(beam, meas, noise, fixed, nuis + [p], pos, n_elements, pairs, fit_mass)

            def lam(u_e):
                d = (prob.residual(np.append(u_n, u_e)) - r0) * weight
                return float(d @ d - np.sum((q.T @ d) ** 2))

            by_x[x] = _crossing(lam, p, thr, weak_at_upper=SIZES[effect][2])
        quantity, _, named_below = SIZES[effect]
        nb = final.beam
        lims = {x: (None if v is None else v * _size_factor(effect, nb, meas, x, n_elements)) for x, v in by_x.items()}
        found = [v for v in lims.values() if v is not None]
        best = (min(found) if not named_below else max(found)) if found else None
        out[effect] = DetectionLimit(effect, quantity, named_below, best,
                                     {x: v for x, v in lims.items()} if xs[0] is not None else {}, thr)
    return out


def _crossing(lam, p: _Param, thr: float, weak_at_upper: bool, n_scan: int = 13, n_bisect: int = 14):
    """Weakest parameter value (physical units) in ``p``'s bounds where ``lam`` reaches ``thr``; None if none."""
    a, b = p.bounds()
    grid = np.linspace(b, a, n_scan) if weak_at_upper else np.linspace(a, b, n_scan)
    prev = None
    for u in grid:
        if lam(u) >= thr:
            if prev is None:
                return p.to_phys(u)
            lo, hi = prev, u        # lam(lo) < thr <= lam(hi)
            for _ in range(n_bisect):
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if lam(mid) >= thr else (mid, hi)
            return p.to_phys(hi)
        prev = u
    return None


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
