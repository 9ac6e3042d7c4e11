"""Damping, complex modes, receptance FRFs and the measurement chain of the independent simulator.

Damping lives in modal coordinates ``q`` of all undamped modes (``u = phi q``):
a diagonal part from the damping model (modal ratios ``2 zeta_r omega_r``, or
Rayleigh ``alpha + beta omega_r^2``) plus ``phi^T C phi`` of the local dashpots.
Diagonal damping gives FRFs by modal superposition of every mode of the model.
Non-proportional damping is solved in the balanced first-order form
``z = [Omega q, q']``, ``A = [[0, Omega], [-Omega, -C_q]]`` (its norm is
``omega_max``, not ``omega_max^2``, which keeps the low eigenvalues accurate),
and the FRF is ``C (i w I - A)^-1 B`` through the eigen-decomposition of ``A``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.second_sim.fem import Assembled, Modes


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


def _modal_damping(asm: Assembled, md: Modes, damping: Damping) -> tuple[np.ndarray, np.ndarray | None]:
    d = damping.diagonal(md.omega_rad_s)
    if not np.any(asm.C):
        return d, None
    Cq = md.phi.T @ asm.C @ md.phi
    Cq[np.diag_indices_from(Cq)] += d
    return d, Cq


def _state_space(md: Modes, Cq: np.ndarray):
    n = md.omega_rad_s.size
    Om = np.diag(md.omega_rad_s)
    A = np.block([[np.zeros((n, n)), Om], [-Om, -Cq]])
    lam, V = np.linalg.eig(A)
    return lam, V, np.linalg.inv(V)


def receptance(asm: Assembled, md: Modes, damping: Damping, freq_hz, resp_dofs, ref_dof: int) -> np.ndarray:
    """Receptance ``H`` (m/N) at free DOFs ``resp_dofs`` driven at ``ref_dof``, shape (n_resp, n_lines).

    Modal superposition of every mode of the model (exact for the discrete model).
    """
    w = 2 * math.pi * np.asarray(freq_hz, dtype=float)
    resp = np.asarray(resp_dofs)
    d, Cq = _modal_damping(asm, md, damping)
    if Cq is None:
        num = md.phi[resp, :] * md.phi[ref_dof, :]                      # (n_resp, n)
        den = md.omega_rad_s[:, None] ** 2 - w[None, :] ** 2 + 1j * w[None, :] * d[:, None]
        return num @ (1.0 / den)
    lam, V, W = _state_space(md, Cq)
    n = md.omega_rad_s.size
    out = (md.phi[resp, :] / md.omega_rad_s) @ V[:n, :]                   # displacement from Omega q
    inp = W[:, n:] @ md.phi[ref_dof, :]                                   # force enters q''
    return (out * inp) @ (1.0 / (1j * w[None, :] - lam[:, None]))


def complex_modes(asm: Assembled, md: Modes, damping: Damping, dofs, n_modes: int = 4):
    """The first ``n_modes`` damped modes: eigenvalues (upper half-plane, rad/s) and shapes at ``dofs``.

    Returns
    -------
    lam : ndarray, complex, shape (n_modes,)
        ``-zeta w + i w sqrt(1 - zeta^2)``, sorted by imaginary part.
    psi : ndarray, complex, shape (len(dofs), n_modes)
        Displacement shapes, each scaled so that its largest entry is real and positive.
    """
    dofs = np.asarray(dofs)
    d, Cq = _modal_damping(asm, md, damping)
    if Cq is None:
        w = md.omega_rad_s[:n_modes]
        lam = -d[:n_modes] / 2 + 1j * np.sqrt(w ** 2 - d[:n_modes] ** 2 / 4 + 0j)
        return lam, md.phi[dofs, :n_modes].astype(complex)
    lam, V, _ = _state_space(md, Cq)
    n = md.omega_rad_s.size
    up = np.nonzero(lam.imag > 1e-9 * np.abs(lam))[0]
    up = up[np.argsort(lam[up].imag)][:n_modes]
    psi = (md.phi[dofs, :] / md.omega_rad_s) @ V[:n, up]
    k = np.argmax(np.abs(psi), axis=0)
    psi = psi * (np.abs(psi[k, np.arange(psi.shape[1])]) / psi[k, np.arange(psi.shape[1])])
    return lam[up], psi


@dataclass(frozen=True)
class Noise:
    """Measurement chain: complex Gaussian noise ``level`` x ``|H|`` plus a ``floor`` x peak ``|H|``
    per response, and an H1-estimator bias that pulls resonance peaks down by up to ``h1_bias``."""

    level: float = 0.01
    floor: float = 0.0
    h1_bias: float = 0.0


def measure(H: np.ndarray, noise: Noise, rng: np.random.Generator) -> np.ndarray:
    """One noisy measurement of ``H`` (n_resp, n_lines)."""
    mag = np.abs(H)
    peak = mag.max(axis=-1, keepdims=True)
    out = H / (1.0 + noise.h1_bias * mag / peak) if noise.h1_bias else H.copy()

    def cn():
        return (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / math.sqrt(2)

    out = out + noise.level * mag * cn()
    if noise.floor:
        out = out + noise.floor * peak * cn()
    return out
