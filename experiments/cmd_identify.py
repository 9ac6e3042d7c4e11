"""``beam-damage identify``: modal identification from a measured FRF file."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from physics.errors import BeamDamageError, ConfigError
# identify_file and identify_frf stay importable from here for commands of other branches (update, classify,
# discrepancy, demo) until they import them from physics.identification
from physics.identification import (METHODS, Identification, identify_file, identify_frf,  # noqa: F401
                                    reconstruction_error_db)
from physics.io import (MeasuredFRF, NodeGeometry, atomic_write_bytes, format_complex, measured_positions,
                        modal_data_to_dict, write_uff58)
from physics.modal import mac


#: Highest LSCF model order accepted.
MAX_ORDER = 200


def result_dict(ident: Identification) -> dict:
    e = ident.estimate
    nan = np.full(e.eigenvalues.size, np.nan)
    f_fit = nan if e.frequency_fit_std_hz is None else e.frequency_fit_std_hz
    z_fit = nan if e.damping_fit_std is None else e.damping_fit_std
    modes = [{"frequency_hz": float(e.natural_frequencies_hz[j]), "damping_ratio": float(e.damping_ratios[j]),
              "frequency_std_hz": float(e.frequency_std_hz[j]), "damping_std": float(e.damping_std[j]),
              "frequency_fit_std_hz": float(f_fit[j]), "damping_fit_std": float(z_fit[j]),
              "eigenvalue": format_complex(e.eigenvalues[j]),
              "shape": [format_complex(z) for z in e.shapes[:, j]], "mpc": float(e.mpc[j])}
             for j in range(e.eigenvalues.size)]
    resid = ident.synthesised - ident.frf.frf
    med, p90 = reconstruction_error_db(ident.frf.frf, ident.synthesised)
    return {"file": ident.frf.metadata.get("source"), "method": e.method, "kind": ident.frf.kind,
            "band_hz": [float(ident.frf.frequency_hz[0]), float(ident.frf.frequency_hz[-1])],
            "modes": modes, "dofs": list(ident.frf.response_dofs),
            "references": list(ident.frf.reference_dofs), "driving_point": ident.drive,
            "scaling": "unit modal A" if e.scaled else "unscaled (no driving point)",
            "mac": mac(e.shapes).tolist(),
            "uncertainty": dict(UNCERTAINTY[e.method]),
            "out_of_band_poles_hz": ident.out_of_band_hz.tolist(),
            "fit_error": float(np.linalg.norm(resid) / np.linalg.norm(ident.frf.frf)),
            "fit_error_db": {"median": med, "p90": p90},
            "units": units_report(ident.frf), **positions_report(ident.frf)}


def units_report(frf: MeasuredFRF) -> dict:
    """What the file said about units and the SI units the FRFs were converted to."""
    found = frf.metadata.get("units")
    if found:
        return dict(found)
    return {"file": [f"{frf.units} ({frf.metadata.get('format', 'file')}: SI units of the declared kind)"],
            "si": frf.units, "factor_to_si": [1.0]}


def positions_report(frf: MeasuredFRF) -> dict:
    """``positions_m`` per response DOF (from node geometry) and the rule used."""
    try:
        pos, source = measured_positions(frf.response_dofs, NodeGeometry.from_metadata(frf.metadata))
    except (BeamDamageError, ValueError) as exc:
        return {"positions_m": None, "positions_source": f"geometry not usable: {exc}"}
    return {"positions_m": None if pos is None else dict(zip(frf.response_dofs, pos.tolist())),
            "positions_source": source}


#: What each method's one-sigma values mean (reported in ``--json`` under "uncertainty").
UNCERTAINTY = {
    "lscf": {"frequency_std_hz, damping_std": "spread of the pole over the LSCF model orders of its cluster "
                                              "(sensitivity to model order, not a confidence interval)",
             "frequency_fit_std_hz, damping_fit_std": "one sigma from the LSFD fit itself: variable-projection "
                                                      "covariance of the poles given every FRF and its residual"},
    "circle": {"frequency_std_hz, damping_std": "weighted scatter of the circle fits over the FRFs"},
    "peak": {"frequency_std_hz, damping_std": "none (NaN)"},
}


def synthesised_frf(ident: Identification) -> MeasuredFRF:
    """The fitted FRFs as a :class:`MeasuredFRF` of the input's kind, units and (band-limited) lines.

    When the input's axis labels named one unit (e.g. ``g/N``) the values are converted back to it and
    the label written; otherwise (SI, or a dataset-164 unit system) they stay SI with SI labels.
    """
    src = ident.frf
    units = src.metadata.get("units") or {}
    found, factors = units.get("file", []), units.get("factor_to_si", [])
    h, label = ident.synthesised, src.units
    if len(found) == 1 and len(factors) == 1 and found[0].endswith(" (axis labels)") and factors[0] != 1.0:
        h, label = h / factors[0], found[0][: -len(" (axis labels)")]
    return MeasuredFRF(src.frequency_hz, h, src.response_dofs, src.reference_dofs, kind=src.kind, units=label,
                       metadata={"id1": "beam-damage identify: synthesised FRF", "source": src.metadata.get("source")})


def write_outputs(ident: Identification, out_dir) -> dict:
    """Write modal JSON, the synthesised FRFs (UFF 58), stabilisation diagram (LSCF) and overlay PNGs.

    Everything is rendered first, then each file is written atomically; returns their paths.
    """
    from experiments import plots_identify as plots

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    f, h = ident.frf.frequency_hz, ident.frf.frf
    labels = [f"{a}/{b}" for a in ident.frf.response_dofs for b in ident.frf.reference_dofs]
    files = {"modal.json": (json.dumps(modal_data_to_dict(ident.modal_data), indent=1) + "\n").encode()}
    if ident.diagram is not None:
        files["stabilisation.png"] = plots.stabilisation_png(ident.diagram, f, h,
                                                             ident.estimate.natural_frequencies_hz)
    files["overlay.png"] = plots.overlay_png(f, h, ident.synthesised, labels, ident.frf.kind, ident.frf.units)
    synth = synthesised_frf(ident)
    written = {}
    for name, data in files.items():
        atomic_write_bytes(out_dir / name, data)
        written[name] = str(out_dir / name)
    write_uff58(out_dir / "synthesised.uff", synth)
    written["synthesised.uff"] = str(out_dir / "synthesised.uff")
    return written


def run(args) -> dict:
    if args.band and not (np.all(np.isfinite(args.band)) and 0 <= args.band[0] < args.band[1]):
        raise ConfigError(f"--band {args.band[0]:g} {args.band[1]:g}: FMIN and FMAX must be finite with "
                          "0 <= FMIN < FMAX")
    if args.modes is not None and args.modes < 1:
        raise ConfigError(f"--modes {args.modes}: must be >= 1")
    if not 1 <= args.max_order <= MAX_ORDER:
        raise ConfigError(f"--max-order {args.max_order}: must be between 1 and {MAX_ORDER} (the LSCF normal "
                          "equations grow with the square of the order)")
    if args.out and Path(args.out).exists() and not Path(args.out).is_dir():
        raise ConfigError(f"--out {args.out}: exists and is not a directory")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident = identify_file(args.file, args.method, tuple(args.band) if args.band else None,
                              args.modes, args.max_order)
    out = result_dict(ident)
    out["warnings"] = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    if args.out:
        out["outputs"] = write_outputs(ident, args.out)
    if not args.json:
        for msg in out["warnings"]:
            print(f"warning: {msg}")
        print(f"{out['file']}: {len(out['modes'])} modes by {out['method']} in "
              f"{out['band_hz'][0]:g}-{out['band_hz'][1]:g} Hz ({out['scaling']}, "
              f"fit error median {out['fit_error_db']['median']:.3g} dB, 90th percentile "
              f"{out['fit_error_db']['p90']:.3g} dB)")
        print(f"{'mode':>4} {'f (Hz)':>12} {'+-order':>9} {'+-fit':>9} {'zeta':>10} {'+-order':>9} "
              f"{'+-fit':>9} {'MPC':>7}")
        for j, m in enumerate(out["modes"], 1):
            print(f"{j:4d} {m['frequency_hz']:12.4f} {m['frequency_std_hz']:9.2g} {m['frequency_fit_std_hz']:9.2g} "
                  f"{m['damping_ratio']:10.5f} {m['damping_std']:9.2g} {m['damping_fit_std']:9.2g} {m['mpc']:7.4f}")
        print("+-order: spread over LSCF model orders; +-fit: one sigma from the LSFD fit covariance")
        if out["out_of_band_poles_hz"]:
            print("poles just outside the band used by the fit (Hz): "
                  + ", ".join(f"{x:.4g}" for x in out["out_of_band_poles_hz"]))
        for name, p in out.get("outputs", {}).items():
            print(f"wrote {p}")
    return out


def add_parser(sub):
    p = sub.add_parser(
        "identify", help="identify natural frequencies, damping and complex modes from measured FRFs",
        description="Modal identification from an FRF file (UFF dataset 58 ASCII/binary, CSV or .npz of "
                    "MeasuredFRF). Methods: lscf (poly-reference LSCF poles with automatic stabilisation-"
                    "diagram selection, then LSFD residues with lower/upper residuals), circle (Nyquist "
                    "circle fit, eq. 3.13), peak (peak picking with half-power damping, eqs. 3.33/3.34). "
                    "Shapes are unit-modal-A scaled when a driving-point FRF is present.")
    p.add_argument("file", metavar="FILE", help="FRF file: .uff/.unv (dataset 58), .csv or .npz")
    p.add_argument("--method", default="lscf", choices=METHODS, help="identification method (default lscf)")
    p.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"), help="frequency band in Hz")
    p.add_argument("--modes", type=int, metavar="N", help="number of modes to keep (default: all found)")
    p.add_argument("--max-order", type=int, default=40, help="highest LSCF model order (default 40)")
    p.add_argument("--out", metavar="DIR",
                   help="write modal.json (feedable to 'beam-damage update --modal'), synthesised.uff (the "
                        "fitted FRFs in the input's kind, units and lines of the band), stabilisation.png "
                        "(lscf) and overlay.png")
    p.add_argument("--json", action="store_true",
                   help='print one JSON object: {"modes": [{"frequency_hz", "damping_ratio", "shape", '
                        '"mpc", ...}], "dofs": [...], ...}')
    p.set_defaults(func=run)
