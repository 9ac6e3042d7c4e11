"""Accuracy of the identification methods on simulated beam-5 FRFs, and sdypy-EMA side by side.

The test case: the thesis's IIRS-reduced beam-5 model (4 translational DOFs,
``beams.json`` key ``beams.5.iirs_reduced``) with a non-proportional damping
matrix (Rayleigh plus dashpots at the root and tip DOFs), receptances to a
tip force on 0.5 Hz lines, 1 % complex Gaussian noise (standard deviation
1 % of ``|H|`` on each line, split evenly over real and imaginary parts).

Run ``python -m experiments.benches.bench_identification [--seeds N] [--csv FILE] [--json FILE]``;
``--case free-free`` instead reports the reconstruction error (dB) of a realistic impact test
(see :func:`simulate_free_free`) for this package, its previous fit and sdypy-EMA.
sdypy-EMA (optional extra ``compare``) is used when installed.
"""

from __future__ import annotations

import contextlib
import io
import sys
import warnings

import numpy as np

from experiments.benches.bench_precision import matched_indices
from experiments.benches.harness import emit_json, parser
from physics.identification import METHODS, identify_frf, lsfd, reconstruction_error_db
from physics.io import MeasuredFRF, atomic_write_text
from physics.modal import mac
from physics.noise import complex_normal
from physics.properties import free_free_beta_l
from physics.thesis import BEAM5_TIP, simulated_beam5_test

__all__ = ["free_free_table", "main", "method_errors", "simulate_free_free"]

DRIVE = BEAM5_TIP  # tip DOF 5:+Y


def simulate(noise=0.01, seed=0, df_hz=0.5, fmax_hz=800.0, damping="heavy"):
    """:func:`physics.thesis.simulated_beam5_test` with this benchmark's default damping ("heavy")."""
    return simulated_beam5_test(noise, seed, df_hz, fmax_hz, damping)


# ---------------------------------------------------------------------------
# A realistic impact test: free-free beam, accelerance, very light damping
# ---------------------------------------------------------------------------

#: Free-free test case of :func:`simulate_free_free`: response positions x/L (the first is
#: the driving point at the struck end) and modal damping ratios of the elastic modes 1..12.
FREE_FREE_X = (0.0, 0.37, 0.71)
FREE_FREE_ZETA = (6e-4, 1e-4, 3e-4, 2e-4, 4e-4, 1.5e-4, 5e-4, 3e-4, 3e-4, 3e-4, 3e-4, 3e-4)


def free_free_shapes(beta_l, x_over_l):
    """Free-free modes ``cosh + cos - sigma (sinh + sin)`` at ``x/L``, shape (n_x, n_modes).

    Times ``1/sqrt(m L)`` they are mass-normalised (``int phi^2 m dx = 1``). The
    hyperbolic part is evaluated as exponentials so that high modes do not cancel.
    """
    b = np.asarray(beta_l, float)[None, :]
    u = np.asarray(x_over_l, float)[:, None] * b
    sigma = (np.cosh(b) - np.cos(b)) / (np.sinh(b) - np.sin(b))
    one_minus_sigma = 2 * np.exp(-b) * (np.cos(b) - np.sin(b) - np.exp(-b)) / \
        (1 - 2 * np.sin(b) * np.exp(-b) - np.exp(-2 * b))
    return 0.5 * (1 + sigma) * np.exp(-u) + 0.5 * one_minus_sigma * np.exp(u) + np.cos(u) - sigma * np.sin(u)


