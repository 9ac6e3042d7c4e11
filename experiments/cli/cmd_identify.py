"""``beam-damage identify``: modal identification from a measured FRF file."""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from physics.errors import BeamDamageError, ConfigError, FileFormatError
from physics.identification import (DEFAULT_OUTPUT_ONLY, METHODS, Identification, RecordsIdentification,
                                    holds_response_records, identify_file, identify_records,
                                    read_response_records, reconstruction_error_db, response_records)
from physics.identification.measured import DEFAULT_MAX_ORDER
from physics.identification.exponential_window import remove_window_decay, slower_than_window, tau_from_end_value
from physics.identification.output_only import FREE_RESPONSE_METHOD, SCALING, STATIONARY_METHOD
from physics.identification.setups import MergedSetups, finite_mac, merge_setups
from physics.io.inputs import repeated_files
from physics.identification.split_modes import split_pairs, split_text
from physics.io import (FRF, TIME, MeasuredFRF, NodeGeometry, accepted, format_complex, measured_positions, read,
                        atomic_write_text, modal_data_to_dict)
from physics.modal import mac
from experiments.cli.args import counted

__all__ = ["add_parser", "run"]


#: Highest model order accepted, and LSCF's default.
MAX_ORDER = 200


def modes_list(e) -> list:
    """One dict per identified mode of a :class:`ModalEstimate` (a shape entry NaN, a DOF the mode was not
    measured at, as None)."""
    nan = np.full(e.eigenvalues.size, np.nan)
    f_fit = nan if e.frequency_fit_std_hz is None else e.frequency_fit_std_hz
    z_fit = nan if e.damping_fit_std is None else e.damping_fit_std
    return [{"frequency_hz": float(e.natural_frequencies_hz[j]), "damping_ratio": float(e.damping_ratios[j]),
              "frequency_std_hz": float(e.frequency_std_hz[j]), "damping_std": float(e.damping_std[j]),
              "frequency_fit_std_hz": float(f_fit[j]), "damping_fit_std": float(z_fit[j]),
              "eigenvalue": format_complex(e.eigenvalues[j]),
              "weakly_stable": None if e.weakly_stable is None else bool(e.weakly_stable[j]),
              "shape": [format_complex(z) if np.isfinite(z) else None for z in e.shapes[:, j]],
              "mpc": float(e.mpc[j])}
             for j in range(e.eigenvalues.size)]


def records_result_dict(ident: RecordsIdentification, band_hz, picked: bool) -> dict:
    """The result of an output-only identification (no FRF, no fit error, unscaled shapes)."""
    e, rec = ident.estimate, ident.records
    fs = rec.sampling_frequency_hz
    band = list(band_hz) if band_hz else [0.0, 0.4 * fs]
    why = (ident.method_choice or f"picked {e.method}: response records without a force channel are identified "
           "output-only") if picked else f"{e.method}: output-only (named by --method)"
    return {"file": rec.metadata.get("source"), "method": e.method, "output_only": True,
            "method_choice": why, "kind": rec.quantities[0],
            "band_hz": [float(b) for b in band], "sampling_frequency_hz": fs,
            "duration_s": rec.signals.shape[1] / fs, "modes": modes_list(e), "dofs": list(rec.dofs),
            "references": [], "driving_point": None, "scaling": SCALING, "mac": mac(e.shapes).tolist(),
            "uncertainty": dict(METHODS[e.method].uncertainty),
            "out_of_band_poles_hz": [], "record_crop": None if ident.crop is None else ident.crop.to_dict(),
            **positions_report_dofs(rec.dofs, rec.metadata)}


def positions_report_dofs(dofs, metadata) -> dict:
    """``positions_m`` per DOF (from node geometry) and the rule used."""
    try:
        pos, source = measured_positions(dofs, NodeGeometry.from_metadata(metadata))
    except (BeamDamageError, ValueError) as exc:
        return {"positions_m": None, "positions_source": f"geometry not usable: {exc}"}
    return {"positions_m": None if pos is None else dict(zip(dofs, pos.tolist())), "positions_source": source}


