"""Files as a test system writes them: UFF (datasets 164, 15, 58 via pyuff), modal JSON, truth tables."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["KINDS", "atomic_target", "complex_text", "convert_receptance", "modal_dict", "write_csv", "write_json",
           "write_text_atomic", "write_uff"]


#: dataset-58 ordinate specific data type and unit label of each FRF kind (SI).
KINDS = {"receptance": (8, "m"), "mobility": (11, "m/s"), "accelerance": (12, "m/s^2")}


def atomic_target(path: Path) -> Path:
    """A new empty temporary file beside ``path`` (its folder made), to be renamed onto it once written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    return Path(tmp)


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same directory and a rename."""
    path = Path(path)
    tmp = atomic_target(path)
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def convert_receptance(H: np.ndarray, freq_hz: np.ndarray, kind: str) -> np.ndarray:
    """Receptance (m/N) -> ``kind`` (m/N, m/s/N or m/s^2/N) on the last axis."""
    iw = 2j * math.pi * np.asarray(freq_hz)
    return {"receptance": H, "mobility": iw * H, "accelerance": iw ** 2 * H}[kind]


def write_uff(path, freq_hz, H, node_x_m, resp_nodes, ref_node: int, kind: str = "receptance",
              description: str = "", node_numbers=None, geometry: bool = True) -> None:
    """One test as a universal file: units (164, mm), node geometry (15, mm; left out with ``geometry`` False, as
    many impact tests are written) and one FRF record (58) per response.

    Dataset 164 declares the MM system (mm, mN), so the ordinates in SI (m/N, m/s/N,
    m/s^2/N) are also right in file units (mm/mN = m/N); the axis labels say it too.

    Parameters
    ----------
    path : path-like
    freq_hz : ndarray, shape (n_lines,)
        Evenly spaced frequency lines (Hz).
    H : ndarray, complex, shape (n_resp, n_lines)
        Receptance (m/N); written as ``kind`` in SI with explicit unit labels.
    node_x_m : sequence of float
        Coordinates of the nodes along X (m), written in mm.
    resp_nodes : sequence of int
        Node number of each response (direction +Y).
    ref_node : int
        Reference (drive) node, direction +Y.
    node_numbers : sequence of int, optional
        Number of each node of ``node_x_m`` (default ``1, 2, ...``).
    """
    import pyuff

    path = Path(path)
    f = np.asarray(freq_hz, dtype=float)
    data = convert_receptance(np.asarray(H), f, kind)
    spec, label = KINDS[kind]
    nodes = np.arange(1, len(node_x_m) + 1) if node_numbers is None else np.asarray(node_numbers, dtype=int)
    if nodes.size != len(node_x_m) or not set(map(int, resp_nodes)) | {int(ref_node)} <= set(nodes.tolist()):
        raise ValueError(f"write_uff: {nodes.size} node numbers for {len(node_x_m)} coordinates, or a response/"
                         f"reference node outside {nodes.tolist()}")
    sets = [pyuff.prepare_164(units_code=5, units_description="mm (milli-newton)", temp_mode=2,
                              length=1000.0, force=1000.0, temp=1.0, temp_offset=273.15),
            pyuff.prepare_15(node_nums=nodes, def_cs=np.zeros(nodes.size, int), disp_cs=np.zeros(nodes.size, int),
                             color=np.full(nodes.size, 8), x=1000.0 * np.asarray(node_x_m, dtype=float),
                             y=np.zeros(nodes.size), z=np.zeros(nodes.size))][:2 if geometry else 1]
    for k, node in enumerate(resp_nodes):
        sets.append(pyuff.prepare_58(
            binary=0, id1=f"FRF {node}:+Y/{ref_node}:+Y", id2=description[:80] or "second_sim",
            id3="NONE", id4="NONE", id5="NONE", func_type=4, ver_num=0, load_case_id=0,
            rsp_ent_name="beam", rsp_node=int(node), rsp_dir=2, ref_ent_name="beam", ref_node=int(ref_node),
            ref_dir=2, ord_data_type=6, num_pts=f.size, abscissa_spacing=1, abscissa_min=float(f[0]),
            abscissa_inc=float(f[1] - f[0]), z_axis_value=0.0, abscissa_spec_data_type=18,
            abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
            abscissa_axis_units_lab="Hz", ordinate_spec_data_type=spec, ordinate_len_unit_exp=1,
            ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0, ordinate_axis_units_lab=label,
            orddenom_spec_data_type=13, orddenom_len_unit_exp=0, orddenom_force_unit_exp=1,
            orddenom_temp_unit_exp=0, orddenom_axis_units_lab="N", z_axis_spec_data_type=0,
            z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
            data=np.ascontiguousarray(data[k]), x=f))
    tmp = atomic_target(path)
    try:
        tmp.unlink()
        pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def complex_text(z: complex) -> str:
    """``"a+bj"`` with 10 significant digits."""
    return f"{z.real:.10g}{z.imag:+.10g}j"


def modal_dict(lam: np.ndarray, psi: np.ndarray, dofs, with_shapes: bool = True) -> dict:
    """Modal-data mapping: eigenvalues (rad/s, upper half-plane), shapes (rows = ``dofs``), frequencies, ratios."""
    lam = np.asarray(lam)
    f_hz = np.abs(lam) / (2 * math.pi)
    zeta = -lam.real / np.abs(lam)
    out = {"natural_frequencies_hz": [float(v) for v in f_hz], "damping_ratios": [float(v) for v in zeta]}
    if with_shapes:
        out["eigenvalues"] = [complex_text(v) for v in lam]
        out["eigenvectors"] = [[complex_text(v) for v in row] for row in np.asarray(psi)]
        out["dofs"] = list(dofs)
    return out


def write_json(path, obj) -> None:
    write_text_atomic(path, json.dumps(obj, indent=1) + "\n")


def write_csv(path, rows: list[dict]) -> None:
    """Rows of flat mappings as CSV (columns: union of keys in first-seen order)."""
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    write_text_atomic(path, buf.getvalue())
