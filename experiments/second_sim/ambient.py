"""Ambient (output-only) response records of the independent simulator's beams.

Broadband random forces (white, or coloured by a second-order low-pass) at one or several points drive the
modes of a :class:`~experiments.second_sim.fem.Beam` with modal damping; each mode's response is the exact
zero-order-hold discretisation of its modal transfer function (``scipy.signal.cont2discrete`` and ``lfilter``),
so the record's poles are the continuous modes' exactly. Sensors measure acceleration (or displacement) at
nodes with Gaussian noise of a fraction of each channel's standard deviation. Optionally the forces carry
harmonics (sinusoids, as from rotating machinery), and the record is simulated at a multiple of its sampling
rate with the modes up to that rate's band and brought down to it with or without an anti-alias filter (without,
the modes above the Nyquist frequency fold into the record). Uses only this package, numpy and scipy.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import signal

from experiments.second_sim.fem import Beam, assemble, modes
from experiments.second_sim.writers import atomic_target

__all__ = ["AmbientRecord", "ambient_record", "write_npz"]


@dataclass(frozen=True)
class AmbientRecord:
    """Simulated ambient records and the truth.

    Attributes
    ----------
    signals : ndarray, shape (n_sensors, n_samples)
        Acceleration (m/s^2) or displacement (m) with sensor noise.
    sampling_frequency_hz : float
    sensor_x_m : ndarray, shape (n_sensors,)
    frequencies_hz, damping_ratios : ndarray, shape (n_modes,)
        Truth of the modes in the record (undamped natural frequency, modal damping ratio).
    shapes : ndarray, shape (n_sensors, n_modes)
        Mass-normalised mode shapes at the sensors.
    quantity : str
    """

    signals: np.ndarray
    sampling_frequency_hz: float
    sensor_x_m: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    quantity: str


def ambient_record(beam: Beam, sensor_x_m, duration_s=600.0, sampling_frequency_hz=2000.0, damping=0.01,
                   input_x_m=None, coloured=False, noise=0.02, n_modes=4, quantity="acceleration",
                   seed=0, harmonics=(), oversample=1, anti_alias=True) -> AmbientRecord:
    """Response records of ``beam`` under random forces at ``input_x_m`` (unknown to the identification).

    Parameters
    ----------
    beam : Beam
    sensor_x_m : sequence of float
        Sensor positions (nodes of the mesh).
    duration_s, sampling_frequency_hz : float
    damping : float or sequence of float
        Modal damping ratio(s) of the modes (the last repeats).
    input_x_m : sequence of float, optional
        Force positions (nodes); default the tip.
    coloured : bool
        Forces filtered by a second-order Butterworth low-pass at the geometric mean of the lowest and highest
        mode's frequencies (40 dB per decade above it) instead of white.
    noise : float
        Sensor noise standard deviation as a fraction of each channel's.
    n_modes : int
        Modes in the record (the lowest; higher modes are left out, so the truth is exactly these modes).
    quantity : {"acceleration", "displacement"}
    seed : int
    harmonics : sequence of (float, float)
        ``(frequency_hz, amplitude)``: sinusoids of random phase added to every force, the amplitude a multiple
        of the random force's standard deviation.
    oversample : int
        Simulated at ``oversample`` times the sampling rate, with every mode below 0.4 of that rate (``n_modes``
        then counts the modes of the truth: those below 0.4 of the sampling rate are kept in it).
    anti_alias : bool
        With ``oversample > 1``: an 8th-order Butterworth low-pass at 0.4 of the sampling rate (causal, as in an
        acquisition system's front end) before keeping every ``oversample``-th sample; without it, modes above
        the Nyquist frequency alias into the record.

    Returns
    -------
    AmbientRecord
    """
    rng = np.random.default_rng(seed)
    asm = assemble(beam)
    md = modes(asm)
    fs = float(sampling_frequency_hz)
    r_over = int(oversample)
    fs_sim = fs * r_over
    n_sim = n_modes if r_over == 1 else int(np.sum(md.omega_rad_s / (2 * np.pi) < 0.4 * fs_sim))
    wn = md.omega_rad_s[:n_sim]
    zeta = np.resize(np.atleast_1d(np.asarray(damping, float)), n_sim)
    if wn[n_modes - 1] / (2 * np.pi) > 0.4 * fs:
        raise ValueError(f"mode {n_modes} at {wn[n_modes - 1] / (2 * np.pi):.4g} Hz is above 0.4 of the sampling "
                         "rate")
    sens = asm.translation_dofs(sensor_x_m)
    inp = asm.translation_dofs([beam.length_m] if input_x_m is None else input_x_m)
    n = int(round(duration_s * fs)) * r_over
    forces = rng.standard_normal((inp.size, n))
    if coloured:
        b, a = signal.butter(2, np.sqrt(wn[0] * wn[n_modes - 1]) / (2 * np.pi), fs=fs_sim)
        forces = signal.lfilter(b, a, forces, axis=1)
    t = np.arange(n) / fs_sim
    for f_h, amp in harmonics:
        forces += amp * np.sin(2 * np.pi * f_h * t + rng.uniform(0, 2 * np.pi, (inp.size, 1)))
    modal_force = md.phi[inp, :n_sim].T @ forces                       # (n_sim, n)
    q = np.empty((n_sim, n))
    for r in range(n_sim):                                             # one exact filter per mode
        num = [1.0, 0.0, 0.0] if quantity == "acceleration" else [1.0]
        bz, az, _ = signal.cont2discrete((num, [1.0, 2 * zeta[r] * wn[r], wn[r] ** 2]), 1 / fs_sim, "zoh")
        q[r] = signal.lfilter(bz.ravel(), az, modal_force[r])
    y = md.phi[sens, :n_sim] @ q
    if r_over > 1:
        if anti_alias:
            y = signal.sosfilt(signal.butter(8, 0.4 * fs, fs=fs_sim, output="sos"), y, axis=1)
        y = y[:, ::r_over]
    y += noise * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    return AmbientRecord(y, fs, np.asarray(sensor_x_m, float), wn[:n_modes] / (2 * np.pi), zeta[:n_modes],
                         md.phi[sens, :n_modes], quantity)


def write_npz(path, rec: AmbientRecord, dofs=None) -> None:
    """The record as ``.npz`` of plain arrays (``signals``, ``sampling_frequency_hz``, ``dofs``, ``quantity``)."""
    path = Path(path)
    dofs = [f"{k + 2}:+Y" for k in range(rec.signals.shape[0])] if dofs is None else list(dofs)
    buf = io.BytesIO()
    np.savez(buf, signals=rec.signals, sampling_frequency_hz=np.array(rec.sampling_frequency_hz),
             dofs=np.array(dofs), quantity=np.array(rec.quantity))
    tmp = atomic_target(path)
    try:
        tmp.write_bytes(buf.getvalue())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
