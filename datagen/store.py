"""Dataset directory format and its writers: manifest, per-sample table, sharded arrays of what defines each sample.

Layout (format ``beam-damage-dataset/2``)::

    DIR/manifest.json             config, seed, package version, counts, schema (arrays, columns with units),
                                  shard list with sizes and sha256 checksums
    DIR/omega_rad_s.npy           FRF lines (rad/s), shape (F,)
    DIR/samples.parquet           one row per sample, row groups of up to 65,536 rows (written at the end)
    DIR/shards/shard-000000/      one complete shard: samples.parquet, one .npy per stored array,
                                  checksums.json; with ``output.store_frf`` also frf_measured.npy, frf_updated.npy

A shard stores what defines its samples (:data:`ARRAYS`): about 4.6 kB per
sample with the tables. FRFs are synthesised when read
(:meth:`datagen.dataset.Dataset.frf`, :mod:`datagen.synth`), on all lines or
only on chosen ones (``lines=``); ``output.store_frf`` writes the very same
arrays into the shard (128 kB per sample as complex64) for tools that want files.

A shard is written into ``shards/.tmp-shard-NNNNNN-<pid>/`` and renamed to
``shards/shard-NNNNNN`` only when all its files (and ``checksums.json``) are
on disk, then recorded in ``manifest.json`` (atomic rewrite). A resumed
``generate`` verifies every recorded shard and regenerates damaged ones
(:func:`recover`).

Array axes: ``state`` (0 = baseline, 1 = current), ``dof`` (the 4 measured
translations, thesis nodes 2..5, the FRFs driven at the first), ``mode``, ``line``.
Nothing is pickled: ``np.load(..., allow_pickle=False)`` reads every file.
Format 1 datasets (FRFs stored in the shards) are read but cannot be resumed.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from datagen.config import OUTPUT_ONLY_VARIABLES, REPEATABILITY
from datagen.damage import DamageModel, element4_index
from datagen.synth import DATASET_FRFS, synthesise
from physics.errors import DISK_FULL_ERRNOS, DiskFullError, FileFormatError
from physics.io import atomic_write_text, read_json
from physics.modal import modal_parameters

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ARRAYS", "ARRAYS_V1", "COLUMN_UNITS", "DATASET_FORMAT", "DATASET_FORMAT_V1", "DERIVED", "OPTIONAL",
           "NO_EFFECT_DROP", "ROW_GROUP", "STATES", "STATUS", "column_units", "damaged_file", "dataset_identity",
           "file_sha256", "finalize", "foreign_shard", "package_version", "read_manifest", "recover", "sample_status",
           "sample_table", "shard_arrays", "shard_name", "verify_shard", "write_manifest", "write_shard"]

DATASET_FORMAT = "beam-damage-dataset/2"
DATASET_FORMAT_V1 = "beam-damage-dataset/1"

#: Stored arrays of a shard: name -> (axes, description).
ARRAYS = {
    "truth_poles": ("sample, state, mode", "noise-free truth eigenvalues (rad/s), Im > 0, all p projected modes"),
    "truth_shapes": ("sample, state, dof, mode", "noise-free truth shapes at the measured DOFs (and at the "
                     "reference DOF, a row after them, when it is no sensor), eq. 1.10 normalised"),
    "eigenvalues_measured": ("sample, state, mode", "noisy measured eigenvalues (rad/s), Im > 0, modes 1..4"),
    "eigenvectors_measured": ("sample, state, dof, mode", "noisy measured mode shapes"),
    "M_updated": ("sample, dof, dof", "mass matrix used by the updating (kg), IIRS or lumped"),
    "C_updated": ("sample, state, dof, dof", "identified damping matrix (N s/m)"),
    "K_updated": ("sample, state, dof, dof", "updated stiffness matrix (N/m)"),
    "updated_poles": ("sample, state, mode", "eigenvalues of the updated models (rad/s), NaN if not 4 pairs"),
    "updated_residues": ("sample, state, dof, mode", "receptance residues of the updated models (drive DOF 1)"),
    "noise_seed": ("sample", "seed of the counter-based FRF noise stream (uint64)"),
    "noise_level": ("sample", "FRF noise std relative to |H| (-)"),
    "noise_floor": ("sample", "FRF noise floor std relative to each FRF's peak (-)"),
    "frf_peak": ("sample, state, dof", "peak over all lines of each noise-free measured |H| (m/N), the floor's "
                 "scale; NaN where the noise floor is 0"),
}

#: Arrays added to the format after its first datasets: a shard without one reads as NaN (recomputed when needed).
OPTIONAL = {"frf_peak": np.nan}

#: Arrays computed from the stored ones (names kept from format 1).
DERIVED = {
    "eigenvalues_true": ("sample, state, mode", "noise-free truth eigenvalues (rad/s), modes 1..4"),
    "eigenvectors_true": ("sample, state, dof, mode", "noise-free truth shapes, modes 1..4"),
    "frf_measured": ("sample, state, dof, line", "noisy truth receptance (m/N), drive at DOF 1 (node 2)"),
    "frf_updated": ("sample, state, dof, line", "receptance of the updated model (m/N), drive at DOF 1"),
}

#: Arrays of format-1 shards.
ARRAYS_V1 = ("frf_measured", "frf_updated", "eigenvalues_measured", "eigenvectors_measured", "eigenvalues_true",
             "eigenvectors_true", "M_updated", "C_updated", "K_updated")

STATES = ("baseline", "current")

#: Units of the samples-table columns of every damage kind ("-" dimensionless); ``{k}``/``{r}`` stand for damage
#: (from 0) and mode (from 1) numbers. The damage model adds its own (:func:`column_units`).
COLUMN_UNITS = {
    "sample_id": "-", "shard": "-", "damaged": "bool: at least one damage", "ei_Nm2": "N m^2",
    "m_per_length_kg_m": "kg/m", "damping_scale": "- (factor on the damping ratios)",
    "root_spring_Nm_rad": "N m/rad (inf: rigid clamp)", "n_damages": "-",
    "temperature_stiffness_change": "- (relative EI change of the current day)",
    "root_spring_change": "- (relative root-spring change on re-clamping)",
    "noise_level": "- (FRF noise std relative to |H|)", "noise_floor": "- (FRF noise std relative to the FRF peak)",
    "noise_seed": "- (uint64 seed of the FRF noise stream)",
    "modal_noise_scale": "- (factor on the standard deviations of the modal noise)",
    "shear_flexibility": "- (EI / (kGA L^2) of the specimen; 0: Euler-Bernoulli)",
    "frequency_scatter": "- (relative std of independent per-mode frequency changes of each test)",
    "damping_scatter": "- (relative std of independent per-mode damping-ratio changes of each test)",
    "shape_scatter": "- (std of independent shape changes of each test, relative to each mode's largest entry)",
    "gain_scatter": "- (relative std of each sensor channel's gain in each test)",
    "support_changed": "bool: an intact specimen whose supports changed beyond re-clamping",
    "sensor_noise": "- (output-only modal noise: sensor noise std relative to the response RMS)",
    "record_length_s": "s (output-only modal noise: record length of each test)",
    "max_frequency_drop_rel": "- (largest relative drop of f1..f4 due to the damage alone)",
    "damage{k}_x_m": "m", "damage{k}_size": "- (the damage model's size_meaning)",
    "damage{k}_element4": "- (1..4, 0 none)",
    "f{r}_hz_base": "Hz", "f{r}_hz_cur": "Hz", "zeta{r}_base": "-", "zeta{r}_cur": "-",
    "f{r}_hz_meas_base": "Hz", "f{r}_hz_meas_cur": "Hz", "zeta{r}_meas_base": "-", "zeta{r}_meas_cur": "-",
    "df{r}_rel": "-", "df{r}_rel_meas": "-", "dzeta{r}": "-", "dzeta{r}_meas": "-",
    "converged_base": "bool", "converged_cur": "bool", "iterations_base": "-", "iterations_cur": "-",
    "residual_base": "-", "residual_cur": "-",
    "converged": "bool: both states converged to a positive definite model with finite poles",
    "status": "str: ok, not_converged, not_positive_definite, nan_poles or no_damage_effect (datagen.store.STATUS)",
}

ROW_GROUP = 65536


def package_version() -> str:
    try:
        return version("beam-damage")
    except PackageNotFoundError:
        return "unknown"


def file_sha256(path) -> str:
    """sha256 hex digest of a file, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def shard_name(index: int) -> str:
    return f"shard-{index:06d}"