def simulate_free_free(noise=0.005, floor=3e-3, seed=0, f1_hz=40.5, mass_kg=2.0, df_hz=1.0,
                       band_hz=(10.0, 1000.0), n_elastic=12):
    """Accelerances of an impact test on a free-free beam, from the closed-form modes.

    A uniform Euler-Bernoulli beam (length 1 m, ``mass_kg``, first elastic mode
    at ``f1_hz``) struck at one end; accelerometers at ``FREE_FREE_X``. The
    accelerance is the modal sum of the two rigid-body modes (translation and
    rotation: a constant mass line in accelerance) and ``n_elastic`` elastic modes
    with the damping ratios ``FREE_FREE_ZETA`` (0.01-0.06 %): six modes in
    10-1000 Hz, the seventh just above the band (1005 Hz).

    Noise: complex Gaussian with standard deviation ``noise |A|`` on each line
    plus a floor ``floor * median|A|`` of each FRF (sensor noise that fills the
    antiresonances).

    Returns
    -------
    frf : MeasuredFRF, accelerance (m/s^2/N), shape (3, 1, n_lines)
    truth : dict
        ``frequency_hz``, ``damping_ratio`` of the in-band modes, ``shapes``
        (n_resp, n_in_band) mass-normalised real shapes, ``exact`` (noise-free
        accelerance, same shape as ``frf.frf``).
    """
    x = np.asarray(FREE_FREE_X)
    bl = free_free_beta_l(n_elastic)
    fn = f1_hz * (bl / bl[0]) ** 2
    wn = 2 * np.pi * fn
    zeta = np.asarray(FREE_FREE_ZETA[:n_elastic])
    m_per_l = mass_kg  # length 1 m
    phi = free_free_shapes(bl, x) / np.sqrt(m_per_l)  # (3, n_elastic), mass-normalised
    rigid = np.column_stack([np.ones_like(x), np.sqrt(12.0) * (x - 0.5)]) / np.sqrt(m_per_l)
    f = np.arange(band_hz[0], band_hz[1] + df_hz / 2, df_hz)
    w = 2 * np.pi * f
    r = 0  # reference: the struck end
    wn3, z3 = wn[None, :, None], zeta[None, :, None]
    elastic = (phi * phi[r])[:, :, None] / (wn3**2 - w**2 + 2j * z3 * wn3 * w)
    receptance = elastic.sum(axis=1) - (rigid @ rigid[r])[:, None] / w**2
    exact = (-(w**2) * receptance)[:, None, :]
    rng = np.random.default_rng(seed)
    sd = noise * np.abs(exact) + floor * np.median(np.abs(exact), axis=-1, keepdims=True)
    noisy = exact + complex_normal(rng, exact.shape, sd)
    dofs = tuple(f"{k + 1}:+Y" for k in range(x.size))
    frf = MeasuredFRF(f, noisy, dofs, (dofs[r],), kind="accelerance",
                      metadata={"source": f"simulated free-free impact test seed {seed}"})
    inband = (fn >= band_hz[0]) & (fn <= band_hz[1])
    return frf, {"frequency_hz": fn[inband], "damping_ratio": zeta[inband], "shapes": phi[:, inband],
                 "exact": exact, "position_m": x}


def run_ours(frf, n_modes=4):
    """The :class:`ModalEstimate` of every FRF method of :data:`physics.identification.METHODS`, by name."""
    return {name: identify_frf(frf, name, n_modes=n_modes).estimate for name, spec in METHODS.items()
            if spec.data == "frf"}


def sdypy_lscf(frf, approx_hz, drive: int):
    """sdypy-EMA on the first reference's FRFs: LSCF to order 60, the poles nearest ``approx_hz`` (20 Hz window),
    LSFD on its own poles; ``(model, reconstructed FRFs, modal constants)``, or None when sdypy-EMA is not
    installed."""
    try:
        from sdypy import EMA
    except ImportError:
        return None
    f = frf.frequency_hz
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        model = EMA.Model(frf=np.asarray(frf.frf[:, 0, :]), freq=f, lower=float(f[0]), upper=float(f[-1]),
                          pol_order_high=60, frf_form=frf.kind, driving_point=drive)
        model.get_poles(method="lscf", show_progress=False)
        model.select_closest_poles(list(approx_hz), f_window=20)
        H, A = model.get_constants(method="lsfd", whose_poles="own")
    return model, H, A


def run_sdypy(frf, approx_hz):
    """sdypy-EMA LSCF + LSFD on the same receptances; None when not installed."""
    if (fit := sdypy_lscf(frf, approx_hz, DRIVE)) is None:
        return None
    model = fit[0]
    return {"frequency_hz": np.asarray(model.nat_freq, float), "damping_ratio": np.asarray(model.nat_xi, float),
            "shapes": np.asarray(model.phi) if hasattr(model, "phi") else None}


def run_sdypy_free_free(frf, approx_hz):
    """sdypy-EMA LSCF + LSFD (its own poles, its own reconstruction) on an accelerance; None if not installed.

    Returns ``(frequency_hz, damping_ratio, shapes, reconstructed, line_mask)``; sdypy-EMA pads the axis
    to 0 Hz and drops the last line, so ``line_mask`` marks the input lines it reconstructs.
    """
    if (fit := sdypy_lscf(frf, approx_hz, 0)) is None:
        return None
    model, H, A = fit
    f = frf.frequency_hz
    on_ours = np.isin(np.round(model.freq, 6), np.round(f, 6))
    mask = np.isin(np.round(f, 6), np.round(model.freq, 6))
    return (np.asarray(model.nat_freq, float), np.asarray(model.nat_xi, float), np.asarray(A),
            np.asarray(H)[:, on_ours], mask)


