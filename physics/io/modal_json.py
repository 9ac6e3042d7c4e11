"""Modal-data JSON: read, validate and write :class:`~physics.io.types.ModalData`.

One object with the keys of a beam state in the thesis fixture ``beams.json``::

    {"natural_frequencies_hz": [f1, ...],            # optional if eigenvalues given
     "damping_ratios": [z1, ...],                    # optional if eigenvalues given
     "eigenvalues": ["-0.21962+135.31j", ...],       # complex strings, upper half-plane
     "eigenvectors": [["0.72+15.0j", ...], ...],     # rows = measured DOFs, cols = modes
     "dofs": ["2:y", "3:y", ...]}                    # optional labels of the rows

Eigenvalues follow the package's conjugate-pair convention: one eigenvalue of
each pair, ``lambda_j = -zeta_j*omega_j + i*omega_j*sqrt(1 - zeta_j**2)``; the
partner is its complex conjugate with the conjugate eigenvector. When only
frequencies and damping ratios are given, the eigenvalues are built from them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from physics.errors import FileFormatError
from physics.io.atomic import atomic_write_text
from physics.io.types import ModalData, format_complex
from physics.modal import eigenvalues_from_modal

__all__ = ["modal_data_from_dict", "modal_data_to_dict", "read_modal_json", "write_modal_json"]

def _complex_array(values, path, key, ndim):
    try:
        arr = np.array(
            [[complex(str(v).replace(" ", "").replace("i", "j")) for v in row] for row in values]
            if ndim == 2
            else [complex(str(v).replace(" ", "").replace("i", "j")) for v in values],
            dtype=complex,
        )
    except (TypeError, ValueError):
        form = "a list of lists of complex strings such as \"0.72+15.0j\"" if ndim == 2 else \
            "a list of complex strings such as \"-0.22+135.3j\""
        raise FileFormatError(f"{path}: field '{key}' must be {form}") from None
    if arr.ndim != ndim or not np.all(np.isfinite(arr)):
        raise FileFormatError(f"{path}: field '{key}' must be a finite {ndim}-D array")
    return arr


def modal_data_from_dict(obj: dict, source="modal data") -> ModalData:
    """Validate a modal-data mapping (see module docstring) into :class:`ModalData`."""
    if not isinstance(obj, dict):
        raise FileFormatError(f"{source}: expected a JSON object with 'eigenvalues' or "
                              "'natural_frequencies_hz' and 'damping_ratios'")
    if "eigenvalues" in obj:
        lam = _complex_array(obj["eigenvalues"], source, "eigenvalues", 1)
    elif "natural_frequencies_hz" in obj and "damping_ratios" in obj:
        try:
            f = np.asarray(obj["natural_frequencies_hz"], dtype=float)
            z = np.asarray(obj["damping_ratios"], dtype=float)
        except (TypeError, ValueError):
            raise FileFormatError(f"{source}: 'natural_frequencies_hz' and 'damping_ratios' "
                                  "must be lists of numbers") from None
        if f.shape != z.shape or f.ndim != 1 or not (np.all(np.isfinite(f)) and np.all(np.isfinite(z))):
            raise FileFormatError(f"{source}: 'natural_frequencies_hz' and 'damping_ratios' must be "
                                  "finite lists of equal length")
        if np.any(z >= 1) or np.any(f <= 0):
            raise FileFormatError(f"{source}: 'damping_ratios' must be < 1 and frequencies > 0 "
                                  "(underdamped modes)")
        lam = eigenvalues_from_modal(f, z)
    else:
        raise FileFormatError(f"{source}: missing key 'eigenvalues' (or 'natural_frequencies_hz' "
                              "with 'damping_ratios')")
    vecs = None
    if obj.get("eigenvectors") is not None:
        vecs = _complex_array(obj["eigenvectors"], source, "eigenvectors", 2)
        if vecs.shape[1] != lam.size:
            raise FileFormatError(f"{source}: field 'eigenvectors' has {vecs.shape[1]} columns "
                                  f"but there are {lam.size} eigenvalues (columns are modes)")
    dofs = tuple(str(d) for d in obj.get("dofs", ()))
    if dofs and vecs is not None and len(dofs) != vecs.shape[0]:
        raise FileFormatError(f"{source}: field 'dofs' has {len(dofs)} labels but "
                              f"'eigenvectors' has {vecs.shape[0]} rows")
    return ModalData(lam, vecs, dofs)


def read_modal_json(path) -> ModalData:
    """Read a modal-data JSON file (see module docstring)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    return modal_data_from_dict(obj, str(path))


def modal_data_to_dict(data: ModalData) -> dict:
    """Inverse of :func:`modal_data_from_dict` (complex values as strings)."""
    fmt = format_complex
    out = {
        "natural_frequencies_hz": data.natural_frequencies_hz.tolist(),
        "damping_ratios": data.damping_ratios.tolist(),
        "eigenvalues": [fmt(z) for z in data.eigenvalues],
    }
    if data.eigenvectors is not None:
        out["eigenvectors"] = [[fmt(z) for z in row] for row in data.eigenvectors]
    if data.dofs:
        out["dofs"] = list(data.dofs)
    return out


def write_modal_json(path, data: ModalData) -> None:
    """Write :class:`ModalData` as modal-data JSON, atomically."""
    atomic_write_text(path, json.dumps(modal_data_to_dict(data), indent=1) + "\n")

