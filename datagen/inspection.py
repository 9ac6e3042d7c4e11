"""Dataset report: counts, label histograms, the frequency-shift-vs-curvature check and FRF overlays.

:func:`inspect_dataset` writes figures (matplotlib, Agg) and tables next to
them and returns a JSON-ready summary; ``beam-damage inspect`` prints it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from datagen.dataset import Dataset
from datagen.store import STATES
from physics.errors import FileFormatError
from physics.io import atomic_write_bytes, atomic_write_text, figure_png, pyplot
from physics.properties import curvature_squared
from physics.supports import THESIS_SUPPORT

__all__ = ["curvature_check", "inspect_dataset"]


def _single_slits(table):
    """Rows of ``table`` with exactly one slit (none for another damage kind or a format-1 table)."""
    if "damage0_ei_loss" not in table:
        return table.iloc[:0]
    return table[table.n_damages == 1]


def curvature_check(table, length_m, bc: str = THESIS_SUPPORT, modes=(1, 2, 3, 4)):
    """Regress the truth frequency shift of single-slit samples on the curvature-squared prediction.

    Prediction (narrow slit of relative loss ``q = dEI/EI``, first order in its
    width ``w``, uniform beam on ideal supports ``bc``; the reduced section's flexibility gives
    ``q / (1 - q)``):
    ``df_r/f_r = -(1/2) q/(1 - q) w phi_r''(x)^2 / int phi_r''^2``
    (:func:`physics.properties.curvature_squared`). Slit datasets only
    (``n`` is 0 for other damage kinds).

    Parameters
    ----------
    table : DataFrame        the samples, with ``df{k}_rel`` of the ``k``-th mode used
    length_m : float
    bc : str                 the supports
    modes : sequence of int  bending-mode number of each mode used (the dataset's ``layout.modes``)

    Returns
    -------
    dict per mode used (``mode{number}``): ``slope`` (1 = exact), ``r2``, ``n``.
    """
    one = _single_slits(table)
    out = {}
    for k, number in enumerate(modes, start=1):
        if len(one) < 3:
            out[f"mode{number}"] = {"slope": None, "r2": None, "n": int(len(one))}
            continue
        q = one["damage0_ei_loss"]
        pred = -0.5 * q / (1 - q) * one["damage0_width_m"] * curvature_squared(
            one["damage0_x_m"].to_numpy(), length_m, number - 1, bc)
        act = one[f"df{k}_rel"]
        pred, act = np.asarray(pred, float), act.to_numpy()
        slope = float(pred @ act / (pred @ pred))
        r2 = float(1 - np.sum((act - slope * pred) ** 2) / np.sum((act - act.mean()) ** 2))
        out[f"mode{number}"] = {"slope": slope, "r2": r2, "n": int(len(act))}
    return out


def inspect_dataset(dataset_dir, out_dir=None) -> dict:
    """Summary, ``labels.png``, ``shift_vs_position.png``, ``curvature_check.csv``, ``frf_overlay.png``,
    ``summary.json``.

    Parameters
    ----------
    dataset_dir : path of a dataset directory
    out_dir : path, optional
        Where the figures and tables go (default ``DATASET_DIR/inspect``).

    Returns
    -------
    dict
        ``dir``, ``complete``, ``samples``, ``shards``, ``converged_fraction``,
        ``curvature_check`` (per mode: slope, r2, n), ``labels`` (min/max), ``figures``.
    """
    plt = pyplot()

    ds = Dataset(dataset_dir)
    if not ds.shards:
        raise FileFormatError(f"{dataset_dir}: incomplete dataset with no finished shard; run or resume its "
                              f"`beam-damage generate` command")
    ds.verify_or_raise()  # every checksum of the manifest, before anything is written
    table = ds.samples
    out = Path(out_dir) if out_dir else Path(dataset_dir) / "inspect"
    out.mkdir(parents=True, exist_ok=True)
    preset = ds.manifest["preset"]
    length = preset.get("length_m", preset.get("length"))  # format-1 manifests: "length"
    layout = ds.manifest.get("layout", {})
    bc, modes = layout.get("bc", THESIS_SUPPORT), tuple(layout.get("modes", (1, 2, 3, 4)))
    check = curvature_check(table, length, bc, modes)
    summary = _summary(ds, table, check, dataset_dir)
    _plot_labels(plt, table, out)
    rows = _plot_shift_vs_position(plt, table, length, bc, modes, check, out)
    atomic_write_text(out / "curvature_check.csv", "mode,slope,r2,n\n" + "\n".join(rows) + "\n")
    if ds.shards:
        _plot_frf_overlay(plt, ds, out)
    summary["figures"] = [str(out / f) for f in ("labels.png", "shift_vs_position.png", "frf_overlay.png")]
    summary["out"] = str(out)
    if not summary["complete"]:
        asked = ds.manifest.get("n_requested")
        summary["warnings"] = [f"{dataset_dir}: incomplete: {summary['samples']} of "
                               f"{asked if asked is not None else 'the'} samples asked (an interrupted generate; the "
                               f"same command resumes it)"]
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=1))
    return summary


def _summary(ds: Dataset, table, check: dict, dataset_dir) -> dict:
    """Counts, converged fraction, curvature check and label ranges of a dataset (``figures`` still empty)."""
    return {"dir": str(dataset_dir), "complete": ds.manifest.get("complete", False), "samples": int(len(table)),
            "shards": len(ds.shards), "converged_fraction": float(table["converged"].mean()) if len(table) else None,
            "curvature_check": check,
            "labels": {c: {"min": float(table[c].min()), "max": float(table[c].max())}
                       for c in ("damage0_x_m", "damage0_size", "damage0_depth_m", "damage0_width_m",
                                 "damage0_ei_loss", "damage0_mass_kg", "ei_Nm2",
                                 "m_per_length_kg_m", "noise_level", "temperature_stiffness_change",
                                 "root_spring_change", "stiffness_loss_Nm3", "max_frequency_drop_rel")
                       if c in table and table[c].notna().any()},
            "figures": []}


def _plot_labels(plt, table, out: Path) -> None:
    """Write ``labels.png``: histograms of the damage and property labels present in ``table``."""
    cols = [c for c in ("n_damages", "damage0_x_m", "damage0_size", "damage0_depth_m", "damage0_width_m",
                        "damage0_ei_loss", "damage0_mass_kg", "ei_Nm2", "m_per_length_kg_m", "damping_scale",
                        "root_spring_Nm_rad") if c in table][:9]
    fig, axs = plt.subplots(3, 3, figsize=(11, 8))
    for ax, c in zip(axs.flat, cols):
        v = table[c].to_numpy(float)
        ax.hist(v[np.isfinite(v)], bins=30)     # a rigid clamp's root spring is inf
        ax.set_title(c, fontsize=9)
    fig.tight_layout()
    atomic_write_bytes(out / "labels.png", figure_png(fig))


def _plot_shift_vs_position(plt, table, length_m: float, bc: str, modes, check: dict, out: Path) -> list[str]:
    """Write ``shift_vs_position.png`` (single-slit shifts against curvature squared); return the CSV rows per mode."""
    one = _single_slits(table)
    ncols = 2 if len(modes) <= 4 else 4
    nrows = -(-len(modes) // ncols)
    fig, axs = plt.subplots(nrows, ncols, figsize=(5.5 * ncols, 3.5 * nrows), squeeze=False)
    for ax in axs.flat[len(modes):]:
        ax.set_visible(False)
    xg = np.linspace(0, length_m, 400)
    rows = []
    for k, (number, ax) in enumerate(zip(modes, axs.flat), start=1):
        if len(one):
            q = one["damage0_ei_loss"]
            norm = -0.5 * q / (1 - q) * one["damage0_width_m"]
            ax.plot(one["damage0_x_m"], one[f"df{k}_rel"] / norm, ".", ms=3, label="truth shift / (-q/(1-q) w/2)")
        ax.plot(xg, curvature_squared(xg, length_m, number - 1, bc), "r-", label="phi''(x)^2 / int phi''^2")
        c = check[f"mode{number}"]
        ax.set_title(f"mode {number}: slope {c['slope']:.3f}, R^2 {c['r2']:.4f}" if c["slope"] is not None
                     else f"mode {number}")
        ax.set_xlabel("slit position x (m)")
        ax.set_ylabel("normalised shift (1/m)")
        ax.legend(fontsize=7)
        rows.append(f"{number},{c['slope']},{c['r2']},{c['n']}")
    fig.tight_layout()
    atomic_write_bytes(out / "shift_vs_position.png", figure_png(fig))
    return rows


def _plot_frf_overlay(plt, ds: Dataset, out: Path) -> None:
    """Write ``frf_overlay.png``: sample 0's measured and (where the dataset has one) updated-model FRF from the
    reference DOF to the last measured DOF, in every state."""
    w = ds.omega_rad_s
    schema = ds.manifest.get("schema", {})
    dofs = schema.get("measured_dofs", ["2:y", "3:y", "4:y", "5:y"])
    ref = dofs[schema.get("frf_reference_row", 0)]
    kinds = [("measured", "measured (truth + noise)")]
    if ds.has_updated_model:
        kinds.append(("updated", "updated model"))
    fig, axs = plt.subplots(len(kinds), 1, figsize=(10, 3.5 * len(kinds) + 0.5), sharex=True, squeeze=False)
    for ax, (kind, name) in zip(axs[:, 0], kinds):
        arr = ds.frf(kind, rows=[0])
        for s, st in enumerate(STATES):
            ax.semilogy(w / (2 * np.pi), np.abs(arr[0, s, -1]), label=st)
        ax.set_title(f"sample 0, {name}: response {dofs[-1]} / reference {ref}")
        ax.set_ylabel("|H| (m/N)")
        ax.legend()
    axs[-1, 0].set_xlabel("frequency (Hz)")
    fig.tight_layout()
    atomic_write_bytes(out / "frf_overlay.png", figure_png(fig))
