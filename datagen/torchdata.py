"""PyTorch access to a dataset: FRFs synthesised in the ``DataLoader`` workers, a batch at a time.

``FRFDataset`` is a map-style dataset whose ``__getitems__`` returns a whole
batch (one vectorised synthesis per batch instead of one call per sample);
:func:`make_loader` wires it into a ``torch.utils.data.DataLoader`` with an
identity collate. Each worker opens the dataset itself (nothing large is
pickled). Every shard's checksums are verified once, when the dataset object
is made in the main process: a damaged shard is refused there with a one-line
:class:`physics.errors.FileFormatError`, before any worker starts.
FRFs are deterministic per sample (counter-based noise), so batches do not
depend on the number of workers or the order of reading.
"""

from __future__ import annotations

import numpy as np
import torch

from datagen.dataset import Dataset
from datagen.synth import DATASET_FRFS, log_magnitude_map
from physics.errors import BeamDamageError

__all__ = ["FEATURES", "FRFDataset", "frf_to_real", "make_loader"]

FEATURES = ("complex", "log_magnitude")


def frf_to_real(H, features: str = "complex") -> np.ndarray:
    """Real-valued network inputs from complex FRFs (..., F).

    ``"complex"``: real and imaginary parts on a trailing axis (..., F, 2) (m/N).
    ``"log_magnitude"``: ``log10 |H|`` (..., F) (log10 of m/N).
    """
    if features == "complex":
        if H.dtype in (np.complex64, np.complex128) and H.flags.c_contiguous:  # (re, im) pairs in memory: a view
            return H.view(np.float32 if H.dtype == np.complex64 else np.float64).reshape(H.shape + (2,))
        return np.stack([H.real, H.imag], axis=-1)
    if features == "log_magnitude":
        with np.errstate(divide="ignore"):
            return np.log10(np.abs(H))
    raise BeamDamageError(f"features {features!r} unknown; expected one of {FEATURES}")


class FRFDataset(torch.utils.data.Dataset):
    """Samples of a dataset directory as tensors: FRFs of ``kind`` and label columns.

    Parameters
    ----------
    root : path of the dataset directory
    kind : "measured" | "updated"
    columns : sample-table columns returned as ``labels`` (float32), in this order
    rows : optional subset of sample rows (e.g. a split by specimen)
    features : see :func:`frf_to_real`
    dtype : torch dtype of the FRF features (default float32)
    weights : optional array (G, F)
        A linear map of ``log10 |H|`` over the F lines (e.g. ``learn.network.features.grid_weights``: the
        classifier's log-frequency grid); only the lines it uses are synthesised
        (:func:`datagen.synth.log_magnitude_map`). Needs ``features="log_magnitude"``.

    Items are dicts: ``frf`` (2, 4, F, 2), (2, 4, F) or (2, 4, G), ``labels`` (len(columns),), ``sample_id``.
    """

    def __init__(self, root, kind="updated", columns=(), rows=None, features="complex", dtype=torch.float32,
                 weights=None):
        if kind not in DATASET_FRFS:
            raise BeamDamageError(f"FRF kind {kind!r} unknown; expected one of {DATASET_FRFS}")
        frf_to_real(np.zeros(1, complex), features)
        if weights is not None and features != "log_magnitude":
            raise BeamDamageError("weights map log-magnitudes: use features='log_magnitude'")
        self.root, self.kind, self.features, self.dtype, self.weights = root, kind, features, dtype, weights
        ds = Dataset(root)
        ds.verify_or_raise()
        self.rows = np.arange(len(ds)) if rows is None else np.asarray(rows, np.int64)
        table = ds.table(["sample_id", *columns])
        self.sample_id = table["sample_id"].to_numpy()[self.rows]
        self.labels = table[list(columns)].to_numpy(dtype=np.float32)[self.rows]
        if weights is not None and (np.ndim(weights) != 2 or np.shape(weights)[1] != ds.omega_rad_s.size):
            raise BeamDamageError(f"weights must have shape (G, {ds.omega_rad_s.size}), got {np.shape(weights)}")
        self._ds = self._map = None

    def __len__(self):
        return self.rows.size

    def __getstate__(self):  # workers reopen the dataset themselves
        return {**self.__dict__, "_ds": None, "_map": None}

    def __getitems__(self, indices):
        if self._ds is None:
            self._ds = Dataset(self.root, verify=False)  # verified in __init__
        idx = np.asarray(indices, np.int64)
        if self.weights is not None:
            if self._map is None:
                self._map = log_magnitude_map(self.weights)
            lines, apply = self._map
            frf = torch.from_numpy(apply(self._ds.frf(self.kind, self.rows[idx], lines=lines))).to(self.dtype)
        elif self.features == "complex" and self.dtype == torch.float32 and self._ds.frf_dtype == np.complex64:
            frf = _frf_buffer((idx.size, 2, 4, self._ds.omega_rad_s.size, 2))
            self._ds.frf(self.kind, self.rows[idx], out=frf.numpy().view(np.complex64)[..., 0])
        else:
            H = self._ds.frf(self.kind, self.rows[idx])
            frf = torch.from_numpy(np.ascontiguousarray(frf_to_real(H, self.features))).to(self.dtype)
        return {"frf": frf,
                "labels": torch.from_numpy(self.labels[idx]), "sample_id": torch.from_numpy(self.sample_id[idx])}

    def __getitem__(self, i):
        return {k: v[0] for k, v in self.__getitems__([i]).items()}


def _frf_buffer(shape) -> torch.Tensor:
    """An uninitialised float32 tensor to synthesise a batch into: in shared memory inside a
    ``DataLoader`` worker, so sending it to the main process copies nothing (``share_memory_`` on a
    finished batch costs about twice its synthesis)."""
    new_shared = getattr(torch.UntypedStorage, "_new_shared", None)
    if torch.utils.data.get_worker_info() is None or new_shared is None:
        return torch.empty(shape, dtype=torch.float32)
    storage = new_shared(int(np.prod(shape)) * 4)
    return torch.empty(0, dtype=torch.float32).set_(storage).view(shape)


def _batch_as_is(batch):
    return batch


def make_loader(root, kind="updated", columns=(), rows=None, batch_size=256, shuffle=False, num_workers=0,
                seed=0, features="complex", weights=None, **kwargs) -> torch.utils.data.DataLoader:
    """A ``DataLoader`` over :class:`FRFDataset` yielding batched dicts; FRFs synthesised in the workers.

    ``seed`` seeds the shuffling (reproducible epochs). ``features`` and ``weights``: see
    :class:`FRFDataset`. Extra keyword arguments go to ``DataLoader``.
    """
    ds = FRFDataset(root, kind, columns, rows, features, weights=weights)
    gen = torch.Generator().manual_seed(seed)
    return torch.utils.data.DataLoader(ds, batch_size=batch_size, shuffle=shuffle, num_workers=num_workers,
                                       collate_fn=_batch_as_is, generator=gen,
                                       persistent_workers=num_workers > 0, **kwargs)
