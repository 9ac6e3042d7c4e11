"""Batched simulation of one shard: truth model -> measured modal data -> Pilkey updating.

Every sample is one specimen tested on two days: state 0 = baseline
(undamaged), state 1 = current (damage, plus what changes between test days:
a global stiffness change from temperature and a re-clamped root spring), so
features can be current-minus-baseline as in the thesis's before/after tests.
All randomness of a batch is drawn up front by :func:`datagen.batch_inputs.draw_batch` (fixed
order), so the batched path :func:`simulate_batch` and the per-sample path
:func:`datagen.naive.simulate_naive` consume the same numbers; what every batch of a configuration shares
(the truth mesh, its supports' springs, the start basis) is its :class:`datagen.setup.Setup`.

What is stored is what defines a sample (see :mod:`datagen.store`): the truth
poles and shapes at the measured DOFs, the noisy measured modal data, the
updated ``M, C, K`` with their poles and residues, and a per-sample noise
seed. FRFs are synthesised from those when read (:mod:`datagen.synth`).

Truth model
-----------
Euler-Bernoulli beam of ``mesh.truth_elements`` (or more, aligned with the sensors) equal elements on the test's
supports (:mod:`physics.supports`; the thesis's clamped-free beam by default): clamps optionally on a drawn
rotational spring, pins, a free beam on its suspension; specimen ``EI`` and mass, the
damage of ``damage.kind`` as element corrections ``(dM, dK, dC)`` of the current
state (:mod:`datagen.damage`); a beam file
(``generate --beam FILE``) adds its effects as described in
:mod:`datagen.truth_beam`. Damping:
``C = C_0 + Delta C_damage`` with the specimen's modal damping
``C_0 = M Phi_p diag(2 zeta_j omega_j) Phi_p^T M`` over the first ``p``
undamped modes of the baseline specimen (``zeta_j`` from
``specimen.damping_ratios`` times the specimen's damping scale, the last ratio
for ``j`` beyond the list; a beam file's Rayleigh damping gives the ratios instead), so the
baseline has exactly the prescribed damping ratios (plus a beam file's dashpot, in both states).

Cheap complex modes (the "projection" shortcut)
-----------------------------------------------
Undamped modes by subspace iteration started from the nominal beam's modes
(batched ``solve`` + Rayleigh-Ritz on ``p x p``), then the damped problem is
projected on those ``p`` modes and solved by a fixed-point iteration that
converges at a rate of order ``zeta`` (light damping). Accuracy against the
full state-space solution is checked in ``tests/datagen/test_pipeline.py``.
"""

from __future__ import annotations

import numpy as np

from datagen.batch_inputs import BatchInputs, draw_batch
from datagen.config import OUTPUT_ONLY_VARIABLES, REPEATABILITY, calibrated_modal_std, output_only_variables
from datagen.setup import Setup
from datagen.solvers import light_damping_modes, ritz_modes
from datagen.synth import measured_peak
from physics.fem import assemble
from physics.frf import poles_and_residues
from physics.modal import eigenvalues_from_modal, modal_parameters
from physics.updating import pilkey

__all__ = ["CHUNK", "LABEL_FIELDS", "damage_frequency_drop", "measure_modes", "per_mode", "projected_modes",
           "simulate_batch", "simulate_chunk", "simulate_shard", "truth_matrices", "unit_mass", "update_models"]


