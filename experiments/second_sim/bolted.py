"""A steel cantilever carrying bolted masses: a solid flat bar with six point masses, tested before and after
material is removed from one of them.

The bar (0.38 m free length, 25.4 x 4.75 mm solid steel section, E = 200 GPa, 7850 kg/m^3, Poisson's ratio
0.29) is a Timoshenko beam with its own shear rigidity ``k G A`` (Cowper's ``k = 10 (1 + nu) / (12 + 11 nu)``
of a rectangle) and rotary inertia ``rho I``; six masses of about 35 g each (their sum 60 % of the bar's
mass) sit at ``x = 0.05, 0.11, ..., 0.35 m``. The test measures modes 1-4 at the quarter points (``2:y``..``5:y``
of a 4-element grid; a roving-hammer test with one accelerometer) with the modal noise of :mod:`.effects`.
Damage: ``removed_kg`` taken off the mass nearest ``damage_x_m`` (every frequency rises).

:func:`write_bolted_test` writes ``baseline_modal.json``, ``current_modal.json`` (and frequency-only
``*_freq.json``), two beam files ``bar.toml`` (the bar alone, as a user who leaves the masses out would write it)
and ``bolted.toml`` (the bar with one ``[[effects.added_mass]]`` table per mass), and ``truth.json``;
:func:`write_mass_change_pairs` a set of specimen pairs with masses added (1-20 % of the bar's mass) or lost
(1-8 %, from a bolted mass).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.second_sim.fem import Beam, PointMass, assemble, modes
from experiments.second_sim.response import Damping, complex_modes, noisy_modal
from experiments.second_sim.writers import modal_dict, write_json, write_text_atomic

__all__ = ["BoltedCantilever", "bolted_beam", "bolted_test", "mass_change_pairs", "write_bolted_test",
           "write_mass_change_pairs"]

LENGTH_M = 0.38
WIDTH_M = 0.0254
THICKNESS_M = 0.00475
MODULUS_PA = 200e9
DENSITY_KG_M3 = 7850.0
POISSON = 0.29
MASS_X_M = (0.05, 0.11, 0.17, 0.23, 0.29, 0.35)
MASS_KG = 0.035
SENSOR_X_M = tuple(LENGTH_M * k / 4 for k in range(1, 5))
DOF_LABELS = ("2:y", "3:y", "4:y", "5:y")


@dataclass(frozen=True)
class BoltedCantilever:
    """The bar's section numbers (SI)."""

    EI_Nm2: float
    mass_per_length_kg_m: float
    kGA_N: float
    rho_I_kg_m: float


def bar() -> BoltedCantilever:
    area = WIDTH_M * THICKNESS_M
    inertia = WIDTH_M * THICKNESS_M ** 3 / 12
    k = 10 * (1 + POISSON) / (12 + 11 * POISSON)
    G = MODULUS_PA / (2 * (1 + POISSON))
    return BoltedCantilever(MODULUS_PA * inertia, DENSITY_KG_M3 * area, k * G * area, DENSITY_KG_M3 * inertia)


def bolted_beam(masses_kg=None) -> Beam:
    """The cantilever with its masses (default: six of :data:`MASS_KG`)."""
    b = bar()
    masses_kg = (MASS_KG,) * len(MASS_X_M) if masses_kg is None else masses_kg
    return Beam(LENGTH_M, b.EI_Nm2, b.mass_per_length_kg_m, kGA_N=b.kGA_N, rho_I_kg_m=b.rho_I_kg_m,
                masses=tuple(PointMass(x, m) for x, m in zip(MASS_X_M, masses_kg)))


def _modal(beam: Beam, damping: Damping):
    asm = assemble(beam)
    md = modes(asm)
    lam, psi = complex_modes(asm, md, damping, asm.translation_dofs(SENSOR_X_M), 4)
    return lam, psi, md.frequencies_hz[:4]


def bolted_test(seed: int = 0, removed_kg: float = 0.005, damage_x_m: float = 0.23) -> dict:
    """Noisy baseline and current modal data of the bolted cantilever and the truth (see the module docstring)."""
    rng = np.random.default_rng(seed)
    damping = Damping("modal", tuple(rng.uniform(0.002, 0.01, 4)))
    j = int(np.argmin(np.abs(np.asarray(MASS_X_M) - damage_x_m)))
    after = [MASS_KG] * len(MASS_X_M)
    after[j] -= removed_kg
    out = {}
    for state, beam in (("baseline", bolted_beam()), ("current", bolted_beam(after))):
        lam, psi, f_hz = _modal(beam, damping)
        lam_n, psi_n = noisy_modal(lam, psi, rng)
        out[state] = {"modal": modal_dict(lam_n, psi_n, DOF_LABELS),
                      "frequencies": modal_dict(lam_n, psi_n, DOF_LABELS, with_shapes=False),
                      "undamped_frequencies_hz": [float(v) for v in f_hz]}
    b = bar()
    beam_mass = b.mass_per_length_kg_m * LENGTH_M
    out["truth"] = {"length_m": LENGTH_M, "width_m": WIDTH_M, "thickness_m": THICKNESS_M, "modulus_pa": MODULUS_PA,
                    "density_kg_m3": DENSITY_KG_M3, "poisson_ratio": POISSON, "EI_Nm2": b.EI_Nm2,
                    "mass_per_length_kg_m": b.mass_per_length_kg_m, "kGA_N": b.kGA_N, "rho_I_kg_m": b.rho_I_kg_m,
                    "bar_mass_kg": beam_mass, "masses": [{"x_m": x, "mass_kg": MASS_KG} for x in MASS_X_M],
                    "damage": {"x_m": MASS_X_M[j], "removed_kg": removed_kg,
                               "mass_ratio": -removed_kg / beam_mass},
                    "seed": seed, "sensor_x_m": list(SENSOR_X_M), "dofs": list(DOF_LABELS)}
    return out


