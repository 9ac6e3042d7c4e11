"""Study ``discrepancy-study``: the discrepancy workflow (:func:`physics.discrepancy.analyse_file`) on beam 5's
Table 4.3 and Table 4.5, and the hidden-effect suite (:func:`confusion`, whose full table
:mod:`experiments.benches.bench_discrepancy` prints; one seed here).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiments.studies.report import Section, Table, figure
from physics import discrepancy as dsc
from physics.beam import load_beam
from physics.effects import candidates_for

__all__ = ["EXAMPLE_SHAPES", "TRUTHS", "beam5_section", "confusion", "run", "run_case"]

BEAM = load_beam("beam5")
L, EI, M = BEAM.length_m, BEAM.EI_Nm2, BEAM.mass_per_length_kg_m
RHO_I = M * BEAM.thickness_m**2 / 12
DAMPING = {"proportional_damping": {"alpha_1_s": 0.4, "beta_s": 2e-6}}
NOISE = dsc.Noise(0.002, 0.05, 0.01, 0.5)

#: name -> (effect, parameters, the parameter checked)
TRUTHS = {
    "none": (None, {}, None),
    "shear small": ("shear_deformation", {"kGA_N": 2e5}, "kGA_N"),
    "shear large": ("shear_deformation", {"kGA_N": 2.5e4}, "kGA_N"),
    "rotary inertia (3x, physical max)": ("rotary_inertia", {"rho_I_kg_m": 3 * RHO_I}, "rho_I_kg_m"),
    "root spring small": ("root_flexibility", {"k_theta_Nm_rad": 50 * EI / L}, "k_theta_Nm_rad"),
    "root spring large": ("root_flexibility", {"k_theta_Nm_rad": 10 * EI / L}, "k_theta_Nm_rad"),
    "tip mass small": ("added_mass", {"mass_kg": 0.03 * M * L, "x_m": L}, "mass_kg"),
    "mass at L/4 large": ("added_mass", {"mass_kg": 0.2 * M * L, "x_m": L / 4}, "mass_kg"),
    "local damping small": ("local_damping", {"c_Ns_m": 0.15, "x_m": L / 4}, "c_Ns_m"),
    "local damping large": ("local_damping", {"c_Ns_m": 0.5, "x_m": L / 4}, "c_Ns_m"),
    # the same beam 40 mm deep (h/L = 0.066, EI and m unchanged): rotary inertia becomes visible
    "thick: rotary inertia (1x)": ("rotary_inertia", {"rho_I_kg_m": M * 0.04**2 / 12}, "rho_I_kg_m"),
}
THICK = BEAM.with_effects({}, thickness_m=0.04, face_thickness_m=0.002)


def run_case(effect, params, seed, shapes, beam=BEAM, estimate_noise=False):
    rng = np.random.default_rng(seed)
    eff = {effect: params} if effect else {}
    truth = beam.with_effects({**eff, **DAMPING}, EI_Nm2=EI * (1 + 0.03 * rng.standard_normal()),
                              mass_per_length_kg_m=M * (1 + 0.02 * rng.standard_normal()))
    meas = dsc.simulate_measurement(truth, seed=seed, noise=NOISE, shapes=shapes)
    return dsc.analyse(beam, meas, NOISE, max_effects=1, n_elements=24, n_starts=3, seed=seed,
                       estimate_noise=estimate_noise)



SHORT = {"none": "none", "shear_deformation": "shear", "rotary_inertia": "rotary", "root_flexibility": "root",
         "clamp_flexibility": "clamp", "bearing_flexibility": "bearing", "suspension": "susp", "added_mass": "mass",
         "local_damping": "l.damp"}


def confusion(seeds: int = 3, kinds=("freq", "shapes"), truths=None, progress: bool = False,
              estimate_noise: bool = False) -> list[dict]:
    """Confusion rows of the hidden-effect suite: per data kind and truth, how often each effect is named.

    Each row: ``kind``, ``truth``, one count per ``none`` and candidate (``"2~"`` when named but reported
    indistinguishable), ``param_error`` (median relative error of the recovered parameter when named right),
    ``gap_before_pct``/``gap_after_pct`` (median max |frequency error|, recalibrated only -> named effect).
    ``estimate_noise``: the simulated noise, given, is treated as only assumed and scaled to the data
    (:func:`physics.discrepancy.analyse`).
    """
    from tqdm import tqdm

    cols = ["none", *candidates_for(BEAM.bc)]
    rows = []
    for kind in kinds:
        for name in tqdm(list(truths or TRUTHS), desc=f"hidden effects ({kind})", leave=False, disable=not progress):
            effect, params, key = TRUTHS[name]
            counts = {c: 0 for c in cols}
            ties = {c: 0 for c in cols}
            perr, gaps = [], []
            for seed in range(seeds):
                res = run_case(effect, params, seed, kind == "shapes", THICK if name.startswith("thick") else BEAM,
                               estimate_noise)
                named = res.named_effects[0] if res.named_effects else "none"
                counts[named] += 1
                if res.steps and res.steps[0].indistinguishable_from:
                    ties[named] += 1
                if effect and named == effect:
                    perr.append(abs(res.final.parameters[f"{effect}.{key}"] / params[key] - 1))
                b, a = res.steps[0].base.residuals, res.final.residuals
                gaps.append((b.max_abs_frequency_error_pct, a.max_abs_frequency_error_pct))
            g = np.median(np.array(gaps), axis=0)
            row = {"kind": kind, "truth": name}
            row.update({SHORT[c]: (f"{counts[c]}~" if ties[c] else counts[c]) for c in cols})
            row.update({"param_error": float(np.median(perr)) if perr else None, "gap_before_pct": g[0],
                        "gap_after_pct": g[1]})
            rows.append(row)
    return rows


EXAMPLE_SHAPES = dsc.EXAMPLE.with_name("beam5_table_4_5.json")


def beam5_section(result: dict, out_dir: Path, title: str):
    """Report section of one :func:`physics.discrepancy.analyse_file` result written into ``out_dir``."""
    gb, ga = result["gap_before"], result["gap_after"]
    params = [{"parameter": k, "value": v, "std": result["parameter_std"].get(k)}
              for k, v in result["parameters"].items()]
    cand = [{"effect": c["effect"], "BIC": c["score"], "max |frequency error| (%)": c["max_abs_frequency_error_pct"]}
            for c in result["candidates"]]
    gap = [{"model": "before (beam as given)", "max |f error| (%)": gb["max_abs_frequency_error_pct"],
            "mean |f error| (%)": gb["mean_abs_frequency_error_pct"]},
           {"model": "after: " + (" + ".join(result["effects"]) or "recalibrated only"),
            "max |f error| (%)": ga["max_abs_frequency_error_pct"],
            "mean |f error| (%)": ga["mean_abs_frequency_error_pct"]}]
    text = (f"Named effect: **{result['named_effect']}** (all named, in order: "
            f"{', '.join(result['effects']) or 'none'}). The largest frequency error falls from "
            f"{gb['max_abs_frequency_error_pct']:.2f} % to {ga['max_abs_frequency_error_pct']:.2f} %."
            + (f" Indistinguishable from: {', '.join(result['indistinguishable_from'])}."
               if result["indistinguishable_from"] else "")
            + (f" Noise check of the final model: chi^2/dof {result['noise_check']['chi2_per_dof']:.2f} on "
               f"{result['noise_check']['dof']} degrees of freedom ({result['noise_check']['verdict']})."
               if "noise_check" in result else ""))
    if "shear_deformation.G_core_pa" in result["parameters"]:
        g = result["parameters"]["shear_deformation.G_core_pa"]
        text += (f" The fitted shear rigidity corresponds to a core shear modulus of {g / 1e6:.0f} MPa, inside the "
                 "10-100 MPa of foam-filled honeycomb cores.")
    return Section(title, (text,), (Table.from_records("Gap before and after", gap),
                                    Table.from_records("Fitted parameters (one-sigma from the Jacobian and noise)",
                                                       params),
                                    Table.from_records("Candidates (BIC: lower is better)", cand)),
                   (figure(out_dir / "frequency_error.png"),))


def run(out_dir, seeds: int = 1) -> tuple[dict, list]:
    """Study ``discrepancy-study``: beam 5 (Table 4.3, Table 4.5) and the hidden-effect confusion table."""
    out = Path(out_dir)
    sections, summary = [], {}
    for name, path, title in (("table_4_3", dsc.EXAMPLE, "Beam 5, measured frequencies (Table 4.3)"),
                              ("table_4_5", EXAMPLE_SHAPES, "Beam 5, measured complex modes (Table 4.5)")):
        res = dsc.analyse_file("beam5", path, out / name)
        res.pop("_result")
        summary[name] = {k: res[k] for k in ("named_effect", "effects", "parameters", "gap_before", "gap_after",
                                             "beam_file")}
        sections.append(beam5_section(res, out / name, title))
    rows = confusion(seeds, ("freq", "shapes"), progress=True)
    summary["confusion"] = rows
    sections.append(Section(
        "Hidden-effect suite", (f"Truth: beam 5 with one hidden effect, random 3 % EI and 2 % mass errors, noise "
                                f"(frequencies 0.2 %, damping 5 %, shapes 1 %), simulated on 80 elements and fitted on "
                                f"24; {seeds} seed(s) per truth. Counts of the effect named; '~' = named but "
                                "reported indistinguishable. Full table: "
                                "`python -m experiments.benches.bench_discrepancy`.",),
        (Table.from_records("Confusion table of the hidden-effect suite", rows),)))
    return summary, sections
