"""The discrepancy workflow on files: a measurement file in; the result, the calibrated beam file, tables and
figures out.

:func:`analyse_file` reads a measurement (:func:`load_measurement`: modal JSON, or FRFs identified by LSCF/LSFD,
on the nodes of :func:`measurement_mesh`), chooses the noise that whitens the residuals (given, of the data, or
assumed), runs :func:`physics.discrepancy.analyse` and, with ``out_dir``, writes the calibrated beam file, the
residual and candidate tables, ``summary.json`` and the figures. ``beam-damage discrepancy``, the demo and the
study ``discrepancy-study`` call it.
"""

from __future__ import annotations

import csv
import io
import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from physics.beam import Beam, beam_to_toml, load_beam
from physics.discrepancy.measurement import Measurement, Noise, frf_scatter_db
from physics.discrepancy.model import ModeResiduals, predict
from physics.discrepancy.pairing import failed_noise_check
from physics.discrepancy.workflow import DiscrepancyResult, analyse, check_candidates
from physics.errors import ConfigError, FileFormatError
from physics.identification import identify_frf
from physics.io import (MODAL, atomic_write_bytes, figure_png, pyplot, modal_data_from_dict, modal_or_frf, number_list,
                        prepare_measured, read_frf, read_json, reference_position_m, sensor_labels, to_jsonable)

__all__ = ["EXAMPLE", "MIN_LINE_SNR", "NOISE_LINES", "analyse_file", "assumed_noise", "estimated_noise",
           "lines_above_noise", "load_measurement", "measured_test_notes", "measurement_mesh"]

#: The thesis's beam 5 measured frequencies (Table 4.3): the example of ``beam-damage discrepancy --help``.
EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "thesis" / "beam5_table_4_3.json"


