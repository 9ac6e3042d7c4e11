"""Damping, complex modes, receptance FRFs and the measurement chain of the independent simulator.

The damping model is diagonal in the undamped modes (modal ratios
``d_r = 2 zeta_r omega_r``, or Rayleigh ``d_r = alpha + beta omega_r^2``), so its
receptance is the modal superposition of every mode of the model; local
dashpots (``c b b^T``, non-proportional) are added exactly by the Woodbury
identity, frequency line by frequency line in one batched solve. Complex modes
of the non-proportional system are the roots of a small determinant (one row
per dashpot) in the modal coordinates of every mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.second_sim.fem import Assembled, Modes

__all__ = ["MODAL_NOISE", "Damping", "Noise", "complex_modes", "complex_normal", "measure", "noisy_modal",
           "rayleigh_for", "receptance"]


@dataclass(frozen=True)
class Damping:
    """Damping model: ``kind = "modal"`` (``ratios``, per mode; the last applies to higher modes)
    or ``"rayleigh"`` (``C = alpha_1_s M + beta_s K``). Dashpots of the beam add to either."""

    kind: str = "modal"
    ratios: tuple[float, ...] = (0.01,)
    alpha_1_s: float = 0.0
    beta_s: float = 0.0

    def __post_init__(self):
        if self.kind not in ("modal", "rayleigh"):
            raise ValueError(f"Damping.kind must be 'modal' or 'rayleigh', got {self.kind!r}")
        if self.kind == "modal" and (not self.ratios or min(self.ratios) < 0):
            raise ValueError("Damping.ratios must be a non-empty tuple of ratios >= 0")

    def diagonal(self, omega_rad_s: np.ndarray) -> np.ndarray:
        """Modal damping coefficients ``c_r`` (1/s) of mass-normalised modes."""
        if self.kind == "rayleigh":
            return self.alpha_1_s + self.beta_s * omega_rad_s ** 2
        z = np.asarray(self.ratios, dtype=float)
        z = np.concatenate([z, np.full(max(0, omega_rad_s.size - z.size), z[-1])])[:omega_rad_s.size]
        return 2.0 * z * omega_rad_s


def rayleigh_for(zeta_1: float, zeta_2: float, omega_1_rad_s: float, omega_2_rad_s: float) -> Damping:
    """Rayleigh damping with ratio ``zeta_1`` at ``omega_1`` and ``zeta_2`` at ``omega_2``."""
    A = np.array([[1 / (2 * omega_1_rad_s), omega_1_rad_s / 2], [1 / (2 * omega_2_rad_s), omega_2_rad_s / 2]])
    alpha, beta = np.linalg.solve(A, [zeta_1, zeta_2])
    return Damping("rayleigh", alpha_1_s=float(alpha), beta_s=float(beta))


def _modal_sum(md: Modes, d: np.ndarray, w: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``sum_r left[a, r] right[b, r] / (omega_r^2 - w^2 + i w d_r)``: (a, n), (b, n) -> (a, b, n_lines)."""
    den = 1.0 / (md.omega_rad_s[:, None] ** 2 - w[None, :] ** 2 + 1j * w[None, :] * d[:, None])
    return np.einsum("ar,br,rl->abl", left, right, den)


def receptance(asm: Assembled, md: Modes, damping: Damping, freq_hz, resp_dofs, ref_dof: int) -> np.ndarray:
    """Receptance ``H`` (m/N) at free DOFs ``resp_dofs`` driven at ``ref_dof``, shape (n_resp, n_lines).

    Modal superposition of every mode of the model, exact for the discrete model;
    dashpots (rank-one damping terms ``c b b^T``) by the Woodbury identity on top of it.
    """
    w = 2 * math.pi * np.asarray(freq_hz, dtype=float)
    d = damping.diagonal(md.omega_rad_s)
    pr, pf = md.phi[np.asarray(resp_dofs), :], md.phi[[ref_dof], :]
    H = _modal_sum(md, d, w, pr, pf)[:, 0, :]
    active = asm.dashpot_c_Ns_m > 0
    if not np.any(active):
        return H
    pb = asm.dashpot_rows[active] @ md.phi                                 # (k, n)
    G_rb = _modal_sum(md, d, w, pr, pb)                                    # (n_resp, k, L)
    G_bf = _modal_sum(md, d, w, pb, pf)[:, 0, :]                           # (k, L)
    G_bb = _modal_sum(md, d, w, pb, pb)                                    # (k, k, L)
    S = np.moveaxis(G_bb, -1, 0) + np.eye(pb.shape[0]) / (1j * w[:, None, None] * asm.dashpot_c_Ns_m[active])
    y = np.linalg.solve(S, np.moveaxis(G_bf, -1, 0)[..., None])[..., 0]     # (L, k)
    return H - np.einsum("akl,lk->al", G_rb, y)


def _dashpot_det(lam, r, md: Modes, d: np.ndarray, P: np.ndarray, c: np.ndarray) -> complex:
    """``D_r(lam) det(I + lam diag(c) P diag(1/D) P^T)``, ``D_s = lam^2 + lam d_s + omega_s^2``: zero at a
    damped eigenvalue, analytic at mode ``r``'s proportional eigenvalue (matrix determinant lemma)."""
    D = lam * lam + lam * d + md.omega_rad_s ** 2
    others = np.ones(D.size, bool)
    others[r] = False
    A = np.eye(c.size) + lam * c[:, None] * ((P[:, others] / D[others]) @ P[:, others].T)
    u = lam * c * P[:, r]
    return np.linalg.det(A) * (D[r] + P[:, r] @ np.linalg.solve(A, u))