def result_dict(ident: Identification) -> dict:
    e = ident.estimate
    modes = modes_list(e)
    resid = ident.synthesised - ident.frf.frf
    med, p90 = reconstruction_error_db(ident.frf.frf, ident.synthesised)
    return {"file": ident.frf.metadata.get("source"), "method": e.method, "kind": ident.frf.kind,
            "band_hz": [float(ident.frf.frequency_hz[0]), float(ident.frf.frequency_hz[-1])],
            "modes": modes, "dofs": list(ident.frf.response_dofs),
            "references": list(ident.frf.reference_dofs), "driving_point": ident.drive,
            "scaling": "unit modal A" if e.scaled else "unscaled (no driving point)",
            "mac": mac(e.shapes).tolist(),
            "uncertainty": dict(METHODS[e.method].uncertainty),
            "out_of_band_poles_hz": ident.out_of_band_hz.tolist(),
            "fit_error": float(np.linalg.norm(resid) / np.linalg.norm(ident.frf.frf)),
            "fit_error_db": {"median": med, "p90": p90},
            "units": units_report(ident.frf), **positions_report_dofs(ident.frf.response_dofs, ident.frf.metadata)}


def units_report(frf: MeasuredFRF) -> dict:
    """What the file said about units and the SI units the FRFs were converted to."""
    found = frf.metadata.get("units")
    if found:
        return dict(found)
    return {"file": [f"{frf.units} ({frf.metadata.get('format', 'file')}: SI units of the declared kind)"],
            "si": frf.units, "factor_to_si": [1.0]}


def run(args) -> dict:
    if args.band and not (np.all(np.isfinite(args.band)) and 0 <= args.band[0] < args.band[1]):
        raise ConfigError(f"--band {args.band[0]:g} {args.band[1]:g}: FMIN and FMAX must be finite with "
                          "0 <= FMIN < FMAX")
    if args.modes is not None and args.modes < 1:
        raise ConfigError(f"--modes {args.modes}: must be >= 1")
    if args.max_order is not None and not 1 <= args.max_order <= MAX_ORDER:
        raise ConfigError(f"--max-order {args.max_order}: must be between 1 and {MAX_ORDER} (a fit's cost grows "
                          "with the square of the order; an output-only model needs at least 2, a pair of poles)")
    window_flag = _check_window_options(args)
    band = tuple(args.band) if args.band else None
    if args.method is None or METHODS[args.method].data == "records":
        records = _output_only_records(args.file, args.method)
        if records is not None:
            if window_flag:
                raise ConfigError(f"{window_flag}: removes an exponential window's decay from the modes of impact "
                                  f"FRFs, but {args.file} holds response records identified output-only")
            return _run_output_only(args, records, band)
    if args.method is not None and holds_response_records(args.file) and not read(args.file, TIME).forces:
        names = ", ".join(n for n, spec in METHODS.items() if spec.data == "records")
        raise ConfigError(f"--method {args.method}: fits FRFs, but {args.file} holds response records without a force "
                          f"channel; identify them output-only: --method {names}, or no --method")
    if getattr(args, "setup", None):
        raise ConfigError(f"--setup: merges setups of response records (output-only); {args.file} holds FRFs")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident = identify_file(args.file, args.method or "lscf", band, args.modes, args.max_order)
        _warn_split(args.file, ident.estimate)
        ident, window = _remove_window(args, ident, window_flag)
    out = result_dict(ident)
    out["exponential_window"] = window
    out["warnings"] = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    if args.out:
        from experiments.studies.plots_identify import write_outputs  # matplotlib: only when writing

        out["outputs"] = write_outputs(ident, args.out)
    if not args.json:
        print(f"{out['file']}: {counted(len(out['modes']), 'mode')} by {out['method']} in "
              f"{out['band_hz'][0]:g}-{out['band_hz'][1]:g} Hz ({out['scaling']}, "
              f"fit error median {out['fit_error_db']['median']:.3g} dB, 90th percentile "
              f"{out['fit_error_db']['p90']:.3g} dB)")
        print(f"{'mode':>4} {'f (Hz)':>12} {'+-std':>9} {'+-fit':>9} {'zeta':>10} {'+-std':>9} "
              f"{'+-fit':>9} {'MPC':>7}")
        for j, m in enumerate(out["modes"], 1):
            print(f"{j:4d} {m['frequency_hz']:12.4f} {m['frequency_std_hz']:9.2g} {m['frequency_fit_std_hz']:9.2g} "
                  f"{m['damping_ratio']:10.5f} {m['damping_std']:9.2g} {m['damping_fit_std']:9.2g} {m['mpc']:7.4f}")
        notes = dict(METHODS[out["method"]].uncertainty)
        print("+-std: " + notes.get("frequency_std_hz, damping_std", "none (NaN)") + "; +-fit: "
              + notes.get("frequency_fit_std_hz, damping_fit_std", "none (NaN)"))
        if window is not None:
            print(window_text(window))
        if out["out_of_band_poles_hz"]:
            print("poles just outside the band used by the fit (Hz): "
                  + ", ".join(f"{x:.4g}" for x in out["out_of_band_poles_hz"]))
        for name, p in out.get("outputs", {}).items():
            print(f"wrote {p}")
    return out


