"""Honesty check of the modal-noise shortcut: identify modes from noisy FRFs and compare error distributions.

Run: ``.venv/bin/python -m experiments.benches.bench_modal_noise [--specimens 8] [--levels 0.001,0.003,0.01,0.03]
[--floors 0,0.0003,0.001] [--workers 2] [--out out/modal_noise] [--write-calibration]``

A dataset's measured modal data come from a shortcut: the truth modes plus
random errors (:func:`datagen.pipeline.measure_modes`). ``classify`` identifies
them from the FRF files. Here specimens of the default configuration (both test
days) go through exactly what ``classify`` runs on a file
(:func:`learn.pairs.measured.identify_modes`: LSCF poles, LSFD residues with the
estimated noise weighting, the 4 modes below 1.4 times the nominal mode 4),
on FRFs synthesised as a dataset does, for every combination of an FRF noise
level, a noise floor (relative to each FRF's peak) and three line layouts
unlike the generator's own (:data:`GRIDS`: 0.25 Hz from 5 Hz, 0.5 Hz from 2 Hz,
1 Hz from 1 Hz, bands ending 15-45 % above mode 4). Per mode, the
identification errors

* relative natural-frequency error ``f_id / f_true - 1``,
* relative damping error ``zeta_id / zeta_true - 1``,
* shape error ``(psi_id - psi_true) / max|psi_true|`` per DOF (complex; the
  sign of the square-root scaling aligned),

are compared with the shortcut's: the fixed default model
(``measurement.modal_noise = "fixed"``) and the calibrated one
(``"calibrated"``: per mode, standard deviation ``sqrt((c level)^2 + (g floor)^2 + e^2)``
of the sample's FRF noise level and floor). The calibration fits ``c``, ``g``
and ``e`` (:func:`learn.pairs.noise_calibration.calibrate_std`) to the full path's robust standard deviation
in each condition (1.4826 MAD for real errors, ``sqrt(median|e|^2 / ln 2)`` for
circular complex errors). ``--write-calibration`` stores them in
``datagen/configs/modal_noise.json`` (what ``"calibrated"`` uses) with the
identification they describe.

Writes ``modal_noise.csv`` (per condition, mode and quantity: robust std of the
full path, of both shortcuts, KS distance full vs calibrated, failed
identifications of the mode), ``modal_noise.json`` and ``modal_noise.png`` (error
distributions, full path vs calibrated shortcut).
"""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from experiments.benches.harness import parser
from learn.pairs.noise_calibration import calibrate_std, robust_std
from datagen.config import CONFIG_DIR, merge
from datagen.batch_inputs import draw_batch
from datagen.pipeline import measure_modes, simulate_batch
from datagen.setup import get_setup
from datagen.synth import measured_frf
from learn.pairs.measured import IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, identify_modes
from learn.explanations.sensitivity import beam_sensitivity
from physics.errors import BeamDamageError
from physics.io import MeasuredFRF, atomic_write_bytes, atomic_write_text, figure_png, pyplot
from physics.modal import modal_parameters

__all__ = ["main"]

QUANTITIES = ("frequency", "damping", "shape")


def _ks(a, b):
    """Two-sample Kolmogorov-Smirnov distance of |a| and |b|."""
    from scipy.stats import ks_2samp

    a, b = np.abs(np.asarray(a)), np.abs(np.asarray(b))
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    return float(ks_2samp(a, b).statistic) if a.size and b.size else float("nan")


def _errors(lam_est, psi_est, lam_true, psi_true):
    """Errors (frequency, damping: (..., 4); shape: (..., 4 dofs, 4)) of estimated modes against the truth."""
    fe, ze = modal_parameters(lam_est)
    ft, zt = modal_parameters(lam_true)
    scale = np.max(np.abs(psi_true), axis=-2, keepdims=True)
    d_plus = psi_est - psi_true
    d_minus = psi_est + psi_true  # the square root of the driving-point residue fixes psi only up to its sign
    pick = np.sum(np.abs(d_minus) ** 2, axis=-2, keepdims=True) < np.sum(np.abs(d_plus) ** 2, axis=-2, keepdims=True)
    return fe / ft - 1, ze / zt - 1, np.where(pick, d_minus, d_plus) / scale