def truth_matrices(setup: Setup, inp: BatchInputs):
    """Mass, the stiffness of both test days and the damage's damping of the current state (explicit matrices).

    The current state's stiffness is ``(1 + t) (EI K_0 + dK)`` plus the root
    spring ``k_r (1 + c)`` and its mass ``M + dM``, with ``(dM, dK, dC)`` the
    element corrections of the damage model (:mod:`datagen.damage`), ``t`` the
    temperature stiffness change and ``c`` the re-clamping change. ``M = m M_0``
    plus a beam file's point mass.

    Returns
    -------
    M : ndarray, shape (B, n, n)      baseline mass (kg ...)
    Mu : ndarray                      the same for unit mass per length (:func:`unit_mass`); with a mass
                                      change (B, 2, n, n), state 1 holding ``(M + dM) / m``
    K : ndarray, shape (B, 2, n, n)   N/m ... (state 0 baseline, 1 current)
    dC : ndarray, shape (B, n, n)     damage damping (N s/m ...)
    dK : ndarray, shape (B, n, n)     damage stiffness change (N/m ...)
    """
    ei, mpl = inp.EI_Nm2, inp.mass_per_length_kg_m
    if setup.shear_varies:
        K0, M0, shear_phi = setup.unit_matrices(inp.shear_flexibility)
    else:
        K0, M0, shear_phi = setup.K0, setup.M0, 12.0 * setup.n_elements**2 * setup.shear_band[0]
    dMe, dKe, dCe = setup.damage.corrections(inp.damage, inp.x_m, ei, mpl, setup.length_m, setup.n_elements,
                                             shear_phi)
    shape = (len(inp),) + setup.K0.shape
    dK = np.zeros(shape) if dKe is None else setup.kept(assemble(dKe))
    dC = np.zeros(shape) if dCe is None else setup.kept(assemble(dCe))
    K = np.empty((len(inp), 2) + setup.K0.shape)
    np.multiply(ei[:, None, None], K0, out=K[:, 0])
    np.add(K[:, 0], dK, out=K[:, 1])
    K[:, 1] *= (1.0 + inp.temperature_stiffness_change)[:, None, None]
    if setup.spring:
        r = setup.spring_dofs
        K[:, 1, r, r] += (inp.root_spring_Nm_rad * (1.0 + inp.root_spring_change))[:, None]
        K[:, 0, r, r] += inp.root_spring_Nm_rad[:, None]
    if setup.day_spring_dofs.size:   # the suspension or bearing springs change between the test days
        r = setup.day_spring_dofs
        K[:, 1, r, r] += (ei * inp.root_spring_change)[:, None] * setup.K0_springs[r, r]
    M = mpl[:, None, None] * M0
    if setup.M_added is not None:
        M += setup.M_added
    Mu = unit_mass(setup, inp, M0)
    if dMe is not None:
        base = np.broadcast_to(Mu, (len(inp), 1) + setup.M0.shape)
        Mu = np.concatenate([base, base + (setup.kept(assemble(dMe)) / mpl[:, None, None])[:, None]], axis=1)
    return M, Mu, K, dC, dK


def unit_mass(setup: Setup, inp: BatchInputs, M0):
    """Mass for unit mass per length from the element mass ``M0`` of :func:`truth_matrices` ((n, n) or, with a
    shear flexibility drawn per specimen, (B, n, n)): ``M0`` (n, n), or (B, 1, n, n) with a beam file's point
    mass or per-specimen elements."""
    if setup.M_added is None:
        return M0 if M0.ndim == 2 else M0[:, None]
    return (M0 + setup.M_added / inp.mass_per_length_kg_m[:, None, None])[:, None]


def projected_modes(setup: Setup, inp: BatchInputs, M, Mu, K, dC):
    """Complex modes of both states by the light-damping shortcut (batched).

    Undamped modes by :func:`datagen.solvers.ritz_modes` on the unit-EI,
    unit-mass problem, the baseline specimen's modal damping projected on both
    states' modes plus a beam file's dashpot and the damage damping ``dC``, then
    :func:`datagen.solvers.light_damping_modes`.

    Parameters
    ----------
    M : ndarray, shape (B, n, n)      baseline mass (the specimen's modal damping ``C_0`` is built on it)
    Mu : ndarray                      mass of each state for unit mass per length (:func:`truth_matrices`)
    K : ndarray, shape (B, 2, n, n)   truth stiffness of baseline and current state
    dC : ndarray, shape (B, n, n)     damage damping

    Returns
    -------
    lam : ndarray, complex, shape (B, 2, p)
    psi_meas : ndarray, complex, shape (B, 2, 4, p)   eq.-1.10 shapes at the measured DOFs
    omega2 : ndarray, shape (B, 2, p)                 undamped squared frequencies (rad^2/s^2)
    """
    sol = setup.cfg["solver"]
    ei, mpl = inp.EI_Nm2, inp.mass_per_length_kg_m
    w2s, V = ritz_modes(Mu, K / ei[:, None, None, None], setup.phi0, sol["subspace_iterations"])
    w2 = w2s * (ei / mpl)[:, None, None]
    phi = V / np.sqrt(mpl)[:, None, None, None]                  # (B,2,n,p), phi^T M phi = I
    d = 2 * setup.zeta * np.sqrt(w2[:, 0]) * inp.damping_scale[:, None]     # (B,p)
    X = phi.mT @ (M[:, None] @ phi[:, :1])                      # (B,2,p,p) = Phi_s^T M Phi_baseline
    c = (X * d[:, None, None, :]) @ X.mT
    if setup.C_local is not None:
        c += phi.mT @ setup.C_local @ phi
    c[:, 1] += phi[:, 1].mT @ dC @ phi[:, 1]
    c = 0.5 * (c + c.mT)
    lam, Z = light_damping_modes(w2, c, sol["damping_iterations"])
    at = phi[..., setup.meas, :] if setup.meas.ndim == 1 else setup.meas @ phi
    return lam, at @ Z, w2