def load_measurement(path, beam: Beam, n_modes=None) -> tuple[Measurement, object, object]:
    """Modal JSON (frequencies alone, or with damping and shapes) or an FRF file identified by LSCF/LSFD.

    Measured DOFs are placed at the nodes of the beam's mesh by :meth:`physics.beam.Beam.map_dofs` (file
    geometry, else the beam file's measured_x_m, else the quarter-point convention).

    An FRF file is identified over the beam file's ``band_hz`` (all its lines without one), as ``classify``
    identifies a beam file's test, and compared over that band on the lines above its noise
    (:func:`lines_above_noise`).

    One sensor (one shape row) gives frequencies, damping ratios and, from an FRF file, the FRF: one entry per
    mode compares no shape. A force where no sensor is (a hammer away from the accelerometer) is placed by the file's
    node geometry, else the beam file's ``drive_x_m``.

    Returns the measurement, the relative frequency std of an identification (or None) and the
    :class:`physics.io.DofMap` of the measured DOFs (None for frequencies alone).
    """
    path = Path(path)
    beam = measurement_mesh(beam)
    if modal_or_frf(path) == MODAL:
        try:
            obj = read_json(path, require_object=False)
        except FileNotFoundError:
            raise FileFormatError(f"{path}: file not found") from None
        if isinstance(obj, dict) and "natural_frequencies_hz" in obj and "damping_ratios" not in obj \
                and "eigenvalues" not in obj:
            f = number_list(obj["natural_frequencies_hz"], str(path), "natural_frequencies_hz")
            try:
                return Measurement(f), None, None
            except ValueError as exc:
                raise FileFormatError(f"{path}: field 'natural_frequencies_hz': {exc}") from None
        data = prepare_measured(modal_data_from_dict(obj, str(path))).data
        shapes, xs, dof_map = data.eigenvectors, (), None
        if shapes is not None and shapes.shape[0] < 2:   # one sensor: one entry per mode compares no shape
            shapes = None
        if shapes is not None:
            if not data.dofs and shapes.shape[0] != len(beam.measured_x_m):
                raise FileFormatError(f"{path}: {shapes.shape[0]} shape rows but the beam has "
                                      f"{len(beam.measured_x_m)} measured positions; add 'dofs' labels such as "
                                      '"2:y"')
            dof_map = beam.map_dofs(data.dofs, targets="nodes", where=str(path))
            xs = _node_x(beam, dof_map.model_dofs)
            rows = np.argsort(xs, kind="stable")   # rows in the order of the beam's nodes
            shapes, xs = shapes[rows], tuple(np.asarray(xs)[rows])
        try:
            return Measurement(data.natural_frequencies_hz, data.damping_ratios, shapes, xs), None, dof_map
        except ValueError as exc:
            raise FileFormatError(f"{path}: {exc}") from None
    frf = read_frf(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # as classify identifies a beam file's test (learn.pairs.measured.identify_band): LSCF over its band_hz
        ident = identify_frf(frf, n_modes=n_modes, band_hz=beam.band_hz)
    est = ident.estimate
    rec = ident.frf  # receptance, band-limited as identified
    # the sensors placed (a driving point's reference is where its response is); a force where no sensor is does
    # not count as one (physics.io.sensor_labels) and is placed by the file's geometry, else the beam file
    labels = tuple(dict.fromkeys(rec.response_dofs)) if rec.metadata.get("geometry") else \
        sensor_labels(rec, beam.measured_x_m if beam.measured_x_given else None)
    dof_map = beam.map_dofs(labels, frf=rec, targets="nodes")
    x = dict(zip(labels, _node_x(beam, dof_map.model_dofs)))
    for d in rec.reference_dofs:
        if d not in x:  # the force where no sensor is: the file's geometry, else the beam file, places it
            x[d] = reference_position_m(rec) if reference_position_m(rec) is not None else beam.drive_x_m
            if x[d] is None:
                raise ConfigError(f"{path}: the reference DOF {d} is no sensor and neither the file's node geometry "
                                  "nor the beam file (drive_x_m) places it")
    rows = np.argsort([x[d] for d in rec.response_dofs], kind="stable")   # in the order of the beam's nodes
    resp = tuple(x[rec.response_dofs[i]] for i in rows)
    ref = tuple(x[d] for d in rec.reference_dofs)
    order = np.argsort(est.natural_frequencies_hz)
    shapes = est.shapes[rows][:, order] if len(resp) >= 2 else None   # one sensor: frequencies and the FRF
    keep = lines_above_noise(rec.frf, ident.synthesised)
    meas = Measurement(est.natural_frequencies_hz[order], est.damping_ratios[order], shapes,
                       resp if shapes is not None else (), rec.frf[rows][..., keep], rec.frequency_hz[keep], resp, ref,
                       rec.kind)
    rel_std = np.asarray(est.frequency_std_hz)[order] / meas.frequencies_hz
    return meas, rel_std, dof_map


#: FRF lines compared: the identified model's magnitude at least this many times the noise around the line (the
#: measured FRF's departure from the identified model, running median over :data:`NOISE_LINES` lines). Where noise
#: dominates, the magnitude in dB is biased upwards (``|H + n|^2`` averages ``|H|^2 + sigma^2``: +0.46 dB at this
#: ratio, +3 dB where the two are equal), and a band mean over a noise floor would pull the fitted mass down.
MIN_LINE_SNR = 3.0
NOISE_LINES = 11


def lines_above_noise(frf, synthesised) -> np.ndarray:
    """``(n_lines,)`` bool: the lines of the measured ``frf`` (n_resp, n_ref, n_lines) where the identified model
    ``synthesised`` (same shape) stands :data:`MIN_LINE_SNR` times over the noise (RMS over the FRFs of both)."""
    from scipy.ndimage import median_filter  # scipy.ndimage: only where an FRF file is compared

    h = np.asarray(synthesised).reshape(-1, np.shape(frf)[-1])
    noise = np.sqrt(np.mean(np.abs(np.asarray(frf).reshape(h.shape) - h) ** 2, axis=0))
    level = np.sqrt(np.mean(np.abs(h) ** 2, axis=0))
    return level >= MIN_LINE_SNR * median_filter(noise, size=NOISE_LINES, mode="nearest")


def measurement_mesh(beam: Beam, most: int = 400) -> Beam:
    """``beam`` on the fewest elements (at least its own, at most ``most``) that put a node at every measured
    position and the drive point, which measured DOFs are placed on; ``beam`` itself when none does."""
    points = np.r_[beam.measured_x_m, [] if beam.drive_x_m is None else [beam.drive_x_m]] / beam.length_m
    for n in range(beam.n_elements, most + 1):
        if np.all(np.abs(points * n - np.rint(points * n)) <= 1e-6 * n):
            return beam if n == beam.n_elements else replace(beam, n_elements=n)
    return beam


def _node_x(beam: Beam, model_dofs) -> tuple:
    """Positions (m) of model DOFs ``"N:y"`` of the beam's mesh."""
    return tuple((int(d.partition(":")[0]) - 1) * beam.length_m / beam.n_elements for d in model_dofs)


def _residual_rows(label: str, r: ModeResiduals) -> list[dict]:
    rows = []
    for j in range(r.measured_hz.size):
        rows.append({
            "model": label, "mode": j + 1, "measured_hz": float(r.measured_hz[j]), "model_hz": float(r.model_hz[j]),
            "frequency_error_pct": float(r.frequency_error_pct[j]),
            "measured_damping": None if r.measured_damping is None else float(r.measured_damping[j]),
            "model_damping": None if r.model_damping is None else float(r.model_damping[j]),
            "mac": None if r.mac is None else float(r.mac[j]),
            "frf_band_error_db": None if r.frf_band_error_db is None else float(r.frf_band_error_db[j]),
        })
    return rows


#: Columns of candidates.csv.
_CANDIDATE_COLUMNS = ("effect", "score", "max_abs_frequency_error_pct", "round", "lomo", "n_params", "parameters")


def _csv(rows: list[dict], columns=()) -> bytes:
    """CSV text of ``rows``; the columns are the first row's keys, else (no rows: a header alone) ``columns``."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    return buf.getvalue().encode()


def _candidate_rows(res: DiscrepancyResult) -> list[dict]:
    rows = []
    for i, st in enumerate(res.steps):
        prefix = " + ".join(res.named_effects[:i])
        if i == 0:
            rows.append({"effect": "none", "score": st.score(st.base), "max_abs_frequency_error_pct":
                         st.base.residuals.max_abs_frequency_error_pct, "parameters": st.base.parameters,
                         "round": 1, "lomo": st.base.lomo, "n_params": st.base.n_params})
        for f in st.candidates:
            rows.append({"effect": f"{prefix} + {f.effect}" if prefix else f.effect, "score": st.score(f),
                         "max_abs_frequency_error_pct": f.residuals.max_abs_frequency_error_pct,
                         "parameters": f.parameters, "round": i + 1, "lomo": f.lomo, "n_params": f.n_params})
    return rows


def _figures(res: DiscrepancyResult, recal: ModeResiduals, meas: Measurement,
             before_frf, after_frf) -> dict:
    plt = pyplot()

    out = {}
    fig, ax = plt.subplots(figsize=(7, 4))
    modes = np.arange(1, meas.n_modes + 1)
    width = 0.27
    after_label = "after: " + (" + ".join(res.named_effects) if res.named_effects else "recalibrated only")
    for k, (r, lab) in enumerate(((res.nominal, "before (beam as given)"), (recal, "EI/m recalibrated only"),
                                  (res.final.residuals, after_label))):
        ax.bar(modes + (k - 1) * width, r.frequency_error_pct, width, label=lab)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(modes)
    ax.set_xlabel("measured mode")
    ax.set_ylabel("frequency error, model vs measured (%)")
    ax.set_title("Frequency error per mode before and after the discrepancy workflow")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out["frequency_error.png"] = figure_png(fig)
    if meas.frf is not None:
        n_resp, n_ref = meas.frf.shape[:2]
        fig, axes = plt.subplots(n_resp, n_ref, figsize=(4 + 3 * n_ref, 2.2 * n_resp), squeeze=False, sharex=True)
        f = meas.frf_frequency_hz
        for s in range(n_resp):
            for r in range(n_ref):
                ax = axes[s, r]
                ax.semilogy(f, np.abs(meas.frf[s, r]), "k", lw=1, label="measured")
                ax.semilogy(f, np.abs(before_frf[s, r]), "tab:red", lw=0.8, ls="--", label="before")
                ax.semilogy(f, np.abs(after_frf[s, r]), "tab:blue", lw=0.8, label="after")
                ax.set_title(f"x = {meas.frf_response_x_m[s]:.3g} m / x = {meas.frf_reference_x_m[r]:.3g} m",
                             fontsize=8)
        axes[0, 0].legend(fontsize=7)
        for ax in axes[-1]:
            ax.set_xlabel("frequency (Hz)")
        fig.tight_layout()
        out["frf_overlay.png"] = figure_png(fig)
    return out


def assumed_noise(meas: Measurement, noise: Noise, sources: dict) -> dict:
    """The noise that whitens the residuals, for the data present, and where it comes from (``sources`` of
    :func:`_noise_for`)."""
    f = np.asarray(noise.frequency, dtype=float)
    out = {"frequency": f.tolist() if f.ndim else float(f), "frequency_source": sources["frequency"]}
    if meas.shapes is not None:
        out["shape"] = noise.shape
        out["shape_source"] = sources["shape"]
    if meas.frf is not None:
        out["frf_db"] = noise.frf_db
        out["frf_db_source"] = sources["frf_db"]
    return out


def estimated_noise(meas: Measurement, res: DiscrepancyResult) -> dict:
    """The noise used for the selection when it was scaled to the data, and the final model's check against it."""
    s = res.noise_scale
    out = {"scale": s, "dof": res.noise_scale_dof, "from": res.noise_scale_from}
    f = np.asarray(res.noise.frequency, dtype=float) * s
    out["frequency"] = f.tolist() if f.ndim else float(f)
    if meas.shapes is not None:
        out["shape"] = res.noise.shape * s
    fin = res.final
    dof = fin.dof
    out["chi2_per_dof"] = fin.chi2 / s**2 / dof if dof > 0 else float("nan")
    return out


def analyse_file(beam_spec, measured, out_dir=None, *, frequency_noise=None, shape_noise=None, frf_noise_db=None,
                    max_effects=2, n_elements=40, seed=0, candidates=None, estimate_noise=False,
                    progress=None, pairing=None) -> dict:
    """The discrepancy workflow on a measurement file: the JSON result of ``beam-damage discrepancy`` and its
    ``"_result"`` (the :class:`DiscrepancyResult` and the residuals of the model with EI/m recalibrated only); with
    ``out_dir``, the calibrated ``beam.toml``, ``residuals.csv/json``, ``candidates.csv/json``, ``summary.json``
    and the figures written there (all rendered first, then written atomically).

    ``beam_spec`` is a :class:`Beam`, a preset name or a beam file; ``measured`` a modal JSON or an FRF file
    (:func:`load_measurement`).

    ``candidates`` (None: every one of the beam's supports, :func:`physics.effects.candidates_for`) are checked
    against the beam's supports before the measurement is read.
    ``frequency_noise``, ``shape_noise`` and ``frf_noise_db`` are the noise stds given (None: not given;
    :func:`_noise_for`). ``estimate_noise`` (modal JSON only; FRF input takes its noise from the identification
    and the FRF's scatter) scales an assumed noise to the data (:func:`physics.discrepancy.analyse`).
    ``pairing`` is the rule that pairs the measured modes with the model's (:func:`physics.discrepancy.analyse`;
    the beam's ``band_hz`` names a model mode below it).

    Nothing is written when the pairing is implausible (:class:`ImplausibleTest` raised before any fit) or the
    calibrated model's chi^2/dof exceeds :data:`STOP_CHI2_PER_DOF`: then ``"stopped"`` holds one line naming
    the likely cause and ``"causes"`` each of them (else ``"stopped"`` is None).
    """
    beam = beam_spec if isinstance(beam_spec, Beam) else load_beam(beam_spec)
    try:
        candidates = check_candidates(candidates, beam.bc, beam.section)
    except ValueError as exc:
        raise ConfigError(f"--candidates: {exc}") from None
    meas, rel_std, dof_map = load_measurement(measured, beam)
    noise, sources = _noise_for(meas, rel_std, frequency_noise, shape_noise, frf_noise_db)
    if out_dir is not None:
        out_dir = Path(out_dir)
        if out_dir.exists() and not out_dir.is_dir():
            raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    res = analyse(beam, meas, noise, candidates=candidates, max_effects=max_effects, n_elements=n_elements,
                      seed=seed, estimate_noise=estimate_noise and meas.frf is None, progress=progress,
                      pairing=pairing, band_hz=beam.band_hz)
    first = res.steps[0] if res.steps else None
    cand = _candidate_rows(res)
    check = res.noise_check.to_dict()
    out = _result_json(res, meas, noise, sources, dof_map, cand, check)
    out["notes"], out["drive_x_m_from_file"] = measured_test_notes(beam, meas, measured)
    recal = first.base.residuals if first else res.final.residuals
    stop = failed_noise_check(res.noise_check, res.final.residuals, res.pairing)
    out["stopped"], out["causes"] = (stop["stopped"], stop["causes"]) if stop else (None, [])
    out["pairing"] = res.pairing.to_list() if res.pairing is not None else []
    out["pairing_notes"] = list(res.pairing.skipped) if res.pairing is not None else []
    if out_dir is not None and stop is None:
        before_frf = after_frf = None
        if meas.frf is not None:
            before_frf = predict(beam, meas, n_elements).frf
            after_frf = predict(res.final.beam, meas, n_elements).frf
        files = _figures(res, recal, meas, before_frf, after_frf)
        files.update(_table_files(res, recal, cand))
        calibrated = res.final.beam.with_effects(res.final.beam.effects_dict(), name=f"{beam.name}-calibrated",
                                                 **({"drive_x_m": out["drive_x_m_from_file"]}
                                                    if out["drive_x_m_from_file"] is not None else {}))
        comment = _calibration_comment(beam, measured, res, meas, noise, check, seed)
        files["summary.json"] = _summary_json(out, out_dir, res, seed)
        files["beam.toml"] = beam_to_toml(calibrated, comment).encode()
        for name, data in files.items():
            atomic_write_bytes(out_dir / name, data)
        out["beam_file"] = str(out_dir / "beam.toml")
    out["_result"] = (res, recal)
    return out


def measured_test_notes(beam: Beam, meas: Measurement, measured) -> tuple[list[str], float | None]:
    """What the measured test adds to or leaves out of the beam file, one line each, and the reference DOF's
    position (m) the calibrated beam file takes from the measured file (None: the beam file's stands).

    The reference DOF of an FRF file is written to the calibrated beam file as ``drive_x_m`` when the beam file
    names none and the file places it elsewhere than the default (the first sensor), so that ``generate`` simulates
    the test as it was run. One sensor: its one entry per mode compares no shape (a MAC of one entry is 1), so the
    frequencies, damping and FRF are compared."""
    notes, drive = [], None
    if meas.frf is not None and meas.frf_response_x_m and len(meas.frf_response_x_m) < 2:
        notes.append(f"{measured}: one sensor: its mode-shape entries compare no shape; frequencies, damping ratios "
                     "and the FRF are compared")
    if meas.frf is not None and beam.drive_x_m is None and meas.frf_reference_x_m:
        x = float(meas.frf_reference_x_m[0])
        if abs(x - beam.measured_x_m[0]) > 1e-6 * beam.length_m:
            drive = x
            notes.append(f"drive_x_m = {x:.6g} m from {measured}: its reference DOF (the beam file names no drive "
                         f"point; the default, the first sensor, lies at {beam.measured_x_m[0]:.6g} m); the "
                         "calibrated beam file records it")
    return notes, drive


def _noise_for(meas: Measurement, rel_std=None, frequency=None, shape=None, frf_db=None) -> tuple[Noise, dict]:
    """The noise that whitens the residuals and where each std comes from (``{"frequency", "shape", "frf_db"}``).

    Each std is the one given, else of the data (the relative frequency std ``rel_std`` of an FRF
    identification, floored at 0.1 %; the FRF's line-to-line scatter), else assumed (:class:`Noise`'s default).
    """
    d = Noise()
    if frequency is not None:
        src_f = "--frequency-noise"
    elif rel_std is not None:
        frequency, src_f = np.maximum(rel_std, 1e-3), "FRF identification (its frequency std, at least 0.1 %)"
    else:
        frequency, src_f = d.frequency, "assumed (default, --frequency-noise)"
    src_s = "--shape-noise" if shape is not None else "assumed (default, --shape-noise)"
    if frf_db is not None:
        src_h = "--frf-noise-db"
    elif meas.frf is not None:
        frf_db = frf_scatter_db(meas)
        src_h = "the FRF's line-to-line scatter; compared as the mean level per mode band"
    else:
        frf_db, src_h = d.frf_db, "assumed (default; no FRF)"
    noise = Noise(frequency, d.damping, d.shape if shape is None else shape, frf_db)
    return noise, {"frequency": src_f, "shape": src_s, "frf_db": src_h}


def _result_json(res: DiscrepancyResult, meas: Measurement, noise: Noise, sources: dict, dof_map,
                 cand: list[dict], check: dict) -> dict:
    """The JSON result of the command (issue 9 keys; ``beam_file`` None until the files are written)."""
    first = res.steps[0] if res.steps else None
    return {
        "named_effect": res.named_effects[0] if res.named_effects else "none",
        "effects": list(res.named_effects),
        "evidence": res.evidence,
        "parameters": res.final.parameters,
        "parameter_std": res.final.parameter_std,
        "indistinguishable_from": list(first.indistinguishable_from) if first else [],
        "separating_measurement": first.separating_measurement if first else "",
        "gap_before": res.nominal.gap(),
        "gap_after": res.final.residuals.gap(),
        "assumed_noise": assumed_noise(meas, noise, sources),
        "chi2_per_dof": check["chi2_per_dof"],
        "noise_consistent": check["noise_consistent"],
        "noise_check": check,
        "not_tested": res.untestable,
        "detection_limits": {k: v.to_dict() for k, v in res.detection_limits.items()},
        "estimated_noise": estimated_noise(meas, res),
        "candidates": [{k: c[k] for k in ("effect", "score", "max_abs_frequency_error_pct", "parameters")}
                       for c in cand],
        "beam_file": None,
        "dof_positions": None if dof_map is None else dof_map.to_dict(),
    }


def _table_files(res: DiscrepancyResult, recal: ModeResiduals, cand: list[dict]) -> dict[str, bytes]:
    """``residuals.csv/json`` (before, recalibrated, after) and ``candidates.csv/json``, rendered."""
    rows = (_residual_rows("before", res.nominal) + _residual_rows("recalibrated", recal)
            + _residual_rows("after", res.final.residuals))
    files = {"residuals.csv": _csv(rows), "residuals.json": (json.dumps(rows, indent=1) + "\n").encode()}
    flat = [{**{k: v for k, v in c.items() if k != "parameters"},
             "parameters": json.dumps(c["parameters"], sort_keys=True)} for c in cand]
    files["candidates.csv"] = _csv(flat, _CANDIDATE_COLUMNS)
    files["candidates.json"] = (json.dumps(to_jsonable(cand), indent=1) + "\n").encode()
    return files


def _calibration_comment(beam: Beam, measured, res: DiscrepancyResult, meas: Measurement,
                         noise: Noise, check: dict, seed: int) -> str:
    """Header of the calibrated beam file: the command, the named effects, seed, noise and chi2/dof."""
    return (f"calibrated by 'beam-damage discrepancy --beam {beam.name} --measured {measured}'\n"
            f"named effects: {', '.join(res.named_effects) or 'none'}; seed {seed}; "
            f"noise: frequency {res.noise_scale * np.max(np.asarray(noise.frequency)):.3g} (relative"
            + (f", the assumed {np.max(np.asarray(noise.frequency)):.3g} scaled by {res.noise_scale:.3g} to the data"
               if res.noise_scale != 1.0 else "") + "); chi2/dof "
            f"{check['chi2_per_dof']:.3g} ({check['verdict']})"
            + ("\ndamping: Rayleigh least-squares fitted to the measured damping ratios"
               if meas.damping_ratios is not None else ""))


def _summary_json(out: dict, out_dir: Path, res: DiscrepancyResult, seed: int) -> bytes:
    """``summary.json``: the JSON result with the beam file's path, the rounds of the selection and the seed."""
    steps = [{"round": i + 1, "named": st.named, "indistinguishable_from": list(st.indistinguishable_from),
              "separating_measurement": st.separating_measurement, "c_hat": st.c_hat}
             for i, st in enumerate(res.steps)]
    summary = dict(out, beam_file=str(out_dir / "beam.toml"), steps=steps,
                   evidence_chi2_drop=res.evidence_chi2_drop, seed=seed)
    return (json.dumps(to_jsonable(summary), indent=1) + "\n").encode()
