"""FRFs synthesised from what a dataset stores (the same function serves reading and ``--store-frf``).

Measured FRFs: the truth modes at the measured DOFs (all ``p`` projected
modes, poles ``truth_poles`` and shapes ``truth_shapes``), drive at the first
measured DOF, with measurement noise

    ``H_meas = H (1 + level z1) + floor max_f|H| z2``   (per response FRF),

``H`` the float64 pole-pair sum of :mod:`physics.kernels`, ``z1, z2`` unit
circular complex Gaussian numbers drawn from a counter-based stream
(:func:`datagen.kernels.add_noise_row`, fused into the synthesis) keyed by the sample's
``noise_seed`` and the state, so a sample's noise never depends on which
other samples are read with it, on the worker or on the order.

Updated FRFs: the poles and residues of the updated ``(M, C, K)`` stored at
generation (:func:`datagen.solvers.pole_residues`); the rare updated models
with real poles fall back to the state-space resolvent of the stored matrices.
"""

from __future__ import annotations

import numpy as np

from datagen.kernels import noise_kernel, noisy_pole_residue_kernel
from physics.frf import pole_residue, receptance_state_space

FRF_KINDS = ("measured", "updated")

#: Stored arrays each FRF kind is synthesised from.
SOURCES = {"measured": ("truth_poles", "truth_shapes", "noise_seed", "noise_level", "noise_floor"),
           "updated": ("updated_poles", "updated_residues", "M_updated", "C_updated", "K_updated")}

_STATE_KEY = np.uint64(0xD1B54A32D192ED03)  # odd constant separating the two states' noise streams


def state_seeds(noise_seed):
    """Noise-stream seeds of both states, shape (n, 2), from the per-sample seeds (n,)."""
    s = np.asarray(noise_seed, np.uint64)
    with np.errstate(over="ignore"):
        return np.stack([s, s + _STATE_KEY], axis=-1)


def add_noise(H, noise_seed, noise_level, noise_floor, out=None):
    """Measured FRFs from noise-free ones (n, 2, S, F), with the sample's (n,) noise seed, level and floor."""
    n, _, S, F = H.shape
    out = np.empty(H.shape, complex) if out is None else out
    rep = lambda a: np.ascontiguousarray(np.repeat(np.asarray(a, float)[:, None], 2, 1).reshape(-1))  # noqa: E731
    noise_kernel(np.ascontiguousarray(H, complex).reshape(2 * n, S, F), state_seeds(noise_seed).reshape(-1),
                 rep(noise_level), rep(noise_floor), out.reshape(2 * n, S, F))
    return out


def _out(out, shape, dtype):
    """``out`` checked against the FRF shape, or a new array."""
    if out is None:
        return np.empty(shape, dtype)
    if out.shape != shape or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous array of shape {shape}, got {out.shape}")
    return out


def measured_frf(a: dict, omega_rad_s, dtype=np.complex64, out=None):
    """Noisy measured receptances (m/N), complex, shape (n, 2, 4, F), from the arrays of :data:`SOURCES`.

    ``out``: optional C-contiguous complex array of that shape to write into (returned).
    """
    lam, psi = np.asarray(a["truth_poles"]), np.asarray(a["truth_shapes"])
    n, _, S, m = psi.shape
    w = np.ascontiguousarray(omega_rad_s, dtype=float)
    out = _out(out, (n, 2, S, w.size), dtype)
    rep = lambda v: np.ascontiguousarray(np.repeat(np.asarray(v, float)[:, None], 2, 1).reshape(-1))  # noqa: E731
    noisy_pole_residue_kernel(np.ascontiguousarray(lam.reshape(2 * n, m)),
                              np.ascontiguousarray((psi * psi[..., :1, :]).reshape(2 * n, S, m)), w,
                              state_seeds(a["noise_seed"]).reshape(-1), rep(a["noise_level"]), rep(a["noise_floor"]),
                              out.reshape(2 * n, S, w.size))
    return out


def updated_frf(a: dict, omega_rad_s, dtype=np.complex64, out=None):
    """Receptances (m/N) of the updated models, complex, shape (n, 2, 4, F), from the arrays of :data:`SOURCES`.

    ``out``: optional C-contiguous complex array of that shape to write into (returned).
    """
    lam, R = a["updated_poles"], a["updated_residues"]
    out = _out(out, R.shape[:-1] + (np.size(omega_rad_s),), dtype)
    pole_residue(lam, R, omega_rad_s, out=out)
    bad = np.isnan(lam).any(axis=-1)
    if bad.any():  # real poles or a diverged update: the general route on the stored matrices
        M = np.broadcast_to(np.asarray(a["M_updated"])[:, None], a["C_updated"].shape)
        out[bad] = receptance_state_space(M[bad], a["C_updated"][bad], a["K_updated"][bad], omega_rad_s,
                                          np.arange(R.shape[-2]), [0])[..., 0, :]
    return out


def synthesise(kind: str, arrays: dict, omega_rad_s, dtype=np.complex64, out=None):
    """FRFs of ``kind`` (``"measured"`` or ``"updated"``) from the stored arrays of :data:`SOURCES`."""
    if kind == "measured":
        return measured_frf(arrays, omega_rad_s, dtype, out)
    if kind == "updated":
        return updated_frf(arrays, omega_rad_s, dtype, out)
    raise ValueError(f"FRF kind {kind!r} unknown; expected one of {FRF_KINDS}")
