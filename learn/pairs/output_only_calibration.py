"""The modal noise of an output-only test, calibrated against the identification ``identify`` runs on response
records (SSI-cov), so that a dataset's modal errors are those ``classify`` then reads from its ``modal.json``.

Specimens of the config are simulated as a dataset simulates them (:func:`datagen.batch_inputs.draw_batch`,
:func:`~datagen.pipeline.simulate_batch`: every projected truth mode at the sensors). Each test day becomes a
record of accelerations at the sensors under a white random force at the sensor that excites the test's modes
best (:func:`drive_row`), synthesised by FFT from the modes (:func:`response_records`), with Gaussian sensor
noise of a fraction of each channel's RMS, sampled at :data:`SAMPLING_FACTOR` times the top of the test's band.
Records of :data:`RECORD_LENGTHS_S` at :data:`SENSOR_NOISES` are identified exactly as ``identify`` identifies a
file of records (:func:`physics.identification.identify_records`, SSI-cov over the test's band, default order),
the modes paired by frequency with the test's nominal modes as the FRF calibration pairs them, and the errors of
frequency, damping and shape measured as :func:`learn.pairs.noise_calibration.mode_errors` measures unscaled shapes.

Per mode and quantity the robust std is fitted by ``std^2 = ((c n)^2 + g^2) / T + e^2`` of the sensor noise
``n`` and the record length ``T`` (s): the estimation errors of an output-only identification fall as
``1 / sqrt(T)`` (the correlations are averages over the record), sensor noise adds its own share, and ``e`` is
what longer records do not remove (model order, filtering, the modes' own bias). The coefficients take the FRF
calibration's places (``c`` ``{q}_noise``, ``g`` ``{q}_noise_per_floor``, ``e`` ``{q}_noise_floor``) with the
variables of :func:`datagen.config.output_only_variables`. Deterministic for a config and seed.
"""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from datagen.batch_inputs import draw_batch
from datagen.pipeline import simulate_batch
from datagen.setup import get_setup
from learn.pairs.noise_calibration import fit_coefficients, mode_errors, on_nominal_modes
from physics.errors import BeamDamageError
from physics.frf import pole_residue
from physics.identification import identify_records
from physics.io.timedata import TimeRecords

__all__ = ["RECORD_LENGTHS_S", "SAMPLING_FACTOR", "SENSOR_NOISES", "calibrate_output_only", "drive_row",
           "output_only_errors", "response_records"]

#: Sensor noise (std relative to each channel's RMS) and record lengths (s) of the calibration: the range the
#: config's ``measurement.sensor_noise`` and ``record_length_s`` draw by default.
SENSOR_NOISES = (0.005, 0.01, 0.03)
RECORD_LENGTHS_S = (120.0, 300.0, 900.0)
#: Sampling rate of the records as a multiple of the top of the test's band.
SAMPLING_FACTOR = 2.56


def drive_row(shapes) -> int:
    """The sensor whose weakest mode is strongest: ``argmax_s min_r |psi_sr| / max_s' |psi_s'r|`` of shapes
    (S, m), the point a single random force excites every mode from."""
    a = np.abs(np.asarray(shapes))
    return int(np.argmax(np.min(a / np.max(a, axis=0, keepdims=True), axis=1)))


def response_records(poles, shapes, drive: int, sampling_frequency_hz: float, n_samples: int, sensor_noise: float,
                     rng: np.random.Generator) -> np.ndarray:
    """Accelerations (m/s^2 per unit force density) at the sensors under a white random force at sensor ``drive``.

    The force's spectrum (the FFT of ``n_samples`` standard normal values) times the acceleration FRF
    ``-w^2 H(w)`` of the modes, ``H`` the pole-residue receptance with residues ``psi psi[drive]``, transformed
    back: a circular, hence stationary, record whose covariance is the modes' (exact at the FFT lines). Sensor
    noise: ``sensor_noise`` times each channel's std, Gaussian.

    Parameters
    ----------
    poles : ndarray, complex, shape (p,)
        One eigenvalue of each conjugate pair (rad/s).
    shapes : ndarray, complex, shape (S, p)
        Shapes at the sensors, scaled as the package's eq.-1.10 modes.
    drive : int
    sampling_frequency_hz : float
    n_samples : int
    sensor_noise : float
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, float, shape (S, n_samples)
    """
    from scipy import fft


    w_rad_s = 2 * np.pi * fft.rfftfreq(n_samples, 1.0 / sampling_frequency_hz)
    force = fft.rfft(rng.standard_normal(n_samples))
    H = pole_residue(np.asarray(poles), np.asarray(shapes) * np.asarray(shapes)[drive], w_rad_s[1:])
    spectrum = np.zeros((H.shape[0], w_rad_s.size), complex)
    spectrum[:, 1:] = -(w_rad_s[1:] ** 2) * H * force[1:]
    y = fft.irfft(spectrum, n=n_samples, axis=-1)
    return y + sensor_noise * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