def _check_window_options(args) -> str | None:
    """Check ``--exp-window-tau`` / ``--exp-window-end`` (at most one; a finite tau > 0, an end value in (0, 1));
    returns the flag given, or None."""
    tau, end = getattr(args, "exp_window_tau", None), getattr(args, "exp_window_end", None)
    if tau is not None and end is not None:
        raise ConfigError("--exp-window-tau and --exp-window-end name the same window: give one")
    if tau is not None and not (np.isfinite(tau) and tau > 0):
        raise ConfigError(f"--exp-window-tau {tau:g}: the window's time constant must be finite and > 0 (s)")
    if end is not None and not 0 < end < 1:
        raise ConfigError(f"--exp-window-end {end:g}: the window's value at the record end must be in (0, 1) "
                          "(0.01: it decays to 1 %)")
    return "--exp-window-tau" if tau is not None else "--exp-window-end" if end is not None else None


def _stored_tau(frf: MeasuredFRF) -> float | None:
    """The exponential window's tau_s that 'beam-damage estimate --excitation impact' stored in the FRFs' metadata
    (``.npz``), or None."""
    stored = frf.metadata.get("exponential_window")
    if stored is None:
        return None
    tau = stored.get("tau_s") if isinstance(stored, dict) else None
    if isinstance(tau, bool) or not isinstance(tau, (int, float)) or not (np.isfinite(tau) and tau > 0):
        raise FileFormatError(f"{frf.metadata.get('source')}: metadata exponential_window.tau_s {tau!r} must be a "
                              "finite number > 0 (s)")
    return float(tau)


def _record_length_s(frf: MeasuredFRF) -> float:
    """``1 / df`` of FRF lines equally spaced ``df`` apart: the length of the record the window spans."""
    df = np.diff(frf.frequency_hz)
    if df.size == 0 or np.ptp(df) > 1e-6 * df.mean():
        raise ConfigError(f"--exp-window-end: {frf.metadata.get('source')} has no equally spaced frequency lines, "
                          "so the record length 1/df is unknown; give the time constant with --exp-window-tau")
    return 1.0 / df.mean()


