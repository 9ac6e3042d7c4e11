"""``beam-damage demo``: the end-to-end job behind ``make demo``.

Runs the thesis reproduction (``validate``), identifies beam 5's models from
the thesis's measured modes (undamaged and damaged, reduced and lumped mass)
and writes a report directory with the validation table (JSON and text) and
an FRF figure of the identified models (cf. thesis Figures 6.1-6.3).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments import validate
from physics import frf, modal, updating
from physics.io import atomic_write_text, modal_data_from_dict


def beam5_frf_figure(path: Path) -> dict:
    """Figure of H_41 (drive DOF 1, response DOF 4) of beam 5's identified models; returns the peaks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b5 = validate.thesis_fixture("beams")["beams"]["5"]
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
    ax_m.set_title("Beam 5: identified models (Lancaster/Pilkey), drive DOF 1, response DOF 4")
    ax_m.legend(fontsize=8)
    ax_m.set_xlim(0, f_hz[-1])
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return peaks


def run(args) -> dict:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    checks = validate.run_checks()
    summary = validate.summary(checks)
    table = validate.format_table(checks)
    atomic_write_text(out / "validate.json", json.dumps(validate_json(summary), indent=1) + "\n")
    atomic_write_text(out / "validate.txt", table + "\n")
    peaks = beam5_frf_figure(out / "beam5_frf.png")
    result = {
        "validate_passed": summary["passed"],
        "checks": len(checks),
        "largest_rel_error_by_group": summary["largest_rel_error_by_group"],
        "beam5_model_frequencies_hz": peaks,
        "outputs": sorted(str(p) for p in out.iterdir() if not p.name.startswith(".")),
    }
    if not args.json:
        print(table)
        print(f"\nReport written to {out}/: validate.json, validate.txt, beam5_frf.png")
        for label, f in peaks.items():
            print(f"  {label:<28} model frequencies (Hz): " + ", ".join(f"{x:.2f}" for x in f))
    result["exit_code"] = 0 if summary["passed"] else 1
    return result


def validate_json(summary: dict) -> dict:
    from experiments.cli import to_jsonable

    return to_jsonable(summary)


def add_parser(sub):
    p = sub.add_parser("demo", help="run the main job: thesis reproduction and beam 5 report",
                       description="Reproduce the thesis (validate), identify beam 5's models and write a report "
                                   "directory with tables and figures.")
    p.add_argument("--out", default="out/demo", help="report directory (default out/demo)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run)
