"""Output-only identification of response records (no force) by a method of :data:`METHODS` with
``data == "records"``: the records of a file, :func:`identify_records` and its :class:`RecordsIdentification`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from physics.io.inputs import MAX_BYTES, check_input_file
from physics.errors import ConfigError, ConvergenceError, FileFormatError, ShapeError
from physics.identification.free_decay import free_response
from physics.identification.methods import METHODS
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.poles import StabilisationDiagram
from physics.identification.record_checks import check_records
from physics.io import FRF, ModalData, TIME, format_of, read
from physics.io.timedata import TimeRecords
from physics.io.uff58 import UffFile
from physics.modal import eigenvalues_from_modal
import zipfile

__all__ = ["DEFAULT_OUTPUT_ONLY", "FREE_RESPONSE_METHOD", "SCALING", "STATIONARY_METHOD", "MergedSetups",
           "RecordsIdentification", "holds_response_records",
           "identify_records", "merge_setups", "read_response_records"]

#: The method ``identify`` takes for a file of response records without a force channel: ``"auto"`` picks
#: :data:`FREE_RESPONSE_METHOD` for a free response (decays after hits,
#: :func:`~physics.identification.free_decay.free_response`), :data:`STATIONARY_METHOD` otherwise.
DEFAULT_OUTPUT_ONLY = "auto"
FREE_RESPONSE_METHOD, STATIONARY_METHOD = "era", "ssi"
#: What modal.json says of output-only shapes.
SCALING = "unscaled (output-only: no force measured, so no modal mass)"


@dataclass(frozen=True)
class RecordsIdentification:
    """An output-only identification of response records.

    Attributes
    ----------
    records : TimeRecords
        The response channels identified (SI units of one quantity).
    estimate : ModalEstimate
        Unit-norm, unscaled shapes over ``records.dofs``.
    diagram : StabilisationDiagram or None
    method_choice : str
        Which method was picked and why (``"auto"``); empty for a method named by the caller.
    """

    records: TimeRecords
    estimate: ModalEstimate
    diagram: StabilisationDiagram | None
    method_choice: str = ""

    @property
    def modal_data(self) -> ModalData:
        """Eigenvalues and unit-norm shapes over the channels' DOFs."""
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.records.dofs)


#: The header of a CSV file is looked for in its first lines, each read up to a bounded length.
SNIFF_LINES, SNIFF_LINE_CHARS = 200, 1 << 16


def holds_response_records(path) -> bool:
    """Whether a file holds time records rather than FRFs: a universal file with time records and no FRF, an
    ``.npz`` with a ``signals`` field, or a CSV whose header starts with ``time_s``."""
    if not Path(path).is_file():
        return False                                  # the FRF reader names what is missing
    fmt = format_of(path, FRF, TIME)
    check_input_file(path, fmt.name if fmt.name in MAX_BYTES else "csv")
    if fmt.name == "uff":
        types = UffFile(path).function_types
        return 1 in types and 4 not in types
    if fmt.name == "npz":

        try:
            with zipfile.ZipFile(path) as zf:
                return "signals.npy" in zf.namelist()
        except (zipfile.BadZipFile, OSError, EOFError, ValueError):
            return False                              # the FRF reader names what is wrong
    if fmt.name == "csv":
        with open(path, encoding="utf-8", errors="replace") as fh:
            lines = (fh.readline(SNIFF_LINE_CHARS) for _ in range(SNIFF_LINES))   # bounded: no newline in 2 GB
            first = next((s.strip() for s in lines if s.strip() and not s.lstrip().startswith("#")), "")
        return first.lower().startswith("time_s")
    return False


def read_response_records(path) -> TimeRecords:
    """The response channels of a time-record file (forces dropped); one quantity over all channels."""
    rec = read(path, TIME)
    resp = rec.responses
    if not resp:
        raise FileFormatError(f"{path}: no response channel, only forces")
    quantities = sorted({rec.quantities[i] for i in resp})
    if len(quantities) > 1:
        raise FileFormatError(f"{path}: response channels of several quantities ({', '.join(quantities)}); "
                              "output-only shapes need one quantity over all channels")
    return TimeRecords(rec.time_step_s, rec.signals[resp], tuple(rec.dofs[i] for i in resp),
                       tuple(rec.quantities[i] for i in resp), rec.metadata)


def identify_records(records: TimeRecords, method=DEFAULT_OUTPUT_ONLY, band_hz=None, n_modes=None,
                     max_order=None) -> RecordsIdentification:
    """Identify modes of response records by an output-only method of :data:`METHODS`.

    Parameters
    ----------
    records : TimeRecords
        Response channels only (see :func:`read_response_records`).
    method : str
        A key of :data:`METHODS` with ``data == "records"``, or ``"auto"``: :data:`FREE_RESPONSE_METHOD` for a
        free response (:func:`~physics.identification.free_decay.free_response`: decays after hits),
        :data:`STATIONARY_METHOD` otherwise; when the picked method finds no mode, the other is tried, and
        :attr:`RecordsIdentification.method_choice` says so.
    band_hz : (float, float), optional
    n_modes : int, optional
    max_order : int, optional
        Highest model order of SSI/ERA (state dimension; default sized to the record's spectrum).

    Returns
    -------
    RecordsIdentification
    """
    names = [n for n, spec in METHODS.items() if spec.data == "records"]
    if method != "auto" and (method not in METHODS or METHODS[method].data != "records"):
        raise ConfigError(f"method {method!r}: response records without a force are identified output-only, by "
                          f"{', '.join(names)} (or auto)")
    if band_hz is not None and not band_hz[0] < band_hz[1]:
        raise ConfigError(f"band_hz ({band_hz[0]}, {band_hz[1]}): the lower bound must be below the upper")
    where = str(records.metadata.get("source", "records"))
    fs = records.sampling_frequency_hz

    def fit(name):
        spec = METHODS[name]
        options = {"max_order": max_order}
        return spec.fit(records.signals, fs, band_hz, n_modes, where, **{k: options[k] for k in spec.options})

    if method != "auto":
        est, diagram = fit(method)
        return RecordsIdentification(records, est, diagram)
    verdict = free_response(check_records(records.signals, fs, band_hz, where))
    picked = FREE_RESPONSE_METHOD if verdict.free else STATIONARY_METHOD
    why = (f"picked {picked}: response records without a force channel, {verdict.text}"
           + ("" if verdict.free else " (identified as a stationary response)"))
    try:
        est, diagram = fit(picked)
    except (ConvergenceError, ShapeError) as first:
        other = STATIONARY_METHOD if verdict.free else FREE_RESPONSE_METHOD
        if other == FREE_RESPONSE_METHOD and not verdict.decays.starts.size:
            raise
        try:
            est, diagram = fit(other)
        except (ConvergenceError, ShapeError):
            raise first from None
        why = f"{why}; {picked} found no mode ({first}), so {other}"
    return RecordsIdentification(records, est, diagram, why)


