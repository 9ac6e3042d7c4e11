"""``beam-damage discrepancy`` on a one-accelerometer cantilever: the UFF, identify's one-sensor modal data and
frequencies alone, with and without the accelerometer's mass in the beam file, a mode below the band and a spurious
pole.

Run: ``python -m experiments.benches.bench_one_sensor [--ei-scale 1.0] [--seeds 0] [--inputs NAME ...] [--out DIR]
[--docs] [--json]``

The test files are the independent simulator's (:mod:`experiments.second_sim.one_sensor`: a steel cantilever,
0.475 m, 25 x 6 mm, the 5 g accelerometer at L/4, hammer at 7L/8, accelerance 0.5-1600 Hz at 0.5 Hz, 1 % noise
plus a floor rising towards low frequency); the truth's EI is ``--ei-scale`` times the beam file's 94.5 N m^2, its
mass the beam file's. Per seed and input, ``discrepancy --json`` with the defaults: the pairing, EI, mass per
length, chi2/dof of the final model and whether a beam file was written, or the one line it stopped with. The
UFF runs take minutes each (``--inputs`` selects names of :data:`INPUTS`). ``--docs`` writes the table into
docs/discrepancy.md's block ``one-sensor`` (``--ei-scale 1``) or ``one-sensor-calibration`` (another scale).
"""

from __future__ import annotations

import json
from pathlib import Path

from experiments.benches.harness import cli_json, emit_json, parser, publish, table
from experiments.second_sim import one_sensor as osc
from physics.io import atomic_write_text

__all__ = ["INPUTS", "main", "run_input"]

#: name -> (what the row says, how its files are made from the written test): ``measured`` one of "uff", "modal",
#: "frequencies" (modal.json's frequencies), "frequencies-1" (without the first), "spurious" (with a pole at
#: 1150 Hz); ``beam`` one of "beam" (the accelerometer's mass in it), "bare" (without), "b30" (band from 30 Hz).
INPUTS = {
    "uff": ("the UFF", "uff", "beam"),
    "modal": ("identify's one-sensor `modal.json`", "modal", "beam"),
    "modal-bare": ("identify's one-sensor `modal.json`, no added mass in the beam file", "modal", "bare"),
    "frequencies": ("frequencies alone", "frequencies", "beam"),
    "below-band": ("frequencies alone, band from 30 Hz (mode 1 below it)", "frequencies-1", "b30"),
    "spurious": ("frequencies and a spurious pole at 1150 Hz", "spurious", "beam"),
}


def _files(out: Path, seed: int, ei_scale: float) -> dict:
    """The simulator's test, identify's modal.json of it, and the beam files and frequency files of :data:`INPUTS`."""
    d = out / f"seed-{seed}"
    files = osc.write_one_sensor_test(d, seed=seed, EI_scale=ei_scale)
    atomic_write_text(d / "bare.toml", osc.beam_toml(masses=False))
    atomic_write_text(d / "b30.toml", osc.beam_toml((30.0, 1600.0)))
    modal = d / "id" / "modal.json"
    if not modal.is_file():
        cli_json(["identify", str(files["uff"]), "--out", str(d / "id")])
    f = json.loads(modal.read_text())["natural_frequencies_hz"]
    for name, freqs in (("frequencies", f), ("frequencies-1", f[1:]), ("spurious", sorted(f + [1150.0]))):
        atomic_write_text(d / f"{name}.json", json.dumps({"natural_frequencies_hz": freqs}))
    return {"uff": files["uff"], "modal": modal, "beam": files["beam"], "bare": d / "bare.toml",
            "b30": d / "b30.toml", "dir": d, "identified_hz": f,
            **{k: d / f"{k}.json" for k in ("frequencies", "frequencies-1", "spurious")}}


