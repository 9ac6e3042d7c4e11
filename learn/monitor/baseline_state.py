"""The baseline period's held-out statistics kept as JSON next to the identification cache: a rerun whose
baseline tests, conditions and normal model are unchanged (a new test appended to the series) reuses them instead
of refitting the model once per baseline test (120 leave-one-out fits of the mixture take over a minute)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from learn.monitor.statistics import held_out_statistics
from physics.io import atomic_write_text

__all__ = ["STATE_FORMAT", "baseline_key", "held_out_cached"]

#: Format tag of a saved baseline state (a change of the held-out procedure or of the models changes it).
STATE_FORMAT = "beam-damage-monitor-baseline/6"


def baseline_key(model, Xb, Cb=None) -> str:
    """SHA-256 of :data:`STATE_FORMAT`, the normal model's class and its choices (an unfitted ``with_choices()``
    copy's parameters) and the baseline's features ``Xb`` (n, p) and conditions ``Cb`` (n, q) bit for bit."""
    h = hashlib.sha256()
    choice = model.with_choices()
    params = {k: v for k, v in sorted(vars(choice).items()) if isinstance(v, (int, float, str, type(None)))}
    h.update(json.dumps([STATE_FORMAT, type(model).__name__, params], sort_keys=True).encode())
    for A in (Xb, Cb):
        if A is not None:
            A = np.ascontiguousarray(A, dtype=np.float64)
            h.update(str(A.shape).encode())
            h.update(A.tobytes())
    return h.hexdigest()


def held_out_cached(model, Xb, Cb=None, cache_dir=None) -> dict:
    """:func:`learn.monitor.statistics.held_out_statistics` of the baseline ``Xb`` (``Cb``): name -> (values (n,),
    whitened vectors (n, d) or None), read from ``cache_dir/baseline/<key>.json`` (:func:`baseline_key`) when the
    same baseline and model were judged before, else computed and written there atomically. Without ``cache_dir``:
    computed."""
    if cache_dir is None:
        return held_out_statistics(model.with_choices, Xb, Cb)
    path = Path(cache_dir) / "baseline" / f"{baseline_key(model, Xb, Cb)}.json"
    if path.is_file():
        try:
            d = json.loads(path.read_text())
            if d.get("format") == STATE_FORMAT and d.get("baseline_tests") == len(Xb):
                return {nm: (np.array(v["values"], float),
                             None if v["vectors"] is None else np.array(v["vectors"], float))
                        for nm, v in d["held_out"].items()}
        except (ValueError, KeyError, TypeError, AttributeError):
            pass                                        # a damaged state: computed again
    held = held_out_statistics(model.with_choices, Xb, Cb)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps({"format": STATE_FORMAT, "model": type(model).__name__,
                                        "baseline_tests": len(Xb),
                                        "held_out": {nm: {"values": _list(v),
                                                          "vectors": None if w is None else _list(w)}
                                                     for nm, (v, w) in held.items()}}))
    return held


def _list(a) -> list:
    """An array as JSON lists, non-finite entries as NaN."""
    a = np.asarray(a, float)
    return np.where(np.isfinite(a), a, np.nan).tolist() if a.ndim else float(a)