def _toml(with_masses: bool) -> str:
    lines = ["# second_sim bolted cantilever: a solid steel flat bar" + (" with its six bolted masses" if with_masses
                                                                         else " (the masses left out)"),
             'name = "bolted-bar"', 'bc = "clamped-free"', 'section = "rectangular"',
             f"length_m = {LENGTH_M!r}", f"width_m = {WIDTH_M!r}", f"thickness_m = {THICKNESS_M!r}",
             f"modulus_pa = {MODULUS_PA!r}", f"poisson_ratio = {POISSON!r}", f"density_kg_m3 = {DENSITY_KG_M3!r}",
             "measured_x_m = [" + ", ".join(repr(x) for x in SENSOR_X_M) + "]"]
    if with_masses:
        for x in MASS_X_M:
            lines += ["", "[[effects.added_mass]]", f"mass_kg = {MASS_KG!r}", f"x_m = {x!r}"]
    return "\n".join(lines) + "\n"


def write_bolted_test(out_dir, seed: int = 0, removed_kg: float = 0.005, damage_x_m: float = 0.23) -> Path:
    """Write the files of the module docstring into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t = bolted_test(seed, removed_kg, damage_x_m)
    for state in ("baseline", "current"):
        write_json(out / f"{state}_modal.json", t[state]["modal"])
        write_json(out / f"{state}_freq.json", t[state]["frequencies"])
    write_text_atomic(out / "bar.toml", _toml(False))
    write_text_atomic(out / "bolted.toml", _toml(True))
    write_json(out / "truth.json", {**t["truth"], **{f"{s}_undamped_frequencies_hz": t[s]["undamped_frequencies_hz"]
                                                     for s in ("baseline", "current")}})
    return out



def mass_change_pairs(n: int, seed: int = 0) -> list[dict]:
    """``n`` baseline/current modal-data pairs of bolted cantilevers with a mass added or lost between the days.

    Each specimen: EI within +-3 %, the bar's mass within +-2 %, each bolted mass 35 +- 0.5 g, modal damping
    0.2-1 %; between the days EI changes by +-0.1 % (temperature). A fifth of the pairs are intact; of the others
    half gain a point mass of 1-20 % of the bar's mass anywhere on 3-97 % of the length, half lose 1-8 % of it from
    one bolted mass (material removed; at most 90 % of that mass). Modal noise as :mod:`.effects`.

    Returns
    -------
    list of dict  ``{"baseline": modal dict, "current": modal dict, "truth": dict}``
    """
    rng = np.random.default_rng(seed)
    b = bar()
    out = []
    for k in range(n):
        ei = b.EI_Nm2 * (1 + rng.uniform(-0.03, 0.03))
        m = b.mass_per_length_kg_m * (1 + rng.uniform(-0.02, 0.02))
        masses = list(MASS_KG + rng.uniform(-0.0005, 0.0005, len(MASS_X_M)))
        damping = Damping("modal", tuple(rng.uniform(0.002, 0.01, 4)))
        kind = "intact" if k % 5 == 4 else ("added" if rng.random() < 0.5 else "lost")
        bar_kg = m * LENGTH_M
        extra, now, x, ratio = (), list(masses), float("nan"), 0.0
        if kind == "added":
            ratio = rng.uniform(0.01, 0.20)
            x = rng.uniform(0.03, 0.97) * LENGTH_M
            extra = (PointMass(x, ratio * bar_kg),)
        elif kind == "lost":
            j = int(rng.integers(len(MASS_X_M)))
            ratio = -min(rng.uniform(0.01, 0.08), 0.9 * masses[j] / bar_kg)
            now[j] += ratio * bar_kg
            x = MASS_X_M[j]

        def beam(ms, more=(), ei_scale=1.0):
            return Beam(LENGTH_M, ei * ei_scale, m, kGA_N=b.kGA_N, rho_I_kg_m=b.rho_I_kg_m,
                        masses=tuple(PointMass(p, q) for p, q in zip(MASS_X_M, ms)) + more)

        pair = {}
        for state, bm in (("baseline", beam(masses)), ("current", beam(now, extra, 1 + rng.uniform(-0.001, 0.001)))):
            lam, psi, _ = _modal(bm, damping)
            pair[state] = modal_dict(*noisy_modal(lam, psi, rng), DOF_LABELS)
        pair["truth"] = {"pair": k, "damaged": kind != "intact", "change": kind, "mass_ratio": ratio,
                         "x_m": x, "x_over_L": x / LENGTH_M, "bar_mass_kg": bar_kg}
        out.append(pair)
    return out


def write_mass_change_pairs(out_dir, n: int, seed: int = 0) -> Path:
    """``pair-KK_baseline.json``, ``pair-KK_current.json`` per pair, ``truth.json`` and ``bolted.toml``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for p in mass_change_pairs(n, seed):
        stem = f"pair-{p['truth']['pair']:02d}"
        write_json(out / f"{stem}_baseline.json", p["baseline"])
        write_json(out / f"{stem}_current.json", p["current"])
        rows.append({**p["truth"], "baseline": f"{stem}_baseline.json", "current": f"{stem}_current.json"})
    write_text_atomic(out / "bolted.toml", _toml(True))
    write_json(out / "truth.json", {"seed": seed, "pairs": rows})
    return out