def dataset_identity(cfg: dict, seed: int) -> dict:
    """What a dataset's samples depend on: format, sha256 of the canonical config JSON, seed.

    Recorded in ``manifest.json`` (``identity``) and, with the shard's ``index``, in every shard entry and the
    shard's ``checksums.json``; a shard or manifest entry whose identity differs belongs to another dataset.
    """
    text = json.dumps(cfg, sort_keys=True)
    return {"format": DATASET_FORMAT, "config_sha256": hashlib.sha256(text.encode()).hexdigest(), "seed": int(seed)}


def foreign_shard(manifest: dict, entry: dict) -> str | None:
    """Why a shard entry belongs to another dataset than ``manifest`` (one phrase), else None.

    Manifests written before identities existed (no ``identity`` key) accept every entry.
    """
    if "identity" not in manifest:
        return None
    want = {**dataset_identity(manifest["config"], manifest["seed"]), "shard": entry.get("index")}
    if manifest["identity"] != {k: v for k, v in want.items() if k != "shard"}:
        return "the manifest's identity does not match its own config and seed"
    got = entry.get("identity")
    if got == want:
        return None
    if not isinstance(got, dict):
        return "its entry carries no dataset identity"
    diff = [k for k in want if got.get(k) != want[k]]
    return f"its identity differs in {', '.join(diff)} (seed {got.get('seed')!r}, not {want['seed']})"


