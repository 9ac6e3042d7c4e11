"""Node geometry of universal files (datasets 15 and 2411) and measured positions along a beam.

Node coordinates are converted to metres with the file's dataset 164 length
factor, and to the global system when a node is defined in a Cartesian
coordinate system of dataset 18. :func:`positions_along_beam` projects nodes on
the beam axis; :func:`measured_positions` gives the positions of measured DOFs,
from geometry when the file has it, else from the quarter-point convention of
the thesis (nodes 2..5 at L/4, L/2, 3L/4, L), and says which;
:func:`match_dofs_by_position` maps measured positions to model DOFs.
:func:`map_measured_dofs` does both for a command: positions from the file's
geometry, else a beam file's ``measured_x_m``, else the quarter-point
convention, and the model DOF at each (:class:`DofMap`).

Positions along the beam are measured from the origin of the file's global
coordinate system (the clamped end, ``x = 0``), projected on the beam axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import BeamDamageError, FileFormatError, ShapeError
from physics.io.types import parse_dof

__all__ = ["DofMap", "NOT_TRANSVERSE", "NodeGeometry", "QUARTER_POINT_CONVENTION", "dof_positions_text",
           "geometry_from_uff_sets", "map_frf_dofs", "map_measured_dofs", "match_dofs_by_position",
           "measured_positions", "not_transverse", "positions_along_beam", "reference_position_m"]

QUARTER_POINT_CONVENTION = ("no node geometry: the thesis convention holds, node N of a 4-element beam at "
                            "(N - 1) L / 4 (nodes 2..5 at the quarter points)")


@dataclass(frozen=True)
class NodeGeometry:
    """Node coordinates in metres, global Cartesian system.

    Attributes
    ----------
    node_ids : ndarray of int, shape (n,)
    xyz_m : ndarray, shape (n, 3)
    source : str
        Which datasets and units gave them.
    """

    node_ids: np.ndarray
    xyz_m: np.ndarray
    source: str

    def coordinates(self, node: int) -> np.ndarray:
        hit = np.nonzero(self.node_ids == int(node))[0]
        if hit.size == 0:
            raise FileFormatError(f"node {node} has no coordinates in the file's geometry ({self.source})")
        return self.xyz_m[hit[0]]

    def to_dict(self) -> dict:
        return {str(int(n)): [float(v) for v in xyz] for n, xyz in zip(self.node_ids, self.xyz_m)}

    @classmethod
    def from_metadata(cls, metadata: dict):
        """The geometry a reader stored in ``MeasuredFRF.metadata["geometry"]``, or None."""
        g = (metadata or {}).get("geometry")
        if not g:
            return None
        nodes = g["nodes_m"]
        return cls(np.array([int(k) for k in nodes]), np.array(list(nodes.values()), float).reshape(-1, 3),
                   str(g.get("source", "")))


def _cs_transforms(cs_sets, where):
    """Rotation and origin of each Cartesian coordinate system of dataset 18 records."""
    out = {}
    for s in cs_sets:  # one dataset 18 holds arrays of systems
        try:
            nums = np.atleast_1d(np.asarray(s["cs_num"], float)).astype(int)
            types = np.atleast_1d(np.asarray(s.get("cs_type", np.zeros(nums.size)), float)).astype(int)
            refs = np.atleast_1d(np.asarray(s.get("ref_cs_num", np.zeros(nums.size)), float)).astype(int)
            o_all, x_all, xz_all = (np.asarray(s[k], float).reshape(-1, 3) for k in ("ref_o", "x_point", "xz_point"))
        except (KeyError, TypeError, ValueError):
            raise FileFormatError(f"{where}: a coordinate-system dataset (18) lacks its origin and axis points") \
                from None
        for num, typ, ref, o, xp, xzp in zip(nums, types, refs, o_all, x_all, xz_all):
            if typ != 0:
                continue  # cylindrical/spherical: refused only if a node uses it
            ex, exz = xp - o, xzp - o
            ey = np.cross(exz, ex)
            if np.linalg.norm(ex) == 0 or np.linalg.norm(ey) == 0:
                raise FileFormatError(f"{where}: coordinate system {num} (dataset 18) has a degenerate axis "
                                      "definition")
            ex, ey = ex / np.linalg.norm(ex), ey / np.linalg.norm(ey)
            out[int(num)] = (np.column_stack([ex, ey, np.cross(ex, ey)]), o, int(ref))
    return out


def geometry_from_uff_sets(node_sets, cs_sets, length_factor: float, where: str, unit_text: str):
    """:class:`NodeGeometry` from pyuff dataset 15/2411 and 18 dictionaries (None without nodes)."""
    ids, xyz, cs = [], [], []
    for s in node_sets:
        try:
            n = np.asarray(s["node_nums"], float)
            c = np.column_stack([np.asarray(s[k], float) for k in ("x", "y", "z")])
            d = np.asarray(s.get("def_cs", np.zeros(n.size)), float)
        except (KeyError, TypeError, ValueError):
            raise FileFormatError(f"{where}: a node dataset (15/2411) lacks node numbers or x, y, z") from None
        if c.shape[0] != n.size or d.size != n.size or not np.all(np.isfinite(c)) or \
                np.any(n != np.round(n)) or np.any(n < 0):
            raise FileFormatError(f"{where}: a node dataset (15/2411) has non-integer node numbers or "
                                  "non-finite coordinates")
        ids.append(n.astype(int))
        xyz.append(c)
        cs.append(d.astype(int))
    if not ids:
        return None
    ids, xyz, cs = np.concatenate(ids), np.concatenate(xyz), np.concatenate(cs)
    if np.unique(ids).size != ids.size:
        dup = ids[np.nonzero(np.bincount(ids) > 1)[0][0]] if ids.max() < 10**7 else ids[0]
        raise FileFormatError(f"{where}: node {dup} is defined twice in the geometry datasets (15/2411)")
    xyz = xyz / length_factor
    used = set(np.unique(cs).tolist()) - {0}
    if used:
        tr = _cs_transforms(cs_sets, where)
        for k in used:
            if k not in tr:
                raise FileFormatError(f"{where}: nodes are defined in coordinate system {k}, which the file does "
                                      "not define as a Cartesian system (dataset 18)")
            R, o, ref = tr[k]
            if ref != 0:
                raise FileFormatError(f"{where}: coordinate system {k} is defined in system {ref}; nested "
                                      "coordinate systems are not supported")
            sel = cs == k
            xyz[sel] = o / length_factor + xyz[sel] @ R.T
    return NodeGeometry(ids, xyz, f"datasets 15/2411, coordinates in {unit_text} converted to m")


def positions_along_beam(geometry: NodeGeometry, nodes) -> np.ndarray:
    """Positions (m) of ``nodes`` along the beam axis of ``geometry``.

    The axis is the principal direction of all nodes of the geometry (the beam
    line), pointing from the origin of the coordinate system towards the nodes;
    positions are the projections of the nodes on it, measured from the origin
    (the clamped end, ``x = 0``), so nodes offset across the beam keep their
    position and a geometry of the measured points alone (no node at the
    clamp) places them right. A geometry of one node (one sensor) places it at its distance from the origin.
    """
    xyz = geometry.xyz_m
    if xyz.shape[0] == 0:
        raise ShapeError("positions along a beam need a geometry of at least 1 node")
    if xyz.shape[0] == 1:  # one sensor: its distance from the origin (the end x = 0)
        return np.array([float(np.linalg.norm(geometry.coordinates(n))) for n in nodes])
    centre = xyz.mean(axis=0)
    _, _, vt = np.linalg.svd(xyz - centre, full_matrices=False)
    axis = vt[0] * (np.sign(vt[0][np.argmax(np.abs(vt[0]))]) or 1.0)  # points along +X/+Y/+Z
    if centre @ axis < 0:  # the nodes lie on the negative side of the origin: measure towards them
        axis = -axis
    return np.array([float(geometry.coordinates(n) @ axis) for n in nodes])


def reference_position_m(frf) -> float | None:
    """Position (m) along the beam of the first reference DOF of a :class:`~physics.io.MeasuredFRF`, from the node
    geometry it carries (:func:`positions_along_beam`); None without geometry or without that node in it."""
    try:
        geometry = NodeGeometry.from_metadata(frf.metadata)
        node = parse_dof(frf.reference_dofs[0])[0]
        return None if geometry is None else float(positions_along_beam(geometry, [node])[0])
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, BeamDamageError):
        return None


def measured_positions(dofs, geometry: NodeGeometry | None = None, length_m: float | None = None,
                       n_elements: int = 4):
    """Positions (m) of measured DOFs ``"NODE:DIR"`` and the rule that gave them.

    With ``geometry``: :func:`positions_along_beam` of each DOF's node. Without:
    the quarter-point convention, node ``N`` at ``(N - 1) length_m / n_elements``
    (``length_m`` None gives positions None with the convention named).

    Returns
    -------
    positions_m : ndarray, shape (n_dofs,), or None
    source : str
    """
    nodes = [parse_dof(d)[0] for d in dofs]
    if geometry is not None:
        return positions_along_beam(geometry, nodes), f"node geometry of the file ({geometry.source})"
    if length_m is None:
        return None, QUARTER_POINT_CONVENTION
    return np.array([(n - 1) * length_m / n_elements for n in nodes], float), QUARTER_POINT_CONVENTION


def match_dofs_by_position(measured_x_m, model_x_m, tol_m, labels=None, model_labels=None, off_grid="refuse"):
    """Index into ``model_x_m`` of the model DOF nearest each measured position.

    Raises :class:`ShapeError` when a measured position is farther than
    ``tol_m`` from every model DOF (unless ``off_grid="ignore"``: its index is then -1),
    or two measured DOFs take the same model DOF (naming them by ``labels`` and
    ``model_labels`` when given).
    """
    mx = np.asarray(measured_x_m, float)
    gx = np.asarray(model_x_m, float)
    lab = [f"measured DOF {a}" for a in labels] if labels is not None else ["measured position"] * mx.size
    mlab = [f"model DOF {a}" for a in model_labels] if model_labels is not None else ["model DOF"] * gx.size
    d = np.abs(mx[:, None] - gx[None, :])
    idx = np.argmin(d, axis=1)
    far = d[np.arange(mx.size), idx] > tol_m
    if off_grid == "ignore":
        idx = np.where(far, -1, idx)
        far = np.zeros_like(far)
    if np.any(far):
        k = int(np.nonzero(far)[0][0])
        raise ShapeError(f"{lab[k]} at x = {mx[k]:.4g} m is not at a model DOF: {d[k, idx[k]]:.3g} m from the "
                         f"nearest, {mlab[idx[k]]} at {gx[idx[k]]:.4g} m (tolerance {tol_m:.3g} m)")
    on = idx[idx >= 0]
    if np.unique(on).size != on.size:
        i, j = (int(k) for k in np.nonzero(idx == np.nonzero(np.bincount(on) > 1)[0][0])[0][:2])
        raise ShapeError(f"{lab[i]} (x = {mx[i]:.4g} m) and {lab[j]} (x = {mx[j]:.4g} m) map to the same "
                         f"{mlab[idx[i]]} (x = {gx[idx[i]]:.4g} m)")
    return idx


@dataclass(frozen=True)
class DofMap:
    """Measured DOFs, their positions along the beam and the model DOF at each.

    Attributes
    ----------
    source : str
        ``"<format> geometry"`` (e.g. ``"uff geometry"``), ``"beam file"`` or
        ``"quarter-point convention"``.
    detail : str
        The rule in words.
    dofs : tuple of str
        Measured DOF labels, in the file's order.
    positions_m : ndarray, shape (n,)
        Position of each measured DOF along the beam (m).
    model_dofs : tuple of str
        Model DOF at each measured DOF.
    """

    source: str
    detail: str
    dofs: tuple
    positions_m: np.ndarray
    model_dofs: tuple

    def rows(self, model_dofs, where: str = "measured data") -> np.ndarray:
        """Index of the measured DOF at each of ``model_dofs`` (refuses naming the missing ones)."""
        missing = [d for d in model_dofs if d not in self.model_dofs]
        if missing:
            have = ", ".join(f"{a} -> {b or f'none (x = {x:.4g} m)'}"
                             for a, b, x in zip(self.dofs, self.model_dofs, self.positions_m))
            raise ShapeError(f"{where}: no measured DOF at model DOF(s) {', '.join(missing)} (positions from the "
                             f"{self.source}; measured: {have or 'none'}); all of {', '.join(model_dofs)} are needed")
        return np.array([self.model_dofs.index(d) for d in model_dofs])

    def to_dict(self) -> dict:
        return {"source": self.source, "detail": self.detail, "dofs": list(self.dofs),
                "positions_m": [float(x) for x in self.positions_m], "model_dofs": list(self.model_dofs)}



def dof_positions_text(d: dict) -> str:
    """One line describing a :meth:`DofMap.to_dict` (for the commands' text output)."""
    pairs = ", ".join(f"{a} at {x:.4g} m -> {b}" for a, x, b in zip(d["dofs"], d["positions_m"], d["model_dofs"]))
    return f"measured DOFs placed by the {d['source']} ({d['detail']}): {pairs}"


#: Why a DOF is no transverse translation of the beam (:func:`not_transverse`).
NOT_TRANSVERSE = "X is the beam's axis without node geometry; RX, RY, RZ are rotations"


def not_transverse(dofs, along_x: bool = True) -> np.ndarray:
    """Which DOF labels (shape (n,)) measure no transverse translation of the beam: a rotation (RX, RY, RZ), or
    with ``along_x`` (the beam along X: no node geometry says otherwise) a translation along X. Y, Z and scalar
    (``S``) labels are transverse; a label that is no ``NODE:DIR`` is refused by :func:`parse_dof`'s callers."""
    codes = np.array([abs(parse_dof(d)[1]) for d in dofs], int)
    return np.isin(codes, (4, 5, 6)) | ((codes == 1) & along_x)


def map_measured_dofs(dofs, model_x_m, model_dofs, *, length_m: float, n_elements: int = 4, geometry=None,
                      geometry_format: str = "file", beam_x_m=None, tol_m=None,
                      where: str = "measured data", off_grid: str = "refuse") -> DofMap:
    """Positions of measured DOFs and the model DOF at each.

    The positions come from the first of: the file's node ``geometry``
    (:func:`positions_along_beam`); a beam file's ``beam_x_m``, paired with the
    measured nodes in ascending node number; the quarter-point convention,
    node ``N`` at ``(N - 1) length_m / n_elements``. Each position is matched to
    the nearest of ``model_x_m`` (:func:`match_dofs_by_position`).

    Parameters
    ----------
    dofs : sequence of str
        Measured DOF labels ``"NODE:DIR"``.
    model_x_m : sequence of float
        Positions (m) of the model DOFs a measured DOF may sit at.
    model_dofs : sequence of str
        Their labels.
    length_m : float
        Beam length (m).
    n_elements : int
        Elements of the beam mesh whose node numbers the convention uses.
    geometry : NodeGeometry, optional
    geometry_format : str
        Name of the file format, for the source (``"uff"`` -> ``"uff geometry"``).
    beam_x_m : sequence of float, optional
        Measured positions a beam file gives.
    tol_m : float, optional
        Largest distance to a model DOF (default 1 % of an element, ``0.01 length_m / n_elements``).
    where : str
        The file, for messages.
    off_grid : {"refuse", "ignore"}
        A measured DOF away from every model DOF is refused, or left out: its model DOF is ``""`` and
        the detail names it.

    Raises
    ------
    ShapeError
        A DOF without coordinates, a count that differs from the beam file's,
        a position not at a model DOF (``off_grid="refuse"``), or two DOFs at one model DOF.
    """
    dofs = tuple(str(d) for d in dofs)
    try:
        nodes = np.array([parse_dof(d)[0] for d in dofs], int)
    except FileFormatError as exc:
        raise FileFormatError(f"{where}: field 'dofs': {exc}") from None
    tol_m = 0.01 * length_m / n_elements if tol_m is None else tol_m
    if geometry is not None:
        source = f"{geometry_format} geometry"
        detail = (f"node coordinates of the file ({geometry.source}), projected on the beam axis from the "
                  "file's origin (the clamped end)")
        try:
            x = positions_along_beam(geometry, nodes)
        except ValueError as exc:
            raise ShapeError(f"{where}: {exc}") from None
    elif beam_x_m is not None:
        source = "beam file"
        detail = "the beam file's measured_x_m, in ascending node number of the measured DOFs"
        beam_x_m = np.asarray(beam_x_m, float)
        if beam_x_m.size != nodes.size:
            raise ShapeError(f"{where}: {nodes.size} measured DOFs ({', '.join(dofs)}) but the beam file gives "
                             f"{beam_x_m.size} measured_x_m positions")
        x = np.empty(nodes.size)
        x[np.argsort(nodes, kind="stable")] = beam_x_m
    else:
        source = "quarter-point convention"
        detail = QUARTER_POINT_CONVENTION if n_elements == 4 else \
            f"no node geometry: node N of the {n_elements}-element beam at (N - 1) L / {n_elements}"
        x = (nodes - 1) * length_m / n_elements
    across = not_transverse(dofs, along_x=geometry is None)
    if across.any() and off_grid == "refuse":
        raise ShapeError(f"{where}: measured DOF{'s' if across.sum() > 1 else ''} "
                         f"{', '.join(d for d, a in zip(dofs, across) if a)} {'are' if across.sum() > 1 else 'is'} "
                         f"no transverse translation ({NOT_TRANSVERSE}); the beam's measured DOFs are its transverse "
                         "translations (Y or Z)")
    idx = np.full(len(dofs), -1)
    try:
        idx[~across] = match_dofs_by_position(x[~across], model_x_m, tol_m, [d for d, a in zip(dofs, across) if not a],
                                              model_dofs, off_grid)
    except ShapeError as exc:
        raise ShapeError(f"{where}: {exc} (positions from the {source})") from None
    if np.any((idx < 0) & ~across):
        detail += "; not at a model DOF, not used: " + ", ".join(f"{d} (x = {xk:.4g} m)" for d, xk, k, a
                                                                 in zip(dofs, x, idx, across) if k < 0 and not a)
    if across.any():
        detail += (f"; no transverse translation ({NOT_TRANSVERSE}), not used: "
                   + ", ".join(d for d, a in zip(dofs, across) if a))
    return DofMap(source, detail, dofs, x, tuple(str(model_dofs[k]) if k >= 0 else "" for k in idx))


def map_frf_dofs(frf, dofs, model_x_m, model_dofs, **kwargs) -> DofMap:
    """:func:`map_measured_dofs` of DOFs of a :class:`~physics.io.MeasuredFRF`, with the geometry it carries.

    ``dofs`` (e.g. ``frf.response_dofs``) are mapped with the node geometry the
    reader stored in ``frf.metadata`` (UFF datasets 15/2411, or an NPZ's
    metadata), named after the file format; the file names the messages.
    """
    fmt = str(frf.metadata.get("format", "file"))
    try:
        geometry = NodeGeometry.from_metadata(frf.metadata)
    except (KeyError, TypeError, ValueError, AttributeError):
        raise ShapeError(f"{frf.metadata.get('source', 'FRF')}: metadata 'geometry' must hold 'nodes_m' = "
                         "{node: [x, y, z]} in metres") from None
    return map_measured_dofs(dofs, model_x_m, model_dofs, geometry=geometry, geometry_format=fmt,
                             where=str(frf.metadata.get("source", "FRF")), **kwargs)
