"""``beam-damage identify``: modal identification from a measured FRF file."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from physics.errors import ConfigError
from physics.identification import METHODS, Identification, identify_frf
from physics.io import atomic_write_bytes, format_complex, modal_data_to_dict, read_frf
from physics.modal import mac


def identify_file(path, method="lscf", band_hz=None, n_modes=None, max_order=40) -> Identification:
    """:func:`physics.identification.identify_frf` on a UFF58, CSV or ``.npz`` file."""
    return identify_frf(read_frf(path), method, band_hz, n_modes, max_order)


def result_dict(ident: Identification) -> dict:
    e = ident.estimate
    modes = [{"frequency_hz": float(e.natural_frequencies_hz[j]), "damping_ratio": float(e.damping_ratios[j]),
              "frequency_std_hz": float(e.frequency_std_hz[j]), "damping_std": float(e.damping_std[j]),
              "eigenvalue": format_complex(e.eigenvalues[j]),
              "shape": [format_complex(z) for z in e.shapes[:, j]], "mpc": float(e.mpc[j])}
             for j in range(e.eigenvalues.size)]
    resid = ident.synthesised - ident.frf.frf
    return {"file": ident.frf.metadata.get("source"), "method": e.method,
            "band_hz": [float(ident.frf.frequency_hz[0]), float(ident.frf.frequency_hz[-1])],
            "modes": modes, "dofs": list(ident.frf.response_dofs),
            "references": list(ident.frf.reference_dofs), "driving_point": ident.drive,
            "scaling": "unit modal A" if e.scaled else "unscaled (no driving point)",
            "mac": mac(e.shapes).tolist(),
            "fit_error": float(np.linalg.norm(resid) / np.linalg.norm(ident.frf.frf))}


def write_outputs(ident: Identification, out_dir) -> dict:
    """Write modal JSON, stabilisation diagram (LSCF) and FRF overlay PNGs; returns their paths.

    All figures are rendered first, then each file is written atomically.
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
    files["overlay.png"] = plots.overlay_png(f, h, ident.synthesised, labels)
    written = {}
    for name, data in files.items():
        atomic_write_bytes(out_dir / name, data)
        written[name] = str(out_dir / name)
    return written


def run(args) -> dict:
    if args.band and not args.band[0] < args.band[1]:
        raise ConfigError(f"--band {args.band[0]:g} {args.band[1]:g}: FMIN must be below FMAX")
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
              f"relative fit error {out['fit_error']:.3g})")
        print(f"{'mode':>4} {'f (Hz)':>12} {'+-':>9} {'zeta':>10} {'+-':>9} {'MPC':>7}")
        for j, m in enumerate(out["modes"], 1):
            print(f"{j:4d} {m['frequency_hz']:12.4f} {m['frequency_std_hz']:9.2g} {m['damping_ratio']:10.5f} "
                  f"{m['damping_std']:9.2g} {m['mpc']:7.4f}")
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
                   help="write modal.json (feedable to 'beam-damage update --modal'), stabilisation.png "
                        "(lscf) and overlay.png")
    p.add_argument("--json", action="store_true",
                   help='print one JSON object: {"modes": [{"frequency_hz", "damping_ratio", "shape", '
                        '"mpc", ...}], "dofs": [...], ...}')
    p.set_defaults(func=run)