@dataclass(frozen=True)
class MergedSetups:
    """Modes of several setups (roving sensors, fixed reference sensors) merged into one set of shapes.

    Attributes
    ----------
    estimate : ModalEstimate
        Frequencies and damping ratios: means over the setups; one sigma: the spread over the setups divided by
        sqrt(their number) (with one setup per mode, that setup's own); unit-norm shapes over ``dofs``.
    dofs : tuple of str
        The first setup's DOFs, then each later setup's new DOFs in its order.
    references : tuple of str
        DOFs measured in every setup (they scale each setup's shapes onto the first's).
    dropped_hz : tuple of float
        Frequencies of the first setup's modes not found in every setup (left out).
    """

    estimate: ModalEstimate
    dofs: tuple
    references: tuple
    dropped_hz: tuple

    @property
    def modal_data(self) -> ModalData:
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.dofs)


def merge_setups(idents, freq_tol=0.02) -> MergedSetups:
    """Merge the output-only identifications of several setups that share reference DOFs.

    Each mode of the first setup is matched in every other setup by the nearest frequency within ``freq_tol``
    (relative); the other setup's shape is scaled onto the first's by the complex least-squares factor on the
    reference DOFs, whose entries are then averaged over the setups.

    Parameters
    ----------
    idents : sequence of RecordsIdentification
    freq_tol : float

    Returns
    -------
    MergedSetups

    Raises
    ------
    ShapeError
        No DOF is measured in every setup, or no mode is found in every setup.
    """
    dof_sets = [list(i.records.dofs) for i in idents]
    refs = [d for d in dof_sets[0] if all(d in ds for ds in dof_sets[1:])]
    if not refs:
        raise ShapeError("setups " + ", ".join(str(i.records.metadata.get("source", "?")) for i in idents)
                         + ": no DOF is measured in every setup; reference sensors must stay in place")
    dofs = list(dof_sets[0])
    for ds in dof_sets[1:]:
        dofs += [d for d in ds if d not in dofs]
    e0 = idents[0].estimate
    rows, fns, zetas, kept, dropped = [], [], [], [], []
    for j, f in enumerate(e0.natural_frequencies_hz):
        picks = []
        for i in idents[1:]:
            fi = i.estimate.natural_frequencies_hz
            k = int(np.argmin(np.abs(fi - f))) if fi.size else -1
            picks.append(k if k >= 0 and abs(fi[k] - f) <= freq_tol * f else -1)
        if min(picks, default=0) < 0:
            dropped.append(float(f))
            continue
        shape = np.zeros(len(dofs), complex)
        count = np.zeros(len(dofs))
        ref0 = e0.shapes[[dof_sets[0].index(d) for d in refs], j]
        for i, k in zip(idents, [j, *picks]):
            psi = i.estimate.shapes[:, k]
            rs = psi[[list(i.records.dofs).index(d) for d in refs]]
            alpha = np.vdot(rs, ref0) / np.vdot(rs, rs)
            idx = [dofs.index(d) for d in i.records.dofs]
            shape[idx] += alpha * psi
            count[idx] += 1
        rows.append(shape / count)
        fns.append([i.estimate.natural_frequencies_hz[k] for i, k in zip(idents, [j, *picks])])
        zetas.append([i.estimate.damping_ratios[k] for i, k in zip(idents, [j, *picks])])
        kept.append(j)
    if not kept:
        raise ShapeError("no mode of the first setup is found in every setup (within "
                         f"{100 * freq_tol:g} % in frequency)")
    F, Z = np.array(fns), np.array(zetas)
    n = F.shape[1]
    f_std = F.std(axis=1, ddof=1) / np.sqrt(n) if n > 1 else e0.frequency_std_hz[kept]
    z_std = Z.std(axis=1, ddof=1) / np.sqrt(n) if n > 1 else e0.damping_std[kept]
    phi = np.array(rows).T
    phi = phi / np.linalg.norm(phi, axis=0)
    fn, zeta = F.mean(axis=1), Z.mean(axis=1)
    est = ModalEstimate(fn, zeta, eigenvalues_from_modal(fn, zeta), phi, np.zeros((len(dofs), 0, fn.size), complex),
                        f_std, z_std, modal_phase_collinearity(phi), e0.method, False)
    return MergedSetups(est, tuple(dofs), tuple(refs), tuple(dropped))
