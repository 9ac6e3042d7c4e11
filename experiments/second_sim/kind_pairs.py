"""Pairs of the thesis's sandwich cantilever (beam 5) with a face-core debond, a slit or a mass added.

Each pair: a specimen (composite ``EI`` within +-3 % of Table 4.1's 22.674 N m^2, mass per length within +-3 %, a
root spring ``k L / EI`` log-uniform in 300-3000, modal damping ratios 0.3-2 %) tested twice, the second time
with one change:

* ``debond``: the top face debonded from the core over 1-10 % of the length (tips on the 120-element mesh, 5.1 mm
  apart) centred in 0.05-0.9 L, on the layered model (:mod:`.layered`: faces sliding freely over it, or with
  ``tied_tips`` held at its tips), the contact's friction as stiffness-proportional damping over it
  (``beta`` in 0-1e-4 s of the debonded section's stiffness, added to each mode's ratio as
  ``beta EI_d phi^T G phi / (2 omega)``, ``G`` the debonded elements' unit bending stiffness);
* ``slit``: ``EI`` lost by 30-90 % over 1-10 mm centred in 0.02-0.9 L (:class:`.fem.Slit`);
* ``mass``: a point mass of 1-5 % of the beam's mass at 0.05-1.0 L (:class:`.fem.PointMass`);
* ``intact``: none.

Files as :func:`.pairs.write_pairs` writes them (UFF receptances with 1 % noise, modal JSON with
:data:`.response.MODAL_NOISE`); ``truth.json`` holds each pair's ``change``, ``x_m`` and ``size`` (the hinge
flexibility ``l r / ((1 - r) L)`` of a debond or slit, the mass ratio of a mass).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from experiments.second_sim.fem import Beam, PointMass, Slit, assemble, modes
from experiments.second_sim.layered import Sandwich, debond_ei, face_modulus_for, layered_assembled
from experiments.second_sim.pairs import DOF_LABELS, LENGTH_M, MASS_PER_LENGTH_KG_M, NODE_X_M, THICKNESS_M, \
    WIDTH_M, FREQ_HZ, PairRecord
from experiments.second_sim.response import Damping, Noise, complex_modes, measure, noisy_modal, receptance
from experiments.second_sim.writers import modal_dict

__all__ = ["CHANGES", "EI_TABLE_4_1_NM2", "simulate_kind_pair", "simulate_kind_pairs"]

#: The changes a pair may hold.
CHANGES = ("debond", "slit", "mass", "intact")
#: Table 4.1's EI of beam 5 (N m^2); the section: 0.5 mm faces on a 0.1 GPa core (the face modulus follows).
EI_TABLE_4_1_NM2 = 22.674
FACE_THICKNESS_M, CORE_MODULUS_PA = 0.0005, 1.0e8
#: Elements of the layered model (debond tips on its nodes) and of the slit/mass model.
N_LAYERED = 120


def _specimen(rng):
    EI = EI_TABLE_4_1_NM2 * (1 + rng.uniform(-0.03, 0.03))
    m = MASS_PER_LENGTH_KG_M * (1 + rng.uniform(-0.03, 0.03))
    k_rel = math.exp(rng.uniform(math.log(300), math.log(3000)))
    ratios = tuple(rng.uniform(0.003, 0.02, 4))
    return EI, m, k_rel * EI / LENGTH_M, ratios


def _tests(asms, ratios, extra, rng, modal_rng, noise, freq_hz):
    """FRFs and modal data of the two states ``asms`` (each with its extra modal damping ratios)."""
    H, modal, f = [], [], []
    for asm, more in zip(asms, extra):
        md = modes(asm)
        z = np.concatenate([ratios, np.full(md.omega_rad_s.size - len(ratios), ratios[-1])]) + more(md)
        damping = Damping("modal", tuple(z))
        dofs = asm.translation_dofs(NODE_X_M[1:])
        H.append(measure(receptance(asm, md, damping, freq_hz, dofs, dofs[0]), noise, rng))
        f.append(md.frequencies_hz[:4])
        modal.append(modal_dict(*noisy_modal(*complex_modes(asm, md, damping, dofs, 4), modal_rng), DOF_LABELS))
    return H, modal, f


def simulate_kind_pair(change: str, pair: int, rng, modal_rng, tied_tips: bool = False, freq_hz=FREQ_HZ,
                       noise: Noise = Noise(0.01)) -> PairRecord:
    """One specimen's two tests with ``change`` (module docstring)."""
    EI, m, k_theta, ratios = _specimen(rng)
    L = LENGTH_M
    none = lambda md: 0.0  # noqa: E731
    truth = {"pair": pair, "set": f"kinds-{'tied' if tied_tips else 'sliding'}", "change": change,
             "damaged": change != "intact", "x_m": None, "size": 0.0, "EI_Nm2": EI, "mass_per_length_kg_m": m,
             "root_k_theta_Nm_rad": k_theta, "damping_ratios": list(ratios)}
    if change == "debond":
        ef = face_modulus_for(EI, WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, CORE_MODULUS_PA)
        sec = Sandwich(WIDTH_M, THICKNESS_M, FACE_THICKNESS_M, ef, CORE_MODULUS_PA)
        h = L / N_LAYERED
        k = int(rng.integers(round(0.01 * N_LAYERED), round(0.10 * N_LAYERED) + 1))
        start = int(np.clip(round(rng.uniform(0.05, 0.9) * N_LAYERED - k / 2), 0, N_LAYERED - k))
        beta = rng.uniform(0.0, 1e-4)
        base, _ = layered_assembled(L, sec, m, (), N_LAYERED, tied_tips, k_theta)
        cur, G = layered_assembled(L, sec, m, [(start * h, (start + k) * h)], N_LAYERED, tied_tips, k_theta)
        r = 1 - debond_ei(sec) / EI

        def contact(md):
            return beta * debond_ei(sec) * np.einsum("ir,ij,jr->r", md.phi, G, md.phi) / (2 * md.omega_rad_s)

        truth.update(x_m=(start + k / 2) * h, length_m=k * h, size=k * h * r / ((1 - r) * L), ei_loss=r,
                     damping_s=beta, tied_tips=tied_tips)
        asms, extra = (base, cur), (none, contact)
    else:
        specimen = Beam(L, EI, m, root_k_theta_Nm_rad=k_theta)
        current = specimen
        if change == "slit":
            s = Slit(x_m=rng.uniform(0.02, 0.9) * L, width_m=rng.uniform(1e-3, 10e-3),
                     ei_loss_fraction=rng.uniform(0.3, 0.9))
            current = replace(specimen, slits=(s,))
            truth.update(x_m=s.x_m, size=s.hinge_flexibility(L), width_m=s.width_m, ei_loss=s.ei_loss_fraction)
        elif change == "mass":
            ratio = rng.uniform(0.01, 0.05)
            p = PointMass(rng.uniform(0.05, 1.0) * L, ratio * m * L)
            current = replace(specimen, masses=(p,))
            truth.update(x_m=p.x_m, size=ratio, mass_kg=p.mass_kg)
        elif change != "intact":
            raise ValueError(f"unknown change {change!r}; expected one of {CHANGES}")
        asms, extra = (assemble(specimen), assemble(current)), (none, none)
    H, modal, f = _tests(asms, ratios, extra, rng, modal_rng, noise, freq_hz)
    truth.update(baseline_frequencies_hz=[float(v) for v in f[0]], current_frequencies_hz=[float(v) for v in f[1]],
                 baseline=f"pair-{pair:03d}_baseline.json", current=f"pair-{pair:03d}_current.json")
    return PairRecord(pair, truth, np.asarray(freq_hz, float), H[0], H[1], "receptance", tuple(modal))


def simulate_kind_pairs(n_per_change: int, seed: int, changes=CHANGES, tied_tips: bool = False,
                        freq_hz=FREQ_HZ) -> list[PairRecord]:
    """``n_per_change`` pairs of each change (in turn), reproducible from ``seed``."""
    rng, modal_rng = np.random.default_rng(seed), np.random.default_rng([seed, 1])
    order = [c for _ in range(n_per_change) for c in changes]
    return [simulate_kind_pair(c, k, rng, modal_rng, tied_tips, freq_hz) for k, c in enumerate(order)]
