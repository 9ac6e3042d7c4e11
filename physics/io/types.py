"""Data types of measured and modal data: :class:`MeasuredFRF`, :class:`ModalData`, DOF labels.

Measured FRFs
-------------
:class:`MeasuredFRF` holds an FRF matrix ``(n_resp, n_ref, n_lines)`` with its
frequency axis (Hz), DOF labels ``"NODE:+DIR"`` and kind (receptance, mobility,
accelerance), always in SI units once read (readers convert).

Complex modes follow the package's conjugate-pair convention (see
:mod:`physics.modal`): one eigenvalue of each pair, ``Im > 0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from physics.errors import FileFormatError, ShapeError
from physics.frf import FRF_KINDS, FRF_UNITS, check_frf_kind, convert_frf
from physics.modal import EigenvalueParameters

__all__ = ["DEFAULT_UNITS", "FRF_KINDS", "MAX_MAGNITUDE", "UNNAMED_REFERENCE", "MeasuredFRF", "ModalData",
           "check_dof_labels", "dof_label", "format_complex", "frf_matrix", "parse_dof"]

#: Largest magnitude a reader accepts in a file's numbers (beyond it products and spectra overflow).
MAX_MAGNITUDE = 1e100


@dataclass(frozen=True)
class ModalData(EigenvalueParameters):
    """Measured or computed complex modal data.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n_modes,)
        One eigenvalue of each conjugate pair (rad/s), ``Im > 0``.
    eigenvectors : ndarray, complex, shape (n_dofs, n_modes) or None
        Complex mode shapes, columns are modes.
    dofs : tuple of str
        Labels of the rows of ``eigenvectors`` (may be empty).
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray | None
    dofs: tuple = ()

    def with_positive_directions(self) -> "ModalData":
        """The same modes on the positive sense of every DOF (rows labelled ``"3:-Y"`` negated, made ``"3:+Y"``)."""
        signs = _direction_signs(self.dofs)
        if self.eigenvectors is None or np.all(signs > 0):
            return self
        return replace(self, eigenvectors=self.eigenvectors * signs[:, None], dofs=_positive_labels(self.dofs, signs))


def format_complex(z: complex) -> str:
    """Complex number as ``"a+bj"`` with 17 significant digits (round-trips ``complex()``)."""
    z = complex(z)
    return f"{z.real:.17g}{z.imag:+.17g}j"


# ---------------------------------------------------------------------------
# Measured FRFs
# ---------------------------------------------------------------------------

#: SI units of each kind (the name physics.io always had for :data:`physics.frf.FRF_UNITS`).
DEFAULT_UNITS = FRF_UNITS

_DIRECTIONS = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
_DIRECTION_CODES = {v: k for k, v in _DIRECTIONS.items()}


def dof_label(node: int, direction: int) -> str:
    """Label ``"node:+Y"`` of a UFF node and direction code (1..6 = X, Y, Z, RX, RY, RZ; sign = sense)."""
    node, direction = int(node), int(direction)
    if direction == 0:
        return f"{node}:S"  # scalar DOF
    if abs(direction) not in _DIRECTIONS:
        raise FileFormatError(f"direction code {direction} is not one of 0, +-1..+-6")
    return f"{node}:{'+' if direction > 0 else '-'}{_DIRECTIONS[abs(direction)]}"


def parse_dof(label: str) -> tuple[int, int]:
    """Inverse of :func:`dof_label`: ``"2:+Y"`` (or ``"2:y"``, ``"2:-RZ"``, ``"2:S"``) -> ``(2, 2)``."""
    text = str(label).strip()
    node, sep, direction = text.partition(":")
    try:
        node_i = int(node)
    except ValueError:
        node_i = None
    direction = direction.strip().upper()
    sign = -1 if direction.startswith("-") else 1
    direction = direction.lstrip("+-")
    if not sep or node_i is None or (direction not in _DIRECTION_CODES and direction != "S"):
        raise FileFormatError(f"DOF label {label!r} must look like 'NODE:+DIR' with an integer node "
                              "and DIR one of X, Y, Z, RX, RY, RZ (e.g. '2:+Y')")
    return node_i, (0 if direction == "S" else sign * _DIRECTION_CODES[direction])


def _direction_signs(labels) -> np.ndarray:
    """+1 or -1 per DOF label: the sense of its direction (+1 for a label that is not ``NODE:DIR``)."""
    out = []
    for label in labels:
        try:
            out.append(-1.0 if parse_dof(label)[1] < 0 else 1.0)
        except FileFormatError:
            out.append(1.0)
    return np.array(out)


