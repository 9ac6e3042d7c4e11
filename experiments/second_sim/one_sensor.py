"""A one-accelerometer impact test of a steel cantilever, written by the independent simulator
(:mod:`experiments.second_sim`) as a test system writes it: one accelerance record (UFF) from 0.5 to 1600 Hz at
0.5 Hz lines, the hammer away from the accelerometer, an accelerometer of 5 g on the beam, and a noise floor that
rises towards low frequency as an accelerometer's does (its acceleration noise over a hammer's force). Modes near
22, 138, 387, 760 and 1256 Hz; the first one's peak stands a factor of about 10 over the floor around it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .fem import Beam, PointMass, assemble, modes
from .response import Damping, complex_normal, receptance
from .writers import convert_receptance, write_uff

__all__ = ["DENSITY", "EI_NM2", "LENGTH_M", "MASS_PER_LENGTH", "SENSOR_X_M", "HAMMER_X_M", "beam_toml",
           "one_sensor_test", "truth_frequencies_hz",
           "write_one_sensor_test"]

LENGTH_M = 0.475
WIDTH_M, THICKNESS_M, MODULUS_PA, DENSITY = 0.025, 0.006, 2.1e11, 7850.0
EI_NM2 = MODULUS_PA * WIDTH_M * THICKNESS_M**3 / 12          # 94.5 N m^2
MASS_PER_LENGTH = DENSITY * WIDTH_M * THICKNESS_M            # 1.1775 kg/m
N_ELEMENTS = 112
SENSOR_X_M = LENGTH_M * 28 / N_ELEMENTS                      # a quarter of the length from the clamp
HAMMER_X_M = LENGTH_M * 98 / N_ELEMENTS                      # near the tip
ACCELEROMETER_KG = 0.005
DAMPING = (0.02, 0.006, 0.004, 0.003, 0.003)
LINES_HZ = np.arange(1, 3201) * 0.5


def truth_beam(EI_scale: float = 1.0) -> Beam:
    return Beam(LENGTH_M, EI_NM2 * EI_scale, MASS_PER_LENGTH, n_elements=N_ELEMENTS,
                masses=(PointMass(SENSOR_X_M, ACCELEROMETER_KG),))


def truth_frequencies_hz(EI_scale: float = 1.0) -> np.ndarray:
    """Undamped frequencies (Hz) of the truth's 6 lowest modes."""
    return modes(assemble(truth_beam(EI_scale))).frequencies_hz[:6]


def one_sensor_test(seed: int = 0, EI_scale: float = 1.0, floor: float = 0.2) -> tuple[np.ndarray, np.ndarray,
                                                                                         np.ndarray]:
    """``(lines Hz, accelerance (1, n_lines) m/s^2/N noisy, undamped frequencies Hz of modes 1-6)``.

    Noise: 1 % of the accelerance's magnitude, plus a floor of ``floor`` m/s^2/N times ``(1 + (50 Hz / f)^2)``
    (complex Gaussian, seeded)."""
    beam = truth_beam(EI_scale)
    asm = assemble(beam)
    md = modes(asm)
    H = receptance(asm, md, Damping("modal", DAMPING), LINES_HZ, asm.translation_dofs([SENSOR_X_M]),
                   int(asm.translation_dofs([HAMMER_X_M])[0]))
    A = convert_receptance(H, LINES_HZ, "accelerance")
    rng = np.random.default_rng(seed)
    relative = 0.01 * np.abs(A) * complex_normal(rng, A.shape)
    A = A + relative + floor * (1 + (50.0 / LINES_HZ) ** 2) * complex_normal(rng, A.shape)
    return LINES_HZ, A, md.frequencies_hz[:6]


def write_one_sensor_test(out_dir, seed: int = 0, EI_scale: float = 1.0, band_hz=(10.0, 1600.0)) -> dict:
    """``test.uff`` (accelerance, node 1 the accelerometer, node 2 the hammer, with their geometry) and
    ``beam.toml`` (the nominal beam: EI and mass of the bar, the accelerometer's 5 g as an added mass; ``band_hz``
    when given); returns their paths and the truth."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    f, A, fn = one_sensor_test(seed, EI_scale)
    H = convert_receptance(np.ones_like(f), f, "accelerance")
    write_uff(out / "test.uff", f, A / H, [SENSOR_X_M, HAMMER_X_M], [1], 2, kind="accelerance")
    (out / "beam.toml").write_text(beam_toml(band_hz))
    return {"uff": out / "test.uff", "beam": out / "beam.toml", "frequencies_hz": fn,
            "EI_Nm2": EI_NM2 * EI_scale}


def beam_toml(band_hz=(10.0, 1600.0), masses: bool = True) -> str:
    lines = ['name = "one-sensor-cantilever"', 'bc = "clamped-free"', f"length_m = {LENGTH_M!r}",
             f"width_m = {WIDTH_M!r}", f"thickness_m = {THICKNESS_M!r}", f"EI_Nm2 = {EI_NM2!r}",
             f"mass_per_length_kg_m = {MASS_PER_LENGTH!r}", f"measured_x_m = [{SENSOR_X_M!r}]",
             f"drive_x_m = {HAMMER_X_M!r}"]
    if band_hz is not None:
        lines.append(f"band_hz = [{band_hz[0]!r}, {band_hz[1]!r}]")
    if masses:
        lines += ["", "[[effects.added_mass]]", f"mass_kg = {ACCELEROMETER_KG!r}", f"x_m = {SENSOR_X_M!r}"]
    return "\n".join(lines) + "\n"
