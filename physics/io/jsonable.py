"""JSON-ready values of results (numpy arrays and scalars, complex numbers), for ``--json`` and the JSON files
the workflows and commands write."""

from __future__ import annotations

import numpy as np

from physics.io.types import format_complex

__all__ = ["finite_or_none", "floats_or_nan", "to_jsonable"]


def to_jsonable(obj):
    """Convert numpy arrays/scalars and complex numbers into JSON-ready values.

    Complex numbers become strings such as ``"-0.21962+135.31j"`` (the form of
    the thesis fixtures), arrays become nested lists. A lone surrogate (a file name that is not UTF-8, as
    ``os.fsdecode`` gives it) is written as the text ``\\udcXX``, so the output is valid UTF-8.
    """
    if isinstance(obj, str):
        return obj.encode("utf-8", "backslashreplace").decode("utf-8")
    if isinstance(obj, dict):
        return {to_jsonable(str(k)): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (complex, np.complexfloating)):
        return format_complex(complex(obj))
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return finite_or_none(obj)
    return obj


def finite_or_none(v) -> float | None:
    """``v`` as a float, None for NaN or inf (JSON has neither)."""
    v = float(v)
    return v if np.isfinite(v) else None


def floats_or_nan(values) -> np.ndarray:
    """A JSON list of numbers back as floats (shape (k,)), NaN for None: the inverse of :func:`finite_or_none`."""
    return np.array([np.nan if v is None else v for v in values], float)
