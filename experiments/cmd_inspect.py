"""``beam-damage inspect``: dataset summary, label distributions, curvature check and FRF overlays."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from datagen.store import Dataset
from physics.io import atomic_write_text

BETA_L = (1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349)


def cantilever_curvature2(x_m, length_m, mode):
    """Normalised squared curvature ``phi_r''(x)^2 / int_0^L phi_r''^2 dx`` of a uniform cantilever (1/m)."""
    b = BETA_L[mode] / length_m
    bl = BETA_L[mode]
    s = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))

    def k(x):
        return b**2 * (np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x)))

    grid = np.linspace(0.0, length_m, 4001)
    norm = np.trapezoid(k(grid) ** 2, grid)
    return k(np.asarray(x_m, float)) ** 2 / norm


def curvature_check(table, length_m):
    """Regress the truth frequency shift of single-slit samples on the curvature-squared prediction.

    Prediction (first-order perturbation, uniform cantilever):
    ``df_r/f_r = -(1/2) (dEI/EI) w phi_r''(x)^2 / int phi_r''^2``.

    Returns
    -------
    dict per mode: ``slope`` (1 = exact), ``r2``, ``n``.
    """
    one = table[(table.n_slits == 1)]
    out = {}
    for r in range(4):
        pred = -0.5 * one["slit1_ei_loss"] * one["slit1_width_m"] * cantilever_curvature2(one["slit1_x_m"],
                                                                                         length_m, r)
        act = one[f"df{r + 1}_rel"]
        pred, act = pred.to_numpy(), act.to_numpy()
        if len(act) < 3:
            out[f"mode{r + 1}"] = {"slope": None, "r2": None, "n": int(len(act))}
            continue
        slope = float(pred @ act / (pred @ pred))
        r2 = float(1 - np.sum((act - slope * pred) ** 2) / np.sum((act - act.mean()) ** 2))
        out[f"mode{r + 1}"] = {"slope": slope, "r2": r2, "n": int(len(act))}
    return out


def add_parser(subparsers):
    p = subparsers.add_parser(
        "inspect", help="summarise a generated dataset and plot labels, shift-vs-position and FRF overlays",
        description="Summary of a dataset directory (counts, convergence, label ranges), label histograms, the "
                    "frequency shift of each mode versus slit position against the mode's curvature squared "
                    "(single-slit samples), and FRF overlays of damaged vs reference.")
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--out", help="directory for figures and tables (default DIR/inspect)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=run)


def run(args) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = Dataset(args.dir)
    table = ds.samples
    out = Path(args.out) if args.out else Path(args.dir) / "inspect"
    out.mkdir(parents=True, exist_ok=True)
    length = ds.manifest["preset"].get("length_m", ds.manifest["preset"].get("length"))  # old manifests: "length"
    check = curvature_check(table, length)
    summary = {"dir": str(args.dir), "complete": ds.manifest.get("complete", False), "samples": int(len(table)),
               "shards": len(ds.shards), "converged_fraction": float(table["converged"].mean()) if len(table) else None,
               "curvature_check": check,
               "labels": {c: {"min": float(table[c].min()), "max": float(table[c].max())}
                          for c in ("slit1_x_m", "slit1_depth_m", "slit1_width_m", "slit1_ei_loss", "ei_Nm2",
                                    "m_per_length_kg_m") if c in table and table[c].notna().any()},
               "figures": []}
    # label distributions
    cols = [c for c in ("n_slits", "slit1_x_m", "slit1_depth_m", "slit1_width_m", "slit1_ei_loss", "ei_Nm2",
                        "m_per_length_kg_m", "damping_scale", "root_spring_Nm_rad") if c in table]
    fig, axs = plt.subplots(3, 3, figsize=(11, 8))
    for ax, c in zip(axs.flat, cols):
        ax.hist(table[c].dropna(), bins=30)
        ax.set_title(c, fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "labels.png", dpi=110)
    plt.close(fig)
    # frequency shift vs position with curvature^2
    one = table[table.n_slits == 1]
    fig, axs = plt.subplots(2, 2, figsize=(11, 7))
    xg = np.linspace(0, length, 400)
    rows = []
    for r, ax in enumerate(axs.flat):
        if len(one):
            norm = -0.5 * one["slit1_ei_loss"] * one["slit1_width_m"]
            ax.plot(one["slit1_x_m"], one[f"df{r + 1}_rel"] / norm, ".", ms=3, label="truth shift / (-dEI/EI w/2)")
        ax.plot(xg, cantilever_curvature2(xg, length, r), "r-", label="phi''(x)^2 / int phi''^2")
        c = check[f"mode{r + 1}"]
        ax.set_title(f"mode {r + 1}: slope {c['slope']:.3f}, R^2 {c['r2']:.4f}" if c["slope"] is not None
                     else f"mode {r + 1}")
        ax.set_xlabel("slit position x (m)")
        ax.set_ylabel("normalised shift (1/m)")
        ax.legend(fontsize=7)
        rows.append(f"{r + 1},{c['slope']},{c['r2']},{c['n']}")
    fig.tight_layout()
    fig.savefig(out / "shift_vs_position.png", dpi=110)
    plt.close(fig)
    atomic_write_text(out / "curvature_check.csv", "mode,slope,r2,n\n" + "\n".join(rows) + "\n")
    # FRF overlays
    if ds.shards:
        w = ds.omega_rad_s
        fm, fu = ds.shard_arrays("frf_measured")[0], ds.shard_arrays("frf_updated")[0]
        fig, axs = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
        for ax, arr, name in ((axs[0], fm, "measured (truth + noise)"), (axs[1], fu, "updated model")):
            for s, st in ((0, "reference"), (1, "damaged")):
                ax.semilogy(w / (2 * np.pi), np.abs(arr[0, s, 3]), label=f"{st}")
            ax.set_title(f"sample 0, {name}: response node 5 / drive node 2")
            ax.set_ylabel("|H| (m/N)")
            ax.legend()
        axs[1].set_xlabel("frequency (Hz)")
        fig.tight_layout()
        fig.savefig(out / "frf_overlay.png", dpi=110)
        plt.close(fig)
    summary["figures"] = [str(out / f) for f in ("labels.png", "shift_vs_position.png", "frf_overlay.png")]
    import json
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=1))
    if not args.json:
        print(f"{args.dir}: {summary['samples']} samples, {summary['shards']} shards, "
              f"converged {summary['converged_fraction']:.3f}")
        for k, c in check.items():
            if c["slope"] is not None:
                print(f"  {k}: shift vs curvature^2 slope {c['slope']:.3f}, R^2 {c['r2']:.4f} (n={c['n']})")
        print(f"  figures in {out}")
    return summary
