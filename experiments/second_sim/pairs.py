"""Specimen pairs (baseline test, current test) of beam-5-like cantilevers, with their truth.

Sets (``PAIR_SETS``): ``easy`` (Euler-Bernoulli, 1 % FRF noise, no test-day
changes, specimen EI and mass within +-3 %), ``eb`` (2 % noise, a noise floor
and H1 bias, EI within +-5 %, temperature (EI +-0.4 %) and re-clamping (root
spring +-8 %) between the tests) and ``timoshenko`` (as ``eb`` with shear and
rotary inertia; nominal ``kGA`` puts mode 4 8 % below Euler-Bernoulli, ~57 kN; a
14.75 % drop, ~27.5 kN, reproduces the measured beam-5 frequencies 21.5, 130, 346,
634 Hz with a clamped root).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.optimize

from experiments.second_sim.fem import Beam, Slit, assemble, modes
from experiments.second_sim.response import Damping, Noise, complex_modes, measure, noisy_modal, receptance
from experiments.second_sim.writers import modal_dict, write_csv, write_json, write_uff

__all__ = ["DOF_LABELS", "EI_NM2", "FREQ_HZ", "LENGTH_M", "MASS_PER_LENGTH_KG_M", "NODE_X_M", "PAIR_SETS", "PairRecord",
           "PairSet", "REF_NODE", "RESP_NODES", "RHO_I_KG_M", "THICKNESS_M", "WIDTH_M", "frequencies_hz", "max_drop",
           "nominal_kGA_N", "simulate_pair", "simulate_pairs", "write_pairs"]


#: Beam 5 of the thesis (Table 4.1, beams.json): cantilever length (m), width (m), thickness (m),
#: mass per length (kg/m, beam mass 0.15792 kg over the 1.219 m total length).
LENGTH_M = 0.6095
WIDTH_M = 0.051
THICKNESS_M = 0.007264
MASS_PER_LENGTH_KG_M = 0.15792 / 1.219
#: Nominal EI (N m^2): the clamped Euler-Bernoulli mode 1 at ~21.7 Hz, so that with a root spring it
#: lands near the measured 21.5 Hz (Table 4.1's static EI, 22.7 N m^2, gives 19.9 Hz).
EI_NM2 = 26.9
#: Rotary inertia of a uniform-density section (kg m).
RHO_I_KG_M = MASS_PER_LENGTH_KG_M * THICKNESS_M ** 2 / 12
#: Measured points x = L/4, L/2, 3L/4, L are nodes 2..5 (node 1 at the clamp); reference node 2.
NODE_X_M = tuple(LENGTH_M * k / 4 for k in range(5))
RESP_NODES = (2, 3, 4, 5)
REF_NODE = 2
DOF_LABELS = tuple(f"{n}:y" for n in RESP_NODES)
#: Default frequency lines (Hz): 0.5 Hz from 2 to 800 Hz.
FREQ_HZ = np.arange(4, 1601) * 0.5


@dataclass(frozen=True)
class PairSet:
    """Distribution of a pair set."""

    name: str
    timoshenko: bool
    noise: Noise
    ei_spread: float
    mass_spread: float = 0.03
    kga_spread: float = 0.05
    temperature_ei: float = 0.0
    reclamp_k: float = 0.0
    damaged_fraction: float = 2 / 3
    min_drop: float = 0.002
    accelerance_every_other: bool = False
    mode4_drop: float = 0.08


PAIR_SETS = {
    "easy": PairSet("easy", False, Noise(0.01), 0.03),
    "eb": PairSet("eb", False, Noise(0.02, 2e-4, 0.02), 0.05, temperature_ei=0.004, reclamp_k=0.08),
    "timoshenko": PairSet("timoshenko", True, Noise(0.02, 2e-4, 0.02), 0.05, temperature_ei=0.004,
                          reclamp_k=0.08, accelerance_every_other=True),
}


def frequencies_hz(beam: Beam, n: int = 4) -> np.ndarray:
    """First ``n`` undamped natural frequencies (Hz)."""
    return modes(assemble(beam)).frequencies_hz[:n]


@functools.lru_cache(maxsize=None)
def nominal_kGA_N(mode4_drop: float = 0.08) -> float:
    """Shear rigidity (N) that puts the clamped nominal beam's mode 4 ``mode4_drop`` below Euler-Bernoulli."""
    base = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M)
    f_eb = frequencies_hz(base)[3]

    def gap(log_kga):
        b = replace(base, kGA_N=math.exp(log_kga), rho_I_kg_m=RHO_I_KG_M)
        return frequencies_hz(b)[3] / f_eb - (1 - mode4_drop)

    return math.exp(scipy.optimize.brentq(gap, math.log(2e3), math.log(1e7), xtol=1e-6))


