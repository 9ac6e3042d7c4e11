"""A small monitoring series of the independent simulator (experiments.second_sim) for the monitor tests: daily
tests of a beam-5-like cantilever whose EI follows the temperature, re-clamped between tests, a slit from a known
day on."""

import csv
from pathlib import Path

import numpy as np

from experiments.second_sim import Beam, Damping, Noise, PointMass, Slit, assemble, complex_modes, measure, modes
from experiments.second_sim import receptance
from experiments.second_sim.pairs import DOF_LABELS, EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M, NODE_X_M, RESP_NODES
from experiments.second_sim.response import noisy_modal
from experiments.second_sim.writers import modal_dict, write_json, write_uff

#: EI change per degree (relative): +-12 degrees around 15 C move EI by about +-1 %.
EI_PER_C = -8e-4
N_ELEMENTS = 12


def specimen(rng, temperature_c, slit=None, mass_x_m=None):
    """One day's beam: EI at the temperature, the clamp re-tightened (root spring +-8 %)."""
    k_rel = 800.0 * (1 + rng.uniform(-0.08, 0.08))
    masses = () if mass_x_m is None else (PointMass(mass_x_m, 0.02 * MASS_PER_LENGTH_KG_M * LENGTH_M),)
    return Beam(LENGTH_M, EI_NM2 * (1 + EI_PER_C * (temperature_c - 15.0)), MASS_PER_LENGTH_KG_M,
                root_k_theta_Nm_rad=k_rel * EI_NM2 / LENGTH_M, slits=(slit,) if slit else (), masses=masses,
                n_elements=N_ELEMENTS)


def simulate(n, slit_day=None, slit=Slit(0.15, 0.004, 0.6), seed=0, mass=False):
    """``n`` days: temperatures (C), true frequencies (n, 4) and complex modes per day."""
    rng = np.random.default_rng(seed)
    days = np.arange(n)
    temp = 15 + 10 * np.sin(2 * np.pi * days / 60) + rng.normal(0, 1.5, n)
    out = []
    for d in days:
        b = specimen(rng, temp[d], slit if slit_day is not None and d >= slit_day else None,
                     rng.uniform(0.4, 0.6) * LENGTH_M if mass else None)
        asm = assemble(b)
        md = modes(asm)
        out.append((b, asm, md))
    return temp, out


def write_modal_series(root, n, slit_day=None, seed=0, mass=False, noise=(3e-4, 0.03, 0.005)):
    """Modal JSON files (4 modes, shapes at nodes 2..5) and ``conditions.csv``; returns (csv path, files, true f)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    temp, days = simulate(n, slit_day, seed=seed, mass=mass)
    rng = np.random.default_rng([seed, 1])
    files, f_true = [], []
    for d, (b, asm, md) in enumerate(days):
        dofs = asm.translation_dofs(NODE_X_M[1:])
        lam, psi = complex_modes(asm, md, Damping("modal", (0.01, 0.008, 0.006, 0.005)), dofs, 4)
        path = root / f"day{d:03d}.json"
        write_json(path, modal_dict(*noisy_modal(lam, psi, rng, noise), DOF_LABELS))
        files.append(path)
        f_true.append(md.frequencies_hz[:4])
    return _conditions(root, files, temp), files, np.array(f_true)


def write_frf_series(root, n, slit_day=None, seed=0, freq_hz=np.arange(8, 1281) * 0.75):
    """UFF files of receptances at nodes 2..5 driven at node 2 (1 % noise) and ``conditions.csv``."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    temp, days = simulate(n, slit_day, seed=seed)
    rng = np.random.default_rng([seed, 2])
    files = []
    for d, (b, asm, md) in enumerate(days):
        dofs = asm.translation_dofs(NODE_X_M[1:])
        H = measure(receptance(asm, md, Damping("modal", (0.01, 0.008, 0.006, 0.005)), freq_hz, dofs, dofs[0]),
                    Noise(0.01), rng)
        path = root / f"day{d:03d}.uff"
        write_uff(path, freq_hz, H, NODE_X_M, RESP_NODES, RESP_NODES[0])
        files.append(path)
    return _conditions(root, files, temp), files


def _conditions(root, files, temp):
    path = Path(root) / "conditions.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["file", "time", "temperature_c"])
        for d, (f, t) in enumerate(zip(files, temp)):
            w.writerow([Path(f).name, d, f"{t:.3f}"])
    return path

