"""FRFs synthesised from what a dataset stores (the same function serves reading and ``--store-frf``).

Measured FRFs: the truth modes at the measured DOFs (all ``p`` projected
modes, poles ``truth_poles`` and shapes ``truth_shapes``), drive at the first
measured DOF, with measurement noise

    ``H_meas = H (1 + level z1) + floor max_f|H| z2``   (per response FRF),

``z1, z2`` unit circular complex Gaussian numbers drawn from a counter-based
stream (:func:`datagen.kernels.hashed_normal`) keyed by the sample's
``noise_seed`` and the state, so a sample's noise never depends on which
other samples are read with it, on the worker or on the order.

Updated FRFs: the poles and residues of the updated ``(M, C, K)`` stored at
generation (:func:`datagen.solvers.pole_residues`); the rare updated models
with real poles fall back to the state-space resolvent of the stored matrices.
"""

from __future__ import annotations

import numpy as np

from datagen.solvers import pair_frf, state_space_frf

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


def measured_frf(a: dict, omega_rad_s, dtype=np.complex64):
    """Noisy measured receptances (m/N), complex, shape (n, 2, 4, F), from the arrays of :data:`SOURCES`."""
    lam, psi = a["truth_poles"], a["truth_shapes"]
    out = np.empty(psi.shape[:-1] + (np.size(omega_rad_s),), dtype)
    level = np.repeat(np.asarray(a["noise_level"], float)[:, None], 2, axis=1)
    floor = np.repeat(np.asarray(a["noise_floor"], float)[:, None], 2, axis=1)
    pair_frf(lam, psi * psi[..., :1, :], omega_rad_s, out, (state_seeds(a["noise_seed"]), level, floor))
    return out


def updated_frf(a: dict, omega_rad_s, dtype=np.complex64):
    """Receptances (m/N) of the updated models, complex, shape (n, 2, 4, F), from the arrays of :data:`SOURCES`."""
    lam, R = a["updated_poles"], a["updated_residues"]
    out = np.empty(R.shape[:-1] + (np.size(omega_rad_s),), dtype)
    pair_frf(lam, R, omega_rad_s, out)
    bad = np.isnan(lam).any(axis=-1)
    if bad.any():  # real poles or a diverged update: the general route on the stored matrices
        M = np.broadcast_to(np.asarray(a["M_updated"])[:, None], a["C_updated"].shape)
        out[bad] = state_space_frf(M[bad], a["C_updated"][bad], a["K_updated"][bad], omega_rad_s,
                                   np.arange(R.shape[-2]), 0)
    return out


def synthesise(kind: str, arrays: dict, omega_rad_s, dtype=np.complex64):
    """FRFs of ``kind`` (``"measured"`` or ``"updated"``) from the stored arrays of :data:`SOURCES`."""
    if kind == "measured":
        return measured_frf(arrays, omega_rad_s, dtype)
    if kind == "updated":
        return updated_frf(arrays, omega_rad_s, dtype)
    raise ValueError(f"FRF kind {kind!r} unknown; expected one of {FRF_KINDS}")
