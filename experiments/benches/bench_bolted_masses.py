"""``discrepancy`` on the steel cantilever with six bolted masses: the beam file without the masses and with them.

Run::

    python -m experiments.benches.bench_bolted_masses [--out out/bolted] [--docs]

Writes the independent simulator's test into ``--out`` (:func:`experiments.second_sim.bolted.write_bolted_test`,
seed 0: ``bar.toml``, ``bolted.toml``, ``baseline_modal.json``, ``truth.json``), then runs on each beam file what
``beam-damage discrepancy --beam FILE --measured baseline_modal.json --max-effects 3 --frequency-noise 0.0003
--shape-noise 0.005`` computes (:func:`physics.discrepancy.analyse_file`). One row per beam file: the effects named
with their fitted parameters (shear deformation against the simulator's truth), the largest frequency error of
the beam file as given, with EI/m recalibrated (and in units of the frequency noise) and with the named effects,
and the final model's noise check. ``bolted.toml`` takes about 30 s, ``bar.toml`` several minutes (two shared
cores). ``--docs`` writes the table into docs/discrepancy.md (block ``bolted-masses``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser, publish, table
from experiments.second_sim.bolted import write_bolted_test
from physics.discrepancy import analyse_file

__all__ = ["FILES", "FREQUENCY_NOISE", "SHAPE_NOISE", "main", "markdown", "named_cell", "noise_cell", "row"]

#: The simulator's modal noise, given to the command.
FREQUENCY_NOISE = 0.0003
SHAPE_NOISE = 0.005

#: Beam file -> its label in the table.
FILES = {"bar.toml": "`bar.toml` (the masses left out)",
         "bolted.toml": "`bolted.toml` (one `[[effects.added_mass]]` per mass)"}


def _e(v: float, digits: int = 2) -> str:
    """``9.2e6``: ``digits`` significant digits, a plain exponent (``nan`` as is)."""
    if not np.isfinite(v):
        return "nan"
    mant, exp = f"{v:.{digits - 1}e}".split("e")
    return f"{mant}e{int(exp)}"


def named_cell(result: dict, truth: dict) -> str:
    """The effects named and their fitted parameters: a point mass ``g at m``; shear deformation ``kGA +- std``
    and ``G +- std`` with the simulator's truth; then the candidates it could not be told from; ``none``."""
    p, sd = result["parameters"], result["parameter_std"]
    parts = []
    for e in result["effects"]:
        if e.startswith("added_mass"):
            parts.append(f"{1e3 * p[f'{e}.mass_kg']:.1f} g"
                         + (f" at {p[f'{e}.x_m']:.3f} m" if f"{e}.x_m" in p else ""))
        elif e == "shear_deformation":
            g_truth = truth["modulus_pa"] / (2 * (1 + truth["poisson_ratio"]))
            parts.append(f"kGA {_e(p[f'{e}.kGA_N'])} +- {_e(sd.get(f'{e}.kGA_N', float('nan')))} N"
                         + (f", G {p[f'{e}.G_pa'] / 1e9:.0f} +- {sd.get(f'{e}.G_pa', float('nan')) / 1e9:.0f} GPa"
                            if f"{e}.G_pa" in p else "")
                         + f"; truth {_e(truth['kGA_N'], 3)} N, {g_truth / 1e9:.1f} GPa")
        else:
            parts.append(", ".join(f"{k.split('.', 1)[1]} {v:.3g}" for k, v in p.items() if k.startswith(f"{e}.")))
    names = ", ".join(f"`{e}`" for e in result["effects"]) or "none"
    cell = f"{names} ({'; '.join(parts)})" if parts else names
    if result.get("indistinguishable_from"):
        cell += ", not told from " + ", ".join(f"`{e}`" for e in result["indistinguishable_from"])
    return cell


def noise_cell(check: dict) -> str:
    """``consistent (chi2/dof X)``, else per data block its chi2/dof (``fitted (no dof left)`` without dof)."""
    if check["noise_consistent"]:
        return f"consistent (chi2/dof {check['chi2_per_dof']:.2g})"
    return ", ".join(f"{name} fitted (no dof left)" if b["dof"] <= 0 or not np.isfinite(b["chi2_per_dof"])
                     else f"{name} chi2/dof {b['chi2_per_dof']:.2g}" for name, b in check["blocks"].items())


def row(beam_file: Path, measured: Path, truth: dict) -> list[str]:
    """The table's row of one beam file."""
    result = analyse_file(str(beam_file), str(measured), max_effects=3, frequency_noise=FREQUENCY_NOISE,
                          shape_noise=SHAPE_NOISE)
    res, recal = result.pop("_result")
    after_ei = recal.max_abs_frequency_error_pct
    return [FILES[beam_file.name], named_cell(result, truth), f"{res.nominal.max_abs_frequency_error_pct:.3g} %",
            f"{after_ei:.2g} % ({after_ei / (100 * FREQUENCY_NOISE):.0f} times the noise)",
            f"{res.final.residuals.max_abs_frequency_error_pct:.3f} %", noise_cell(result["noise_check"])]


def markdown(rows: list[list[str]]) -> str:
    return table(["beam file", "named", "max \\|f error\\| nominal", "after EI/m", "after the named effects",
                  "noise check"], rows)


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, docs="discrepancy.md", out="out/bolted")
    a = ap.parse_args(argv)
    out = write_bolted_test(Path(a.out), seed=0)
    truth = json.loads((out / "truth.json").read_text())
    md = markdown([row(out / name, out / "baseline_modal.json", truth) for name in FILES])
    print(md)
    publish(a, "bolted-masses", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
