"""Reading a dataset directory (:mod:`datagen.store` format): :class:`Dataset`, FRFs synthesised on read.

A reader uses only the shards listed in the manifest. Opening a dataset
checks every listed file's size (cheap); the first read of a shard in a
process checks its sha256 checksums, and a damaged shard is refused with a
one-line error. Format 1 datasets (FRFs stored in the shards) are read
(:meth:`Dataset.frf` returns the stored arrays).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from datagen.store import (ARRAYS, ARRAYS_V1, DERIVED, DATASET_FORMAT_V1, OPTIONAL, damaged_file, file_sha256,
                           foreign_shard, read_manifest)
from datagen.synth import DATASET_FRFS, SOURCES, line_index, synthesise
from physics.errors import FileFormatError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Dataset", "load_torch"]


class Dataset:
    """Read-only view of a dataset directory; FRFs synthesised on read.

    Only shards recorded in ``manifest.json`` are used. Opening checks the
    size of every shard file; the first read of a shard checks its sha256
    checksums (``verify=False`` skips both).

    Attributes
    ----------
    root : Path
    manifest : dict
    shards : list of dict           manifest entries of the complete shards, in sample order
    offsets : ndarray, shape (n_shards + 1,)   first sample row of each shard
    """

    def __init__(self, root, verify: bool = True):
        self.root = Path(root)
        self.manifest = read_manifest(self.root)
        self.legacy = self.manifest["format"] == DATASET_FORMAT_V1
        self.shards = list(self.manifest["shards"])
        self.offsets = np.concatenate([[0], np.cumsum([e["n_samples"] for e in self.shards])]).astype(np.int64)
        self._verify = verify
        self._verified = set()
        self._omega = None
        if verify:
            for e in self.shards:
                why = foreign_shard(self.manifest, e)
                if why is not None:
                    raise FileFormatError(f"{self.root / 'shards' / e['name']}: belongs to another dataset ({why}); "
                                          f"re-run the same `beam-damage generate` command to regenerate the shard")
                bad = damaged_file(self.root, e, sizes_only=True)
                if bad is not None:
                    raise FileFormatError(self._damage_message(e, bad))
            self._check_top("omega_rad_s.npy")

    def __len__(self) -> int:
        return int(self.offsets[-1])

    def _damage_message(self, entry, file):
        return (f"{self.root / 'shards' / entry['name'] / file}: missing or damaged (checksum/size mismatch); "
                f"re-run the same `beam-damage generate` command to regenerate the shard")

    def _check_top(self, name, force=False):
        """Check a top-level file (omega_rad_s.npy, samples.parquet) against the manifest's checksum, once."""
        want = self.manifest.get("checksums", {}).get(name)
        if not (self._verify or force) or want is None or name in self._verified:
            return
        try:
            ok = file_sha256(self.root / name) == want
        except OSError:
            ok = False
        if not ok:
            raise FileFormatError(f"{self.root / name}: missing or damaged (checksum mismatch with manifest.json); "
                                  f"re-run the same `beam-damage generate` command to repair it")
        self._verified.add(name)

    @property
    def omega_rad_s(self) -> np.ndarray:
        if self._omega is None:
            self._check_top("omega_rad_s.npy")
            p = self.root / "omega_rad_s.npy"
            try:
                w = np.load(p, allow_pickle=False)
            except FileNotFoundError:
                raise FileFormatError(f"{p}: missing; re-run the same `beam-damage generate` command") from None
            except (ValueError, OSError, EOFError) as exc:
                raise FileFormatError(f"{p}: not a readable .npy file ({str(exc)[:80]})") from None
            if w.ndim != 1 or w.dtype != np.float64 or w.size < 2 or not np.all(np.isfinite(w)):
                raise FileFormatError(f"{p}: expected a finite float64 vector of FRF lines (rad/s), got "
                                      f"{w.dtype} of shape {w.shape}")
            self._omega = w
        return self._omega

    @property
    def frf_dtype(self):
        return np.dtype(self.manifest["config"]["output"].get("frf_dtype", "complex64"))

    @property
    def samples(self) -> pd.DataFrame:
        """The whole samples table (see :meth:`table` for column selection)."""
        return self.table()

    def table(self, columns=None) -> pd.DataFrame:
        """Samples table, optionally only ``columns`` (read column by column from parquet)."""
        import pandas as pd  # pandas, pyarrow: only where the samples table is read
        import pyarrow.parquet as pq

        cols = None if columns is None else list(columns)
        known = self.manifest.get("columns")
        if cols is not None and known and set(cols) - set(known):
            raise FileFormatError(f"{self.root}: unknown column(s) {sorted(set(cols) - set(known))}; "
                                  f"see manifest.json 'schema.columns'")
        p = self.root / "samples.parquet"
        if self.manifest.get("complete") and p.exists():
            self._check_top("samples.parquet")
            return pq.read_table(p, columns=cols).to_pandas()
        parts = [pq.read_table(self.root / "shards" / e["name"] / "samples.parquet", columns=cols).to_pandas()
                 for e in self.shards]
        return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)

    def _check(self, i):
        if self._verify and i not in self._verified:
            bad = damaged_file(self.root, self.shards[i])
            if bad is not None:
                raise FileFormatError(self._damage_message(self.shards[i], bad))
            self._verified.add(i)

    def _load(self, i, name):
        self._check(i)
        return np.load(self.root / "shards" / self.shards[i]["name"] / f"{name}.npy", mmap_mode="r",
                       allow_pickle=False)

    def _rows(self, rows):
        if rows is None:
            return np.arange(len(self))
        r = np.atleast_1d(np.asarray(rows))
        if r.dtype == bool:
            r = np.flatnonzero(r)
        r = r.astype(np.int64)
        if r.size and (r.min() < -len(self) or r.max() >= len(self)):
            raise IndexError(f"sample rows must lie in [0, {len(self)}), got {r.min()}..{r.max()}")
        return np.where(r < 0, r + len(self), r)

    def _gather(self, names, rows):
        """``{name: array[rows]}`` over shards (rows are positions in sample order)."""
        r = self._rows(rows)
        shard = np.searchsorted(self.offsets, r, side="right") - 1
        out = {}
        for name in names:
            parts, where = [], []
            for i in np.unique(shard):
                sel = shard == i
                if name in OPTIONAL and f"{name}.npy" not in self.shards[i]["checksums"]:
                    like = self._load(i, "truth_shapes")  # (sample, state, dof, mode)
                    parts.append(np.full((int(sel.sum()),) + like.shape[1:3], OPTIONAL[name]))
                else:
                    parts.append(np.asarray(self._load(i, name)[r[sel] - self.offsets[i]]))
                where.append(np.flatnonzero(sel))
            if not parts:
                first = self._load(0, name) if self.shards else np.empty((0,))
                out[name] = np.empty((0,) + first.shape[1:], first.dtype)
                continue
            a = np.empty((r.size,) + parts[0].shape[1:], parts[0].dtype)
            for w, p in zip(where, parts):
                a[w] = p
            out[name] = a
        return out

    def shard_arrays(self, name: str) -> list:
        """One memory-mapped stored array per complete shard, in sample order."""
        stored = ARRAYS_V1 if self.legacy else ARRAYS
        if name not in stored:
            raise FileFormatError(f"array {name!r} is not stored; stored arrays: {sorted(stored)}")
        return [self._load(i, name) for i in range(len(self.shards))]

    def array(self, name: str, rows=None) -> np.ndarray:
        """Array ``name`` (stored, or derived: :data:`DERIVED`) for ``rows`` (default all), in memory."""
        if self.legacy:
            if name not in ARRAYS_V1:
                raise FileFormatError(f"unknown array {name!r}; a format-1 dataset has {sorted(ARRAYS_V1)}")
            return self._gather([name], rows)[name]
        if name in ARRAYS:
            return self._gather([name], rows)[name]
        if name in ("eigenvalues_true", "eigenvectors_true"):
            src = "truth_poles" if name == "eigenvalues_true" else "truth_shapes"
            used = self.manifest.get("layout", {}).get("modes_idx", [0, 1, 2, 3])
            a = self._gather([src], rows)[src][..., used]
            return a if name == "eigenvalues_true" else a[..., :self._n_responses, :]
        if name in ("frf_measured", "frf_updated"):
            return self.frf(name[4:], rows)
        raise FileFormatError(f"unknown array {name!r}; expected one of {sorted(ARRAYS) + sorted(DERIVED)}")

    @property
    def _n_responses(self) -> int | None:
        """Measured DOFs (rows of ``truth_shapes`` before the reference DOF's, when it is no sensor); None (every
        row) for datasets that do not name them."""
        return len(self.manifest.get("schema", {}).get("measured_dofs", ())) or None

    @property
    def updating(self) -> str:
        """What the dataset's Lancaster/Pilkey update uses, in one sentence ("" for datasets that predate it)."""
        return self.manifest.get("layout", {}).get("updating", "")

    @property
    def has_updated_model(self) -> bool:
        """False when the test holds fewer modes than sensors, so no updated model (nor its FRFs) exists
        (:attr:`datagen.setup.Setup.n_update`); datasets that predate ``layout`` are the thesis's test."""
        layout = self.manifest.get("layout")
        return not layout or len(layout["modes"]) >= len(layout["sensors_x_m"])

    def frf(self, kind: str, rows=None, out=None, lines=None) -> np.ndarray:
        """FRFs of ``kind`` ("measured" | "updated"), complex, shape (n, 2 states, 4 dofs, L).

        Synthesised from the stored arrays (:mod:`datagen.synth`), identical
        to what ``generate --store-frf`` writes. Format-1 datasets return their stored FRFs.
        ``lines``: optional indices into :attr:`omega_rad_s` (default all, L = F); only those lines are
        synthesised, with exactly their values in the full FRF (noise included), e.g. the lines a
        feature grid interpolates from.
        ``out``: optional C-contiguous complex array of that shape written in place (e.g. shared memory).
        """
        if kind not in DATASET_FRFS:
            raise FileFormatError(f"FRF kind {kind!r} unknown; expected one of {', '.join(DATASET_FRFS)}")
        if kind == "updated" and not self.has_updated_model:
            raise FileFormatError(f"{self.root}: {self.updating}")
        if self.legacy:
            H = self._gather([f"frf_{kind}"], rows)[f"frf_{kind}"]
            H = H if lines is None else H[..., line_index(lines, H.shape[-1])]
            if out is None:
                return H
            out[...] = H
            return out
        arrays = self._gather(SOURCES[kind], rows)
        schema = self.manifest.get("schema", {})
        arrays["drive_row"] = schema.get("frf_reference_row", 0)
        arrays["update_drive_row"] = schema.get("updated_reference_row", arrays["drive_row"])
        arrays["n_responses"] = self._n_responses
        return synthesise(kind, arrays, self.omega_rad_s, self.frf_dtype, out, lines)

    def verify_or_raise(self) -> None:
        """Check every file's sha256 checksum (shards, omega_rad_s.npy, samples.parquet); damage raises one line."""
        for name in ("omega_rad_s.npy", "samples.parquet"):
            self._check_top(name, force=True)
        for i, e in enumerate(self.shards):
            if i not in self._verified:
                bad = damaged_file(self.root, e)
                if bad is not None:
                    raise FileFormatError(self._damage_message(e, bad))
                self._verified.add(i)

    def verify(self) -> bool:
        """Full check: every shard file and the top-level files against their sha256 checksums."""
        try:
            self.verify_or_raise()
        except FileFormatError:
            return False
        return True


def load_torch(root, arrays=("frf_updated",), columns=("damage0_x_m", "damage0_size"), converged_only=False,
               dtype=None):
    """Torch-ready tensors of a whole dataset: complex arrays with a trailing real/imag axis, labels as floats.

    Parameters
    ----------
    root : path of the dataset directory
    arrays : names from :data:`ARRAYS` or :data:`DERIVED`
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
    table = ds.table(list(columns) + ["sample_id", "converged"])
    keep = table["converged"].to_numpy() if converged_only else np.ones(len(table), bool)
    dt = torch.float32 if dtype is None else dtype
    out = {}
    for name in arrays:
        a = ds.array(name, np.flatnonzero(keep))
        if np.iscomplexobj(a):
            a = np.stack([a.real, a.imag], axis=-1)
        out[name] = torch.as_tensor(np.ascontiguousarray(a)).to(dt)
    out["labels"] = torch.as_tensor(np.array(table.loc[keep, list(columns)].to_numpy(dtype=float))).to(dt)
    out["sample_id"] = torch.as_tensor(np.array(table.loc[keep, "sample_id"].to_numpy()))
    return out
