"""Node geometry of universal files (datasets 15 and 2411) and measured positions along a beam.

Node coordinates are converted to metres with the file's dataset 164 length
factor, and to the global system when a node is defined in a Cartesian
coordinate system of dataset 18. :func:`positions_along_beam` projects nodes on
the beam axis; :func:`measured_positions` gives the positions of measured DOFs,
from geometry when the file has it, else from the quarter-point convention of
the thesis (nodes 2..5 at L/4, L/2, 3L/4, L), and says which;
:func:`match_dofs_by_position` maps measured positions to model DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import FileFormatError, ShapeError

__all__ = ["NodeGeometry", "QUARTER_POINT_CONVENTION", "geometry_from_uff_sets", "match_dofs_by_position",
           "measured_positions", "positions_along_beam"]

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
    line); positions are measured from the geometry node with the smallest
    projection (one end of the beam), so the whole mesh lies in ``[0, L]``.
    """
    xyz = geometry.xyz_m
    if xyz.shape[0] < 2:
        raise ShapeError("positions along a beam need a geometry of at least 2 nodes")
    centre = xyz.mean(axis=0)
    _, _, vt = np.linalg.svd(xyz - centre, full_matrices=False)
    axis = vt[0] * (np.sign(vt[0][np.argmax(np.abs(vt[0]))]) or 1.0)  # points along +X/+Y/+Z
    proj = (xyz - centre) @ axis
    start = proj.min()
    return np.array([float((geometry.coordinates(n) - centre) @ axis - start) for n in nodes])


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
    from physics.io.types import parse_dof

    nodes = [parse_dof(d)[0] for d in dofs]
    if geometry is not None:
        return positions_along_beam(geometry, nodes), f"node geometry of the file ({geometry.source})"
    if length_m is None:
        return None, QUARTER_POINT_CONVENTION
    return np.array([(n - 1) * length_m / n_elements for n in nodes], float), QUARTER_POINT_CONVENTION


def match_dofs_by_position(measured_x_m, model_x_m, tol_m):
    """Index into ``model_x_m`` of the model DOF nearest each measured position.

    Raises :class:`ShapeError` when a measured position is farther than
    ``tol_m`` from every model DOF, or two measured DOFs take the same model DOF.
    """
    mx = np.asarray(measured_x_m, float)
    gx = np.asarray(model_x_m, float)
    d = np.abs(mx[:, None] - gx[None, :])
    idx = np.argmin(d, axis=1)
    far = d[np.arange(mx.size), idx] > tol_m
    if np.any(far):
        k = int(np.nonzero(far)[0][0])
        raise ShapeError(f"measured position {mx[k]:.4g} m is {d[k, idx[k]]:.3g} m from the nearest model DOF "
                         f"(at {gx[idx[k]]:.4g} m); tolerance {tol_m:.3g} m")
    if np.unique(idx).size != idx.size:
        raise ShapeError("two measured positions map to the same model DOF; refine the model mesh")
    return idx
