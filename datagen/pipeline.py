"""Batched simulation: truth model -> measured modal data and FRFs -> Pilkey updating -> updated FRFs.

Every sample is one specimen in two states, index 0 = undamaged reference,
1 = damaged (slits), so features can be damaged-minus-reference as in the
thesis's before/after tests. All randomness of a batch is drawn up front by
:func:`draw_batch` (fixed order), so the batched path :func:`simulate_batch`
and the straightforward per-sample path :func:`simulate_naive` consume the
same numbers and can be compared sample by sample.

Truth model
-----------
Clamped-free Euler-Bernoulli beam of ``mesh.truth_elements`` equal elements
(optionally with a root rotational spring), specimen ``EI`` and mass, slits as
exact partial-element energy corrections (:mod:`datagen.damage`). Damping:
``C = C_0 + Delta C_slits`` with the specimen's modal damping
``C_0 = M Phi_p diag(2 zeta_j omega_j) Phi_p^T M`` over the first ``p``
undamped modes of the undamaged specimen (``zeta_j`` from
``specimen.damping_ratios`` times the specimen's damping scale, the last ratio
for ``j`` beyond the list), so the undamaged specimen has exactly the
prescribed damping ratios.

Cheap complex modes (the "projection" shortcut)
-----------------------------------------------
Undamped modes by subspace iteration started from the nominal beam's modes
(batched ``solve`` + Rayleigh-Ritz on ``p x p``), then the damped problem is
projected on those ``p`` modes and solved by a fixed-point iteration that
converges at a rate of order ``zeta`` (light damping). Accuracy against the
full state-space solution is checked in ``tests/datagen/test_pipeline.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import json

import numpy as np

from datagen.damage import draw_slits, slit_corrections
from datagen.kernels import band_cholesky, band_cholesky_solve, noise_kernel, pair_frf_kernel
from datagen.specimen import BeamPreset, SectionLayout, beam_preset, draw_specimens, slit_section_ei
from physics.errors import ConfigError
from physics.fem import assemble, beam_model, element_mass, element_stiffness, lumped_mass
from physics.modal import eigenvalues_from_modal, modal_parameters, normalize_modes, state_matrix, undamped_modes
from physics.reduction import iirs
from physics.updating import pilkey

N_MEAS = 4          # measured translational DOFs (thesis nodes 2..5)
BANDWIDTH = 3       # half-bandwidth of beam matrices with DOFs ordered node by node
STATES = ("reference", "damaged")


def _t(a):
    return np.swapaxes(a, -1, -2)


# --------------------------------------------------------------------------- setup
@dataclass(frozen=True, eq=False)
class Setup:
    """Everything a batch needs that does not depend on the sample (built once per config).

    Attributes
    ----------
    cfg : dict                      validated configuration
    preset : BeamPreset
    layout : SectionLayout          face/core layout matching the preset's EI (eq. 4.1)
    n_elements : int                truth mesh
    keep : ndarray (n,)             global DOF indices kept after the boundary condition
    spring : bool                   root rotation held by a spring (kept as DOF 0 of the model)
    K0, M0 : ndarray (n, n)         truth matrices for unit EI and unit mass per length
    meas : ndarray (4,)             model indices of the measured translations
    phi0 : ndarray (n, p)           nominal modes (unit mass per length), subspace start
    omega_rad_s : ndarray (F,)      FRF lines
    zeta : ndarray (p,)             target modal damping ratios of modes 1..p
    M_ref4 : None                   (placeholder, analyst mass is per specimen)
    """

    cfg: dict
    preset: BeamPreset
    layout: SectionLayout
    n_elements: int
    keep: np.ndarray
    spring: bool
    K0: np.ndarray
    M0: np.ndarray
    meas: np.ndarray
    phi0: np.ndarray
    omega_rad_s: np.ndarray
    zeta: np.ndarray
    dof_names: tuple = field(default=())

    @property
    def length_m(self) -> float:
        return self.preset.length

    @property
    def p(self) -> int:
        return self.phi0.shape[-1]


def build_setup(cfg: dict) -> Setup:
    """Precompute the nominal truth matrices, measured DOFs, start basis and FRF grid."""
    preset = beam_preset(cfg["preset"])
    sec = cfg["section"]
    layout = SectionLayout.matching(preset.EI, preset.width, preset.thickness, sec["face_thickness_m"],
                                    sec["core_modulus_pa"])
    if cfg["damage"]["depth_m"][1] >= preset.thickness / 2:
        raise ConfigError(f"config key 'damage.depth_m' must stay below half the beam thickness "
                          f"({preset.thickness / 2:g} m)")
    n_el = cfg["mesh"]["truth_elements"]
    le = preset.length / n_el
    spring = bool(cfg["specimen"]["root_spring_relative"])
    K_full = assemble(np.broadcast_to(element_stiffness(1.0, le), (n_el, 4, 4)))
    M_full = assemble(np.broadcast_to(element_mass(1.0, le), (n_el, 4, 4)))
    keep = np.arange(1 if spring else 2, 2 * (n_el + 1))
    names = tuple(f"{n}:{d}" for n in range(1, n_el + 2) for d in ("y", "rz"))
    names = tuple(names[i] for i in keep)
    K0, M0 = K_full[np.ix_(keep, keep)], M_full[np.ix_(keep, keep)]
    step = n_el // 4
    meas = np.array([names.index(f"{1 + step * q}:y") for q in range(1, 5)])
    p = cfg["solver"]["projection_modes"]
    Kn = K0.copy()
    if spring:
        lo, hi = cfg["specimen"]["root_spring_relative"]
        Kn[0, 0] += np.sqrt(lo * hi) / preset.length
    w2, v = _gen_eigh(Kn, M0)
    zr = np.asarray(cfg["specimen"]["damping_ratios"], float)
    zeta = np.concatenate([zr, np.full(max(p - zr.size, 0), zr[-1])])[:p]
    lo, hi = cfg["measurement"]["band_rad_s"]
    return Setup(cfg, preset, layout, n_el, keep, spring, K0, M0, meas, v[:, :p].copy(),
                 np.linspace(lo, hi, cfg["measurement"]["lines"]), zeta, names)


@lru_cache(maxsize=8)
def _setup_cached(cfg_json: str) -> Setup:
    return build_setup(json.loads(cfg_json))


def get_setup(cfg: dict) -> Setup:
    """Cached :func:`build_setup` (keyed by the configuration's JSON)."""
    return _setup_cached(json.dumps(cfg, sort_keys=True))


# --------------------------------------------------------------------------- randomness
@dataclass(frozen=True)
class BatchInputs:
    """All random draws of a batch of ``B`` samples (see :func:`draw_batch`).

    Specimen: ``EI`` (N m^2), ``m_per_length`` (kg/m), ``damping_scale``,
    ``root_spring`` (N m/rad) each (B,). Slits: ``n_slits`` (B,), ``x_m``,
    ``width_m``, ``depth_m``, ``beta_s`` (B, S) NaN-padded, ``ei_loss`` (B, S)
    relative loss of section rigidity. Noise (standard normal, per state
    0 = reference, 1 = damaged): ``n_freq``, ``n_zeta`` (B, 2, 4),
    ``n_shape`` (B, 2, 4, 4, 2); FRF noise as float32 uniforms ``n_frf``
    (B, 2, 4, F, 2) turned into unit-variance circular complex Gaussian noise
    by the Box-Muller transform (about 3x cheaper than drawing normals).
    """

    EI: np.ndarray
    m_per_length: np.ndarray
    damping_scale: np.ndarray
    root_spring: np.ndarray
    n_slits: np.ndarray
    x_m: np.ndarray
    width_m: np.ndarray
    depth_m: np.ndarray
    beta_s: np.ndarray
    ei_loss: np.ndarray
    n_freq: np.ndarray
    n_zeta: np.ndarray
    n_shape: np.ndarray
    n_frf: np.ndarray

    def __len__(self):
        return self.EI.shape[0]

    def take(self, i) -> "BatchInputs":
        """Sub-batch by index (slice or array)."""
        return BatchInputs(**{k: getattr(self, k)[i] for k in self.__dataclass_fields__})


def draw_batch(rng: np.random.Generator, n: int, setup: Setup) -> BatchInputs:
    """Draw specimens, slits and all measurement noise of ``n`` samples, in a fixed order."""
    cfg = setup.cfg
    sp = draw_specimens(rng, n, cfg, setup.preset)
    sl = draw_slits(rng, n, cfg, setup.length_m)
    F = setup.omega_rad_s.size
    nf = rng.standard_normal((n, 2, N_MEAS))
    nz = rng.standard_normal((n, 2, N_MEAS))
    ns = rng.standard_normal((n, 2, N_MEAS, N_MEAS, 2))
    nh = rng.random((n, 2, N_MEAS, F, 2), dtype=np.float32)   # uniforms -> complex Gaussian (Box-Muller)
    ei0 = setup.layout.EI
    loss = np.where(np.isfinite(sl["depth_m"]),
                    1.0 - slit_section_ei(setup.layout, np.nan_to_num(sl["depth_m"])) / ei0, np.nan)
    if not np.all(np.isfinite(sp["root_spring"])) and setup.spring:
        raise ConfigError("config key 'specimen.root_spring_relative' gave an infinite spring")
    return BatchInputs(sp["EI"], sp["m_per_length"], sp["damping_scale"], sp["root_spring"], sl["n_slits"],
                       sl["x_m"], sl["width_m"], sl["depth_m"], sl["beta_s"], loss, nf, nz, ns, nh)


# --------------------------------------------------------------------------- truth model
def truth_matrices(setup: Setup, inp: BatchInputs):
    """Stiffness of both states and the slit damping of the damaged state (explicit matrices).

    Returns
    -------
    K : ndarray, shape (B, 2, n, n)   N/m ... (state 0 reference, 1 damaged)
    M : ndarray, shape (B, n, n)      kg ...
    dC : ndarray, shape (B, n, n)     slit damping (N s/m ...)
    """
    ei = inp.EI
    K = ei[:, None, None] * setup.K0
    if setup.spring:
        K[:, 0, 0] += inp.root_spring
    ok = np.isfinite(inp.x_m)
    dKe, dCe = slit_corrections(np.where(ok, inp.x_m, 0.0), np.where(ok, inp.width_m, 0.0),
                                np.where(ok, inp.ei_loss * ei[:, None], 0.0), np.where(ok, inp.beta_s, 0.0),
                                ei, setup.length_m, setup.n_elements)
    sel = np.ix_(setup.keep, setup.keep)
    dK = assemble(dKe)[(...,) + sel]
    dC = assemble(dCe)[(...,) + sel]
    return np.stack([K, K + dK], axis=1), inp.m_per_length[:, None, None] * setup.M0, dC


def _gen_eigh(K, M):
    """``K v = w M v`` (batched), ``v^T M v = I``, ascending ``w`` (rad^2/s^2): :func:`physics.modal.undamped_modes`."""
    omega, v = undamped_modes(M, K)
    return omega**2, v


def ritz_modes(K, M, start, iterations):
    """Lowest undamped modes by subspace iteration with Rayleigh-Ritz (batched).

    Parameters
    ----------
    K : ndarray, shape (..., n, n)
        Banded (half-bandwidth :data:`BANDWIDTH`), symmetric positive definite.
    M : ndarray, shape (n, n) or (..., n, n)
    start : ndarray, shape (n, p)
    iterations : int

    Returns
    -------
    omega2 : ndarray, shape (..., p)   ascending (rad^2/s^2 for SI K, M)
    phi : ndarray, shape (..., n, p)   ``phi^T M phi = I``
    """
    V = np.broadcast_to(start, K.shape[:-2] + start.shape)
    n = K.shape[-1]
    Kf = np.ascontiguousarray(K).reshape(-1, n, n)
    L = band_cholesky(Kf, BANDWIDTH)  # factor once: beam stiffness is banded (2 DOFs per node)
    for _ in range(iterations):
        MV = np.broadcast_to(M @ V, K.shape[:-2] + V.shape[-2:])
        X = band_cholesky_solve(L, np.ascontiguousarray(MV).reshape(-1, n, V.shape[-1])).reshape(MV.shape)
        Kr = _t(X) @ K @ X
        Mr = _t(X) @ M @ X
        w2, Q = _gen_eigh(0.5 * (Kr + _t(Kr)), 0.5 * (Mr + _t(Mr)))
        V = X @ Q
    return w2, V


def light_damping_modes(omega2, c, iterations):
    """Complex modes of ``z'' + c z' + diag(omega2) z = 0`` for light damping (batched).

    Fixed-point iteration on ``lambda_j`` and the modal-coordinate shape ``z_j``
    (``z_jj = 1``), starting from the uncoupled modes; each pass gains a factor
    of order ``zeta``.

    Parameters
    ----------
    omega2 : ndarray, shape (..., p)      squared undamped frequencies (rad^2/s^2)
    c : ndarray, shape (..., p, p)        modal damping matrix ``Phi^T C Phi`` (1/s)
    iterations : int

    Returns
    -------
    lam : ndarray, complex, shape (..., p)     Im > 0
    Z : ndarray, complex, shape (..., p, p)    columns = modes, eq.-1.10 normalised in modal coordinates
    """
    p = omega2.shape[-1]
    eye = np.eye(p, dtype=bool)
    cd = np.diagonal(c, axis1=-2, axis2=-1)
    lam = (-cd + 1j * np.sqrt(4 * omega2 - cd**2 + 0j)) / 2
    Z = np.broadcast_to(np.eye(p, dtype=complex), c.shape).copy()
    c_off = np.where(eye, 0.0, c)
    for _ in range(iterations):
        # rows k != j: (lam_j^2 + w_k^2 + lam_j c_kk) Z_kj = -lam_j sum_{l != k} c_kl Z_lj
        rhs = -(c_off @ Z) * lam[..., None, :]
        den = lam[..., None, :] ** 2 + omega2[..., :, None] + lam[..., None, :] * cd[..., :, None]
        Z = np.where(eye, 1.0 + 0j, rhs / np.where(eye, 1.0, den))
        b = cd + np.einsum("...jk,...kj->...j", c_off, Z)
        lam = (-b + 1j * np.sqrt(4 * omega2 - b**2)) / 2
    h = 2 * lam * np.einsum("...kj,...kj->...j", Z, Z) + np.einsum("...kj,...kl,...lj->...j", Z, c, Z)
    return lam, Z / np.sqrt(h)[..., None, :]


def projected_modes(setup: Setup, inp: BatchInputs, K, M, dC):
    """Complex modes of both states by the light-damping shortcut (batched).

    Undamped modes by :func:`ritz_modes` on the unit-EI, unit-mass problem,
    the undamaged specimen's modal damping projected on both states' modes
    plus the slit damping ``dC``, then :func:`light_damping_modes`.

    Parameters
    ----------
    K : ndarray, shape (B, 2, n, n)   truth stiffness of reference and damaged state
    M : ndarray, shape (B, n, n)
    dC : ndarray, shape (B, n, n)     slit damping

    Returns
    -------
    lam : ndarray, complex, shape (B, 2, p)
    psi_meas : ndarray, complex, shape (B, 2, 4, p)   eq.-1.10 shapes at the measured DOFs
    """
    sol = setup.cfg["solver"]
    ei, mpl = inp.EI, inp.m_per_length
    w2s, V = ritz_modes(K / ei[:, None, None, None], setup.M0, setup.phi0, sol["subspace_iterations"])
    w2 = w2s * (ei / mpl)[:, None, None]
    phi = V / np.sqrt(mpl)[:, None, None, None]                  # (B,2,n,p), phi^T M phi = I
    d = 2 * setup.zeta * np.sqrt(w2[:, 0]) * inp.damping_scale[:, None]     # (B,p)
    X = _t(phi) @ (M[:, None] @ phi[:, :1])                      # (B,2,p,p) = Phi_s^T M Phi_ref
    c = (X * d[:, None, None, :]) @ _t(X)
    c[:, 1] += _t(phi[:, 1]) @ dC @ phi[:, 1]
    c = 0.5 * (c + _t(c))
    lam, Z = light_damping_modes(w2, c, sol["damping_iterations"])
    return lam, phi[..., setup.meas, :] @ Z


def pair_frf(lam, residues, omega_rad_s, out=None, noise=None):
    """Receptance from conjugate pairs: ``sum_j a_j/(i w - lam_j) + conj(a_j)/(i w - conj(lam_j))``.

    Each pair is one real-coefficient term
    ``(2 i w Re a_j - 2 Re(a_j conj(lam_j))) / (|lam_j|^2 - w^2 - 2 i w Re lam_j)``,
    evaluated in one compiled pass (:func:`datagen.kernels.pair_frf_kernel`).

    Parameters
    ----------
    lam : ndarray, complex, shape (..., m)
    residues : ndarray, complex, shape (..., S, m)     ``a_sj = psi_sj psi_rj``
    omega_rad_s : ndarray, shape (F,)
    out : ndarray, complex, shape (..., S, F), optional
        C-contiguous storage to write into (e.g. complex64 dataset arrays).
    noise : (uniforms, level), optional
        Multiplicative measurement noise ``H (1 + level z)``, ``z`` circular
        complex Gaussian from float32 uniforms of shape (..., S, F, 2) by the
        Box-Muller transform (:func:`datagen.kernels.box_muller`).

    Returns
    -------
    ndarray, complex, shape (..., S, F)
    """
    w = np.ascontiguousarray(omega_rad_s, dtype=float)
    lam = np.asarray(lam, complex)
    batch = lam.shape[:-1]
    m, S = lam.shape[-1], residues.shape[-2]
    lam2 = np.ascontiguousarray(lam.reshape(-1, m))
    res2 = np.ascontiguousarray(np.asarray(residues, complex).reshape(-1, S, m))
    if out is None:
        out = np.empty(batch + (S, w.size), complex)
    uniforms, level = (np.zeros((0, 2), np.float32), 0.0) if noise is None else noise
    pair_frf_kernel(lam2, res2, w, np.ascontiguousarray(uniforms).reshape(-1, 2), float(level),
                    out.reshape(-1, S, w.size))
    return out


def state_space_frf(M, C, K, omega_rad_s, response, reference, out=None):
    """Receptance of any ``(M, C, K)`` from the eigen-decomposition of the state matrix (batched).

    ``H(w) = S_out V diag(1/(i w - lambda)) V^-1 B``. Underdamped members (all
    eigenvalues in conjugate pairs) use the pair form (:func:`pair_frf`);
    others use all ``2n`` poles. Members with non-finite matrices give NaN.

    Returns
    -------
    ndarray, complex, shape (..., n_response, F)   (single reference DOF)
    """
    w = np.asarray(omega_rad_s, float)
    n = M.shape[-1]
    M, C, K = np.broadcast_arrays(np.asarray(M, float), np.asarray(C, float), np.asarray(K, float))
    batch = M.shape[:-2]
    M, C, K = (a.reshape(-1, n, n) for a in (M, C, K))
    good = np.isfinite(C).all(axis=(-2, -1)) & np.isfinite(K).all(axis=(-2, -1))
    Cg = np.where(good[:, None, None], C, 0.0)
    Kg = np.where(good[:, None, None], K, np.eye(n))
    lam, V = np.linalg.eig(state_matrix(M, Cg, Kg))
    Bf = np.zeros(M.shape[:-1] + (1,))
    Bf[:, reference, 0] = 1.0
    Bv = np.concatenate([np.zeros_like(Bf), np.linalg.solve(M, Bf)], axis=-2)
    W = np.linalg.solve(V, Bv.astype(complex))[..., 0]                          # (N, 2n)
    R = V[:, np.atleast_1d(response), :] * W[:, None, :]                          # (N, S, 2n)
    scale = np.max(np.abs(lam), axis=-1, keepdims=True)
    upper = lam.imag > 1e-9 * scale
    pairs = upper.sum(axis=-1) == n
    if pairs.all() and good.all():  # the usual case: straight into the output
        order = np.argsort(np.where(upper, lam.imag, np.inf), axis=-1)[:, :n]
        dest = None if out is None else out.reshape(-1, R.shape[1], w.size)
        H = pair_frf(np.take_along_axis(lam, order, axis=-1), np.take_along_axis(R, order[:, None, :], axis=-1), w,
                     dest)
        return H.reshape(batch + H.shape[1:])
    H = np.empty((M.shape[0], R.shape[1], w.size), complex)
    if pairs.any():
        order = np.argsort(np.where(upper, lam.imag, np.inf), axis=-1)[:, :n][pairs]
        lp = np.take_along_axis(lam[pairs], order, axis=-1)
        rp = np.take_along_axis(R[pairs], order[:, None, :], axis=-1)
        H[pairs] = pair_frf(lp, rp, w)
    if (~pairs).any():
        poles = 1.0 / (1j * w - lam[~pairs][:, :, None])
        H[~pairs] = R[~pairs] @ poles
    H[~good] = np.nan
    if out is not None:
        out.reshape(H.shape)[...] = H
        return out
    return H.reshape(batch + H.shape[1:])


def full_complex_modes(M, C, K, m):
    """Lowest ``m`` underdamped complex modes of one model from the full state-space eigenproblem.

    Unlike :func:`physics.modal.complex_modes` this tolerates overdamped
    high-order modes (local stiffness-proportional slit damping overdamps the
    mesh's highest modes); they are simply not returned.

    Returns
    -------
    lam : ndarray, complex, shape (m,)      Im > 0, ascending
    psi : ndarray, complex, shape (n, m)    eq.-1.10 normalised
    """
    n = M.shape[-1]
    ev, vec = np.linalg.eig(state_matrix(M, C, K))
    up = ev.imag > 1e-9 * np.max(np.abs(ev))
    order = np.flatnonzero(up)[np.argsort(ev.imag[up])][:m]
    lam = ev[order]
    return lam, normalize_modes(lam, vec[:n, order], M, C)


@lru_cache(maxsize=8)
def _unit_iirs_mass(length_m: float) -> np.ndarray:
    """IIRS-reduced mass of the 4-element clamped beam with ``EI = 1`` and ``m = 1``."""
    model = beam_model(4, length_m, 1.0, 1.0)
    red = iirs(model.M, model.K, model.index(["2:y", "3:y", "4:y", "5:y"]))
    return 0.5 * (red.M + red.M.T)


def analyst_mass(setup: Setup, ei, mpl):
    """Mass matrix the updating trusts: IIRS of the 4-element clamped FE model, or eq. 4.6 (batched).

    For a uniform beam ``K = EI K1`` and ``M = m M1``: the IIRS transformation
    (eq. 3.42) only sees ``M_R^-1 K_R`` next to ``K_ss^-1 M_s.``, where the
    factors ``EI`` and ``m`` cancel, so the reduced mass is exactly ``m`` times
    the reduced unit mass (tested against a direct IIRS).

    Returns
    -------
    ndarray, shape (B, 4, 4)   kg
    """
    L = setup.length_m
    if setup.cfg["updating"]["mass_model"] == "lumped":
        return lumped_mass(mpl, L / 4)
    return np.asarray(mpl, float)[:, None, None] * _unit_iirs_mass(float(L))


# --------------------------------------------------------------------------- measurement + updating
def _measure(setup, inp, lam4, psi4):
    """Noisy modal data from noise-free eigenvalues (B,2,4) and shapes (B,2,4,4)."""
    mcfg = setup.cfg["measurement"]
    f, z = modal_parameters(lam4)
    f_m = f * (1 + mcfg["frequency_noise"] * inp.n_freq)
    z_m = z * (1 + mcfg["damping_noise"] * inp.n_zeta)
    lam_m = eigenvalues_from_modal(f_m, z_m)
    scale = np.max(np.abs(psi4), axis=-2, keepdims=True)
    noise = (inp.n_shape[..., 0] + 1j * inp.n_shape[..., 1]) / np.sqrt(2)
    return lam_m, psi4 + mcfg["shape_noise"] * scale * noise


def _finish(setup, inp, lam_true, psi_true, lam_m, psi_m, H_meas, Ma, up):
    C, K, phi_n, conv, iters, resid = up
    return {
        "eigenvalues_true": lam_true, "eigenvectors_true": psi_true,
        "eigenvalues_measured": lam_m, "eigenvectors_measured": psi_m,
        "frf_measured": H_meas, "M_updated": Ma, "C_updated": C, "K_updated": K,
        "converged": conv, "iterations": iters, "residual": resid,
    }


#: Samples per vectorised chunk (cache-sized; fixed so results never depend on it).
CHUNK = 128


def simulate_batch(setup: Setup, inp: BatchInputs, chunk: int = CHUNK) -> dict:
    """Batched pipeline for ``B`` samples, in vectorised chunks of ``chunk`` samples.

    See :func:`_simulate_chunk` for the outputs.
    """
    parts = [_simulate_chunk(setup, inp.take(slice(i, i + chunk))) for i in range(0, len(inp), chunk)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


LABEL_FIELDS = ("EI", "m_per_length", "damping_scale", "root_spring", "n_slits", "x_m", "width_m", "depth_m",
                "beta_s", "ei_loss")


def simulate_shard(setup: Setup, seed_seq: np.random.SeedSequence, n: int, chunk: int = CHUNK):
    """Draw and simulate ``n`` samples from one shard's seed, chunk by chunk (bounded memory).

    FRFs are written straight into arrays of ``output.frf_dtype``.

    Returns
    -------
    labels : dict of ndarray
        The drawn specimen and slit parameters (fields ``LABEL_FIELDS`` of :class:`BatchInputs`).
    outputs : dict of ndarray (see :func:`_simulate_chunk`)
    """
    rng = np.random.default_rng(seed_seq)
    frf_dtype = np.dtype(setup.cfg["output"]["frf_dtype"])
    frfs = {k: np.empty((n, 2, N_MEAS, setup.omega_rad_s.size), frf_dtype) for k in ("frf_measured", "frf_updated")}
    labs, outs = [], None
    for i in range(0, n, chunk):
        b = draw_batch(rng, min(chunk, n - i), setup)
        o = _simulate_chunk(setup, b, {k: v[i:i + len(b)] for k, v in frfs.items()})
        if outs is None:
            outs = {k: np.empty((n,) + v.shape[1:], v.dtype) for k, v in o.items() if k not in frfs}
            outs.update(frfs)
        for k, v in o.items():
            if k not in frfs:
                outs[k][i:i + len(b)] = v
        labs.append({k: getattr(b, k) for k in LABEL_FIELDS})
    return {k: np.concatenate([p[k] for p in labs]) for k in labs[0]}, outs


def _simulate_chunk(setup: Setup, inp: BatchInputs, frf_out=None) -> dict:
    """Batched pipeline for ``B`` samples (no Python loop over samples or lines).

    ``frf_out`` optionally maps ``"frf_measured"`` and ``"frf_updated"`` to
    C-contiguous arrays of shape (B,2,4,F) (e.g. complex64 dataset storage)
    that the FRF kernels write into directly.

    Returns
    -------
    dict of ndarray (state axis 1: 0 = reference, 1 = damaged)
        ``eigenvalues_true`` (B,2,4), ``eigenvectors_true`` (B,2,4,4) at the measured DOFs,
        ``eigenvalues_measured``, ``eigenvectors_measured`` (noisy), ``frf_measured`` (B,2,4,F),
        ``M_updated`` (B,4,4), ``C_updated``, ``K_updated`` (B,2,4,4), ``converged``,
        ``iterations``, ``residual`` (B,2), ``frf_updated`` (B,2,4,F).
    """
    cfg = setup.cfg
    B = len(inp)
    K, M, dC = truth_matrices(setup, inp)
    lam, psi_meas = projected_modes(setup, inp, K, M, dC)
    lam_true, psi_true = lam[..., :N_MEAS], psi_meas[..., :N_MEAS]
    frf_out = frf_out or {}
    H_meas = pair_frf(lam, psi_meas * psi_meas[..., :1, :], setup.omega_rad_s, frf_out.get("frf_measured"),
                      (inp.n_frf, cfg["measurement"]["frf_noise"]))
    lam_m, psi_m = _measure(setup, inp, lam_true, psi_true)
    Ma = analyst_mass(setup, inp.EI, inp.m_per_length)
    Ma2 = np.repeat(Ma[:, None], 2, axis=1).reshape(2 * B, N_MEAS, N_MEAS)
    res = pilkey(Ma2, lam_m.reshape(2 * B, N_MEAS), psi_m.reshape(2 * B, N_MEAS, N_MEAS),
                 tol=cfg["updating"]["tol"], max_iter=cfg["updating"]["max_iter"], raise_on_failure=False,
                 check_spurious=False)  # modes of the 20-element truth are never consistent with the 4-DOF M
    up = tuple(a.reshape((B, 2) + a.shape[1:])
               for a in (res.C, res.K, res.eigenvectors, res.converged, res.iterations, res.residual))
    out = _finish(setup, inp, lam_true, psi_true, lam_m, psi_m, H_meas, Ma, up)
    out["frf_updated"] = state_space_frf(Ma[:, None], up[0], up[1], setup.omega_rad_s,
                                         np.arange(N_MEAS), 0, frf_out.get("frf_updated"))
    return out


# --------------------------------------------------------------------------- naive reference
def simulate_naive(setup: Setup, inp: BatchInputs, modes: str = "full") -> dict:
    """One-sample-at-a-time implementation of the same pipeline (benchmark and cross-check).

    ``modes="full"``: exact undamped modes (for ``C_0``) and the state-space
    complex eigen-solution of the truth model, all modes in the measured FRF.
    ``modes="projection"``: the batched path's shortcut, called per sample.
    Updating with :func:`physics.updating.pilkey` and updated FRFs by direct
    inversion (:func:`physics.frf.receptance`).
    """
    from physics.frf import receptance, receptance_modal

    cfg = setup.cfg
    results = []
    for i in range(len(inp)):
        s = inp.take(slice(i, i + 1))
        K, M, dC = truth_matrices(setup, s)
        if modes == "full":
            w2r, phir = _gen_eigh(K[0, 0], M[0])
            p = setup.p
            d = 2 * setup.zeta * np.sqrt(w2r[:p]) * s.damping_scale[0]
            C0 = M[0] @ (phir[:, :p] * d) @ phir[:, :p].T @ M[0]
            lam_l, psi_l, H_l = [], [], []
            for st in range(2):
                C = C0 + (dC[0] if st else 0.0)
                lam_s, psi_s = full_complex_modes(M[0], C, K[0, st], setup.p)
                lam_l.append(lam_s)
                psi_l.append(psi_s[setup.meas])
                H_l.append(state_space_frf(M[0], C, K[0, st], setup.omega_rad_s, setup.meas, setup.meas[0]))
            lam = np.stack(lam_l)[None]
            psi = np.stack(psi_l)[None]
            H = np.stack(H_l)[None]
        elif modes == "projection":
            lam, psi = projected_modes(setup, s, K, M, dC)
            H = receptance_modal(lam, psi, setup.omega_rad_s, np.arange(N_MEAS), [0])[..., 0, :]
        else:
            raise ValueError(f"modes must be 'full' or 'projection', got {modes!r}")
        lam_true, psi_true = lam[..., :N_MEAS], psi[..., :N_MEAS]
        H_meas = np.empty(H.shape, complex)  # the same noise model, applied to this sample's FRFs
        noise_kernel(np.ascontiguousarray(H).reshape(-1), s.n_frf.reshape(-1, 2), cfg["measurement"]["frf_noise"],
                     H_meas.reshape(-1))
        lam_m, psi_m = _measure(setup, s, lam_true, psi_true)
        Ma = analyst_mass(setup, s.EI, s.m_per_length)
        ups = [pilkey(Ma[0], lam_m[0, st], psi_m[0, st], tol=cfg["updating"]["tol"],
                      max_iter=cfg["updating"]["max_iter"], raise_on_failure=False, check_spurious=False)
               for st in range(2)]
        C = np.stack([u.C for u in ups])[None]
        Kq = np.stack([u.K for u in ups])[None]
        up = (C, Kq, np.stack([u.eigenvectors for u in ups])[None], np.array([[u.converged for u in ups]]),
              np.array([[u.iterations for u in ups]]), np.array([[u.residual for u in ups]]))
        out = _finish(setup, s, lam_true, psi_true, lam_m, psi_m, H_meas, Ma, up)
        with np.errstate(all="ignore"):
            Hu = np.stack([receptance(Ma[0], C[0, st], Kq[0, st], setup.omega_rad_s, np.arange(N_MEAS), [0])
                           [:, 0, :] if np.all(np.isfinite(C[0, st])) and np.all(np.isfinite(Kq[0, st]))
                           else np.full((N_MEAS, setup.omega_rad_s.size), np.nan + 0j) for st in range(2)])
        out["frf_updated"] = Hu[None]
        results.append(out)
    return {k: np.concatenate([r[k] for r in results]) for k in results[0]}