#: Line layouts (line spacing Hz, first line Hz, last line Hz) of the files the calibration identifies.
GRIDS = ((0.25, 5.0, 800.0), (0.5, 2.0, 950.0), (1.0, 1.0, 1000.0))


def _identify(args):
    """Full path for one (sample, state): what ``classify`` runs on a file, modes matched to the truth.

    Returns (eigenvalues (4,), shapes (4 dofs, 4)) with NaN for truth modes no
    identified pole lies within 5 % of, or None when the identification fails.
    """
    f_hz, H, fmax_hz, f_true = args
    frf = MeasuredFRF(f_hz, H[:, None, :], ("2:+Y", "3:+Y", "4:+Y", "5:+Y"), ("2:+Y",))
    with threadpool_limits(1):
        try:
            md = identify_modes(frf, fmax_hz)
        except (ArithmeticError, ValueError, RuntimeError, BeamDamageError):  # counted, not fatal
            return None
    fn = md.natural_frequencies_hz
    lam = np.full(4, np.nan + 0j)
    psi = np.full((H.shape[0], 4), np.nan + 0j)
    for r, f in enumerate(f_true):
        k = int(np.argmin(np.abs(fn - f)))
        if abs(fn[k] / f - 1) < 0.05:
            lam[r], psi[:, r] = md.eigenvalues[k], md.eigenvectors[:, k]
    return lam, psi


def _config(level, floor, calibration=None, grid=None):
    meas = {"frf_noise": level, "frf_noise_floor": floor}
    if grid is not None:
        df, lo, hi = grid
        meas.update(band_rad_s=[2 * np.pi * lo, 2 * np.pi * hi], lines=int(round((hi - lo) / df)) + 1)
    if calibration:
        meas.update(modal_noise="calibrated", **{f"{q}_noise{s}": calibration[q + s] for q in QUANTITIES
                                                 for s in ("", "_floor", "_per_floor")})
    return merge({"measurement": meas})


def shortcut_errors(level, floor, specimens, seed, calibration=None, grid=None):
    """Errors of the modal-noise shortcut (fixed default, or calibrated with the given coefficients)."""
    setup = get_setup(_config(level, floor, calibration, grid))
    inp = draw_batch(np.random.default_rng(seed), specimens, setup)
    sim = simulate_batch(setup, inp)
    lam_t, psi_t = sim["truth_poles"][..., :4], sim["truth_shapes"][..., :4]
    return _errors(*measure_modes(setup, inp, lam_t, psi_t), lam_t, psi_t), (setup, inp, sim)