def max_drop(beam: Beam, slit: Slit) -> float:
    """Largest relative drop of modes 1-4 caused by ``slit`` alone (noise-free, same day)."""
    f0 = frequencies_hz(beam)
    f1 = frequencies_hz(replace(beam, slits=(slit,)))
    return float(np.max(1 - f1 / f0))


@dataclass(frozen=True)
class PairRecord:
    """One specimen's two tests: receptances (m/N) at nodes 2..5 driven at node 2, and the truth; ``modal``: the
    two tests' modal data (modal-data mappings of the first 4 complex modes with :data:`MODAL_NOISE`)."""

    pair: int
    truth: dict
    freq_hz: np.ndarray
    baseline: np.ndarray
    current: np.ndarray
    kind: str = "receptance"
    modal: tuple = ()


def _uniform(rng, spread):
    return 1.0 + rng.uniform(-spread, spread) if spread else 1.0


def _slit(rng, beam: Beam, min_drop: float) -> tuple[Slit, float]:
    for _ in range(1000):
        s = Slit(x_m=rng.uniform(0.02, 0.9) * LENGTH_M, width_m=rng.uniform(1e-3, 10e-3),
                 ei_loss_fraction=rng.uniform(0.3, 0.9))
        drop = max_drop(beam, s)
        if drop >= min_drop:
            return s, drop
    raise RuntimeError("no slit reached the minimum frequency drop in 1000 draws")