def output_only_errors(setup, sim: dict, sensor_noise: float, record_length_s: float, seed):
    """Errors of SSI-cov on the records of every test in ``sim`` (:func:`datagen.pipeline.simulate_batch` of
    ``setup``) at one sensor noise and record length: relative frequency and damping errors (N, m) and shape
    errors (N, S, m) (:func:`learn.pairs.noise_calibration.mode_errors`, unscaled), NaN where a mode was not found;
    N = 2 x specimens; a record holds the next fast FFT length of samples from ``record_length_s``. ``seed``:
    anything :func:`numpy.random.default_rng` takes; record ``i`` draws from ``[*seed, i]``."""
    from scipy.fft import next_fast_len


    test, used, S = setup.test, setup.modes_idx, setup.n_meas
    poles = sim["truth_poles"].reshape(-1, sim["truth_poles"].shape[-1])
    shapes = sim["truth_shapes"][:, :, :S].reshape(-1, S, sim["truth_shapes"].shape[-1])
    fs = SAMPLING_FACTOR * float(test.band_hz[1])
    n = next_fast_len(int(round(record_length_s * fs)), real=True)
    nominal = np.asarray(test.frequencies_hz)
    dofs = tuple(f"{k + 1}:+Y" for k in range(S))
    lam_e = np.full((poles.shape[0], used.size), np.nan + 0j)
    psi_e = np.full((poles.shape[0], S, used.size), np.nan + 0j)
    for i in range(poles.shape[0]):
        rng = np.random.default_rng([*np.atleast_1d(seed), i])
        y = response_records(poles[i], shapes[i], drive_row(shapes[i][:, used]), fs, n, sensor_noise, rng)
        rec = TimeRecords(1.0 / fs, y, dofs, ("acceleration",) * S, {"source": "calibration record"})
        try:
            with threadpool_limits(1):      # small SVDs: one BLAS thread is fastest
                est = identify_records(rec, "ssi", band_hz=tuple(test.band_hz)).estimate
        except BeamDamageError:
            continue
        lam_e[i], psi_e[i] = on_nominal_modes(est.eigenvalues, est.shapes, nominal)
    return mode_errors(lam_e, psi_e, poles[:, used], shapes[:, :, used], unscaled=True)


def calibrate_output_only(cfg: dict, specimens: int = 8, seed: int = 0) -> dict:
    """``measurement`` overrides of ``cfg`` for output-only modal noise: ``modal_noise = "output-only"`` and the
    per-mode coefficients fitted on its test (module docstring); a mode no record found takes each coefficient's
    largest value over the modes found."""
    setup = get_setup(cfg)
    if setup.test is None:
        raise BeamDamageError("the output-only calibration needs the config's test (sensors, band, modes)")
    sim = simulate_batch(setup, draw_batch(np.random.default_rng(seed), specimens, setup))
    conditions = [(nz, t) for nz in SENSOR_NOISES for t in RECORD_LENGTHS_S]
    errors = [output_only_errors(setup, sim, nz, t, [seed, k]) for k, (nz, t) in enumerate(conditions)]
    coef = fit_coefficients([nz / np.sqrt(t) for nz, t in conditions], [1 / np.sqrt(t) for _, t in conditions],
                            errors)
    if any(np.isnan(v).all() for v in coef.values()):
        raise BeamDamageError(f"output-only calibration: SSI-cov found none of the test's modes in "
                              f"{2 * specimens * len(conditions)} simulated records")
    # a mode never found: each coefficient's largest value over the modes found
    return {"modal_noise": "output-only", **{k: np.where(np.isnan(v), np.nanmax(v), v).tolist()
                                             for k, v in coef.items()}}
