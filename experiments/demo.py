"""``beam-damage demo``: the end-to-end job behind ``make demo``.

1. Reproduces the thesis (``validate``) and identifies beam 5's models from
   the thesis's measured modes (undamaged and damaged, reduced and lumped
   mass): validation table (JSON, text) and an FRF figure (cf. Figures 6.1-6.3).
2. Measured-data path: writes simulated beam-5 FRFs (thesis damping, 1 %
   noise, 0.5 Hz lines) as a binary UFF58 file, identifies the modes by
   LSCF/LSFD and updates the model from them.
3. Dataset path: generates a small dataset of slit-damaged specimens and
   inspects it (frequency shift versus slit position against curvature squared).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments import validate
from experiments.cli import to_jsonable
from physics import frf, modal, properties, thesis, updating
from physics.io import atomic_write_text, modal_data_from_dict


def beam5_frf_figure(path: Path) -> dict:
    """Figure of H_41 (reference DOF 1, response DOF 4) of beam 5's identified models; returns the peaks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b5 = thesis.load("beams")["beams"]["5"]
    ident = b5["identified_models"]
    w = np.linspace(1, 5000, 25000)  # the thesis's Program A grid (rad/s)
    f_hz = w / (2 * np.pi)
    fig, (ax_m, ax_p) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    peaks = {}
    for state, ls in (("undamaged", "-"), ("damaged", "--")):
        data = modal_data_from_dict(b5[state])
        for mass, color in (("reduced_mass", "C0"), ("lumped_mass", "C3")):
            M = np.array(ident["undamaged"][mass]["M"])
            res = updating.pilkey(M, data.eigenvalues, data.eigenvectors)
            h = frf.receptance(M, res.C, res.K, w, response=[3], reference=[0])[0, 0]
            label = f"{state}, {mass.replace('_', ' ')}"
            ax_m.plot(f_hz, frf.magnitude_db(h), ls, color=color, lw=1, label=label)
            ax_p.plot(f_hz, frf.phase_deg(h, unwrap=True), ls, color=color, lw=1)
            peaks[label] = modal.complex_modes(M, res.C, res.K).natural_frequencies_hz.tolist()
    for f in b5["undamaged"]["natural_frequencies_hz"]:
        ax_m.axvline(f, color="0.7", lw=0.6)
    ax_m.set_ylabel("|H41| (dB re 1 m/N)")
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (Hz)")
    ax_m.set_title("Beam 5: identified models (Lancaster/Pilkey), reference DOF 1, response DOF 4")
    ax_m.legend(fontsize=8)
    ax_m.set_xlim(0, f_hz[-1])
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return peaks


def measured_data_step(out: Path) -> dict:
    """Simulated measurement -> UFF58 -> LSCF/LSFD identification -> Pilkey updating."""
    from experiments.cmd_identify import identify_frf, write_outputs
    from physics.io import read_frf, read_modal_json, write_uff58

    frf, exact = thesis.simulated_beam5_test(noise=0.01, damping="thesis")
    uff = out / "beam5_simulated.uff"
    write_uff58(uff, frf, binary=True)
    ident = identify_frf(read_frf(uff), n_modes=4)
    write_outputs(ident, out / "identify")
    data = read_modal_json(out / "identify" / "modal.json")
    beam = properties.beam_preset("beam5")
    M = updating.analyst_mass(beam.mass_per_length_kg_m, beam.length_m, "iirs", beam.n_elements)
    upd = updating.pilkey(M, data.eigenvalues, data.eigenvectors)
    return {"exact_frequencies_hz": exact.natural_frequencies_hz, "exact_damping_ratios": exact.damping_ratios,
            "identified_frequencies_hz": ident.estimate.natural_frequencies_hz,
            "identified_damping_ratios": ident.estimate.damping_ratios,
            "updated_model_frequencies_hz": modal.complex_modes(M, upd.C, upd.K).natural_frequencies_hz,
            "pilkey_iterations": upd.iterations}


def dataset_step(out: Path, n: int, workers: int) -> dict:
    """Generate ``n`` samples and run ``inspect`` on them."""
    from argparse import Namespace

    from datagen.config import merge
    from datagen.parallel import generate
    from experiments import cmd_inspect

    manifest = generate(out / "dataset", merge({}), n=n, seed=0, workers=workers, progress=True)
    summary = cmd_inspect.run(Namespace(dir=str(out / "dataset"), out=str(out / "inspect"), json=True))
    return {"samples": manifest["counts"]["samples"], "converged": manifest["counts"]["converged"],
            "curvature_check": summary["curvature_check"]}


def run(args) -> dict:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    checks = validate.run_checks()
    summary = validate.summary(checks)
    table = validate.format_table(checks)
    atomic_write_text(out / "validate.json", json.dumps(to_jsonable(summary), indent=1) + "\n")
    atomic_write_text(out / "validate.txt", table + "\n")
    peaks = beam5_frf_figure(out / "beam5_frf.png")
    measured = measured_data_step(out)
    dataset = dataset_step(out, args.samples, args.workers) if args.samples > 0 else None
    result = {
        "validate_passed": summary["passed"],
        "checks": len(checks),
        "largest_rel_error_by_group": summary["largest_rel_error_by_group"],
        "beam5_model_frequencies_hz": peaks,
        "measured_data": measured,
        "dataset": dataset,
        "outputs": sorted(str(p) for p in out.iterdir() if not p.name.startswith(".")),
    }
    if not args.json:
        print(table)
        print(f"\nReport written to {out}/: validate.json, validate.txt, beam5_frf.png, beam5_simulated.uff, "
              "identify/, dataset/, inspect/")
        for label, f in peaks.items():
            print(f"  {label:<28} model frequencies (Hz): " + ", ".join(f"{x:.2f}" for x in f))
        fmt = lambda v, p=3: ", ".join(f"{x:.{p}f}" for x in v)  # noqa: E731
        print("\nSimulated beam-5 test (UFF58, 1% noise, 0.5 Hz lines) -> LSCF/LSFD -> Pilkey:")
        print(f"  exact frequencies (Hz):      {fmt(measured['exact_frequencies_hz'])}")
        print(f"  identified frequencies (Hz): {fmt(measured['identified_frequencies_hz'])}")
        print(f"  exact damping ratios:        {fmt(measured['exact_damping_ratios'], 5)}")
        print(f"  identified damping ratios:   {fmt(measured['identified_damping_ratios'], 5)}")
        print(f"  updated model (Hz):          {fmt(measured['updated_model_frequencies_hz'])}")
        if dataset:
            print(f"\nDataset: {dataset['samples']} samples ({dataset['converged']} converged) in {out}/dataset; "
                  "frequency shift vs curvature^2 of each mode (slope, R^2):")
            for mode, c in dataset["curvature_check"].items():
                print(f"  {mode}: {c['slope']:.3f}, {c['r2']:.4f}")
    result["exit_code"] = 0 if summary["passed"] else 1
    return result


def add_parser(sub):
    p = sub.add_parser("demo", help="run the main job: thesis reproduction and beam 5 report",
                       description="Reproduce the thesis (validate), identify beam 5's models and write a report "
                                   "directory with tables and figures.")
    p.add_argument("--out", default="out/demo", help="report directory (default out/demo)")
    p.add_argument("--samples", type=int, default=2000, help="dataset samples to generate (0 skips; default 2000)")
    p.add_argument("--workers", type=int, default=2, help="processes for the dataset (default 2)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run)
