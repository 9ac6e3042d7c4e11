"""The modal noise of a test, calibrated against the identification ``classify`` runs on that test's files.

A dataset's measured modal data are the truth modes plus random errors whose standard deviation per mode is
``sqrt((c level)^2 + (g floor)^2 + e^2)`` of the sample's FRF noise level and floor
(:func:`datagen.pipeline.measure_modes`, ``measurement.modal_noise = "calibrated"``). The coefficients shipped in
``datagen/configs/modal_noise.json`` describe LSCF/LSFD on the thesis's test (4 sensors, modes 1-4). Another test
identifies differently: more sensors, modes that a sensor barely sees, higher modes, another band and model order.
:func:`calibrate_test` measures it on the test itself: specimens of the config are simulated, their FRFs
synthesised as a dataset synthesises them at :data:`LEVELS` x :data:`FLOORS`, identified exactly as ``classify``
identifies a file of that model (:func:`learn.pairs.measured.identify_band`: as ``identify --band`` over the test's
band, modes paired by frequency), and ``c``, ``g``, ``e`` of every mode fitted to the
robust standard deviations of the errors (:func:`calibrate_std`). Deterministic for a config and seed.
"""

from __future__ import annotations

import numpy as np

from datagen.config import merge
from datagen.batch_inputs import draw_batch
from datagen.pipeline import per_mode, simulate_batch
from datagen.setup import get_setup
from datagen.synth import measured_frf
from learn.pairs.measured import identify_band, pair_modes_by_frequency
from physics.errors import BeamDamageError
from physics.io import MeasuredFRF
from physics.modal import modal_parameters

__all__ = ["FLOORS", "LEVELS", "QUANTITIES", "calibrate_std", "calibrate_test", "fit_coefficients",
           "identification_errors", "mode_errors", "on_nominal_modes", "robust_std"]

#: FRF noise levels (relative to |H|) and floors (relative to each FRF's peak) of the calibration: the range the
#: training config draws (floors 1e-4 to 1e-3; without a floor LSFD weights the lines otherwise).
LEVELS = (0.003, 0.01, 0.03)
FLOORS = (0.0001, 0.0003, 0.001)
QUANTITIES = ("frequency", "damping", "shape")


def robust_std(e) -> float:
    """1.4826 MAD of real errors, ``sqrt(median |e|^2 / ln 2)`` of circular complex ones; NaN without data."""
    e = np.asarray(e)
    e = e[np.isfinite(e)]
    if e.size == 0:
        return float("nan")
    if np.iscomplexobj(e):
        return float(np.sqrt(np.median(np.abs(e) ** 2) / np.log(2)))
    return float(1.4826 * np.median(np.abs(e - np.median(e))))


def calibrate_std(levels, floors, stds) -> tuple[float, float, float]:
    """``(c, g, e)`` of ``std = sqrt((c level)^2 + (g floor)^2 + e^2)`` fitted to per-condition stds (relative
    least squares, c, g, e >= 0)."""
    from scipy.optimize import nnls

    lv, fl, sd = (np.asarray(a, float) for a in (levels, floors, stds))
    ok = np.isfinite(sd) & (sd > 0)
    if not ok.any():
        return float("nan"), float("nan"), float("nan")
    A = np.stack([lv[ok] ** 2, fl[ok] ** 2, np.ones(ok.sum())], axis=1) / sd[ok, None] ** 2
    coef, _ = nnls(A, np.ones(ok.sum()))
    return tuple(float(np.sqrt(c)) for c in coef)


def identification_errors(cfg: dict, level: float, floor: float, specimens: int, seed: int):
    """Errors of ``classify``'s identification on ``specimens`` specimens of ``cfg`` (both test days) at one FRF
    noise level and floor: relative frequency and damping errors (N, m) and shape errors relative to each mode's
    largest entry (N, S, m), NaN where a mode was not found; N = 2 specimens."""
    setup = get_setup(merge({"measurement": {"frf_noise": level, "frf_noise_floor": floor}}, base=cfg))
    test = setup.test
    inp = draw_batch(np.random.default_rng(seed), specimens, setup)
    sim = simulate_batch(setup, inp)
    S = setup.n_meas
    H = measured_frf({**sim, "drive_row": setup.drive_row, "n_responses": S, "noise_seed": inp.noise_seed,
                      "noise_level": inp.noise_level, "noise_floor": inp.noise_floor}, setup.omega_rad_s, np.complex128)
    used = setup.modes_idx
    lam_t = sim["truth_poles"][..., used].reshape(2 * specimens, -1)
    psi_t = sim["truth_shapes"][..., :S, used].reshape(2 * specimens, S, -1)
    dofs = tuple(f"{k + 1}:+Y" for k in range(S + int(setup.drive_off_sensors)))   # the reference DOF last
    f_hz = setup.omega_rad_s / (2 * np.pi)
    fmin, fmax = test.band_hz
    nominal = np.asarray(test.frequencies_hz)
    lam_e, psi_e = np.full(lam_t.shape, np.nan + 0j), np.full(psi_t.shape, np.nan + 0j)
    for i, Hs in enumerate(H.reshape(2 * specimens, S, -1)):
        frf = MeasuredFRF(f_hz, Hs[:, None, :], dofs[:S], (dofs[setup.drive_row],))
        try:
            md = identify_band(frf, (fmin, fmax), "calibration")
        except BeamDamageError:
            continue
        lam_e[i], psi_e[i] = on_nominal_modes(md.eigenvalues, md.eigenvectors, nominal)
    return mode_errors(lam_e, psi_e, lam_t, psi_t, unscaled=setup.drive_off_sensors)   # no driving point: unscaled


