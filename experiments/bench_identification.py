"""Accuracy of the identification methods on simulated beam-5 FRFs, and sdypy-EMA side by side.

The test case: the thesis's IIRS-reduced beam-5 model (4 translational DOFs,
``beams.json`` key ``beams.5.iirs_reduced``) with a non-proportional damping
matrix (Rayleigh plus dashpots at the root and tip DOFs), receptances to a
tip force on 0.5 Hz lines, 1 % complex Gaussian noise (standard deviation
1 % of ``|H|`` on each line, split evenly over real and imaginary parts).

Run ``python -m experiments.bench_identification [--seeds N] [--csv FILE] [--json FILE]``.
sdypy-EMA (optional extra ``compare``) is used when installed.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from importlib import resources

import numpy as np

from physics.frf import receptance
from physics.identification import circle_fit, identify_lscf, peak_picking
from physics.io import MeasuredFRF, atomic_write_text
from physics.modal import complex_modes, mac

DOFS = ("2:+Y", "3:+Y", "4:+Y", "5:+Y")
DRIVE = 3  # tip DOF 5:+Y


def beam5_matrices(damping="heavy"):
    """M (kg), C (N s/m, non-proportional), K (N/m) of the IIRS-reduced beam 5.

    ``damping="heavy"``: Rayleigh plus root and tip dashpots (damping ratios
    1-9 %). ``damping="thesis"``: the damping matrix the thesis identified for
    the undamaged beam 5 (reduced-mass model, Chapter Six), damping ratios
    0.1-0.4 %, so mode 1's half-power band (about 0.05 Hz) is far narrower
    than a 0.5 Hz line.
    """
    text = resources.files("experiments").joinpath("data/thesis/beams.json").read_text()
    b5 = json.loads(text)["beams"]["5"]
    red = b5["iirs_reduced"]
    M, K = np.array(red["M"]), np.array(red["K"])
    if damping == "thesis":
        return M, np.array(b5["identified_models"]["undamaged"]["reduced_mass"]["C"]), K
    C = 2.0 * M + 4e-6 * K
    C[3, 3] += 0.4
    C[0, 0] += 0.2
    return M, C, K


def simulate(noise=0.01, seed=0, df_hz=0.5, fmax_hz=800.0, damping="heavy"):
    """Noisy tip-force receptances of beam 5 and the exact complex modes.

    Returns
    -------
    frf : MeasuredFRF, shape (4, 1, n_lines)
    modes : physics.modal.ComplexModes (exact)
    """
    M, C, K = beam5_matrices(damping)
    f = np.arange(df_hz, fmax_hz + df_hz / 2, df_hz)
    H = receptance(M, C, K, 2 * np.pi * f, reference=[DRIVE])
    rng = np.random.default_rng(seed)
    H = H + noise * np.abs(H) * (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)) / np.sqrt(2)
    frf = MeasuredFRF(f, H, DOFS, (DOFS[DRIVE],), metadata={"source": f"simulated beam5 seed {seed}"})
    return frf, complex_modes(M, C, K)


def run_ours(frf, n_modes=4):
    f, h = frf.frequency_hz, np.asarray(frf.frf)
    return {"peak": peak_picking(f, h, n_modes, drive=(DRIVE, 0)),
            "circle": circle_fit(f, h, n_modes, drive=(DRIVE, 0)),
            "lscf": identify_lscf(f, h, n_modes, drive=(DRIVE, 0)).estimate}


def run_sdypy(frf, approx_hz):
    """sdypy-EMA LSCF + LSFD on the same receptances; None when not installed."""
    try:
        from sdypy import EMA
    except ImportError:
        return None
    f = frf.frequency_hz
    import contextlib
    import io

    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        model = EMA.Model(frf=np.asarray(frf.frf[:, 0, :]), freq=f, lower=float(f[0]), upper=float(f[-1]),
                          pol_order_high=60, frf_form="receptance", driving_point=DRIVE)
        model.get_poles(method="lscf", show_progress=False)
        model.select_closest_poles(list(approx_hz), f_window=20)
        model.get_constants(method="lsfd", whose_poles="own")
    return {"frequency_hz": np.asarray(model.nat_freq, float), "damping_ratio": np.asarray(model.nat_xi, float),
            "shapes": np.asarray(model.phi) if hasattr(model, "phi") else None}


def table(seeds=1, noise=0.01, damping="heavy"):
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
        for name, (fi, zi, sh) in results.items():
            m = np.diag(mac(sh, psi)) if sh is not None and sh.shape == psi.shape else np.full(4, np.nan)
            r = rows.setdefault(name, {"f": [], "z": [], "mac": [], "fi": [], "zi": []})
            r["f"].append(100 * (fi / fe - 1))
            r["z"].append(100 * (zi / ze - 1))
            r["mac"].append(m)
            r["fi"].append(fi)
            r["zi"].append(zi)
    out = {"exact_frequency_hz": fe.tolist(), "exact_damping_ratio": ze.tolist(), "seeds": seeds,
           "noise": noise, "damping": damping, "warnings": sorted(notes), "methods": {}}
    for name, r in rows.items():
        out["methods"][name] = {
            "frequency_error_pct_rms": np.sqrt(np.mean(np.square(r["f"]), axis=0)).tolist(),
            "damping_error_pct_rms": np.sqrt(np.mean(np.square(r["z"]), axis=0)).tolist(),
            "mac_mean": np.mean(r["mac"], axis=0).tolist(),
            "frequency_hz_seed0": np.asarray(r["fi"][0]).tolist(),
            "damping_ratio_seed0": np.asarray(r["zi"][0]).tolist()}
    return out


def format_table(out) -> str:
    lines = [f"beam5, non-proportional damping ({out['damping']}), {100 * out['noise']:g}% complex noise, 0.5 Hz lines, "
             f"{out['seeds']} seed(s); errors are RMS over seeds",
             "exact f (Hz):  " + "  ".join(f"{x:10.4f}" for x in out["exact_frequency_hz"]),
             "exact zeta:    " + "  ".join(f"{x:10.5f}" for x in out["exact_damping_ratio"]), "",
             f"{'method':<16}{'mode':>5}{'df (%)':>11}{'dzeta (%)':>11}{'MAC':>10}{'f (Hz) s0':>12}{'zeta s0':>10}"]
    for name, m in out["methods"].items():
        for j in range(len(m["frequency_error_pct_rms"])):
            lines.append(f"{name:<16}{j + 1:>5}{m['frequency_error_pct_rms'][j]:>11.4f}"
                         f"{m['damping_error_pct_rms'][j]:>11.3f}{m['mac_mean'][j]:>10.6f}"
                         f"{m['frequency_hz_seed0'][j]:>12.4f}{m['damping_ratio_seed0'][j]:>10.5f}")
    lines += [f"warning: {w}" for w in out.get("warnings", [])]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--noise", type=float, default=0.01)
    p.add_argument("--damping", choices=("heavy", "thesis"), default="heavy",
                   help="heavy: ratios 1-9 %%; thesis: the identified beam-5 damping matrix, ratios 0.1-0.4 %%")
    p.add_argument("--csv")
    p.add_argument("--json")
    a = p.parse_args(argv)
    out = table(a.seeds, a.noise, a.damping)
    print(format_table(out))
    if a.json:
        atomic_write_text(a.json, json.dumps(out, indent=1) + "\n")
    if a.csv:
        rows = ["method,mode,frequency_error_pct_rms,damping_error_pct_rms,mac_mean"]
        for name, m in out["methods"].items():
            for j in range(len(m["mac_mean"])):
                rows.append(f"{name},{j + 1},{m['frequency_error_pct_rms'][j]:.6g},"
                            f"{m['damping_error_pct_rms'][j]:.6g},{m['mac_mean'][j]:.8f}")
        atomic_write_text(a.csv, "\n".join(rows) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