def damage_frequency_drop(setup: Setup, inp: BatchInputs, Mu, K, dK, omega2):
    """Largest relative drop of the first four natural frequencies caused by the damage alone.

    Undamped frequencies (subspace iteration). Without day-to-day changes
    that is the drop between the two states' ``omega2`` (B, 2, p); otherwise
    the baseline stiffness plus ``dK`` is solved once more (unit masses ``Mu`` of both states), so
    temperature and re-clamping do not enter this label.

    Returns
    -------
    ndarray, shape (B,)   ``max_r (1 - f_r,damaged / f_r,baseline)`` (>= 0 for a stiffness loss or a mass
                          added; < 0 when every frequency rises, e.g. a mass lost)
    """
    used = setup.modes_idx
    if not setup.day_to_day:
        return np.max(1.0 - np.sqrt(omega2[:, 1, used] / omega2[:, 0, used]), axis=-1)
    Ks = (K[:, 0] + dK) / inp.EI_Nm2[:, None, None]
    K0 = K[:, 0] / inp.EI_Nm2[:, None, None]
    it = setup.cfg["solver"]["subspace_iterations"]
    w2, _ = ritz_modes(Mu, np.stack([K0, Ks], axis=1), setup.phi0, it)
    return np.max(1.0 - np.sqrt(w2[:, 1, used] / w2[:, 0, used]), axis=-1)


# --------------------------------------------------------------------------- measurement + updating
def measure_modes(setup, inp, lam4, psi4):
    """Noisy modal data from noise-free poles (B,2,4) and shapes (B,2,4,4): the modal-noise shortcut.

    Natural frequencies and damping ratios get relative Gaussian errors,
    shapes complex circular errors relative to each mode's largest entry,
    all scaled by the sample's ``modal_noise_scale`` (``measurement.modal_noise_scale``:
    identifications of real files vary beyond what the FRF noise level predicts); each std is
    combined in quadrature with the sample's ``frequency_scatter``, ``damping_scatter`` or
    ``shape_scatter`` (the repeatability of the tests: per-mode changes of each test that
    temperature and re-clamping do not describe), and each sensor's entries are multiplied by
    ``1 + gain_scatter n_gain`` (its channel's gain error in that test, common to its modes).
    The synthesised FRFs carry none of the repeatability terms.
    Standard deviations per mode: ``measurement.frequency_noise`` etc.
    ("fixed"), or ``sqrt((c level)^2 + (g floor)^2 + e^2)`` of the sample's FRF
    noise level and noise floor with the coefficients ``c`` (``*_noise``), ``g``
    (``*_noise_per_floor``) and ``e`` (``*_noise_floor``): "calibrated" against
    the identification ``classify`` runs (``experiments.benches.bench_modal_noise``); "output-only": the same form of
    the sample's sensor noise and record length (:func:`datagen.config.output_only_variables`), calibrated
    against SSI-cov of response records (:mod:`learn.pairs.output_only_calibration`).
    """
    mcfg = setup.cfg["measurement"]
    if mcfg["modal_noise"] in ("calibrated", "output-only"):
        coef = {k: per_mode(mcfg[k], setup.n_modes) for q in ("frequency", "damping", "shape")
                for k in (f"{q}_noise", f"{q}_noise_per_floor", f"{q}_noise_floor")}
        x, y = ((inp.noise_level, inp.noise_floor) if mcfg["modal_noise"] == "calibrated"
                else output_only_variables(inp.sensor_noise, inp.record_length_s))
        sig = calibrated_modal_std(coef, np.asarray(x, float)[:, None, None],
                                   np.asarray(y, float)[:, None, None])   # (B, 1, m)
    else:
        sig = {q: per_mode(mcfg[f"{q}_noise"], setup.n_modes) for q in ("frequency", "damping", "shape")}
    scale = np.asarray(inp.modal_noise_scale, float)[:, None, None]
    sig = {q: v * scale for q, v in sig.items()}
    for q in ("frequency", "damping", "shape"):
        sig[q] = np.hypot(sig[q], np.asarray(getattr(inp, f"{q}_scatter"), float)[:, None, None])
    f, z = modal_parameters(lam4)
    f_m = f * (1 + sig["frequency"] * inp.n_freq)
    z_m = z * (1 + sig["damping"] * inp.n_zeta)
    lam_m = eigenvalues_from_modal(f_m, z_m)
    scale = np.max(np.abs(psi4), axis=-2, keepdims=True) * np.expand_dims(sig["shape"], -2)
    noise = (inp.n_shape[..., 0] + 1j * inp.n_shape[..., 1]) / np.sqrt(2)
    gain = 1 + np.asarray(inp.gain_scatter, float)[:, None, None, None] * inp.n_gain[..., None]
    return lam_m, gain * (psi4 + scale * noise)


