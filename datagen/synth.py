"""FRFs synthesised from what a dataset stores (the same function serves reading and ``--store-frf``).

Measured FRFs: the truth modes at the measured DOFs (all ``p`` projected
modes, poles ``truth_poles`` and shapes ``truth_shapes``), drive at the measured DOF
``drive_row`` (the manifest's ``schema.frf_reference_row``, default the first; a row after the
``n_responses`` sensors' when the reference DOF is no sensor), with measurement noise

    ``H_meas = H (1 + level z1) + floor max_f|H| z2``   (per response FRF),

``H`` the float64 pole-pair sum of :mod:`physics.frf_kernels`, ``max_f|H|`` over
all lines stored at generation (``frf_peak``, :func:`measured_peak`), ``z1, z2`` unit
circular complex Gaussian numbers drawn from a counter-based stream
(:func:`datagen.noise_kernels.add_noise_row`, fused into the synthesis) keyed by the sample's
``noise_seed`` and the state, so a sample's noise never depends on which
other samples are read with it, on the worker or on the order. Noise keyed
by the line index and the stored peak let any subset of lines be synthesised
alone, with exactly the values of the full FRF (``lines=``; e.g. only the 168
of 1024 lines the classifier's log-frequency grid interpolates from).

Updated FRFs: the poles and residues of the updated ``(M, C, K)`` stored at
generation (:func:`datagen.solvers.pole_residues`); the rare updated models
with real poles fall back to the state-space resolvent of the stored matrices.
"""

from __future__ import annotations

import numpy as np

from physics.frf import pole_residue, receptance_state_space

__all__ = ["DATASET_FRFS", "SOURCES", "add_noise", "line_index", "log_magnitude_map", "measured_frf", "measured_peak",
           "state_seeds", "synthesise", "updated_frf"]

#: FRFs a dataset synthesises: the noisy measurement of the truth beam and the updated model's.
DATASET_FRFS = ("measured", "updated")

#: Stored arrays each FRF kind is synthesised from.
SOURCES = {"measured": ("truth_poles", "truth_shapes", "noise_seed", "noise_level", "noise_floor", "frf_peak"),
           "updated": ("updated_poles", "updated_residues", "M_updated", "C_updated", "K_updated")}

_STATE_KEY = np.uint64(0xD1B54A32D192ED03)  # odd constant separating the two states' noise streams


def state_seeds(noise_seed):
    """Noise-stream seeds of both states, shape (n, 2), from the per-sample seeds (n,)."""
    s = np.asarray(noise_seed, np.uint64)
    with np.errstate(over="ignore"):
        return np.stack([s, s + _STATE_KEY], axis=-1)


def add_noise(H, noise_seed, noise_level, noise_floor, out=None):
    """Measured FRFs from noise-free ones (n, 2, S, F), with the sample's (n,) noise seed, level and floor."""
    from datagen.noise_kernels import noise_kernel  # numba: only where noise is drawn

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


def line_index(lines, n_lines: int) -> np.ndarray:
    """The dataset lines to synthesise: ``lines`` (indices into the F lines) checked, or all of them."""
    if lines is None:
        return np.arange(n_lines)
    idx = np.asarray(lines)
    if idx.ndim != 1 or idx.dtype.kind not in "iu" or (idx.size and (idx.min() < 0 or idx.max() >= n_lines)):
        raise ValueError(f"lines must be a 1-D array of line indices in [0, {n_lines})")
    return idx.astype(np.int64)


def _measured_inputs(a: dict):
    """Poles (2n, m) and drive-point-scaled residues (2n, S, m) of the measured FRFs, states flattened: the first
    ``n_responses`` rows of ``truth_shapes`` (default all) are the responses, row ``drive_row`` the reference DOF
    (a row after the responses when the reference DOF is no sensor)."""
    lam, psi = np.asarray(a["truth_poles"]), np.asarray(a["truth_shapes"])
    n, _, rows, m = psi.shape
    S, d = int(a.get("n_responses") or rows), int(a.get("drive_row", 0))
    return (np.ascontiguousarray(lam.reshape(2 * n, m)),
            np.ascontiguousarray((psi[..., :S, :] * psi[..., d:d + 1, :]).reshape(2 * n, S, m)))


def measured_peak(a: dict, omega_rad_s) -> np.ndarray:
    """``max |H|`` over all lines of each noise-free measured receptance (m/N), shape (n, 2, 4): the scale
    of the noise floor, stored as ``frf_peak`` so that a subset of lines can be synthesised exactly.
    NaN where the sample's noise floor is 0 (not needed)."""
    lam, R = _measured_inputs(a)
    need = np.repeat(np.asarray(a["noise_floor"], float) != 0, 2)
    peak = np.full(R.shape[:2], np.nan)
    if need.any():  # the float64 sum of datagen.noise_kernels.row_peak, the same values
        H = pole_residue(lam[need], R[need], omega_rad_s)
        peak[need] = np.sqrt(np.max(H.real ** 2 + H.imag ** 2, axis=-1))
    return peak.reshape(-1, 2, R.shape[1])