def column_units(model: DamageModel) -> dict:
    """:data:`COLUMN_UNITS` plus the columns of the damage ``model`` (``damage{k}_size`` says what its size is)."""
    return {**COLUMN_UNITS, "damage{k}_size": f"- ({model.size_meaning})", **model.sample_units,
            **{f"damage{{k}}_{c}": u for c, u in model.units.items()}}


def sample_table(labels: dict, outputs: dict, shard: int, first_id: int, length_m: float,
                 model: DamageModel) -> pd.DataFrame:
    """Per-sample labels and scalar results as a DataFrame (one row per sample).

    Damage columns ``damage{k}_*`` (k = 0..S-1): centre ``x_m``, ``size`` and the
    ``model``'s own columns hold NaN (0 for ``element4``) where a sample has fewer
    damages. Frequencies/damping ratios per mode r = 1..4 for the
    baseline (``_base``) and current (``_cur``) states, truth and measured
    (``_meas``). Units in :func:`column_units`.
    """
    n = labels["EI_Nm2"].shape[0]
    ei, mpl, x_m = labels["EI_Nm2"], labels["mass_per_length_kg_m"], labels["x_m"]
    size = model.size(labels, x_m, ei, mpl, length_m)
    per_sample, per_damage = model.columns(labels, x_m, ei, mpl, length_m)
    cols = {
        "sample_id": np.arange(first_id, first_id + n, dtype=np.int64),
        "shard": np.full(n, shard, dtype=np.int32),
        "damaged": labels["n_damages"] > 0,
        "ei_Nm2": ei, "m_per_length_kg_m": labels["mass_per_length_kg_m"],
        "damping_scale": labels["damping_scale"], "root_spring_Nm_rad": labels["root_spring_Nm_rad"],
        "n_damages": labels["n_damages"].astype(np.int32),
        "temperature_stiffness_change": labels["temperature_stiffness_change"],
        "root_spring_change": labels["root_spring_change"],
        "noise_level": labels["noise_level"], "noise_floor": labels["noise_floor"],
        "noise_seed": labels["noise_seed"].astype(np.uint64),
        "modal_noise_scale": labels["modal_noise_scale"],
        "shear_flexibility": labels["shear_flexibility"],
        **{k: labels[k] for k in REPEATABILITY},
        "support_changed": labels["support_changed"].astype(bool),
        **{k: labels[k] for k in OUTPUT_ONLY_VARIABLES if k in labels},   # output-only modal noise
        **per_sample,
        "max_frequency_drop_rel": outputs["damage_frequency_drop"],
    }
    for k in range(x_m.shape[1]):
        cols[f"damage{k}_x_m"] = x_m[:, k]
        cols[f"damage{k}_size"] = size[:, k]
        cols.update({f"damage{k}_{c}": v[:, k] for c, v in per_damage.items()})
        cols[f"damage{k}_element4"] = element4_index(x_m[:, k], length_m).astype(np.int8)
    truth = outputs["truth_poles_used"] if "truth_poles_used" in outputs else outputs["truth_poles"][..., :4]
    for lam, tag in ((truth, ""), (outputs["eigenvalues_measured"], "_meas")):
        f, z = modal_parameters(lam)
        for r in range(f.shape[-1]):
            for s, st in ((0, "base"), (1, "cur")):
                cols[f"f{r + 1}_hz{tag}_{st}"] = f[:, s, r]
                cols[f"zeta{r + 1}{tag}_{st}"] = z[:, s, r]
            cols[f"df{r + 1}_rel{tag}"] = f[:, 1, r] / f[:, 0, r] - 1
            cols[f"dzeta{r + 1}{tag}"] = z[:, 1, r] - z[:, 0, r]
    for s, st in ((0, "base"), (1, "cur")):
        cols[f"converged_{st}"] = outputs["converged"][:, s].astype(bool)
        cols[f"iterations_{st}"] = outputs["iterations"][:, s].astype(np.int32)
        cols[f"residual_{st}"] = outputs["residual"][:, s].astype(float)
    status = sample_status(labels, outputs)
    cols["converged"] = cols["converged_base"] & cols["converged_cur"] & np.isin(status, ("ok", "no_damage_effect"))
    cols["status"] = status
    import pandas as pd  # pandas: only where a samples table is built

    return pd.DataFrame(cols)