def simulate_pair(cfg: PairSet, pair: int, rng: np.random.Generator, freq_hz=FREQ_HZ,
                  modal_rng: np.random.Generator | None = None) -> PairRecord:
    """Draw one specimen (and slit, if damaged) and simulate its baseline and current tests.

    ``modal_rng`` draws the noise of the modal data (its own stream: the FRFs do not depend on it)."""
    EI = EI_NM2 * _uniform(rng, cfg.ei_spread)
    m = MASS_PER_LENGTH_KG_M * _uniform(rng, cfg.mass_spread)
    k_r_rel = math.exp(rng.uniform(math.log(200), math.log(2000)))
    kGA = nominal_kGA_N(cfg.mode4_drop) * _uniform(rng, cfg.kga_spread) if cfg.timoshenko else math.inf
    specimen = Beam(LENGTH_M, EI, m, kGA_N=kGA, rho_I_kg_m=RHO_I_KG_M if cfg.timoshenko else 0.0,
                    root_k_theta_Nm_rad=k_r_rel * EI / LENGTH_M)
    damping = Damping("modal", tuple(rng.uniform(0.003, 0.02, 4)))
    damaged = bool(rng.random() < cfg.damaged_fraction)
    slit, drop = _slit(rng, specimen, cfg.min_drop) if damaged else (None, 0.0)
    temp = _uniform(rng, cfg.temperature_ei)
    clamp = _uniform(rng, cfg.reclamp_k)
    current = replace(specimen, EI_Nm2=EI * temp, root_k_theta_Nm_rad=specimen.root_k_theta_Nm_rad * clamp,
                      slits=(slit,) if slit else ())
    H, f_true, modal = [], [], []
    modal_rng = np.random.default_rng(0) if modal_rng is None else modal_rng
    for beam in (specimen, current):
        asm = assemble(beam)
        md = modes(asm)
        dofs = asm.translation_dofs(NODE_X_M[1:])
        H.append(measure(receptance(asm, md, damping, freq_hz, dofs, dofs[0]), cfg.noise, rng))
        f_true.append(md.frequencies_hz[:4])
        modal.append(modal_dict(*noisy_modal(*complex_modes(asm, md, damping, dofs, 4), modal_rng), DOF_LABELS))
    kind = "accelerance" if cfg.accelerance_every_other and pair % 2 else "receptance"
    truth = {
        "pair": pair, "set": cfg.name, "damaged": damaged,
        "slit_x_m": slit.x_m if slit else None,
        "slit_x_over_L": slit.x_m / LENGTH_M if slit else None,
        "element": min(4, int(slit.x_m // (LENGTH_M / 4)) + 1) if slit else None,
        "width_m": slit.width_m if slit else None,
        "ei_loss_fraction": slit.ei_loss_fraction if slit else None,
        "stiffness_loss_Nm3": slit.stiffness_loss_Nm3(EI) if slit else 0.0,
        "hinge_flexibility": slit.hinge_flexibility(LENGTH_M) if slit else 0.0,
        # depth / thickness of a cut in a homogeneous rectangular section with the same EI loss
        "depth_fraction_rect_equiv": 1 - (1 - slit.ei_loss_fraction) ** (1 / 3) if slit else 0.0,
        "max_frequency_drop_rel": drop,
        "noise_level": cfg.noise.level, "noise_floor": cfg.noise.floor, "h1_bias": cfg.noise.h1_bias,
        "temperature_ei_factor": temp, "reclamp_k_factor": clamp,
        "EI_Nm2": EI, "mass_per_length_kg_m": m, "kGA_N": kGA if cfg.timoshenko else None,
        "rho_I_kg_m": specimen.rho_I_kg_m, "nominal_mode4_shear_drop": cfg.mode4_drop if cfg.timoshenko else 0.0,
        "root_k_theta_Nm_rad": specimen.root_k_theta_Nm_rad,
        "root_k_L_over_EI": k_r_rel, "length_m": LENGTH_M,
        "damping_ratios": list(damping.ratios), "n_elements": specimen.n_elements, "kind": kind,
        "baseline_frequencies_hz": [float(v) for v in f_true[0]],
        "current_frequencies_hz": [float(v) for v in f_true[1]],
    }
    return PairRecord(pair, truth, np.asarray(freq_hz, dtype=float), H[0], H[1], kind, tuple(modal))


def simulate_pairs(set_name: str, n: int, seed: int, freq_hz=FREQ_HZ, mode4_drop: float | None = None
                   ) -> list[PairRecord]:
    """``n`` pairs of set ``set_name`` (``easy``, ``eb``, ``timoshenko``), reproducible from ``seed``.

    ``mode4_drop`` overrides the timoshenko set's shear drop of mode 4 (fraction, default 0.08).
    """
    if set_name not in PAIR_SETS:
        raise ValueError(f"unknown pair set {set_name!r}; expected one of {sorted(PAIR_SETS)}")
    cfg = PAIR_SETS[set_name]
    if mode4_drop is not None:
        if not (cfg.timoshenko and 0 < mode4_drop < 0.5):
            raise ValueError(f"mode4_drop applies to the timoshenko set only and must be in (0, 0.5), got {mode4_drop}")
        cfg = replace(cfg, mode4_drop=mode4_drop)
    rng, modal_rng = np.random.default_rng(seed), np.random.default_rng([seed, 1])
    return [simulate_pair(cfg, k, rng, freq_hz, modal_rng) for k in range(n)]


def write_pairs(records: list[PairRecord], out_dir) -> Path:
    """``pair-KKK_baseline.uff``, ``pair-KKK_current.uff`` (and the modal data ``pair-KKK_baseline.json``,
    ``pair-KKK_current.json``) per record, ``truth.csv`` and ``truth.json``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for r in records:
        for day, H in (("baseline", r.baseline), ("current", r.current)):
            write_uff(out / f"pair-{r.pair:03d}_{day}.uff", r.freq_hz, H, NODE_X_M, RESP_NODES, REF_NODE,
                      kind=r.kind, description=f"second_sim {r.truth['set']} pair {r.pair} {day}")
        for day, md in zip(("baseline", "current"), r.modal):
            write_json(out / f"pair-{r.pair:03d}_{day}.json", md)
        rows.append(r.truth)
    write_json(out / "truth.json", {"length_m": LENGTH_M, "measured_x_m": list(NODE_X_M[1:]),
                                    "dofs": list(DOF_LABELS), "reference_dof": f"{REF_NODE}:y", "pairs": rows})
    flat = [{k: (";".join(f"{x:.6g}" for x in v) if isinstance(v, list) else v) for k, v in row.items()}
            for row in rows]
    write_csv(out / "truth.csv", flat)
    return out