def complex_modes(asm: Assembled, md: Modes, damping: Damping, dofs, n_modes: int = 4):
    """The first ``n_modes`` damped modes: eigenvalues (upper half-plane, rad/s) and shapes at ``dofs``.

    Without dashpots the modes are the undamped ones with ``lambda_r = -d_r/2 + i sqrt(omega_r^2 - d_r^2/4)``.
    Dashpots ``sum_j c_j b_j b_j^T`` make the modal equations ``D_s(lambda) q_s + lambda p_s^T diag(c) P q = 0``
    (``P = B phi``); their eigenvalues are the roots of a ``k x k`` determinant (k dashpots), found by
    Newton's method from each proportional eigenvalue, with the shape ``q_s = -lambda p_s^T diag(c) y / D_s``.

    Returns
    -------
    lam : ndarray, complex, shape (n_modes,)
        ``-zeta w + i w sqrt(1 - zeta^2)``, sorted by imaginary part.
    psi : ndarray, complex, shape (len(dofs), n_modes)
        Displacement shapes, each scaled so that its largest entry is real and positive.
    """
    dofs = np.asarray(dofs)
    d = damping.diagonal(md.omega_rad_s)
    w = md.omega_rad_s[:n_modes]
    lam0 = -d[:n_modes] / 2 + 1j * np.sqrt(w ** 2 - d[:n_modes] ** 2 / 4 + 0j)
    active = asm.dashpot_c_Ns_m > 0
    if not np.any(active):
        return lam0, md.phi[dofs, :n_modes].astype(complex)
    P, c = asm.dashpot_rows[active] @ md.phi, asm.dashpot_c_Ns_m[active]
    lams, shapes = [], []
    for r, lam in enumerate(lam0):
        for _ in range(60):
            h = 1e-7 * abs(lam)
            f = _dashpot_det(lam, r, md, d, P, c)
            df = (_dashpot_det(lam + h, r, md, d, P, c) - _dashpot_det(lam - h, r, md, d, P, c)) / (2 * h)
            step = f / df
            lam = lam - step
            if abs(step) < 1e-13 * abs(lam):
                break
        else:
            raise RuntimeError(f"complex mode {r + 1}: Newton's method did not converge")
        D = lam * lam + lam * d + md.omega_rad_s ** 2
        G = (P / D) @ P.T                                   # (k, k)
        y = np.linalg.svd(np.eye(c.size) + lam * G * c[None, :])[2][-1].conj()
        q = -lam * (P.T @ (c * y)) / D
        lams.append(lam)
        shapes.append(md.phi[dofs, :] @ q)
    psi = np.array(shapes).T
    k = np.argmax(np.abs(psi), axis=0)
    top = psi[k, np.arange(psi.shape[1])]
    order = np.argsort(np.imag(lams))
    return np.array(lams)[order], (psi * (np.abs(top) / top))[:, order]


@dataclass(frozen=True)
class Noise:
    """Measurement chain: complex Gaussian noise ``level`` x ``|H|`` plus a ``floor`` x peak ``|H|``
    per response, and an H1-estimator bias that pulls resonance peaks down by up to ``h1_bias``."""

    level: float = 0.01
    floor: float = 0.0
    h1_bias: float = 0.0


def complex_normal(rng: np.random.Generator, shape, scale=None) -> np.ndarray:
    """``scale (x + i y) / sqrt(2)``, ``x`` and ``y`` standard normal (every real part drawn before every imaginary
    part): complex noise of variance ``scale^2`` (1 without ``scale``), shape ``shape``."""
    z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    return (z if scale is None else scale * z) / math.sqrt(2)


def measure(H: np.ndarray, noise: Noise, rng: np.random.Generator) -> np.ndarray:
    """One noisy measurement of ``H`` (n_resp, n_lines)."""
    mag = np.abs(H)
    peak = mag.max(axis=-1, keepdims=True)
    out = H / (1.0 + noise.h1_bias * mag / peak) if noise.h1_bias else H.copy()
    out = out + noise.level * mag * complex_normal(rng, H.shape)
    if noise.floor:
        out = out + noise.floor * peak * complex_normal(rng, H.shape)
    return out


#: Noise of the modal data: relative sd of frequencies, damping ratios and shape entries (x max |shape|).
MODAL_NOISE = (0.0003, 0.03, 0.005)


def noisy_modal(lam: np.ndarray, psi: np.ndarray, rng: np.random.Generator, noise=MODAL_NOISE):
    """Modal data with relative noise on frequencies, damping ratios and shapes; returns ``(lam, psi)``."""
    sf, sz, sp = noise
    w = np.abs(lam) * (1 + sf * rng.standard_normal(lam.size))
    z = (-lam.real / np.abs(lam)) * (1 + sz * rng.standard_normal(lam.size))
    lam_n = -z * w + 1j * w * np.sqrt(1 - z ** 2)
    scale = np.abs(psi).max(axis=0, keepdims=True)
    psi_n = psi + complex_normal(rng, psi.shape, sp * scale)
    return lam_n, psi_n