#: Values of the samples table's ``status`` column, the first that applies (updating failures first).
STATUS = {
    "not_converged": "the Pilkey iteration did not reach its tolerance in a state",
    "not_positive_definite": "an updated stiffness matrix has an eigenvalue <= 0 (converged = false)",
    "nan_poles": "the updated model has no 4 finite conjugate pole pairs (converged = false)",
    "no_damage_effect": "damaged, yet its slits lower no frequency f1..f4 by 1e-9 or more (a label without effect)",
    "ok": "none of the above",
}

#: Relative frequency change below which a sample's damage counts as changing nothing.
NO_EFFECT_DROP = 1e-9


#: An updated stiffness whose smallest eigenvalue is at most this fraction of its largest is not positive definite.
SINGULAR_RTOL = 1e-12


def sample_status(labels: dict, outputs: dict) -> np.ndarray:
    """Status of each sample (:data:`STATUS`), shape (B,), from the pipeline's labels and outputs."""
    K = np.asarray(outputs["K_updated"], dtype=float)
    finite_k = np.all(np.isfinite(K), axis=(-2, -1))
    Ks = np.where(finite_k[..., None, None], 0.5 * (K + np.swapaxes(K, -1, -2)), 0.0)
    updated = np.asarray(outputs.get("has_update", True), bool)   # False: no updated model (fewer modes than sensors)
    eig = np.linalg.eigvalsh(Ks)
    # singular to working precision counts as not positive definite (the rounding decides the sign of a zero)
    not_pd = updated & np.any(~finite_k | (eig[..., 0] <= SINGULAR_RTOL * np.abs(eig[..., -1])), axis=1)
    nan_poles = updated & ~np.all(np.isfinite(outputs["updated_poles"]), axis=(1, 2))
    no_effect = (labels["n_damages"] > 0) & ~(np.abs(outputs["damage_frequency_drop"]) >= NO_EFFECT_DROP)
    not_converged = ~np.all(np.asarray(outputs["converged"], dtype=bool), axis=1)
    return np.select([not_converged, not_pd, nan_poles, no_effect],
                     ["not_converged", "not_positive_definite", "nan_poles", "no_damage_effect"], default="ok")


def shard_arrays(labels: dict, outputs: dict) -> dict:
    """The stored arrays (:data:`ARRAYS`) of one shard from the pipeline's labels and outputs."""
    out = {k: outputs[k] for k in ARRAYS if k in outputs}
    out.update(noise_seed=labels["noise_seed"].astype(np.uint64), noise_level=labels["noise_level"].astype(float),
               noise_floor=labels["noise_floor"].astype(float))
    return out


def write_shard(root, index: int, table: pd.DataFrame, arrays: dict, omega_rad_s=None, frf_dtype=None,
                identity: dict | None = None) -> dict:
    """Write one shard atomically (temp directory, then rename); returns its manifest entry.

    ``identity`` (:func:`dataset_identity`) is recorded with the shard's index in the entry and ``checksums.json``.

    With ``omega_rad_s`` given, the FRFs synthesised from ``arrays`` (exactly
    what :meth:`datagen.dataset.Dataset.frf` returns) are written too (``--store-frf``).
    """
    root = Path(root)
    shards = root / "shards"
    shards.mkdir(parents=True, exist_ok=True)
    final = shards / shard_name(index)
    tmp = shards / f".tmp-{shard_name(index)}-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        tmp.mkdir()
        entry = _write_files(tmp, index, table, arrays, omega_rad_s, frf_dtype, identity)
    except BaseException as exc:  # a full disk, an interrupt: no half-written shard directory is left behind
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS:
            raise DiskFullError(f"{final}: no space left on device; the shard was not written and the dataset's "
                                f"recorded shards are intact: free space and re-run the same command to resume") \
                from None
        raise
    if final.exists():  # a stale or damaged shard of an interrupted run
        shutil.rmtree(final)
    os.replace(tmp, final)
    return entry