def _remove_window(args, ident: Identification, flag) -> tuple:
    """``(ident, report)``: the identification with the exponential window's decay removed from its modes when a
    window is known (the options, else the tau 'estimate' stored in the file), and the ``exponential_window``
    report (None: no window known). A window the file's dataset 1858 names is reported and warned about, not
    removed: the format leaves the unit of its damping factor undefined."""
    frf, est = ident.frf, ident.estimate
    stored = _stored_tau(frf)
    if flag is None and stored is None:
        named = [w for w in frf.metadata.get("windows", ()) if w["window_type"] in (4, 6)]
        if not named:
            return ident, None
        text = "; ".join(f"{w['window']} (damping factor {w['exponential_window_damping_factor']:.4g}, "
                         f"{w['records']} record(s))" for w in named)
        warnings.warn(f"{args.file}: its dataset 1858 records name an exponential window: {text}; the format does "
                      "not define the damping factor's unit, so the window's decay is not removed: the damping "
                      "ratios include it; remove it with --exp-window-tau S or --exp-window-end FRACTION",
                      UserWarning, stacklevel=2)
        return ident, {"tau_s": None, "added_decay_rate_1_s": None, "source": "dataset 1858 (not removed: unit of "
                       "the damping factor undefined)", "file_windows": named, "identified": None, "at_zero": []}
    if "random excitation" in frf.metadata.get("estimated", ""):
        raise ConfigError(f"{flag}: {args.file} holds time records whose FRFs are estimated here with a Hann "
                          "window (random excitation), no exponential window; for an impact test estimate them "
                          "with 'beam-damage estimate --excitation impact --out FRF.npz' and identify that")
    tau_opt, end_opt = getattr(args, "exp_window_tau", None), getattr(args, "exp_window_end", None)
    if tau_opt is not None:
        tau, source = tau_opt, "--exp-window-tau"
    elif end_opt is not None:
        length = _record_length_s(frf)
        tau = tau_from_end_value(length, end_opt)
        source = f"--exp-window-end {end_opt:g} over the record length 1/df = {length:.6g} s"
    else:
        tau, source = stored, f"{args.file}: stored by 'beam-damage estimate' (impact, exponential window)"
    if flag and stored is not None and not np.isclose(tau, stored, rtol=1e-6):
        warnings.warn(f"{args.file}: stores an exponential window of tau {stored:.6g} s; {flag} ({tau:.6g} s) is "
                      "removed instead", UserWarning, stacklevel=2)
    slow = slower_than_window(est.eigenvalues, tau, est.damping_std)
    if slow.any() and not slow.all():
        modes = ", ".join(f"{f:.5g} Hz ({-lam.real:.3g} 1/s)" for f, lam in
                          zip(est.natural_frequencies_hz[slow], est.eigenvalues[slow]))
        warnings.warn(f"{args.file}: left out {modes}: they decay slower than the exponential window's "
                      f"{1 / tau:.4g} 1/s makes every mode of the windowed FRFs decay, so they are poles the fit "
                      "placed in the noise (or the window's tau is shorter than the one applied)", UserWarning,
                      stacklevel=2)
        est = est.take(~slow)
        ident = replace(ident, estimate=est)
    fix = remove_window_decay(est.eigenvalues, tau, est.damping_std)
    if fix.at_zero.any():
        modes = ", ".join(f"{j + 1} ({est.natural_frequencies_hz[j]:.5g} Hz)" for j in np.nonzero(fix.at_zero)[0])
        warnings.warn(f"exponential window: mode(s) {modes} set to zero damping: their identified decay rates lie "
                      f"within the noise of the window's {fix.added_decay_rate_1_s:.4g} 1/s", UserWarning,
                      stacklevel=2)
    report = {"tau_s": fix.tau_s, "added_decay_rate_1_s": fix.added_decay_rate_1_s, "source": source,
              "file_windows": list(frf.metadata.get("windows", ())),
              "identified": [{"frequency_hz": float(f), "damping_ratio": float(z)}
                             for f, z in zip(est.natural_frequencies_hz, est.damping_ratios)],
              "at_zero": [int(j) + 1 for j in np.nonzero(fix.at_zero)[0]]}
    est = replace(est, eigenvalues=fix.eigenvalues, natural_frequencies_hz=fix.natural_frequencies_hz,
                  damping_ratios=fix.damping_ratios)
    return replace(ident, estimate=est), report


def window_text(window: dict) -> str:
    """One line on the exponential window removed (or named by the file and not removed)."""
    if window["tau_s"] is None:
        return f"exponential window named by the file, not removed ({window['source']})"
    return (f"exponential window removed: tau {window['tau_s']:.4g} s ({window['source']}): "
            f"{window['added_decay_rate_1_s']:.4g} 1/s off every mode's decay rate")


def _output_only_records(path, method):
    """The response records of a file to identify output-only, or None for the FRF path.

    With no method named, a file of time records without a force channel is output-only; a named output-only
    method takes the response channels of any time-record file (forces, if any, left out).
    """
    if method is None and not holds_response_records(path):
        return None
    if method is not None and not holds_response_records(path):
        raise ConfigError(f"--method {method}: identifies response records output-only, but {path} holds FRFs; "
                          f"time records as {accepted(TIME)}")

    rec = read(path, TIME)
    if method is None and rec.forces:
        return None                                   # force and responses: FRFs estimated first (H1)
    return response_records(rec, path)


def _warn_split(path, estimate) -> None:
    """Warn of adjacent modes the fit most likely split in two (:func:`split_pairs`)."""
    pairs = split_pairs(estimate.natural_frequencies_hz, estimate.damping_ratios, estimate.shapes)
    if pairs.size:
        warnings.warn(split_text(path, estimate.natural_frequencies_hz, pairs), UserWarning, stacklevel=2)