def full_path_errors(level, floor, specimens, seed, pool, grid):
    """Errors of the identification ``classify`` runs on the measured FRFs a dataset synthesises, the modes it
    missed, and the errors of the fixed-default shortcut on the same draws."""
    fixed, (setup, inp, sim) = shortcut_errors(level, floor, specimens, seed, grid=grid)
    lam_t, psi_t = sim["truth_poles"][..., :4], sim["truth_shapes"][..., :4]
    H = measured_frf({**sim, "noise_seed": inp.noise_seed, "noise_level": inp.noise_level,
                      "noise_floor": inp.noise_floor}, setup.omega_rad_s, np.complex128)
    f_hz = setup.omega_rad_s / (2 * np.pi)
    f_true = np.abs(lam_t) / (2 * np.pi)
    r = setup.cfg["specimen"]["root_spring_relative"]
    fmax = IDENTIFICATION_BAND_FACTOR * beam_sensitivity("beam5", float(np.sqrt(r[0] * r[1]))).frequencies_hz[3]
    ids = list(pool.map(_identify, [(f_hz, H[i, s], fmax, f_true[i, s]) for i in range(specimens)
                                    for s in range(2)]))
    lam_e = np.full(lam_t.shape, np.nan + 0j)
    psi_e = np.full(psi_t.shape, np.nan + 0j)
    for k, r_ in enumerate(ids):
        if r_ is not None:
            lam_e[k // 2, k % 2], psi_e[k // 2, k % 2] = r_
    missed = np.isnan(lam_e.real).reshape(-1, 4).sum(axis=0)   # per mode, over samples and states
    return _errors(lam_e, psi_e, lam_t, psi_t), missed, fixed


def _pooled(parts):
    """Concatenate per-grid error triples along the sample axis."""
    return tuple(np.concatenate([p[q] for p in parts], axis=0) for q in range(3))


def main(argv=None):
    ap = parser(__file__, __doc__, json=True, out="out/modal_noise", seed=0, workers=2)
    ap.add_argument("--specimens", type=int, default=8, help="specimens per condition and line layout (2 tests each)")
    ap.add_argument("--levels", default="0.001,0.003,0.01,0.03", help="FRF noise levels (relative to |H|)")
    ap.add_argument("--floors", default="0,0.0003,0.001", help="FRF noise floors (relative to each FRF's peak)")
    ap.add_argument("--write-calibration", action="store_true",
                    help="store the fitted coefficients in datagen/configs/modal_noise.json")
    a = ap.parse_args(argv)


    levels = [float(x) for x in a.levels.split(",")]
    floors = [float(x) for x in a.floors.split(",")]
    conditions = [(lv, fl) for lv in levels for fl in floors]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = _run_conditions(conditions, a.specimens, a.seed, a.workers)
    calib = _calibrate(runs, conditions, a.specimens)
    table = _table(runs, conditions, 2 * a.specimens * len(GRIDS))
    rows = [",".join(table[0])] + [",".join(str(v) for v in t.values()) for t in table]
    atomic_write_text(out / "modal_noise.csv", "\n".join(rows) + "\n")
    result = {"levels": levels, "floors": floors, "grids": GRIDS, "specimens": a.specimens,
              "identification": IDENTIFICATION, "calibration": calib, "table": table}
    atomic_write_text(out / "modal_noise.json", json.dumps(result, indent=1))
    if a.write_calibration:
        note = ("per mode 1..4: std of the identification error = sqrt((c level)^2 + (g floor)^2 + e^2) of the FRF "
                "noise level and floor, c under 'frequency', 'damping', 'shape', g under '<quantity>_per_floor', e "
                f"under '<quantity>_floor', fitted to robust stds of learn.pairs.measured.identify_modes on the "
                f"default config, {a.specimens} specimens x 2 states x line layouts {list(GRIDS)} x levels {levels} "
                f"x floors {floors}; written by experiments.benches.bench_modal_noise")
        atomic_write_text(CONFIG_DIR / "modal_noise.json",
                          json.dumps({**calib, "identification": IDENTIFICATION, "note": note}, indent=1) + "\n")
    _figure(out / "modal_noise.png", runs, conditions)
    if a.json:
        print(json.dumps(result, indent=1))
    else:
        _print(calib, table)
        print(f"figures and tables in {out}")
    return result


def _run_conditions(conditions, specimens: int, seed: int, workers: int) -> dict:
    """Per (level, floor): pooled errors of the full path and of the fixed-default shortcut, the modes the full
    path missed and the seeds (one per line layout of :data:`GRIDS`)."""
    runs = {}
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        for k, (lv, fl) in enumerate(conditions):
            seeds = [seed + 100 * k + g for g in range(len(GRIDS))]
            full = [full_path_errors(lv, fl, specimens, sd, pool, grid) for sd, grid in zip(seeds, GRIDS)]
            runs[lv, fl] = {"full": _pooled([f[0] for f in full]), "failed": sum(f[1] for f in full).tolist(),
                            "fixed": _pooled([f[2] for f in full]), "seeds": seeds}
    return runs


def _calibrate(runs: dict, conditions, specimens: int) -> dict:
    """Per quantity and mode, ``std = sqrt((c level)^2 + (g floor)^2 + e^2)`` fitted to the full path's robust
    std in each condition; adds to ``runs`` the same specimens and draws through the calibrated shortcut."""
    calib = {}
    for qi, q in enumerate(QUANTITIES):
        fits = [calibrate_std([c[0] for c in conditions], [c[1] for c in conditions],
                              [robust_std(runs[c]["full"][qi][..., r]) for c in conditions]) for r in range(4)]
        for j, suffix in enumerate(("", "_per_floor", "_floor")):
            calib[q + suffix] = [float(f"{f[j]:.4g}") for f in fits]
    for c in conditions:
        runs[c]["calibrated"] = _pooled([shortcut_errors(*c, specimens, sd, calib, grid)[0]
                                         for sd, grid in zip(runs[c]["seeds"], GRIDS)])
    return calib


def _table(runs: dict, conditions, fits_per_condition: int) -> list:
    """One row per condition, quantity and mode: robust stds of the three paths and their KS distances."""
    table = []
    for (lv, fl) in conditions:
        R = runs[lv, fl]
        for qi, q in enumerate(QUANTITIES):
            for r in range(4):
                full, fix, cal = (R[k][qi][..., r] for k in ("full", "fixed", "calibrated"))
                table.append({"level": lv, "floor": fl, "mode": r + 1, "quantity": q,
                              "full_path_std": robust_std(full), "shortcut_fixed_std": robust_std(fix),
                              "shortcut_calibrated_std": robust_std(cal), "ks_full_vs_calibrated": _ks(full, cal),
                              "ks_full_vs_fixed": _ks(full, fix), "modes_not_identified": R["failed"][r],
                              "fits": fits_per_condition})
    return table


def _figure(path: Path, runs: dict, conditions) -> None:
    """Cumulative distributions of |error| / FRF noise level per quantity and mode, the three paths."""
    plt = pyplot()

    fig, axs = plt.subplots(3, 4, figsize=(14, 9))
    for qi, q in enumerate(QUANTITIES):
        for r in range(4):
            ax = axs[qi, r]
            for key, style in (("full", "-"), ("calibrated", "--"), ("fixed", ":")):
                e = np.concatenate([np.abs(runs[c][key][qi][..., r]).ravel() / c[0] for c in conditions])
                e = np.sort(e[np.isfinite(e)])
                if e.size:
                    ax.semilogx(e, np.arange(1, e.size + 1) / e.size, style,
                                label={"full": "full path (classify's LSCF/LSFD)", "calibrated": "shortcut, calibrated",
                                       "fixed": "shortcut, fixed default"}[key])
            ax.set_title(f"{q}, mode {r + 1}", fontsize=9)
            ax.set_xlabel("|error| / FRF noise level", fontsize=8)
            if r == 0:
                ax.set_ylabel("cumulative fraction")
    axs[0, 0].legend(fontsize=7)
    fig.tight_layout()
    atomic_write_bytes(path, figure_png(fig))


def _print(calib: dict, table: list) -> None:
    print(f"calibration (std = sqrt((c level)^2 + (g floor)^2 + e^2), modes 1..4): {json.dumps(calib)}")
    print(f"{'level':>7} {'floor':>7} {'q':>9} {'mode':>4} {'full':>10} {'fixed':>10} {'calib':>10} {'KS cal':>7} "
          f"{'KS fix':>7} {'missed':>6}")
    for t in table:
        print(f"{t['level']:7.3g} {t['floor']:7.3g} {t['quantity']:>9} {t['mode']:4d} {t['full_path_std']:10.3g} "
              f"{t['shortcut_fixed_std']:10.3g} {t['shortcut_calibrated_std']:10.3g} "
              f"{t['ks_full_vs_calibrated']:7.3f} {t['ks_full_vs_fixed']:7.3f} "
              f"{t['modes_not_identified']:3d}/{t['fits']}")


if __name__ == "__main__":
    main()
