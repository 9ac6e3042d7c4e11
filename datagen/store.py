"""Dataset directory format: manifest, per-sample table, sharded memory-mappable arrays.

Layout::

    DIR/manifest.json             config, seed, package version, counts, schema, shard list + checksums
    DIR/omega_rad_s.npy           FRF lines (rad/s), shape (F,)
    DIR/samples.parquet           one row per sample (written when every shard is complete)
    DIR/shards/shard-000000/      one complete shard: samples.parquet and one .npy per array,
                                  checksums.json (sha256 of every file)

A shard is written into ``shards/.tmp-shard-NNNNNN-<pid>/`` and renamed to
``shards/shard-NNNNNN`` only when all its files (and its ``checksums.json``)
are on disk, then recorded in ``manifest.json`` (atomic rewrite). A reader
uses only the shards listed in the manifest, so a partial shard is never
mistaken for a complete one; a resumed run deletes temporary directories and
adopts a renamed-but-unrecorded shard after verifying its checksums.

Array axes: ``state`` (0 = undamaged reference, 1 = damaged), ``dof`` (the 4
measured translations, thesis nodes 2..5), ``mode`` (1..4), ``line``.
Nothing is pickled: ``np.load(..., allow_pickle=False)`` reads every file.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from datagen.damage import element4_index
from physics.errors import FileFormatError
from physics.io import atomic_write_text
from physics.modal import modal_parameters

FORMAT = "beam-damage-dataset/1"

#: Array files of a shard: name -> (axes, description).
ARRAYS = {
    "frf_measured": ("sample, state, dof, line", "noisy truth receptance (m/N), drive at DOF 1 (node 2)"),
    "frf_updated": ("sample, state, dof, line", "receptance of the updated model (m/N), drive at DOF 1"),
    "eigenvalues_measured": ("sample, state, mode", "noisy measured eigenvalues (rad/s), Im > 0"),
    "eigenvectors_measured": ("sample, state, dof, mode", "noisy measured mode shapes"),
    "eigenvalues_true": ("sample, state, mode", "noise-free truth eigenvalues (rad/s)"),
    "eigenvectors_true": ("sample, state, dof, mode", "noise-free truth shapes, eq. 1.10 normalised"),
    "M_updated": ("sample, dof, dof", "mass matrix used by the updating (kg), IIRS or lumped"),
    "C_updated": ("sample, state, dof, dof", "identified damping matrix (N s/m)"),
    "K_updated": ("sample, state, dof, dof", "updated stiffness matrix (N/m)"),
}


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("beam-damage")
    except PackageNotFoundError:
        return "unknown"


def _sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def shard_name(index: int) -> str:
    return f"shard-{index:06d}"


def sample_table(labels: dict, outputs: dict, shard: int, first_id: int, length_m: float) -> pd.DataFrame:
    """Per-sample labels and scalar results as a DataFrame (one row per sample).

    Slit columns ``slit{k}_*`` (k = 1..S) hold NaN (0 for ``element4``) where a
    sample has fewer slits. Frequencies/damping ratios per mode r = 1..4 for the
    reference (``_ref``) and damaged (``_dam``) states, truth and measured.
    """
    n = labels["EI"].shape[0]
    cols = {
        "sample_id": np.arange(first_id, first_id + n, dtype=np.int64),
        "shard": np.full(n, shard, dtype=np.int32),
        "ei_Nm2": labels["EI"], "m_per_length_kg_m": labels["m_per_length"],
        "damping_scale": labels["damping_scale"], "root_spring_Nm_rad": labels["root_spring"],
        "n_slits": labels["n_slits"].astype(np.int32),
    }
    for k in range(labels["x_m"].shape[1]):
        x = labels["x_m"][:, k]
        cols[f"slit{k + 1}_x_m"] = x
        cols[f"slit{k + 1}_width_m"] = labels["width_m"][:, k]
        cols[f"slit{k + 1}_depth_m"] = labels["depth_m"][:, k]
        cols[f"slit{k + 1}_ei_loss"] = labels["ei_loss"][:, k]
        cols[f"slit{k + 1}_stiffness_loss_Nm3"] = labels["ei_loss"][:, k] * labels["EI"] * labels["width_m"][:, k]
        cols[f"slit{k + 1}_damping_s"] = labels["beta_s"][:, k]
        cols[f"slit{k + 1}_element4"] = element4_index(x, length_m).astype(np.int8)
    for src, tag in (("eigenvalues_true", ""), ("eigenvalues_measured", "_meas")):
        f, z = modal_parameters(outputs[src])
        for r in range(f.shape[-1]):
            for s, st in ((0, "ref"), (1, "dam")):
                cols[f"f{r + 1}_hz{tag}_{st}"] = f[:, s, r]
                cols[f"zeta{r + 1}{tag}_{st}"] = z[:, s, r]
            cols[f"df{r + 1}_rel{tag}"] = f[:, 1, r] / f[:, 0, r] - 1
            cols[f"dzeta{r + 1}{tag}"] = z[:, 1, r] - z[:, 0, r]
    for s, st in ((0, "ref"), (1, "dam")):
        cols[f"converged_{st}"] = outputs["converged"][:, s].astype(bool)
        cols[f"iterations_{st}"] = outputs["iterations"][:, s].astype(np.int32)
        cols[f"residual_{st}"] = outputs["residual"][:, s].astype(float)
    cols["converged"] = cols["converged_ref"] & cols["converged_dam"]
    return pd.DataFrame(cols)


def write_shard(root, index: int, table: pd.DataFrame, arrays: dict) -> dict:
    """Write one shard atomically (temp directory, then rename); returns its manifest entry."""
    root = Path(root)
    shards = root / "shards"
    shards.mkdir(parents=True, exist_ok=True)
    final = shards / shard_name(index)
    tmp = shards / f".tmp-{shard_name(index)}-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    table.to_parquet(tmp / "samples.parquet", index=False)
    for name in ARRAYS:
        np.save(tmp / f"{name}.npy", np.ascontiguousarray(arrays[name]), allow_pickle=False)
    sums = {p.name: _sha256(p) for p in sorted(tmp.iterdir())}
    entry = {"index": index, "name": shard_name(index), "n_samples": int(len(table)),
             "n_converged": int(table["converged"].sum()), "checksums": sums}
    (tmp / "checksums.json").write_text(json.dumps(entry, indent=1))
    for p in tmp.iterdir():  # flush file data before the rename makes the shard visible
        with open(p, "rb") as fh:
            os.fsync(fh.fileno())
    if final.exists():  # a stale complete shard from an interrupted run with the same content
        shutil.rmtree(final)
    os.replace(tmp, final)
    return entry


def verify_shard(root, entry: dict) -> bool:
    """True when every file of the shard exists and matches its checksum."""
    d = Path(root) / "shards" / entry["name"]
    try:
        return all(_sha256(d / f) == h for f, h in entry["checksums"].items())
    except OSError:
        return False


def read_manifest(root) -> dict:
    p = Path(root) / "manifest.json"
    try:
        m = json.loads(p.read_text())
    except FileNotFoundError:
        raise FileFormatError(f"{root}: not a dataset directory (no manifest.json)") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{p}: corrupt manifest ({exc})") from None
    if m.get("format") != FORMAT:
        raise FileFormatError(f"{p}: format {m.get('format')!r} is not {FORMAT!r}")
    return m


def write_manifest(root, manifest: dict) -> None:
    atomic_write_text(Path(root) / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True))


def recover(root, manifest: dict) -> dict:
    """Clean up after an interrupted run: drop temp shards, adopt verified unrecorded ones."""
    shards = Path(root) / "shards"
    if not shards.exists():
        return manifest
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
            if verify_shard(root, entry):
                manifest["shards"].append(entry)
            else:
                shutil.rmtree(d, ignore_errors=True)
    manifest["shards"].sort(key=lambda e: e["index"])
    return manifest


def finalize(root, manifest: dict) -> dict:
    """Write the combined ``samples.parquet`` and mark the manifest complete."""
    root = Path(root)
    tables = [pd.read_parquet(root / "shards" / e["name"] / "samples.parquet") for e in manifest["shards"]]
    table = pd.concat(tables, ignore_index=True)
    tmp = root / ".samples.parquet.tmp"
    table.to_parquet(tmp, index=False)
    os.replace(tmp, root / "samples.parquet")
    manifest["complete"] = True
    manifest["counts"] = {"samples": int(len(table)), "converged": int(table["converged"].sum()),
                          "not_converged": int((~table["converged"]).sum()), "shards": len(manifest["shards"])}
    manifest["checksums"] = {"samples.parquet": _sha256(root / "samples.parquet"),
                             "omega_rad_s.npy": _sha256(root / "omega_rad_s.npy")}
    manifest["columns"] = list(table.columns)
    write_manifest(root, manifest)
    return manifest


class Dataset:
    """Read-only view of a dataset directory (pandas + numpy; arrays memory-mapped).

    Only shards recorded in ``manifest.json`` are used.
    """

    def __init__(self, root):
        self.root = Path(root)
        self.manifest = read_manifest(self.root)
        self.shards = [e for e in self.manifest["shards"]]

    @property
    def omega_rad_s(self) -> np.ndarray:
        return np.load(self.root / "omega_rad_s.npy", allow_pickle=False)

    @property
    def samples(self) -> pd.DataFrame:
        p = self.root / "samples.parquet"
        if self.manifest.get("complete") and p.exists():
            return pd.read_parquet(p)
        return pd.concat([pd.read_parquet(self.root / "shards" / e["name"] / "samples.parquet")
                          for e in self.shards], ignore_index=True)

    def shard_arrays(self, name: str, mmap: bool = True) -> list:
        """One (memory-mapped) array per complete shard, in sample order."""
        if name not in ARRAYS:
            raise FileFormatError(f"unknown array {name!r}; expected one of {sorted(ARRAYS)}")
        return [np.load(self.root / "shards" / e["name"] / f"{name}.npy", mmap_mode="r" if mmap else None,
                        allow_pickle=False) for e in self.shards]

    def array(self, name: str) -> np.ndarray:
        """Whole array over all shards (loaded into memory)."""
        parts = self.shard_arrays(name)
        return np.concatenate(parts) if parts else np.empty((0,))

    def verify(self) -> bool:
        return all(verify_shard(self.root, e) for e in self.shards)


def load_torch(root, arrays=("frf_updated",), columns=("slit1_x_m", "slit1_depth_m"), converged_only=False,
               dtype=None):
    """Torch-ready tensors: complex arrays as a trailing real/imag axis, labels as a float tensor.

    Parameters
    ----------
    root : path of the dataset directory
    arrays : names from :data:`ARRAYS`
    columns : sample-table columns stacked into ``labels`` (N, len(columns))
    converged_only : keep only samples whose updating converged in both states
    dtype : torch dtype (default float32)

    Returns
    -------
    dict of torch.Tensor
        ``{name: tensor}`` for each array plus ``"labels"`` and ``"sample_id"``.
    """
    import torch

    ds = Dataset(root)
    table = ds.samples
    keep = table["converged"].to_numpy() if converged_only else np.ones(len(table), bool)
    dt = torch.float32 if dtype is None else dtype
    out = {}
    for name in arrays:
        a = ds.array(name)[keep]
        if np.iscomplexobj(a):
            a = np.stack([a.real, a.imag], axis=-1)
        out[name] = torch.as_tensor(np.ascontiguousarray(a)).to(dt)
    out["labels"] = torch.as_tensor(np.array(table.loc[keep, list(columns)].to_numpy(dtype=float))).to(dt)
    out["sample_id"] = torch.as_tensor(np.array(table.loc[keep, "sample_id"].to_numpy()))
    return out
