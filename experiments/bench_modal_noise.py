"""Honesty check of the modal-noise shortcut: identify modes from noisy FRFs and compare error distributions.

Run: ``.venv/bin/python -m experiments.bench_modal_noise [--specimens 8] [--levels 0.001,0.005,0.01,0.03]
[--workers 2] [--out out/modal_noise] [--write-calibration]``

A dataset's measured modal data come from a shortcut: the truth modes plus
random errors (:func:`datagen.pipeline.measure_modes`). The full path would
identify them from the noisy FRFs. Here a few specimens (both test days) of
the default configuration are run through the full path at several FRF noise
levels (noise floor ``--floor`` relative to the peak): the measured FRFs
exactly as a dataset synthesises them -> LSCF poles -> LSFD residues ->
unit-modal-A shapes (:func:`physics.identification.identify_lscf`, driving
point at the first DOF). Per mode, the identification errors

* relative natural-frequency error ``f_id / f_true - 1``,
* relative damping error ``zeta_id / zeta_true - 1``,
* shape error ``(psi_id - psi_true) / max|psi_true|`` per DOF (complex; the
  sign of the square-root scaling aligned),

are compared with the shortcut's: the fixed default model
(``measurement.modal_noise = "fixed"``) and the calibrated one
(``"calibrated"``: per mode, standard deviation ``sqrt((c level)^2 + floor^2)``
of the sample's FRF noise level: errors proportional to the noise above a
floor of the method itself, e.g. the shapes' bias at low noise). The
calibration fits ``c`` and ``floor`` (:func:`calibrate_std`) to the full
path's robust standard deviation at each level (1.4826 MAD for real errors,
``sqrt(median|e|^2 / ln 2)`` for circular complex errors).
``--write-calibration`` stores them in
``datagen/configs/modal_noise.json`` (what ``"calibrated"`` uses).

Writes ``modal_noise.csv`` (per level, mode and quantity: robust std of the
full path, of both shortcuts, KS distance full vs calibrated, failed
identifications of the mode), ``modal_noise.json`` and ``modal_noise.png`` (error
distributions, full path vs calibrated shortcut).
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np

QUANTITIES = ("frequency", "damping", "shape")


def _robust_std(e):
    e = np.asarray(e)
    e = e[np.isfinite(e)]
    if np.iscomplexobj(e):
        return float(np.sqrt(np.median(np.abs(e) ** 2) / np.log(2)))
    return float(1.4826 * np.median(np.abs(e - np.median(e))))


def _ks(a, b):
    """Two-sample Kolmogorov-Smirnov distance of |a| and |b|."""
    from scipy.stats import ks_2samp

    a, b = np.abs(np.asarray(a)), np.abs(np.asarray(b))
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    return float(ks_2samp(a, b).statistic) if a.size and b.size else float("nan")


def _errors(lam_est, psi_est, lam_true, psi_true):
    """Errors (frequency, damping: (..., 4); shape: (..., 4 dofs, 4)) of estimated modes against the truth."""
    from physics.modal import modal_parameters

    fe, ze = modal_parameters(lam_est)
    ft, zt = modal_parameters(lam_true)
    scale = np.max(np.abs(psi_true), axis=-2, keepdims=True)
    d_plus = psi_est - psi_true
    d_minus = psi_est + psi_true  # the square root of the driving-point residue fixes psi only up to its sign
    pick = np.sum(np.abs(d_minus) ** 2, axis=-2, keepdims=True) < np.sum(np.abs(d_plus) ** 2, axis=-2, keepdims=True)
    return fe / ft - 1, ze / zt - 1, np.where(pick, d_minus, d_plus) / scale


def _identify(args):
    """Full path for one (sample, state): FRF -> LSCF/LSFD -> modes matched to the truth by frequency.

    Returns (eigenvalues (4,), shapes (4 dofs, 4)) with NaN for truth modes no
    identified pole lies within 5 % of, or None when the identification fails.
    """
    from threadpoolctl import threadpool_limits

    from physics.identification import identify_lscf

    f_hz, H, max_order, f_true = args
    with threadpool_limits(1):
        try:
            est = identify_lscf(f_hz, H[:, None, :], n_modes=4, drive=(0, 0), max_order=max_order).estimate
        except (ArithmeticError, ValueError, RuntimeError):  # a failed identification is counted, not fatal
            return None
    lam = np.full(4, np.nan + 0j)
    psi = np.full((H.shape[0], 4), np.nan + 0j)
    for r, f in enumerate(f_true):
        if est.natural_frequencies_hz.size:
            k = int(np.argmin(np.abs(est.natural_frequencies_hz - f)))
            if abs(est.natural_frequencies_hz[k] / f - 1) < 0.05:
                lam[r], psi[:, r] = est.eigenvalues[k], est.shapes[:, k]
    return lam, psi


def _config(level, floor, calibration=None):
    from datagen.config import merge

    meas = {"frf_noise": level, "frf_noise_floor": floor}
    if calibration:
        meas.update(modal_noise="calibrated", **{f"{q}_noise": calibration[q] for q in QUANTITIES},
                    **{f"{q}_noise_floor": calibration[f"{q}_floor"] for q in QUANTITIES})
    return merge({"measurement": meas})


def shortcut_errors(level, floor, specimens, seed, calibration=None):
    """Errors of the modal-noise shortcut (fixed default, or calibrated with the given coefficients)."""
    from datagen.pipeline import draw_batch, get_setup, measure_modes, simulate_batch

    setup = get_setup(_config(level, floor, calibration))
    inp = draw_batch(np.random.default_rng(seed), specimens, setup)
    sim = simulate_batch(setup, inp)
    lam_t, psi_t = sim["truth_poles"][..., :4], sim["truth_shapes"][..., :4]
    return _errors(*measure_modes(setup, inp, lam_t, psi_t), lam_t, psi_t), (setup, inp, sim)


def full_path_errors(level, floor, specimens, seed, max_order, pool):
    """Errors of LSCF/LSFD identification from the measured FRFs a dataset synthesises; and the failures."""
    from datagen.synth import measured_frf

    _, (setup, inp, sim) = shortcut_errors(level, floor, specimens, seed)
    lam_t, psi_t = sim["truth_poles"][..., :4], sim["truth_shapes"][..., :4]
    H = measured_frf({**sim, "noise_seed": inp.noise_seed, "noise_level": inp.noise_level,
                      "noise_floor": inp.noise_floor}, setup.omega_rad_s, np.complex128)
    f_hz = setup.omega_rad_s / (2 * np.pi)
    f_true = np.abs(lam_t) / (2 * np.pi)
    ids = list(pool.map(_identify, [(f_hz, H[i, s], max_order, f_true[i, s]) for i in range(specimens)
                                    for s in range(2)]))
    lam_e = np.full(lam_t.shape, np.nan + 0j)
    psi_e = np.full(psi_t.shape, np.nan + 0j)
    for k, r in enumerate(ids):
        if r is not None:
            lam_e[k // 2, k % 2], psi_e[k // 2, k % 2] = r
    missed = np.isnan(lam_e.real).reshape(-1, 4).sum(axis=0)   # per mode, over samples and states
    return _errors(lam_e, psi_e, lam_t, psi_t), missed.tolist()


def calibrate_std(levels, stds):
    """``(a, b)`` of ``std = sqrt((a level)^2 + b^2)`` fitted to per-level stds (relative least squares, a, b >= 0)."""
    from scipy.optimize import nnls

    lv, sd = np.asarray(levels, float), np.asarray(stds, float)
    ok = np.isfinite(sd) & (sd > 0)
    if not ok.any():
        return float("nan"), float("nan")
    A = np.stack([lv[ok] ** 2, np.ones(ok.sum())], axis=1) / sd[ok, None] ** 2
    (a2, b2), _ = nnls(A, np.ones(ok.sum()))
    return float(np.sqrt(a2)), float(np.sqrt(b2))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--specimens", type=int, default=8, help="specimens per noise level (2 FRF sets each)")
    ap.add_argument("--levels", default="0.001,0.005,0.01,0.03", help="FRF noise levels (relative to |H|)")
    ap.add_argument("--floor", type=float, default=0.0, help="noise floor relative to each FRF's peak (the calibration "
                    "is fitted without one: the shortcut scales with the multiplicative level only)")
    ap.add_argument("--max-order", type=int, default=16, help="LSCF maximum model order")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="out/modal_noise")
    ap.add_argument("--write-calibration", action="store_true",
                    help="store the fitted coefficients in datagen/configs/modal_noise.json")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from datagen.config import CONFIG_DIR
    from physics.io import atomic_write_text

    levels = [float(x) for x in a.levels.split(",")]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    with ProcessPoolExecutor(a.workers, mp_context=get_context("spawn")) as pool:
        for k, lv in enumerate(levels):
            full, failed = full_path_errors(lv, a.floor, a.specimens, a.seed + k, a.max_order, pool)
            runs[lv] = {"full": full, "failed": failed,
                        "fixed": shortcut_errors(lv, a.floor, a.specimens, a.seed + k)[0]}

    # calibration: per mode, std(level) = sqrt((a level)^2 + b^2) fitted to the full path's robust std at each
    # level (relative least squares, a, b >= 0): errors grow with the FRF noise, above a floor of the method
    calib = {}
    for qi, q in enumerate(QUANTITIES):
        fits = [calibrate_std(levels, [_robust_std(runs[lv]["full"][qi][..., r]) for lv in levels]) for r in range(4)]
        calib[q] = [float(f"{a_:.4g}") for a_, _ in fits]
        calib[f"{q}_floor"] = [float(f"{b_:.4g}") for _, b_ in fits]
    for k, lv in enumerate(levels):  # the same specimens and draws through the calibrated shortcut
        runs[lv]["calibrated"] = shortcut_errors(lv, a.floor, a.specimens, a.seed + k, calib)[0]
    rows, table = ["level,mode,quantity,full_path_std,shortcut_fixed_std,shortcut_calibrated_std,"
                   "ks_full_vs_calibrated,ks_full_vs_fixed,modes_not_identified,fits"], []
    for lv in levels:
        R = runs[lv]
        for qi, q in enumerate(QUANTITIES):
            for r in range(4):
                full, fix, cal = (R[k][qi][..., r] for k in ("full", "fixed", "calibrated"))
                rec = {"level": lv, "mode": r + 1, "quantity": q, "full_path_std": _robust_std(full),
                       "shortcut_fixed_std": _robust_std(fix), "shortcut_calibrated_std": _robust_std(cal),
                       "ks_full_vs_calibrated": _ks(full, cal), "ks_full_vs_fixed": _ks(full, fix),
                       "modes_not_identified": R["failed"][r], "fits": 2 * a.specimens}
                table.append(rec)
                rows.append(",".join(str(v) for v in rec.values()))
    atomic_write_text(out / "modal_noise.csv", "\n".join(rows) + "\n")
    result = {"levels": levels, "floor": a.floor, "specimens": a.specimens, "max_order": a.max_order,
              "calibration": calib, "table": table}
    atomic_write_text(out / "modal_noise.json", json.dumps(result, indent=1))
    if a.write_calibration:
        note = (f"per mode 1..4: std of the LSCF/LSFD error = sqrt((c level)^2 + floor^2), c under 'frequency', "
                f"'damping', 'shape', floors under '<quantity>_floor', fitted to robust stds, default config, "
                f"{a.specimens} specimens x 2 states x levels {levels}, floor {a.floor}, max_order {a.max_order}; "
                f"written by experiments.bench_modal_noise")
        atomic_write_text(CONFIG_DIR / "modal_noise.json", json.dumps({**calib, "note": note}, indent=1) + "\n")

    fig, axs = plt.subplots(3, 4, figsize=(14, 9))
    for qi, q in enumerate(QUANTITIES):
        for r in range(4):
            ax = axs[qi, r]
            for key, style in (("full", "-"), ("calibrated", "--"), ("fixed", ":")):
                e = np.concatenate([np.abs(runs[lv][key][qi][..., r]).ravel() / lv for lv in levels])
                e = np.sort(e[np.isfinite(e)])
                if e.size:
                    ax.semilogx(e, np.arange(1, e.size + 1) / e.size, style,
                                label={"full": "full path (LSCF/LSFD)", "calibrated": "shortcut, calibrated",
                                       "fixed": "shortcut, fixed default"}[key])
            ax.set_title(f"{q}, mode {r + 1}", fontsize=9)
            ax.set_xlabel("|error| / FRF noise level", fontsize=8)
            if r == 0:
                ax.set_ylabel("cumulative fraction")
    axs[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "modal_noise.png", dpi=110)
    plt.close(fig)
    if a.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"calibration (std = sqrt((c level)^2 + floor^2), modes 1..4): {json.dumps(calib)}")
        print(f"{'level':>7} {'q':>9} {'mode':>4} {'full':>10} {'fixed':>10} {'calib':>10} {'KS cal':>7} {'KS fix':>7} "
              f"{'missed':>6}")
        for t in table:
            print(f"{t['level']:7.3g} {t['quantity']:>9} {t['mode']:4d} {t['full_path_std']:10.3g} "
                  f"{t['shortcut_fixed_std']:10.3g} {t['shortcut_calibrated_std']:10.3g} "
                  f"{t['ks_full_vs_calibrated']:7.3f} {t['ks_full_vs_fixed']:7.3f} "
                  f"{t['modes_not_identified']:3d}/{t['fits']}")
        print(f"figures and tables in {out}")
    return result


if __name__ == "__main__":
    main()