def per_mode(values, m: int) -> np.ndarray:
    """A number or per-mode list (modes 1, 2, ...) as ``m`` values, the last repeated beyond the list."""
    v = np.atleast_1d(np.asarray(values, float))
    return np.concatenate([v, np.full(max(m - v.size, 0), v[-1])])[:m]


def update_models(setup, Ma, lam_m, psi_m, batched=True):
    """Pilkey updating of both states on the analyst mass ``Ma`` (B,S,S) with ``S`` modes ``lam_m`` (B,2,S) and
    shapes ``psi_m`` (B,2,S,S): returns a dict of (B,2,...) arrays."""
    up = setup.cfg["updating"]
    B, S = Ma.shape[0], Ma.shape[-1]
    Ma2 = np.repeat(Ma[:, None], 2, axis=1).reshape(2 * B, S, S)
    kw = dict(tol=up["tol"], max_iter=up["max_iter"], raise_on_failure=False,
              check_spurious=False)  # modes of the truth mesh are never consistent with the 4-DOF M
    if batched:
        res = pilkey(Ma2, lam_m.reshape(2 * B, S), psi_m.reshape(2 * B, S, S), **kw)
        parts = {k: getattr(res, k) for k in ("C", "K", "converged", "iterations", "residual")}
    else:
        rs = [pilkey(Ma2[i], lam_m.reshape(2 * B, S)[i], psi_m.reshape(2 * B, S, S)[i], **kw)
              for i in range(2 * B)]
        parts = {k: np.stack([np.asarray(getattr(r, k)) for r in rs])
                 for k in ("C", "K", "converged", "iterations", "residual")}
    return {k: v.reshape((B, 2) + v.shape[1:]) for k, v in parts.items()}


#: Samples per vectorised chunk (cache-sized; fixed so results never depend on it).
CHUNK = 128

#: Drawn inputs recorded per sample (the columns of the samples table and the noise of the FRFs on read).
#: The damage model's parameters (``BatchInputs.damage``) are recorded next to them under their own names.
LABEL_FIELDS = ("EI_Nm2", "mass_per_length_kg_m", "damping_scale", "root_spring_Nm_rad", "n_damages", "x_m",
                "temperature_stiffness_change", "root_spring_change", "noise_level", "noise_floor", "noise_seed",
                "modal_noise_scale", "shear_flexibility", *REPEATABILITY, "support_changed")



