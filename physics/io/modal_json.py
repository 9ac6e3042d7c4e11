"""Modal-data JSON: read, validate and write :class:`~physics.io.types.ModalData`.

One object with the keys of a beam state in the thesis fixture ``beams.json``::

    {"natural_frequencies_hz": [f1, ...],            # optional if eigenvalues given (then the same modes)
     "damping_ratios": [z1, ...],                    # optional (0 without: natural frequencies alone)
     "eigenvalues": ["-0.21962+135.31j", ...],       # complex strings, upper half-plane
     "eigenvectors": [["0.72+15.0j", ...], ...],     # rows = measured DOFs, cols = modes
     "dofs": ["2:y", "3:y", ...]}                    # optional labels of the rows

An eigenvector entry ``null`` is a DOF not measured for that mode (a mode of ``identify --setup`` found in only
some setups, listed in ``partial_modes``): it is written so, and refused on reading, naming the row and column
(updating and classification need every mode at every DOF; drop the mode's column or the DOF's row).

Eigenvalues follow the package's conjugate-pair convention: one eigenvalue of
each pair, ``lambda_j = -zeta_j*omega_j + i*omega_j*sqrt(1 - zeta_j**2)``; the
partner is its complex conjugate with the conjugate eigenvector. When only
frequencies and damping ratios are given, the eigenvalues are built from them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from physics.io.inputs import check_input_file
from physics.errors import FileFormatError
from physics.io.atomic import atomic_write_text
from physics.io.types import MAX_MAGNITUDE, ModalData, format_complex
from physics.modal import eigenvalues_from_modal

__all__ = ["modal_data_from_dict", "modal_data_to_dict", "number_list", "read_json", "read_modal_json",
           "write_modal_json"]

#: Largest modal-data JSON file read (bytes).
MAX_JSON_BYTES = 64 * 2**20
#: Smallest modulus of an eigenvalue (rad/s), natural frequency (Hz) or mode shape's largest entry accepted
#: (below it reciprocals and squares leave the floating-point range).
MIN_EIGENVALUE = 1e-100


def _complex_array(values, path, key, ndim):
    rows = values if ndim == 2 and isinstance(values, list) else [values]
    bad = next((k for k, row in enumerate(rows) if not isinstance(row, list)), None)
    if bad is not None:  # a string row would be read character by character
        where = f"row {bad + 1} is a {type(rows[bad]).__name__}" if ndim == 2 and isinstance(values, list) \
            else f"is a {type(values).__name__}"
        form = "a list of lists (one per measured DOF) of complex strings such as \"0.72+15.0j\"" if ndim == 2 \
            else "a list of complex strings such as \"-0.22+135.3j\""
        raise FileFormatError(f"{path}: field '{key}' {where}; expected {form}")
    gap = next(((r, c) for r, row in enumerate(rows) for c, v in enumerate(row) if v is None), None)
    if gap is not None:
        where = f"row {gap[0] + 1}, column {gap[1] + 1}" if ndim == 2 else f"entry {gap[1] + 1}"
        raise FileFormatError(f"{path}: field '{key}' {where} is null: a DOF not measured for that mode (a mode "
                              "found in only some setups of 'identify --setup'); drop the mode's column or the "
                              "DOF's row to use the file here")
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
    if arr.size and np.max(np.abs(arr)) > MAX_MAGNITUDE:
        raise FileFormatError(f"{path}: field '{key}' has values of magnitude {np.max(np.abs(arr)):.3g}, beyond "
                              f"the {MAX_MAGNITUDE:g} this package accepts")
    return arr


def number_list(values, path, key):
    """A list of finite real numbers (JSON numbers, not booleans) as a 1-D float array."""
    if not (isinstance(values, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                             for v in values)):
        raise FileFormatError(f"{path}: field '{key}' must be a list of numbers, one per mode")
    arr = np.array(values, dtype=float)
    if not np.all(np.isfinite(arr)) or (arr.size and np.max(np.abs(arr)) > MAX_MAGNITUDE):
        raise FileFormatError(f"{path}: field '{key}' must hold finite numbers of magnitude <= {MAX_MAGNITUDE:g}")
    return arr


def _check_beside_eigenvalues(obj: dict, lam: np.ndarray, source) -> None:
    """Refuse ``natural_frequencies_hz`` or ``damping_ratios`` given beside the eigenvalues that are no finite
    numbers, one per eigenvalue, or that disagree with them: a frequency more than 1 % from both ``|lambda| / 2 pi``
    and the damped ``Im lambda / 2 pi`` (tools write either), a damping ratio more than 0.005 from ``-Re lambda /
    |lambda|``: the file holds two different answers, and the eigenvalues would be read silently."""
    w = np.abs(lam)
    expected = {"natural_frequencies_hz": (w / (2 * np.pi), lam.imag / (2 * np.pi)),
                "damping_ratios": (-lam.real / w,)}
    for key, options in expected.items():
        if key not in obj:
            continue
        v = number_list(obj[key], source, key)
        if v.size != lam.size:
            raise FileFormatError(f"{source}: field {key!r} has {v.size} entries for {lam.size} eigenvalues; "
                                  "expected one per mode (or leave it out)")
        off = np.min([np.abs(v - o) / (np.abs(o) if key == "natural_frequencies_hz" else 1.0) for o in options],
                     axis=0)
        bad = np.flatnonzero(off > (0.01 if key == "natural_frequencies_hz" else 0.005))
        if bad.size:
            k = int(bad[0])
            raise FileFormatError(f"{source}: field {key!r} entry {k + 1} is {v[k]:.6g}, but eigenvalue {k + 1} "
                                  f"({lam[k]:.6g}) gives {options[0][k]:.6g}; expected the same modes (or leave "
                                  f"{key!r} out)")


def modal_data_from_dict(obj: dict, source="modal data") -> ModalData:
    """Validate a modal-data mapping (see module docstring) into :class:`ModalData`."""
    if not isinstance(obj, dict):
        raise FileFormatError(f"{source}: expected a JSON object with 'eigenvalues' or "
                              "'natural_frequencies_hz' and 'damping_ratios'")
    if "eigenvalues" in obj:
        if not isinstance(obj["eigenvalues"], list):
            raise FileFormatError(f"{source}: field 'eigenvalues' must be a list of complex strings")
        lam = _complex_array(obj["eigenvalues"], source, "eigenvalues", 1)
        if lam.size and np.min(np.abs(lam)) < MIN_EIGENVALUE:
            k = int(np.argmin(np.abs(lam)))
            raise FileFormatError(f"{source}: field 'eigenvalues' entry {k + 1} ({lam[k]:.6g}) has modulus below "
                                  f"{MIN_EIGENVALUE:g} rad/s; expected eigenvalues in rad/s such as \"-0.22+135.3j\"")
        if np.any(lam.imag <= 0):
            k = int(np.nonzero(lam.imag <= 0)[0][0])
            raise FileFormatError(f"{source}: field 'eigenvalues' entry {k + 1} ({lam[k]:.6g}) is not in the upper "
                                  "half-plane; give the Im > 0 member of each conjugate pair")
        _check_beside_eigenvalues(obj, lam, source)

    elif "natural_frequencies_hz" in obj:
        f = number_list(obj["natural_frequencies_hz"], source, "natural_frequencies_hz")
        z = (number_list(obj["damping_ratios"], source, "damping_ratios") if "damping_ratios" in obj
             else np.zeros(f.size))   # natural frequencies alone
        if f.shape != z.shape:
            raise FileFormatError(f"{source}: 'natural_frequencies_hz' has {f.size} entries but 'damping_ratios' "
                                  f"has {z.size}; expected one of each per mode")
        if not np.all(np.abs(z) < 1):
            k = int(np.nonzero(~(np.abs(z) < 1))[0][0])
            raise FileFormatError(f"{source}: field 'damping_ratios' entry {k + 1} is {z[k]:g}; expected "
                                  "-1 < zeta < 1 (underdamped modes)")
        if not np.all(f >= MIN_EIGENVALUE):
            k = int(np.nonzero(~(f >= MIN_EIGENVALUE))[0][0])
            raise FileFormatError(f"{source}: field 'natural_frequencies_hz' entry {k + 1} is {f[k]:g}; expected "
                                  f"a frequency >= {MIN_EIGENVALUE:g} Hz")
        lam = eigenvalues_from_modal(f, z)
    else:
        raise FileFormatError(f"{source}: missing key 'eigenvalues' (or 'natural_frequencies_hz', "
                              "optionally with 'damping_ratios')")
    vecs = None
    if obj.get("eigenvectors") is not None:
        vecs = _complex_array(obj["eigenvectors"], source, "eigenvectors", 2)
        if vecs.shape[1] != lam.size:
            raise FileFormatError(f"{source}: field 'eigenvectors' has {vecs.shape[1]} columns "
                                  f"but there are {lam.size} eigenvalues (columns are modes)")
        zero_rows = np.nonzero(~np.any(vecs != 0, axis=1))[0]
        zero_cols = np.nonzero(~np.any(vecs != 0, axis=0))[0]
        if zero_rows.size or zero_cols.size:
            what = f"row {zero_rows[0] + 1}" if zero_rows.size else f"column {zero_cols[0] + 1}"
            raise FileFormatError(f"{source}: field 'eigenvectors' {what} is zero; every measured DOF and mode "
                                  "needs a non-zero entry")
        peak = np.max(np.abs(vecs), axis=0)
        if np.any(peak < MIN_EIGENVALUE):
            k = int(np.argmin(peak))
            raise FileFormatError(f"{source}: field 'eigenvectors' column {k + 1} has largest modulus {peak[k]:.3g}, "
                                  f"below {MIN_EIGENVALUE:g}; a mode shape may have any scale above it")

    if lam.size != np.unique(lam).size:
        _, first = np.unique(lam, return_index=True)
        k = sorted(set(range(lam.size)) - set(first.tolist()))[0]
        raise FileFormatError(f"{source}: field 'eigenvalues' entry {k + 1} repeats an earlier eigenvalue "
                              f"({lam[k]:.6g}); each mode must appear once")
    dofs = obj.get("dofs", ())
    if not isinstance(dofs, (list, tuple)):
        raise FileFormatError(f"{source}: field 'dofs' must be a list of labels such as \"2:y\"")
    dofs = tuple(str(d) for d in dofs)
    if dofs and vecs is not None and len(dofs) != vecs.shape[0]:
        raise FileFormatError(f"{source}: field 'dofs' has {len(dofs)} labels but "
                              f"'eigenvectors' has {vecs.shape[0]} rows")
    return ModalData(lam, vecs, dofs)


def read_json(path, max_bytes: int = MAX_JSON_BYTES, require_object: bool = True):
    """The value of a JSON file; a file that is too large, not UTF-8, not JSON, nested too deeply or (with
    ``require_object``) not an object raises a one-line :class:`FileFormatError` naming it.

    A missing file raises ``FileNotFoundError`` (callers say what the file should have been).
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        raise FileNotFoundError(2, "No such file or directory", str(path))
    check_input_file(path, "json", what="a JSON file")
    try:
        if path.stat().st_size > max_bytes:
            raise FileFormatError(f"{path}: {path.stat().st_size} bytes, more than the {max_bytes} this JSON "
                                  "file may hold")
        obj = json.loads(path.read_bytes().decode("utf-8"))
    except IsADirectoryError:
        raise FileFormatError(f"{path}: is a directory, expected a JSON file") from None
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{path}: not UTF-8 text (byte {exc.start}); expected a JSON object") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except RecursionError:
        raise FileFormatError(f"{path}: JSON nested too deeply; expected a flat object") from None
    if require_object and not isinstance(obj, dict):
        raise FileFormatError(f"{path}: expected a JSON object, got a {type(obj).__name__}")
    return obj


def read_modal_json(path) -> ModalData:
    """Read a modal-data JSON file (see module docstring)."""
    try:
        obj = read_json(path, require_object=False)
    except FileNotFoundError:
        raise FileFormatError(f"{path}: file not found") from None
    return modal_data_from_dict(obj, str(path))


def modal_data_to_dict(data: ModalData) -> dict:
    """Inverse of :func:`modal_data_from_dict` (complex values as strings; a NaN eigenvector entry as null)."""
    def fmt(z):
        return format_complex(z) if np.isfinite(z) else None
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