def free_free_table(seed=0, noise=0.005, floor=3e-3):
    """Reconstruction error (dB), MAC and pole errors on :func:`simulate_free_free` data.

    Rows: this package's ``identify_frf`` (LSCF with poles just outside the band,
    LSFD on the accelerance with relative weighting); the previous fit (the same
    in-band poles, LSFD on the receptance with uniform weights); sdypy-EMA when
    installed (given the true in-band frequencies to pick its poles); the noise
    itself (measured against the noise-free truth).
    """
    frf, truth = simulate_free_free(noise, floor, seed)
    exact = truth["exact"]
    f, w = frf.frequency_hz, frf.omega_rad_s
    rows = {"noise (measured vs truth)": {"db_measured": reconstruction_error_db(frf.frf, exact)}}
    ident = identify_frf(frf)
    est = ident.estimate
    rows["beam-damage lscf+lsfd"] = {
        "db_measured": reconstruction_error_db(frf.frf, ident.synthesised),
        "db_truth": reconstruction_error_db(exact, ident.synthesised),
        "mac": np.diag(mac(est.shapes, truth["shapes"])).tolist(),
        "frequency_error_pct": (100 * (est.natural_frequencies_hz / truth["frequency_hz"] - 1)).tolist(),
        "damping_error_pct": (100 * (est.damping_ratios / truth["damping_ratio"] - 1)).tolist()}
    inband = est.eigenvalues
    old = lsfd(f, np.asarray(frf.to_kind("receptance").frf), inband, weighting="uniform")
    old_acc = -(w**2) * old.synthesised
    rows["previous fit (receptance, uniform)"] = {
        "db_measured": reconstruction_error_db(frf.frf, old_acc),
        "db_truth": reconstruction_error_db(exact, old_acc),
        "mac": np.diag(mac(shapes_of(old.residues), truth["shapes"])).tolist()}
    sd = run_sdypy_free_free(frf, truth["frequency_hz"])
    if sd is not None:
        fs, zs, A, H, mask = sd
        rows["sdypy-EMA lscf+lsfd"] = {
            "db_measured": reconstruction_error_db(frf.frf[:, 0, mask], H),
            "db_truth": reconstruction_error_db(exact[:, 0, mask], H),
            "mac": np.diag(mac(A, truth["shapes"])).tolist(),
            "frequency_error_pct": (100 * (fs / truth["frequency_hz"] - 1)).tolist(),
            "damping_error_pct": (100 * (zs / truth["damping_ratio"] - 1)).tolist()}
    return {"case": "free-free beam impact test, accelerance, 3 responses, 1 Hz lines 10-1000 Hz, damping "
                    "0.01-0.06 %, a mode at 1005 Hz", "seed": seed, "noise": noise, "floor": floor,
            "frequency_hz": truth["frequency_hz"].tolist(), "rows": rows}


def shapes_of(residues):
    """Unscaled shapes (first reference column) of residues, for MAC."""
    return np.asarray(residues)[:, 0, :]


def format_free_free(out) -> str:
    lines = [out["case"] + f", seed {out['seed']}",
             f"{'fit':<36}{'median dB':>10}{'p90 dB':>9}{'vs truth median':>17}{'p90':>7}{'min MAC':>11}"]
    for name, r in out["rows"].items():
        tm = r.get("db_truth", (np.nan, np.nan))
        mn = min(r["mac"]) if "mac" in r else np.nan
        lines.append(f"{name:<36}{r['db_measured'][0]:>10.3f}{r['db_measured'][1]:>9.3f}{tm[0]:>17.3f}"
                     f"{tm[1]:>7.3f}{mn:>11.6f}")
    return "\n".join(lines)