def measured_frf(a: dict, omega_rad_s, dtype=np.complex64, out=None, lines=None):
    """Noisy measured receptances (m/N), complex, shape (n, 2, 4, L), from the arrays of :data:`SOURCES`.

    ``lines``: optional indices of the lines of ``omega_rad_s`` (F,) to synthesise (default all, L = F);
    each line gets the value it has in the full FRF, noise included (the noise is keyed by the line
    index; the floor's scale is the stored ``frf_peak``; datasets written before it existed are
    synthesised on all lines where a floor needs it).
    ``out``: optional C-contiguous complex array of shape (n, 2, 4, L) to write into (returned).
    """
    from datagen.noise_kernels import noisy_pole_residue_kernel  # numba: only where noise is drawn

    lam, R = _measured_inputs(a)
    n2, S, _ = R.shape
    w = np.ascontiguousarray(omega_rad_s, dtype=float)
    idx = line_index(lines, w.size)
    out = _out(out, (n2 // 2, 2, S, idx.size), dtype)
    rep = lambda v: np.ascontiguousarray(np.repeat(np.asarray(v, float)[:, None], 2, 1).reshape(-1))  # noqa: E731
    peak = a.get("frf_peak")
    peak = np.full((n2, S), np.nan) if peak is None else np.ascontiguousarray(np.reshape(peak, (n2, S)), float)
    args = (lam, R)
    noise = (state_seeds(a["noise_seed"]).reshape(-1), rep(a["noise_level"]), rep(a["noise_floor"]), peak)
    full = (noise[2] != 0) & np.isnan(peak).any(axis=1) & (idx.size < w.size)  # the floor's peak needs every line
    flat = out.reshape(n2, S, idx.size)
    if not full.any():
        noisy_pole_residue_kernel(*args, w[idx], idx, w.size, *noise, flat)
        return out
    every = np.empty((int(full.sum()), S, w.size), dtype)
    noisy_pole_residue_kernel(*(x[full] for x in args), w, np.arange(w.size), w.size, *(x[full] for x in noise), every)
    flat[full] = every[..., idx]
    part = np.empty((int((~full).sum()), S, idx.size), dtype)
    noisy_pole_residue_kernel(*(x[~full] for x in args), w[idx], idx, w.size, *(x[~full] for x in noise), part)
    flat[~full] = part
    return out


def updated_frf(a: dict, omega_rad_s, dtype=np.complex64, out=None, lines=None):
    """Receptances (m/N) of the updated models, complex, shape (n, 2, 4, L), from the arrays of :data:`SOURCES`.

    ``lines``: optional indices of the lines of ``omega_rad_s`` to synthesise (default all).
    ``out``: optional C-contiguous complex array of that shape to write into (returned).
    """
    lam, R = a["updated_poles"], a["updated_residues"]
    w = np.asarray(omega_rad_s, float)[line_index(lines, np.size(omega_rad_s))]
    out = _out(out, R.shape[:-1] + (w.size,), dtype)
    pole_residue(lam, R, w, out=out)
    bad = np.isnan(lam).any(axis=-1)
    if bad.any():  # real poles or a diverged update: the general route on the stored matrices
        M = np.broadcast_to(np.asarray(a["M_updated"])[:, None], a["C_updated"].shape)
        out[bad] = receptance_state_space(M[bad], a["C_updated"][bad], a["K_updated"][bad], w,
                                          np.arange(R.shape[-2]),
                                          [int(a.get("update_drive_row", a.get("drive_row", 0)))])[..., 0, :]
    return out


def log_magnitude_map(weights):
    """A linear map of log-magnitudes, ``log10|H| @ W.T``, made cheap by reading only the lines it uses.

    Parameters
    ----------
    weights : array_like, shape (G, F)
        Each row maps the F lines' ``log10 |H|`` to one output (e.g. linear interpolation onto a
        log-frequency grid: two non-zero entries per row).

    Returns
    -------
    lines : ndarray of int, shape (L,)
        The lines with a non-zero weight (synthesise only these: ``Dataset.frf(..., lines=lines)``).
    apply : callable
        ``apply(H)`` with ``H`` (..., L) complex on ``lines`` returns ``log10 |H| @ W.T`` (..., G), float32.
    """
    W = np.asarray(weights, float)
    lines = np.flatnonzero(W.any(axis=0))
    W = W[:, lines]
    k = max(1, int((W != 0).sum(axis=1).max()))
    cols = np.argsort(W == 0, axis=1, kind="stable")[:, :k].T           # (k, G): the non-zero columns
    wts = (np.take_along_axis(W, cols.T, axis=1).T / np.log(10)).astype(np.float32)

    def apply(H):
        ln = np.log(np.abs(H) + np.float32(1e-30))                        # float32 log (log10 costs 2x)
        out = ln[..., cols[0]] * wts[0]
        for c, w in zip(cols[1:], wts[1:]):
            out += ln[..., c] * w
        return out

    return lines, apply


def synthesise(kind: str, arrays: dict, omega_rad_s, dtype=np.complex64, out=None, lines=None):
    """FRFs of ``kind`` (``"measured"`` or ``"updated"``) from the stored arrays of :data:`SOURCES`,
    on all lines of ``omega_rad_s`` or on the subset ``lines`` (indices)."""
    if kind == "measured":
        return measured_frf(arrays, omega_rad_s, dtype, out, lines)
    if kind == "updated":
        return updated_frf(arrays, omega_rad_s, dtype, out, lines)
    raise ValueError(f"FRF kind {kind!r} unknown; expected one of {DATASET_FRFS}")