def run_input(files: dict, name: str, true_ei_nm2: float) -> dict:
    """``discrepancy --json`` on input ``name`` of :data:`INPUTS`: a row of the table's values."""
    _, measured, beam = INPUTS[name]
    out_dir = files["dir"] / f"out-{name}"
    try:
        out = cli_json(["discrepancy", "--beam", str(files[beam]), "--measured", str(files[measured]),
                        "--out", str(out_dir)])
    except RuntimeError as exc:
        return {"input": name, "stopped": str(exc).split("error: ", 1)[-1], "beam_file": (out_dir / "beam.toml")
                .is_file()}
    p, s = out["parameters"], out["parameter_std"]
    return {"input": name, "stopped": out["stopped"], "beam_file": bool(out["beam_file"]),
            "model_modes": [q["model_mode"] for q in out["pairing"]],
            "max_pair_error_pct": max(abs(q["error_pct"]) for q in out["pairing"] if q["model_mode"]),
            "pairing_notes": out["pairing_notes"], "EI_Nm2": p.get("EI_Nm2"), "EI_std_Nm2": s.get("EI_Nm2"),
            "EI_error_pct": 100 * (p["EI_Nm2"] / true_ei_nm2 - 1) if "EI_Nm2" in p else None,
            "mass_per_length_kg_m": p.get("mass_per_length_kg_m"),
            "mass_fitted": bool(s.get("mass_per_length_kg_m")),
            "mass_error_pct": (100 * (p["mass_per_length_kg_m"] / osc.MASS_PER_LENGTH - 1)
                               if "mass_per_length_kg_m" in p else None),
            "chi2_per_dof": out["noise_check"]["chi2_per_dof"], "effects": out["effects"]}


def _cell(r: dict) -> list[str]:
    if r["stopped"]:
        return ["-", "-", "-", "-", "-", "no" + (" (written!)" if r["beam_file"] else ""), f"stopped: {r['stopped']}"]
    pairs = ",".join("-" if m is None else str(m) for m in r["model_modes"])
    mass = (f"{r['mass_per_length_kg_m']:.4g} ({r['mass_error_pct']:+.2f} %)" if r["mass_fitted"] else
            "the beam file's")
    return [f"{pairs} (max {r['max_pair_error_pct']:.2f} %)",
            f"{r['EI_Nm2']:.2f} +- {r['EI_std_Nm2']:.2f} ({r['EI_error_pct']:+.2f} %)", mass,
            ", ".join(r["effects"]) or "none", f"{r['chi2_per_dof']:.2g}", "yes" if r["beam_file"] else "no",
            "; ".join(r["pairing_notes"]) or "-"]


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="discrepancy.md", json=True, out="out/bench_one_sensor")
    p.add_argument("--ei-scale", type=float, default=1.0, help="the truth's EI over the beam file's (default 1)")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="noise seeds (default 0)")
    p.add_argument("--inputs", nargs="+", choices=list(INPUTS), default=list(INPUTS),
                   help="inputs to run (default all; the UFF's runs take minutes each)")
    args = p.parse_args(argv)
    out = Path(args.out) / f"ei-{args.ei_scale:g}"
    true_ei = osc.EI_NM2 * args.ei_scale
    rows = []
    for seed in args.seeds:
        files = _files(out, seed, args.ei_scale)
        for name in args.inputs:
            rows.append({"seed": seed, **run_input(files, name, true_ei)})
    emit_json(args, {"config": vars(args), "true_EI_Nm2": true_ei, "rows": rows})
    md = table(["input", "seed", "model modes paired (largest nominal gap)", "EI N m^2 (vs truth)",
                "mass kg/m (vs truth)", "named effects", "chi2/dof",
                "beam file", "pairing notes / stop"],
               [[INPUTS[r["input"]][0], r["seed"], *_cell(r)] for r in rows])
    if not args.json:
        print(f"truth EI {true_ei:.2f} N m^2 ({args.ei_scale:g} x the beam file's), mass {osc.MASS_PER_LENGTH} kg/m")
        print(md)
    publish(args, "one-sensor" if args.ei_scale == 1 else "one-sensor-calibration",
            md + f"\n\nTruth EI {true_ei:.2f} N m^2 ({args.ei_scale:g} x the beam file's), seeds "
            f"{' '.join(map(str, args.seeds))}.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