def _warn_duplicate_dofs(path, dofs) -> None:
    """Warn of channels that share a DOF label (two records of one node and direction): their shape entries are kept
    apart here, but modal data with a DOF twice are refused by 'update', 'classify' and 'discrepancy'."""
    where = {}
    for k, dof in enumerate(dofs, 1):
        where.setdefault(dof, []).append(k)
    twice = [f"{dof} (channels {', '.join(map(str, ks))})" for dof, ks in where.items() if len(ks) > 1]
    if twice:
        warnings.warn(f"{path}: channels share a DOF label: {'; '.join(twice)}; modal.json keeps each channel's "
                      "row, but 'update', 'classify' and 'discrepancy' refuse a DOF measured twice: relabel or drop "
                      "one of them", UserWarning, stacklevel=2)


def _run_output_only(args, records, band) -> dict:
    method = args.method or DEFAULT_OUTPUT_ONLY
    files = [args.file, *(args.setup or ())]
    if (pairs := repeated_files(files)):
        i, j = pairs[0]
        again = ("given twice" if os.path.realpath(files[i]) == os.path.realpath(files[j])
                 else f"the same bytes as {files[i]}")
        raise ConfigError(f"--setup {files[j]}: {again}; each setup is another record of the structure")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _warn_duplicate_dofs(args.file, records.dofs)
        ident = identify_records(records, method, band, args.modes, args.max_order)
        _warn_split(args.file, ident.estimate)
        method = ident.estimate.method                # the method picked: every setup by the same
        others = [identify_records(read_response_records(f), method, band, args.modes, args.max_order)
                  for f in getattr(args, "setup", None) or ()]
    out = records_result_dict(ident, band, picked=args.method is None)
    modal_data = ident.modal_data
    if others:
        with warnings.catch_warnings(record=True) as merging:
            warnings.simplefilter("always")
            merged = merge_setups([ident, *others])
        caught += merging
        modal_data = merged.modal_data
        out.update(modes=modes_list(merged.estimate), dofs=list(merged.dofs),
                   mac=finite_mac(merged.estimate.shapes).tolist(), **setups_report(merged, [out["file"], *args.setup]),
                   **positions_report_dofs(merged.dofs, records.metadata))
    out["warnings"] = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        obj = {**modal_data_to_dict(modal_data), "scaling": SCALING, "method": method,
               "frequency_std_hz": [m["frequency_std_hz"] for m in out["modes"]],
               "damping_std": [m["damping_std"] for m in out["modes"]],
               **({"partial_modes": out["partial_modes"]} if others else {}),
               **({"record_crop": out["record_crop"]} if out["record_crop"] else {})}
        path = Path(args.out) / "modal.json"
        atomic_write_text(path, json.dumps(obj, indent=1) + "\n")
        out["outputs"] = {"modal.json": str(path)}
    if not args.json:
        print(out["method_choice"])
        if others:
            print(setups_text(out))
        print(f"{out['file']}: {counted(len(out['modes']), 'mode')} by {method} in {out['band_hz'][0]:g}-"
              f"{out['band_hz'][1]:g} Hz from {counted(len(out['dofs']), 'channel')} x {out['duration_s']:.4g} s "
              f"({out['scaling']})")
        print(f"{'mode':>4} {'f (Hz)':>12} {'+-std':>9} {'zeta':>10} {'+-std':>9} {'MPC':>7}")
        partial = {p["mode"] for p in out.get("partial_modes", ())}
        for j, m in enumerate(out["modes"], 1):
            print(f"{j:4d} {m['frequency_hz']:12.4f} {m['frequency_std_hz']:9.2g} {m['damping_ratio']:10.5f} "
                  f"{m['damping_std']:9.2g} {m['mpc']:7.4f}" + ("  weakly stable" if m["weakly_stable"] else "")
                  + ("  partial" if j in partial else ""))
        print("+-std: " + out["uncertainty"].get("frequency_std_hz, damping_std", "none (NaN)"))
        for name, p in out.get("outputs", {}).items():
            print(f"wrote {p}")
    return out


def setups_report(merged: MergedSetups, files) -> dict:
    """What a multi-setup merge used and found: the setups, their reference DOFs (and whether assumed by position),
    each mode's reference MAC per setup (None where the setup does not hold it) and the partial modes (1-based,
    with the setups that hold them)."""
    rm = merged.reference_mac
    return {"setups": [str(f) for f in files], "setup_references": list(merged.references),
            "references_by_position": merged.by_position,
            "reference_mac": [[None if np.isnan(x) else float(x) for x in row] for row in rm],
            "partial_modes": [{"mode": int(j) + 1, "frequency_hz": float(merged.estimate.natural_frequencies_hz[j]),
                               "setups": [str(files[s]) for s in merged.found_in[j]]}
                              for j in np.nonzero(merged.partial)[0]]}