def simulate_batch(setup: Setup, inp: BatchInputs, chunk: int = CHUNK) -> dict:
    """Batched pipeline for ``B`` samples, in vectorised chunks of ``chunk`` samples (see :func:`simulate_chunk`)."""
    parts = [simulate_chunk(setup, inp.take(slice(i, i + chunk))) for i in range(0, len(inp), chunk)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def simulate_shard(setup: Setup, seed_seq: np.random.SeedSequence, n: int, chunk: int = CHUNK):
    """Draw and simulate ``n`` samples from one shard's seed, chunk by chunk (bounded memory).

    Returns
    -------
    labels : dict of ndarray
        The drawn inputs (fields ``LABEL_FIELDS`` of :class:`BatchInputs`).
    outputs : dict of ndarray (see :func:`simulate_chunk`)
    """
    rng = np.random.default_rng(seed_seq)
    labs, outs = [], []
    for i in range(0, n, chunk):
        b = draw_batch(rng, min(chunk, n - i), setup)
        outs.append(simulate_chunk(setup, b))
        labs.append({**{k: getattr(b, k) for k in LABEL_FIELDS + OUTPUT_ONLY_VARIABLES if getattr(b, k) is not None},
                     **b.damage})
    cat = lambda parts: {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}  # noqa: E731
    return cat(labs), cat(outs)


def simulate_chunk(setup: Setup, inp: BatchInputs) -> dict:
    """Batched pipeline for ``B`` samples (no Python loop over samples or lines).

    Returns
    -------
    dict of ndarray (state axis 1: 0 = baseline, 1 = current)
        ``truth_poles`` (B,2,p) and ``truth_shapes`` (B,2,4,p): all ``p`` projected truth modes at the
        measured DOFs (and at the reference DOF, one more row, when it is no sensor; the measured FRFs are
        synthesised from them), ``eigenvalues_measured`` (B,2,4),
        ``eigenvectors_measured`` (B,2,4,4) (noisy), ``M_updated`` (B,4,4), ``C_updated``, ``K_updated``
        (B,2,4,4), ``updated_poles`` (B,2,4) and ``updated_residues`` (B,2,4,4) of the updated models
        (drive at the first measured DOF), ``frf_peak`` (B,2,4) (:func:`datagen.synth.measured_peak`),
        ``converged``, ``iterations``, ``residual`` (B,2) and ``damage_frequency_drop`` (B,).
    """
    M, Mu, K, dC, dK = truth_matrices(setup, inp)
    lam, psi, w2 = projected_modes(setup, inp, M, Mu, K, dC)
    used = setup.modes_idx
    B, S, d = len(inp), setup.n_meas, setup.drive_row
    lam_m, psi_m = measure_modes(setup, inp, lam[..., used], psi[..., :S, used])
    Ma = setup.analyst_mass(inp.mass_per_length_kg_m)
    if setup.n_update:
        up = update_models(setup, Ma, lam_m[..., :S], psi_m[..., :S])
        pr = poles_and_residues(Ma[:, None], up["C"], up["K"], np.arange(S), [setup.update_drive_row])
        poles, res = pr.eigenvalues, pr.residues[..., 0, :]
    else:  # fewer modes than sensors: no updated model (stated in the manifest)
        nan = np.full((B, 2, S, S), np.nan)
        up = {"C": nan, "K": nan.copy(), "converged": np.ones((B, 2), bool), "iterations": np.zeros((B, 2), int),
              "residual": np.zeros((B, 2))}
        poles, res = np.full((B, 2, S), np.nan + 0j), np.full((B, 2, S, S), np.nan + 0j)
    peak = measured_peak({"truth_poles": lam, "truth_shapes": psi, "drive_row": d, "n_responses": S,
                          "noise_floor": inp.noise_floor}, setup.omega_rad_s)
    return {"has_update": np.full(B, bool(setup.n_update)), "truth_poles_used": lam[..., used],
            "truth_poles": lam, "truth_shapes": psi, "eigenvalues_measured": lam_m, "eigenvectors_measured": psi_m,
            "M_updated": Ma, "C_updated": up["C"], "K_updated": up["K"], "updated_poles": poles,
            "updated_residues": res, "frf_peak": peak,
            "converged": up["converged"], "iterations": up["iterations"],
            "residual": up["residual"], "damage_frequency_drop": damage_frequency_drop(setup, inp, Mu, K, dK, w2)}