def _positive_labels(labels, signs) -> tuple:
    """Labels whose sign (:func:`_direction_signs`) is negative made positive (``"3:-Y"`` -> ``"3:+Y"``)."""
    return tuple(str(d).replace(":-", ":+", 1) if s < 0 else str(d) for d, s in zip(labels, signs))


#: Reference label of single-reference FRFs whose file does not name the reference DOF (CSV ``re(2:+Y)``).
UNNAMED_REFERENCE = "ref"


def check_dof_labels(labels, where: str, unnamed_reference: bool = False) -> None:
    """Refuse a label that is not a DOF (:func:`parse_dof`) with one :class:`FileFormatError` naming ``where``.

    ``unnamed_reference`` also accepts :data:`UNNAMED_REFERENCE` (references only).
    """
    for label in labels:
        if unnamed_reference and label == UNNAMED_REFERENCE:
            continue
        try:
            parse_dof(label)
        except FileFormatError as exc:
            raise FileFormatError(f"{where}: {exc}") from None


def frf_matrix(table: dict, where: str) -> tuple:
    """Response DOFs, reference DOFs (in first-seen order) and the ``(n_resp, n_ref, n_lines)`` FRF of
    ``{(response DOF, reference DOF): values}``.

    Raises
    ------
    FileFormatError
        A response without an FRF for every reference (the message starts with ``where``).
    """
    resp = list(dict.fromkeys(k[0] for k in table))
    refs = list(dict.fromkeys(k[1] for k in table))
    missing = [(a, b) for a in resp for b in refs if (a, b) not in table]
    if missing:
        a, b = missing[0]
        raise FileFormatError(f"{where}: no FRF for response {a} and reference {b} ({len(missing)} missing "
                              f"of {len(resp)}x{len(refs)}); every response needs an FRF for every reference")
    return resp, refs, np.array([[table[(a, b)] for b in refs] for a in resp])


