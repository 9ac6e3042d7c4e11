"""Measured data made ready for a model: every DOF on its positive sense, the DOF map, and an FRF file read by
reciprocity when its references, not its responses, cover the DOFs wanted.

The one reciprocity rule (:func:`reads_by_reciprocity`): an FRF file is read with responses and references
swapped (``H_ij = H_ji``, :meth:`~physics.io.MeasuredFRF.reciprocal`) when its responses do not cover the DOFs
wanted and its references do. The DOFs wanted are a model's DOFs when there is one (``classify``: the model's
DOFs, compared after the DOF map), else every DOF the file names (``identify``: the shapes run over every DOF the
test touched). A roving-hammer test (one accelerometer, the hammer at every point) is so read as one drive at the
accelerometer; a file whose responses already cover the DOFs wanted (SIMO, MIMO) stays as it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from physics.io.geometry import DofMap
from physics.io.types import MeasuredFRF, ModalData

__all__ = ["Prepared", "prepare_measured", "reads_by_reciprocity", "sensor_labels"]


@dataclass(frozen=True)
class Prepared:
    """Measured data as a model reads it.

    Attributes
    ----------
    data : MeasuredFRF or ModalData      positive senses; an FRF file read by reciprocity when the rule says so
    dof_map : DofMap or None             the map ``map_dofs`` gave (None without one)
    reciprocal : bool                    whether responses and references were swapped
    """

    data: MeasuredFRF | ModalData
    dof_map: DofMap | None = None
    reciprocal: bool = False


def reads_by_reciprocity(response_dofs, reference_dofs, wanted=None) -> bool:
    """Whether an FRF file is read with responses and references swapped: its responses do not cover the DOFs
    ``wanted`` and its references do (``wanted`` None: every DOF of the file)."""
    resp, ref = set(response_dofs), set(reference_dofs)
    wanted = resp | ref if wanted is None else set(wanted)
    return not wanted <= resp and wanted <= ref


def prepare_measured(data, map_dofs: Callable[[object], DofMap] | None = None, wanted=None) -> Prepared:
    """Measured data on the positive sense of every DOF, mapped, and read by reciprocity by the one rule.

    Parameters
    ----------
    data : MeasuredFRF or ModalData
    map_dofs : callable, optional
        ``map_dofs(data) -> DofMap`` of the positive-sense data's DOF labels (an FRF's responses and references
        together); the rule then compares the model DOFs they map to with ``wanted``.
    wanted : sequence of str, optional
        DOFs the data must cover as responses (model DOFs when ``map_dofs`` is given); default every DOF of the
        file.

    Returns
    -------
    Prepared
    """
    data = data.with_positive_directions()
    dof_map = map_dofs(data) if map_dofs is not None else None
    if not isinstance(data, MeasuredFRF):
        return Prepared(data, dof_map)
    name = dict(zip(dof_map.dofs, dof_map.model_dofs)) if dof_map is not None else {}
    resp = [name.get(d, d) for d in data.response_dofs]
    ref = [name.get(d, d) for d in data.reference_dofs]
    if reads_by_reciprocity(resp, ref, wanted):
        return Prepared(data.reciprocal(), dof_map, True)
    return Prepared(data, dof_map)


def sensor_labels(frf, beam_x_m=None) -> tuple:
    """The DOF labels of an FRF file that stand for sensors: its responses and references together; but a file
    without node geometry whose positions come from a beam file's ``beam_x_m`` (paired in ascending node number)
    names the DOFs that match their count: its responses alone when the references are forces where no sensor is
    (one accelerometer and a hammer elsewhere, or roving accelerometers with a fixed hammer), its references alone
    for a roving hammer (one accelerometer, the hammer at every point)."""
    both = tuple(dict.fromkeys(frf.response_dofs + frf.reference_dofs))
    if beam_x_m is None or frf.metadata.get("geometry"):
        return both
    n = len(beam_x_m)
    for labels in (both, tuple(dict.fromkeys(frf.response_dofs)), tuple(dict.fromkeys(frf.reference_dofs))):
        if len(labels) == n:
            return labels
    return both
