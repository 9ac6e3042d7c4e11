"""Hidden-effect cases for the discrepancy workflow.

Each case is a beam-5-like clamped cantilever whose EI (+-8 %) and mass (+-5 %)
are off nominal, with at most one hidden effect (names as the project's beam
file): ``none``; ``root_flexibility`` (rotational root spring, ``k L / EI`` in
5, 13, 40, 100); ``added_mass`` (tip mass 1, 3, 10 % of ``m L``; mass at ``L/4``
5, 20 %); ``shear_deformation`` (``kGA / (EI / L^2)`` in 100, 300, 2000, with
rotary inertia); ``local_damping`` (dashpot at ``L/4`` adding up to 0.5 % or
2 % damping ratio to a mode of 1-4). The base damping of each case is modal or
Rayleigh, drawn. Per case: modal JSON (4 complex modes at ``2:y..5:y`` with
noise 0.03 % on frequencies, 3 % on damping ratios, 0.5 % on shapes), a
frequency-only JSON and a UFF58 baseline test (1 % FRF noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.second_sim.fem import Beam, Dashpot, PointMass, assemble, modes
from experiments.second_sim.pairs import (DOF_LABELS, EI_NM2, FREQ_HZ, LENGTH_M, MASS_PER_LENGTH_KG_M, NODE_X_M,
                                          REF_NODE, RESP_NODES, RHO_I_KG_M)
from experiments.second_sim.response import (MODAL_NOISE, Damping, Noise, complex_modes, measure, noisy_modal,
                                              rayleigh_for, receptance)
from experiments.second_sim.writers import modal_dict, write_json, write_uff

__all__ = ["CASES", "EffectCase", "FRF_NOISE", "effect_cases", "write_effect_cases"]


#: (effect, label, value) of every case, in order.
CASES = (
    [("none", "none", 0.0)]
    + [("root_flexibility", "k_L_over_EI", v) for v in (5.0, 13.0, 40.0, 100.0)]
    + [("added_mass", "tip_mass_fraction", v) for v in (0.01, 0.03, 0.10)]
    + [("added_mass", "quarter_mass_fraction", v) for v in (0.05, 0.20)]
    + [("shear_deformation", "kGA_over_EI_L2", v) for v in (100.0, 300.0, 2000.0)]
    + [("local_damping", "added_damping_ratio", v) for v in (0.005, 0.02)]
)
#: FRF noise of the UFF baseline test.
FRF_NOISE = Noise(0.01)


@dataclass(frozen=True)
class EffectCase:
    """One hidden-effect case: the beam, its damping, noisy modal data, a noisy receptance test and the truth."""

    case: int
    truth: dict
    beam: Beam
    damping: Damping
    modal: dict
    frequencies: dict
    freq_hz: np.ndarray
    frf: np.ndarray


def _beam(effect: str, label: str, value: float, EI: float, m: float):
    L = LENGTH_M
    if effect == "root_flexibility":
        k = value * EI / L
        return Beam(L, EI, m, root_k_theta_Nm_rad=k), {"k_theta_Nm_rad": k}
    if effect == "added_mass":
        x = L if label.startswith("tip") else L / 4
        mass = value * m * L
        return Beam(L, EI, m, masses=(PointMass(x, mass),)), {"mass_kg": mass, "x_m": x}
    if effect == "shear_deformation":
        kga = value * EI / L ** 2
        return Beam(L, EI, m, kGA_N=kga, rho_I_kg_m=RHO_I_KG_M), {"kGA_N": kga, "rho_I_kg_m": RHO_I_KG_M}
    if effect == "local_damping":
        # first-order added damping ratio of mode r: c phi_r(x)^2 / (2 omega_r), mass-normalised phi
        plain = Beam(L, EI, m)
        asm = assemble(plain)
        md = modes(asm)
        dof = asm.translation_dofs([L / 4])[0]
        per_c = md.phi[dof, :4] ** 2 / (2 * md.omega_rad_s[:4])
        c = value / float(per_c.max())
        return Beam(L, EI, m, dashpots=(Dashpot(L / 4, c),)), {"c_Ns_m": c, "x_m": L / 4}
    return Beam(L, EI, m), {}


def _base_damping(rng: np.random.Generator) -> Damping:
    if rng.random() < 0.5:
        return Damping("modal", tuple(rng.uniform(0.003, 0.02, 4)))
    w1, w4 = 2 * math.pi * 21.7, 2 * math.pi * 746.0
    return rayleigh_for(rng.uniform(0.003, 0.02), rng.uniform(0.003, 0.02), w1, w4)


def effect_cases(seed: int, freq_hz=FREQ_HZ) -> list[EffectCase]:
    """Every case of :data:`CASES` once, reproducible from ``seed``."""
    rng = np.random.default_rng(seed)
    out = []
    for k, (effect, label, value) in enumerate(CASES):
        EI = EI_NM2 * (1 + rng.uniform(-0.08, 0.08))
        m = MASS_PER_LENGTH_KG_M * (1 + rng.uniform(-0.05, 0.05))
        damping = _base_damping(rng)
        beam, params = _beam(effect, label, value, EI, m)
        asm = assemble(beam)
        md = modes(asm)
        dofs = asm.translation_dofs(NODE_X_M[1:])
        lam, psi = complex_modes(asm, md, damping, dofs, 4)
        lam_n, psi_n = noisy_modal(lam, psi, rng)
        H = measure(receptance(asm, md, damping, freq_hz, dofs, dofs[0]), FRF_NOISE, rng)
        exact = modal_dict(lam, psi, DOF_LABELS, with_shapes=False)
        truth = {
            "case": k, "effect": effect, "label": label, "value": value, "parameters": params,
            "EI_Nm2": EI, "mass_per_length_kg_m": m, "length_m": LENGTH_M,
            "nominal": {"EI_Nm2": EI_NM2, "mass_per_length_kg_m": MASS_PER_LENGTH_KG_M},
            "damping": {"kind": damping.kind, "ratios": list(damping.ratios) if damping.kind == "modal" else None,
                        "alpha_1_s": damping.alpha_1_s, "beta_s": damping.beta_s},
            "natural_frequencies_hz": exact["natural_frequencies_hz"], "damping_ratios": exact["damping_ratios"],
            "undamped_frequencies_hz": [float(v) for v in md.frequencies_hz[:4]],
            "n_elements": beam.n_elements,
            "modal_noise": dict(zip(("frequency", "damping_ratio", "shape"), MODAL_NOISE)),
            "frf_noise_level": FRF_NOISE.level,
        }
        out.append(EffectCase(k, truth, beam, damping, modal_dict(lam_n, psi_n, DOF_LABELS),
                              modal_dict(lam_n, psi_n, DOF_LABELS, with_shapes=False),
                              np.asarray(freq_hz, dtype=float), H))
    return out


def write_effect_cases(cases: list[EffectCase], out_dir) -> Path:
    """Per case ``case-KK_modal.json``, ``case-KK_freq.json``, ``case-KK_baseline.uff``; then ``cases.json``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for c in cases:
        stem = f"case-{c.case:02d}"
        write_json(out / f"{stem}_modal.json", c.modal)
        write_json(out / f"{stem}_freq.json", c.frequencies)
        write_uff(out / f"{stem}_baseline.uff", c.freq_hz, c.frf, NODE_X_M, RESP_NODES, REF_NODE,
                  description=f"second_sim effect case {c.case} {c.truth['effect']}")
        rows.append({**c.truth, "files": {"modal": f"{stem}_modal.json", "frequencies": f"{stem}_freq.json",
                                          "uff": f"{stem}_baseline.uff"}})
    write_json(out / "cases.json", {"dofs": list(DOF_LABELS), "measured_x_m": list(NODE_X_M[1:]),
                                    "reference_dof": f"{REF_NODE}:y", "cases": rows})
    return out