def _write_files(tmp: Path, index: int, table: pd.DataFrame, arrays: dict, omega_rad_s, frf_dtype,
                 identity) -> dict:
    """Write a shard's files, its ``checksums.json`` and fsync them into ``tmp``; returns its manifest entry."""
    table.to_parquet(tmp / "samples.parquet", index=False)
    for name in ARRAYS:
        np.save(tmp / f"{name}.npy", np.ascontiguousarray(arrays[name]), allow_pickle=False)
    if omega_rad_s is not None:
        for kind in DATASET_FRFS:
            np.save(tmp / f"frf_{kind}.npy", synthesise(kind, arrays, omega_rad_s, frf_dtype), allow_pickle=False)
    files = sorted(tmp.iterdir())
    entry = {"index": index, "name": shard_name(index), "n_samples": int(len(table)),
             "n_converged": int(table["converged"].sum()), "checksums": {p.name: file_sha256(p) for p in files},
             "sizes": {p.name: p.stat().st_size for p in files}}
    if "status" in table:
        entry["status"] = {k: int((table["status"] == k).sum()) for k in STATUS}
    if identity is not None:
        entry["identity"] = dict(sorted({**identity, "shard": index}.items()))  # same bytes after a JSON reload
    (tmp / "checksums.json").write_text(json.dumps(entry, indent=1))
    for p in tmp.iterdir():  # flush file data before the rename makes the shard visible
        with open(p, "rb") as fh:
            os.fsync(fh.fileno())
    return entry


def verify_shard(root, entry: dict) -> bool:
    """True when every file of the shard exists and matches its checksum."""
    return damaged_file(root, entry) is None


def damaged_file(root, entry: dict, sizes_only: bool = False):
    """Name of the first missing or damaged file of a shard, else None."""
    d = Path(root) / "shards" / entry["name"]
    for f, h in entry["checksums"].items():
        p = d / f
        try:
            if "sizes" in entry and p.stat().st_size != entry["sizes"][f]:
                return f
            if not sizes_only and file_sha256(p) != h:
                return f
        except OSError:
            return f
    return None


def read_manifest(root, formats=(DATASET_FORMAT, DATASET_FORMAT_V1)) -> dict:
    """``DIR/manifest.json``, checked: a JSON object of a supported format with a well-formed shard list.

    Raises
    ------
    FileFormatError
        Missing, not UTF-8, not JSON, not an object, another format, or a field of the wrong form
        (one line naming the file and the field).
    """
    p = Path(root) / "manifest.json"
    try:
        m = read_json(p, max_bytes=2**31)  # a manifest lists every shard's checksums: large, but bounded
    except FileNotFoundError:
        raise FileFormatError(f"{root}: not a dataset directory (no manifest.json)") from None
    if m.get("format") not in formats:
        raise FileFormatError(f"{p}: dataset format {m.get('format')!r} is not supported by this version "
                              f"(reads {', '.join(formats)}); regenerate it with `beam-damage generate`")
    _check_manifest_fields(p, m)
    damage = m["config"].get("damage")
    if m["format"] == DATASET_FORMAT and not (isinstance(damage, dict) and "kind" in damage):
        raise FileFormatError(f"{p}: written before the damage kinds (columns n_slits, slit{{k}}_*; now n_damages, "
                              f"damage{{k}}_*, see docs/datasets.md); regenerate it with `beam-damage generate` "
                              f"(the same config and seed give the same samples)")
    return m


def _check_manifest_fields(p, m: dict) -> None:
    """The fields readers index without further checks: config, shards (name, index, n_samples, checksums)."""
    def bad(field, expected):
        raise FileFormatError(f"{p}: corrupt manifest, field {field!r} must be {expected}")

    if not isinstance(m.get("config"), dict):
        bad("config", "an object (the generator config)")
    if not isinstance(m.get("shards"), list):
        bad("shards", "a list of shard entries")
    for k, e in enumerate(m["shards"]):
        f = f"shards[{k}]"
        if not isinstance(e, dict):
            bad(f, "an object with name, index, n_samples, checksums")
        if not (isinstance(e.get("index"), int) and e["index"] >= 0 and e.get("name") == shard_name(e["index"])):
            bad(f"{f}.name/index", "'shard-NNNNNN' and its index NNNNNN")
        if not (isinstance(e.get("n_samples"), int) and e["n_samples"] >= 0):
            bad(f"{f}.n_samples", "an integer >= 0")
        cs = e.get("checksums")
        if not (isinstance(cs, dict) and cs and all(isinstance(h, str) and "/" not in n and n not in (".", "..")
                                                    for n, h in cs.items())):
            bad(f"{f}.checksums", "an object of file name -> sha256")
        if "sizes" in e and not (isinstance(e["sizes"], dict) and set(e["sizes"]) == set(cs)
                                 and all(isinstance(v, int) for v in e["sizes"].values())):
            bad(f"{f}.sizes", "an object of file name -> size in bytes, for the files of 'checksums'")
    if "checksums" in m and not isinstance(m["checksums"], dict):
        bad("checksums", "an object of file name -> sha256")