@dataclass(frozen=True)
class MeasuredFRF:
    """A matrix of measured frequency response functions.

    Attributes
    ----------
    frequency_hz : ndarray, float, shape (n_lines,)
        Strictly increasing frequency axis (Hz); need not be evenly spaced.
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines)
        ``frf[s, r, k]`` = response ``s`` over force at reference ``r`` at line ``k``.
    response_dofs, reference_dofs : tuple of str
        DOF labels such as ``"2:+Y"`` (node 2, +Y; see :func:`dof_label`).
    kind : {"receptance", "mobility", "accelerance"}
        Displacement, velocity or acceleration over force.
    units : str
        Units of ``frf`` (SI by default, e.g. ``"m/N"`` for receptance).
    metadata : dict
        Free-form, JSON-serialisable information (source file, test id, ...).
    """

    frequency_hz: np.ndarray
    frf: np.ndarray
    response_dofs: tuple
    reference_dofs: tuple
    kind: str = "receptance"
    units: str = ""
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        f = np.asarray(self.frequency_hz)
        if f.dtype.kind not in "iuf":
            raise ShapeError(f"MeasuredFRF.frequency_hz must be real numbers (got {f.dtype})")
        f = f.astype(np.float64)
        h = np.asarray(self.frf)
        if not np.iscomplexobj(h):
            raise ShapeError(f"MeasuredFRF.frf must be complex (got {h.dtype}); a magnitude alone is not an FRF")
        if h.ndim == 1:
            h = h[None, None, :]
        h = h.astype(np.complex128)
        resp = tuple(str(d) for d in self.response_dofs)
        ref = tuple(str(d) for d in self.reference_dofs)
        if f.ndim != 1 or f.size < 2:
            raise ShapeError("MeasuredFRF.frequency_hz must be 1-D with at least 2 lines")
        if h.ndim != 3 or h.shape != (len(resp), len(ref), f.size):
            raise ShapeError(f"MeasuredFRF.frf has shape {h.shape}; expected (n_resp, n_ref, n_lines) = "
                             f"({len(resp)}, {len(ref)}, {f.size})")
        if not np.all(np.isfinite(f)) or np.any(np.diff(f) <= 0) or f[0] < 0:
            raise ShapeError("MeasuredFRF.frequency_hz must be finite, >= 0 and strictly increasing")
        if not np.all(np.isfinite(h)):
            raise ShapeError("MeasuredFRF.frf has NaN or inf entries")
        mag = np.abs(h).reshape(-1, f.size)
        if np.any(mag.max(axis=1) < 1e-250):
            k = int(np.nonzero(mag.max(axis=1) < 1e-250)[0][0])
            raise ShapeError(f"MeasuredFRF.frf: FRF {k + 1} is zero (all |H| < 1e-250) on every line")
        if mag.max() > MAX_MAGNITUDE:
            raise ShapeError(f"MeasuredFRF.frf has a value of magnitude {mag.max():.3g}, beyond the {MAX_MAGNITUDE:g} "
                             "this package accepts (a unit or export error?)")
        if len(set(resp)) != len(resp) or len(set(ref)) != len(ref):
            raise ShapeError("MeasuredFRF DOF labels must be unique")
        if self.kind not in FRF_KINDS:
            raise ShapeError(f"MeasuredFRF.kind {self.kind!r} must be one of {', '.join(FRF_KINDS)}")
        f.setflags(write=False)
        h.setflags(write=False)
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "frf", h)
        object.__setattr__(self, "response_dofs", resp)
        object.__setattr__(self, "reference_dofs", ref)
        object.__setattr__(self, "units", self.units or DEFAULT_UNITS[self.kind])
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def omega_rad_s(self) -> np.ndarray:
        """Angular frequency axis (rad/s), shape (n_lines,)."""
        return 2 * np.pi * self.frequency_hz

    @property
    def driving_points(self) -> tuple:
        """``(response_index, reference_index)`` pairs whose DOF labels coincide."""
        return tuple((self.response_dofs.index(d), j) for j, d in enumerate(self.reference_dofs)
                     if d in self.response_dofs)

    def to_kind(self, kind: str) -> "MeasuredFRF":
        """Convert between receptance, mobility and accelerance.

        Mobility = ``i omega`` x receptance and accelerance = ``-omega^2`` x
        receptance. Converting towards receptance divides by ``i omega``, so a
        0 Hz line is then rejected (:class:`ShapeError`). Units become the SI
        units of the new kind.
        """
        if check_frf_kind(kind) == self.kind:
            return self
        if FRF_KINDS.index(kind) < FRF_KINDS.index(self.kind) and self.frequency_hz[0] == 0:
            raise ShapeError(f"cannot convert a {self.kind} to a {kind} at 0 Hz: drop the 0 Hz line first")
        return replace(self, frf=convert_frf(self.frf, self.omega_rad_s, self.kind, kind), kind=kind,
                       units=DEFAULT_UNITS[kind])

    def with_positive_directions(self) -> "MeasuredFRF":
        """The same FRFs on the positive sense of every DOF: ``H(+i, +j) = s_i s_j H(s_i i, s_j j)``.

        A response or reference labelled ``"3:-Y"`` (an accelerometer mounted upside down, a hammer struck
        towards -Y) has its row or column negated and its label made ``"3:+Y"``; other labels are kept.
        """
        rs, qs = _direction_signs(self.response_dofs), _direction_signs(self.reference_dofs)
        if np.all(rs > 0) and np.all(qs > 0):
            return self
        return replace(self, frf=self.frf * rs[:, None, None] * qs[None, :, None],
                       response_dofs=_positive_labels(self.response_dofs, rs),
                       reference_dofs=_positive_labels(self.reference_dofs, qs))

    def reciprocal(self) -> "MeasuredFRF":
        """Responses and references swapped, ``H_ji = H_ij`` (Maxwell-Betti reciprocity of a linear structure).

        A roving-hammer test (one accelerometer, the hammer at every measured point) then reads as one drive at
        the accelerometer with responses at every point. Both DOF sets must be on the same kind of motion
        (translations along one axis).
        """
        return replace(self, frf=np.swapaxes(self.frf, 0, 1), response_dofs=self.reference_dofs,
                       reference_dofs=self.response_dofs)

    def select_band(self, fmin_hz=None, fmax_hz=None) -> "MeasuredFRF":
        """Lines with ``fmin_hz <= f <= fmax_hz`` (either bound may be None)."""
        keep = np.ones(self.frequency_hz.size, bool)
        if fmin_hz is not None:
            keep &= self.frequency_hz >= fmin_hz
        if fmax_hz is not None:
            keep &= self.frequency_hz <= fmax_hz
        if keep.sum() < 2:
            raise ShapeError(f"band [{fmin_hz}, {fmax_hz}] Hz keeps fewer than 2 of the "
                             f"{self.frequency_hz.size} lines ({self.frequency_hz[0]:g}-"
                             f"{self.frequency_hz[-1]:g} Hz)")
        return replace(self, frequency_hz=self.frequency_hz[keep], frf=self.frf[..., keep])


