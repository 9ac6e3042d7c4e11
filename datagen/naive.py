"""One-sample-at-a-time implementation of the dataset pipeline (benchmark reference and cross-check only).

:func:`simulate_naive` runs the pipeline of :mod:`datagen.pipeline` on one
sample at a time, from the same drawn inputs, and computes the FRFs eagerly
as a straightforward implementation would (with the same measurement noise).
``tests/datagen`` compares it with the batched path; ``experiments.benches.bench_datagen``
times it.
"""

from __future__ import annotations

import numpy as np

from datagen.batch_inputs import BatchInputs
from datagen.pipeline import damage_frequency_drop, measure_modes, projected_modes, truth_matrices, update_models
from datagen.setup import Setup
from datagen.synth import add_noise
from physics.frf import poles_and_residues, receptance, receptance_modal, receptance_state_space
from physics.modal import underdamped_modes, undamped_modes

__all__ = ["simulate_naive"]


def simulate_naive(setup: Setup, inp: BatchInputs, solution: str = "full") -> dict:
    """Per-sample pipeline: the outputs of :func:`datagen.pipeline.simulate_chunk` plus eager FRFs.

    ``solution="full"``: exact undamped modes (for ``C_0``) and the state-space
    complex eigen-solution of the truth model, all modes in the measured FRF
    (state-space route). ``solution="projection"``: the batched path's shortcut,
    called per sample, FRFs by modal superposition
    (:func:`physics.frf.receptance_modal`). Updating with
    :func:`physics.updating.pilkey` per state; updated FRFs by direct
    inversion (:func:`physics.frf.receptance`).

    Returns
    -------
    dict of ndarray: the keys of ``simulate_chunk`` plus ``frf_measured`` and
    ``frf_updated`` (B, 2, 4, F) complex128.
    """
    w = setup.omega_rad_s
    S, drive, used = setup.n_meas, setup.drive_row, setup.modes_idx
    if not setup.n_update:
        raise ValueError("simulate_naive needs an updated model: as many modes as sensors or more")
    results = []
    for i in range(len(inp)):
        s = inp.take(slice(i, i + 1))
        M, Mu, K, dC, dK = truth_matrices(setup, s)
        if solution == "full":
            wr, phir = undamped_modes(M[0], K[0, 0])
            p = setup.p
            d = 2 * setup.zeta * wr[:p] * s.damping_scale[0]
            C0 = M[0] @ (phir[:, :p] * d) @ phir[:, :p].T @ M[0]
            if setup.C_local is not None:
                C0 = C0 + setup.C_local
            # a mass change: the current state's mass is m Mu[1] (Mu of both states, truth_matrices)
            Ms = [M[0], Mu[0, 1] * s.mass_per_length_kg_m[0] if Mu.ndim == 4 and Mu.shape[1] == 2 else M[0]]
            lam_l, psi_l, H_l = [], [], []
            for st in range(2):
                C = C0 + (dC[0] if st else 0.0)
                cm = underdamped_modes(Ms[st], C, K[0, st], setup.p)
                lam_l.append(cm.eigenvalues)
                psi_l.append(cm.eigenvectors[setup.meas])
                H_l.append(receptance_state_space(Ms[st], C, K[0, st], w, setup.meas, [setup.meas[drive]])[:, 0, :])
            lam, psi, H = np.stack(lam_l)[None], np.stack(psi_l)[None], np.stack(H_l)[None]
            w2 = np.stack([undamped_modes(Ms[st], K[0, st])[0][:setup.p] ** 2 for st in range(2)])[None]
        elif solution == "projection":
            lam, psi, w2 = projected_modes(setup, s, M, Mu, K, dC)
            H = receptance_modal(lam, psi, w, np.arange(S), [drive])[..., 0, :]
        else:
            raise ValueError(f"solution must be 'full' or 'projection', got {solution!r}")
        lam_m, psi_m = measure_modes(setup, s, lam[..., used], psi[..., used])
        Ma = setup.analyst_mass(s.mass_per_length_kg_m)
        up = update_models(setup, Ma, lam_m[..., :S], psi_m[..., :S], batched=False)
        pr = poles_and_residues(Ma[:, None], up["C"], up["K"], np.arange(S), [drive])
        poles, res = pr.eigenvalues, pr.residues[..., 0, :]
        with np.errstate(all="ignore"):
            Hu = np.stack([receptance(Ma[0], up["C"][0, st], up["K"][0, st], w, np.arange(S), [drive])[:, 0, :]
                           if np.all(np.isfinite(up["C"][0, st])) and np.all(np.isfinite(up["K"][0, st]))
                           else np.full((S, w.size), np.nan + 0j) for st in range(2)])[None]
        results.append({
            "truth_poles": lam, "truth_shapes": psi, "eigenvalues_measured": lam_m, "eigenvectors_measured": psi_m,
            "M_updated": Ma, "C_updated": up["C"], "K_updated": up["K"], "updated_poles": poles,
            "updated_residues": res, "converged": up["converged"], "iterations": up["iterations"],
            "residual": up["residual"], "damage_frequency_drop": damage_frequency_drop(setup, s, Mu, K, dK, w2),
            "frf_measured": add_noise(H, s.noise_seed, s.noise_level, s.noise_floor), "frf_updated": Hu})
    return {k: np.concatenate([r[k] for r in results]) for k in results[0]}