def setups_text(out: dict) -> str:
    """One line on a merge: setups, references, the least reference MAC, the partial modes."""
    rm = np.array([[np.nan if x is None else x for x in row] for row in out["reference_mac"]], float)
    shared = rm[np.sum(np.isfinite(rm), axis=1) > 1]
    least = f"; reference MAC across setups >= {np.nanmin(shared):.3g}" if shared.size else ""
    partial = out["partial_modes"]
    return (f"{len(out['setups'])} setups merged on the reference DOFs {', '.join(out['setup_references'])}"
            + (" (assumed by position: no DOF labels)" if out["references_by_position"] else "") + least
            + ("; partial modes (found in some setups only, the others' DOFs empty): "
               + ", ".join(f"{p['frequency_hz']:.4g} Hz ({len(p['setups'])} of {len(out['setups'])})"
                           for p in partial) if partial else ""))


def add_parser(sub):
    p = sub.add_parser(
        "identify",
        description="Modal identification from an FRF file, or output-only from response time records without "
                    f"a force. Methods (--method): {'; '.join(f'{n}: {s.help}' for n, s in METHODS.items())}. "
                    "Shapes are unit-modal-A scaled when a driving-point FRF is present; output-only shapes are "
                    "unit-norm and unscaled.")
    p.add_argument("file", metavar="FILE", help=f"FRF file: {accepted(FRF)}; or response time records without a "
                                                f"force (output-only): {accepted(TIME)}")
    p.add_argument("--method", default=None, choices=list(METHODS),
                   help="identification method (default: lscf for FRFs; for response records without a force "
                        f"{FREE_RESPONSE_METHOD} for a free response (decays after hits), {STATIONARY_METHOD} "
                        "otherwise; see the methods above)")
    p.add_argument("--setup", action="append", metavar="FILE",
                   help="output-only: another setup's response records (repeatable); its modes are scaled onto "
                        "FILE's on the DOFs every setup measures (fixed references; by position for files without "
                        "DOF labels), checked by the MAC of each mode's reference part (a setup below 0.9 is "
                        "refused) and merged into one set of shapes; a mode of some setups only is kept, 'partial', "
                        "its other DOFs empty (null)")
    p.add_argument("--band", nargs=2, type=float, metavar=("FMIN", "FMAX"), help="frequency band in Hz")
    p.add_argument("--modes", type=int, metavar="N", help="number of modes to keep (default: all found)")
    p.add_argument("--max-order", type=int, default=None,
                   help=f"highest model order (default {DEFAULT_MAX_ORDER} for lscf, or the highest the band's lines "
                        "carry where that is lower; ssi and era size it to the "
                        "clear peaks of the record's spectrum; used by "
                        f"{', '.join(m for m, spec in METHODS.items() if 'max_order' in spec.options)})")
    p.add_argument("--exp-window-tau", type=float, metavar="S",
                   help="FRFs of an impact test estimated with an exponential window exp(-t/S) on the response: "
                        "remove the 1/S (1/s) it adds to every mode's decay rate sigma = zeta omega_n (omega_d is "
                        "kept; omega_n and zeta recomputed); reported as exponential_window in the JSON. FRFs from "
                        "'beam-damage estimate --excitation impact --out FILE.npz' carry their S and are corrected "
                        "without it")
    p.add_argument("--exp-window-end", type=float, metavar="FRACTION",
                   help="as --exp-window-tau, the window given by its value at the record end (0.01: it decays to "
                        "1 %%): S = T / ln(1/FRACTION), T = 1/df the record length of the FRF lines")
    p.add_argument("--out", metavar="DIR",
                   help="write modal.json (feedable to 'beam-damage update --modal'; an exponential window's decay "
                        "removed), synthesised.uff (the "
                        "fitted FRFs in the input's kind, units and lines of the band; synthesised.csv for a CSV "
                        "without reference DOF), stabilisation.png "
                        "(lscf) and overlay.png")
    p.add_argument("--json", action="store_true",
                   help='print one JSON object: {"modes": [{"frequency_hz", "damping_ratio", "shape", '
                        '"mpc", ...}], "dofs": [...], ...}')
    p.set_defaults(func=run)
