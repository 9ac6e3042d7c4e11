"""Reading and writing measured and modal data (file I/O lives only here).

One module per format, listed in one table (:data:`FORMATS`), the data types and the atomic writer apart:

* :mod:`physics.io.types` -- :class:`MeasuredFRF`, :class:`ModalData`, DOF labels;
* :mod:`physics.io.atomic` -- the one temp-file-then-rename writer, and a figure's PNG bytes;
* :mod:`physics.io.uff58` -- universal file dataset 58 (ASCII and binary 58b);
* :mod:`physics.io.csv` -- FRFs as CSV text;
* :mod:`physics.io.npz` -- FRFs as ``.npz`` of plain arrays;
* :mod:`physics.io.modal_json` -- modal data (eigenvalues, complex shapes) as JSON;
* :mod:`physics.io.timedata` -- time records (dataset 58, function type 1) of force and responses;
* :mod:`physics.io.formats` -- the format table :data:`FORMATS` (extensions, content, sniffing, reader,
  writer, description) and :func:`read_frf` / :func:`read`, choosing a reader from the name or content,
  and :func:`modal_or_frf`, whether a file of measured data holds modal data or FRFs;
* :mod:`physics.io.jsonable` -- :func:`to_jsonable`, JSON-ready values of results;
* :mod:`physics.io.units` -- dataset 164 unit factors and unit labels, to SI;
* :mod:`physics.io.geometry` -- node geometry (datasets 15/2411) and measured positions along the beam;
* :mod:`physics.io.prepare` -- measured data made ready for a model (positive senses, DOF map, the one
  reciprocity rule).

Every name below is importable from ``physics.io`` directly.
"""

from physics.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text, figure_png, pyplot
from physics.io.csv import read_frf_csv, write_frf_csv
from physics.io.formats import (FORMATS, FRF, MODAL, TIME, FileFormat, accepted, format_of, modal_or_frf, read,
                               read_frf, writable)
from physics.io.modal_json import (modal_data_from_dict, modal_data_to_dict, number_list, read_json,
                                   read_modal_json, write_modal_json)
from physics.io.npz import read_frf_npz, write_frf_npz
from physics.io.types import (DEFAULT_UNITS, FRF_KINDS, MeasuredFRF, ModalData, dof_label,
                              format_complex, parse_dof)
from physics.io.jsonable import finite_or_none, floats_or_nan, to_jsonable
from physics.io.geometry import (QUARTER_POINT_CONVENTION, DofMap, NodeGeometry, dof_positions_text, map_frf_dofs,
                                 map_measured_dofs, match_dofs_by_position, measured_positions, positions_along_beam,
                                 reference_position_m)
from physics.io.prepare import Prepared, prepare_measured, reads_by_reciprocity, sensor_labels
from physics.io.uff58 import read_uff58, read_uff_geometry, write_uff58
from physics.io.units import UnitSystem, frf_unit_factor

__all__ = ["FORMATS", "FRF", "MODAL", "TIME", "FileFormat", "accepted", "format_of", "modal_or_frf", "read",
           "writable",
           "DEFAULT_UNITS", "FRF_KINDS", "MeasuredFRF", "ModalData", "atomic_path", "atomic_write_bytes",
           "atomic_write_text", "dof_label", "format_complex", "modal_data_from_dict", "modal_data_to_dict",
           "number_list", "parse_dof", "read_frf", "read_json", "read_frf_csv", "read_frf_npz", "read_modal_json",
           "read_uff58", "write_frf_csv", "write_frf_npz", "write_modal_json", "write_uff58",
           "DofMap", "NodeGeometry", "dof_positions_text", "QUARTER_POINT_CONVENTION", "map_frf_dofs",
           "map_measured_dofs", "UnitSystem", "frf_unit_factor", "match_dofs_by_position",
           "measured_positions", "positions_along_beam", "reference_position_m", "read_uff_geometry", "Prepared",
           "prepare_measured", "sensor_labels", "reads_by_reciprocity", "to_jsonable", "finite_or_none",
           "floats_or_nan", "figure_png", "pyplot"]
