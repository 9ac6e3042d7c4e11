"""A beam model's modes at the measured points, paired with the measured ones, and simulated measurements."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics import effects as fx
from physics.beam import Beam
from physics.errors import BeamDamageError, ShapeError
from physics.frf import convert_frf, receptance
from physics.modal import mac
from physics.noise import complex_normal
from physics.discrepancy.measurement import Measurement, Noise
from physics.frf import magnitude_db

__all__ = ["ModeResiduals", "Prediction", "aligned", "bending_modes", "dashpot_damping_per_c", "mode_residuals",
           "pair_modes_by_mac", "predict", "rayleigh_fit", "simulate_measurement"]


@dataclass(frozen=True)
class Prediction:
    """Model modes at the measured points (``n`` lowest modes, ascending)."""

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray          # complex, (n_points, n)
    frf: np.ndarray | None      # like Measurement.frf


def bending_modes(beam: Beam, model, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest bending modes of ``model`` (of ``beam``): ``(w^2 (rad/s)^2, mass-normalised phi)``.

    A free-free beam's two lowest modes, rigid-body ones or (with ``suspension``) the bounce and pitch modes
    on the suspension, are left out (:attr:`physics.supports.Support.rigid_body_modes`): the measured modes are bending
    modes. Fewer than ``n`` when the model has fewer DOFs.
    """
    from scipy.linalg import eigh  # scipy.linalg: 0.2-0.4 s to import, only where modes are solved

    first = beam.support.rigid_body_modes
    last = min(first + n, len(model.dofs)) - 1
    return eigh(model.K, model.M, subset_by_index=[first, last])


def predict(beam: Beam, meas: Measurement, n_elements: int = 40, n_modes: int | None = None,
            *, EI_scale=1.0, mass_scale=1.0, modal_zeta=None) -> Prediction:
    """Modes of ``beam`` (every effect applied) at the measured points.

    Damped modes come from the lowest ``n_modes + 6`` undamped bending modes (:func:`bending_modes`; modal
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
    w2, phi = bending_modes(beam, model, n + 6)   # phi^T M phi = I
    n_proj = w2.size
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
        frf = convert_frf(frf, 2 * np.pi * meas.frf_frequency_hz, "receptance", meas.frf_kind)
    return Prediction(wn[:n] / (2 * np.pi), zeta[:n], shapes, frf)


def dashpot_damping_per_c(beam: Beam, x_m, n_modes: int, n_elements: int) -> np.ndarray:
    """First-order damping ratio a dashpot of 1 N s/m adds to each of the lowest modes, at each position.

    ``phi_r(x)^2 / (2 w_r)`` with mass-normalised ``phi`` of the undamped ``n_elements`` model of ``beam``
    (its bending modes, :func:`bending_modes`; one eigensolution for every position); a dashpot ``c`` adds
    ``c`` times this.

    Parameters
    ----------
    x_m : sequence of float
        Dashpot positions (m), shape (n_x,).

    Returns
    -------
    ndarray, shape (n_x, n_modes)   (m/(N s))
    """
    model = beam.fe_model(n_elements)
    w2, phi = bending_modes(beam, model, n_modes)
    return (fx.interpolation_matrix(model, list(x_m)) @ phi) ** 2 / (2 * np.sqrt(w2))


def _real_shape(v):
    """Rotate a complex shape to be as real as possible; normalise to its largest entry."""
    v = np.asarray(v, dtype=complex)
    theta = 0.5 * np.angle(np.sum(v**2))
    r = v * np.exp(-1j * theta)
    return r / r[np.argmax(np.abs(r))]


def aligned(a, b):
    """``a - c b`` with ``a`` made real (:func:`_real_shape`) and ``c`` the least-squares complex scale."""
    a = _real_shape(a)
    b = np.asarray(b, dtype=complex)
    return a - b * (np.vdot(b, a) / np.vdot(b, b))


def pair_modes_by_mac(meas: Measurement, pred: Prediction) -> np.ndarray:
    """Model mode index paired with each measured mode: the assignment of largest MAC when the measurement has
    shapes, else of smallest log-frequency distance after the median frequency ratio."""
    from scipy.optimize import linear_sum_assignment  # scipy.optimize: 0.4 s to import, only where modes are paired

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


def mode_residuals(meas: Measurement, pred: Prediction, pairs=None) -> ModeResiduals:
    """Per-mode residuals of ``pred`` against ``meas`` (modes paired by :func:`pair_modes_by_mac`)."""
    pairs = pair_modes_by_mac(meas, pred) if pairs is None else pairs
    f = pred.frequencies_hz[pairs]
    macs = None
    if meas.shapes is not None:
        macs = np.array([mac(meas.shapes[:, [j]], pred.shapes[:, [p]])[0, 0] for j, p in enumerate(pairs)])
    band = total = None
    if meas.frf is not None:
        err = magnitude_db(pred.frf) - meas.frf_db
        band = np.array([np.sqrt(np.mean(err[..., meas.frf_band == j] ** 2)) if np.any(meas.frf_band == j) else np.nan
                         for j in range(meas.n_modes)])
        total = float(np.sqrt(np.mean(err**2)))
    return ModeResiduals(meas.frequencies_hz, f, 100 * (f / meas.frequencies_hz - 1), meas.damping_ratios,
                         None if meas.damping_ratios is None else pred.damping_ratios[pairs], macs, band, total)


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
    noise = noise or Noise(0.002, 0.05, 0.01, 0.5)
    rng = np.random.default_rng(seed)
    xs = truth.measured_x_m
    if shapes and len(xs) < 2:
        raise ShapeError(f"simulate_measurement: mode shapes need at least 2 measured positions, the beam has "
                         f"{len(xs)}")
    probe = (Measurement(np.ones(n_modes), shapes=np.zeros((len(xs), n_modes)), shape_x_m=xs) if len(xs) >= 2 else
             Measurement(np.ones(n_modes)))
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
        sh = sh + complex_normal(rng, sh.shape, noise.shape)
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