def method_errors(seeds=1, noise=0.01, damping="heavy"):
    """Rows of per-mode errors for each method, averaged (RMS) over ``seeds`` noise realisations."""
    rows = {}
    notes = set()
    for seed in range(seeds):
        frf, exact = simulate(noise, seed, damping=damping)
        fe, ze, psi = exact.natural_frequencies_hz, exact.damping_ratios, exact.eigenvectors
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ours = run_ours(frf)
        notes.update(str(w.message) for w in caught)
        results = {k: (v.natural_frequencies_hz, v.damping_ratios, v.shapes) for k, v in ours.items()}
        sd = run_sdypy(frf, ours["peak"].natural_frequencies_hz)
        if sd is not None:
            results["sdypy-EMA lscf"] = (sd["frequency_hz"], sd["damping_ratio"], sd["shapes"])
        for name, (f_all, z_all, sh_all) in results.items():
            k = matched_indices(f_all, fe, 0.05)        # a mode a method misses: NaN
            fi, zi = np.where(k >= 0, np.asarray(f_all)[k], np.nan), np.where(k >= 0, np.asarray(z_all)[k], np.nan)
            sh = None if sh_all is None or sh_all.shape[0] != psi.shape[0] else np.asarray(sh_all)[:, k]
            m = np.where(k >= 0, np.diag(mac(sh, psi)), np.nan) if sh is not None else np.full(fe.size, np.nan)
            r = rows.setdefault(name, {"f": [], "z": [], "mac": [], "fi": [], "zi": []})
            r["f"].append(100 * (fi / fe - 1))
            r["z"].append(100 * (zi / ze - 1))
            r["mac"].append(m)
            r["fi"].append(fi)
            r["zi"].append(zi)
    out = {"exact_frequency_hz": fe.tolist(), "exact_damping_ratio": ze.tolist(), "seeds": seeds,
           "noise": noise, "damping": damping, "warnings": sorted(notes), "methods": {}}
    for name, r in rows.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)                # a mode missed in every seed: NaN
            out["methods"][name] = {
                "found": np.sum(np.isfinite(r["f"]), axis=0).tolist(),
                "frequency_error_pct_rms": np.sqrt(np.nanmean(np.square(r["f"]), axis=0)).tolist(),
                "damping_error_pct_rms": np.sqrt(np.nanmean(np.square(r["z"]), axis=0)).tolist(),
                "mac_mean": np.nanmean(r["mac"], axis=0).tolist(),
                "frequency_hz_seed0": np.asarray(r["fi"][0]).tolist(),
                "damping_ratio_seed0": np.asarray(r["zi"][0]).tolist()}
    return out


def format_table(out) -> str:
    lines = [f"beam5, non-proportional damping ({out['damping']}), {100 * out['noise']:g}% complex noise, "
             f"0.5 Hz lines, {out['seeds']} seed(s); errors are RMS over seeds",
             "exact f (Hz):  " + "  ".join(f"{x:10.4f}" for x in out["exact_frequency_hz"]),
             "exact zeta:    " + "  ".join(f"{x:10.5f}" for x in out["exact_damping_ratio"]), "",
             f"{'method':<16}{'mode':>5}{'found':>7}{'df (%)':>11}{'dzeta (%)':>11}{'MAC':>10}{'f (Hz) s0':>12}"
             f"{'zeta s0':>10}"]
    for name, m in out["methods"].items():
        for j in range(len(m["frequency_error_pct_rms"])):
            lines.append(f"{name:<16}{j + 1:>5}{m['found'][j]:>7}{m['frequency_error_pct_rms'][j]:>11.4f}"
                         f"{m['damping_error_pct_rms'][j]:>11.3f}{m['mac_mean'][j]:>10.6f}"
                         f"{m['frequency_hz_seed0'][j]:>12.4f}{m['damping_ratio_seed0'][j]:>10.5f}")
    lines += [f"warning: {w}" for w in out.get("warnings", [])]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = parser(__file__, __doc__, json="FILE")
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--noise", type=float, default=0.01)
    p.add_argument("--damping", choices=("heavy", "thesis"), default="heavy",
                   help="heavy: ratios 1-9 %%; thesis: the identified beam-5 damping matrix, ratios 0.1-0.4 %%")
    p.add_argument("--case", choices=("beam5", "free-free"), default="beam5",
                   help="beam5: the method table above; free-free: reconstruction error of a realistic "
                        "impact test (accelerance, 0.01-0.06 %% damping, rigid-body mass line, a mode just "
                        "above the band) against the previous fit and sdypy-EMA")
    p.add_argument("--csv")
    a = p.parse_args(argv)
    if a.case == "free-free":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = free_free_table()
        print(format_free_free(out))
    else:
        out = method_errors(a.seeds, a.noise, a.damping)
        print(format_table(out))
    emit_json(a, out)
    if a.csv and a.case == "beam5":
        rows = ["method,mode,frequency_error_pct_rms,damping_error_pct_rms,mac_mean"]
        for name, m in out["methods"].items():
            for j in range(len(m["mac_mean"])):
                rows.append(f"{name},{j + 1},{m['frequency_error_pct_rms'][j]:.6g},"
                            f"{m['damping_error_pct_rms'][j]:.6g},{m['mac_mean'][j]:.8f}")
        atomic_write_text(a.csv, "\n".join(rows) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