def write_manifest(root, manifest: dict) -> None:
    atomic_write_text(Path(root) / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True))


def recover(root, manifest: dict) -> tuple[dict, list]:
    """Clean up after an interrupted run before resuming.

    Drops temporary shard directories, verifies every recorded shard (sha256)
    and forgets damaged ones and ones of another dataset (:func:`foreign_shard`;
    they are regenerated), and adopts renamed-but-unrecorded shards whose
    checksums verify and whose identity is this dataset's.

    Returns
    -------
    manifest : dict
    damaged : list of int       indices of the recorded shards found damaged or foreign
    """
    shards = Path(root) / "shards"
    damaged = [e["index"] for e in manifest["shards"] if foreign_shard(manifest, e) or not verify_shard(root, e)]
    manifest["shards"] = [e for e in manifest["shards"] if e["index"] not in damaged]
    if damaged:
        manifest["complete"] = False
    if not shards.exists():
        return manifest, damaged
    known = {e["index"] for e in manifest["shards"]}
    for d in sorted(shards.iterdir()):
        if d.name.startswith(".tmp-"):
            shutil.rmtree(d, ignore_errors=True)
        elif d.name.startswith("shard-") and int(d.name[6:]) not in known:
            try:
                entry = json.loads((d / "checksums.json").read_text())
            except (OSError, json.JSONDecodeError):
                shutil.rmtree(d, ignore_errors=True)
                continue
            if isinstance(entry, dict) and entry.get("index") == int(d.name[6:]) \
                    and foreign_shard(manifest, entry) is None and verify_shard(root, entry):
                manifest["shards"].append(entry)
            else:
                shutil.rmtree(d, ignore_errors=True)
    manifest["shards"].sort(key=lambda e: e["index"])
    return manifest, damaged


def finalize(root, manifest: dict) -> dict:
    """Write the combined ``samples.parquet`` (streamed shard by shard) and mark the manifest complete."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    root = Path(root)
    tmp = root / ".samples.parquet.tmp"
    writer, buf, rows, n, n_conv = None, [], 0, 0, 0
    status = dict.fromkeys(STATUS, 0)

    def flush(final=False):  # whole row groups of ROW_GROUP rows; the remainder waits for more rows
        nonlocal writer, buf, rows
        if not buf:
            return
        t = pa.concat_tables(buf)
        keep = 0 if final else t.num_rows % ROW_GROUP
        if writer is None:
            writer = pq.ParquetWriter(tmp, t.schema)
        writer.write_table(t.slice(0, t.num_rows - keep), row_group_size=ROW_GROUP)
        buf, rows = ([t.slice(t.num_rows - keep)] if keep else []), keep

    try:
        for e in manifest["shards"]:
            t = pq.read_table(root / "shards" / e["name"] / "samples.parquet")
            buf.append(t)
            rows += t.num_rows
            n += t.num_rows
            n_conv += e["n_converged"]
            for k, c in e.get("status", {}).items():
                status[k] = status.get(k, 0) + c
            if rows >= ROW_GROUP:
                flush()
        flush(final=True)
    finally:
        if writer is not None:
            writer.close()
    os.replace(tmp, root / "samples.parquet")
    manifest["complete"] = True
    manifest["counts"] = {"samples": n, "converged": n_conv, "not_converged": n - n_conv, "status": status,
                          "shards": len(manifest["shards"])}
    manifest["checksums"] = {"samples.parquet": file_sha256(root / "samples.parquet"),
                             "omega_rad_s.npy": file_sha256(root / "omega_rad_s.npy")}
    manifest["columns"] = pq.read_schema(root / "samples.parquet").names
    write_manifest(root, manifest)
    return manifest