def on_nominal_modes(eigenvalues, shapes, nominal_hz):
    """Identified poles (k,) and shapes (S, k) placed on the nominal modes they pair with by frequency
    (:func:`learn.pairs.measured.pair_modes_by_frequency`): (m,) and (S, m), NaN where no identified mode pairs."""
    lam = np.asarray(eigenvalues)
    psi = np.asarray(shapes)
    which = pair_modes_by_frequency(np.abs(lam) / (2 * np.pi), nominal_hz)
    lam_out = np.full(len(nominal_hz), np.nan + 0j)
    psi_out = np.full((psi.shape[0], len(nominal_hz)), np.nan + 0j)
    k = np.flatnonzero(which >= 0)
    lam_out[which[k]], psi_out[:, which[k]] = lam[k], psi[:, k]
    return lam_out, psi_out


def mode_errors(lam_e, psi_e, lam_t, psi_t, unscaled: bool = False):
    """Relative frequency and damping errors (..., m) and shape errors relative to each mode's largest truth entry
    (..., S, m) of identified poles ``lam_e`` and shapes ``psi_e`` against the truth ``lam_t``, ``psi_t`` (NaN
    where a mode was not found).

    Shapes of the FRF path (the square root of the driving-point residue) are compared up to their sign;
    ``unscaled`` ones (output-only, unit norm) are first scaled onto the truth by the complex least-squares factor,
    and the errors multiplied by ``sqrt(S / (S - 1))`` for the one complex direction that factor absorbs (so that
    circular errors of a given std, as a dataset draws them, measure that std)."""
    fe, ze = modal_parameters(lam_e)
    ft, zt = modal_parameters(lam_t)
    scale = np.max(np.abs(psi_t), axis=-2, keepdims=True)
    if unscaled:
        S = psi_t.shape[-2]
        with np.errstate(invalid="ignore"):         # NaN where a mode was not found
            alpha = (np.sum(np.conj(psi_e) * psi_t, axis=-2, keepdims=True)
                     / np.sum(np.abs(psi_e) ** 2, axis=-2, keepdims=True))
        err = (alpha * psi_e - psi_t) * (np.sqrt(S / (S - 1)) if S > 1 else 0.0)
        return fe / ft - 1, ze / zt - 1, err / scale
    plus, minus = psi_e - psi_t, psi_e + psi_t          # the square root of the driving-point residue: sign free
    pick = np.sum(np.abs(minus) ** 2, axis=-2, keepdims=True) < np.sum(np.abs(plus) ** 2, axis=-2, keepdims=True)
    return fe / ft - 1, ze / zt - 1, np.where(pick, minus, plus) / scale


def fit_coefficients(xs, ys, errors, default: dict | None = None) -> dict:
    """``measurement`` keys ``{q}_noise``, ``{q}_noise_per_floor``, ``{q}_noise_floor`` (per mode) fitted by
    :func:`calibrate_std` to the robust stds of ``errors`` (one :func:`mode_errors` triple per condition
    ``(xs[k], ys[k])``); a mode without data takes its index's value of those keys in ``default`` (a
    ``measurement`` section), else NaN."""
    m = errors[0][0].shape[-1]
    suffixes = ("_noise", "_noise_per_floor", "_noise_floor")
    out = {}
    for qi, q in enumerate(QUANTITIES):
        keep = [per_mode(default[q + s], m) if default else np.full(m, np.nan) for s in suffixes]
        fits = []
        for r in range(m):
            fit = calibrate_std(xs, ys, [robust_std(e[qi][..., r]) for e in errors])
            fits.append(fit if np.all(np.isfinite(fit)) else tuple(v[r] for v in keep))
        for j, suffix in enumerate(suffixes):
            out[q + suffix] = [float(f"{f[j]:.4g}") for f in fits]
    return out


def calibrate_test(cfg: dict, specimens: int = 8, seed: int = 0) -> dict:
    """``measurement`` keys ``{q}_noise``, ``{q}_noise_per_floor``, ``{q}_noise_floor`` (per mode used) of the
    test of ``cfg`` (module docstring); a mode no identification found keeps the shipped value of its index."""
    conditions = [(lv, fl) for lv in LEVELS for fl in FLOORS]
    errors = [identification_errors(cfg, lv, fl, specimens, seed + 100 * k) for k, (lv, fl) in enumerate(conditions)]
    return fit_coefficients([c[0] for c in conditions], [c[1] for c in conditions], errors, cfg["measurement"])
