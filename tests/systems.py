"""Shared test helpers: random, lightly and non-proportionally damped systems."""

import numpy as np


def random_system(n, seed, damping=0.02):
    """A stable, underdamped, non-proportionally damped (M, C, K) of ``n`` DOFs.

    ``M`` and ``K`` are random symmetric positive definite matrices; ``C`` is a
    random SPD matrix scaled so the modal damping ratios are about ``damping``
    (light damping) while the modal damping matrix is far from diagonal.
    """
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    M = a @ a.T / n + np.eye(n)
    b = rng.standard_normal((n, n))
    K = 100.0 * (b @ b.T / n + 0.5 * np.eye(n))
    c = rng.standard_normal((n, n))
    C = c @ c.T / n + 0.1 * np.eye(n)
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real
    C *= 2 * damping * np.sqrt(np.max(w2)) / np.max(np.linalg.eigvals(np.linalg.solve(M, C)).real)
    return M, C, K


def write_renumbered_uff(path, frf, nodes, x_mm=None, order=None):
    """Write ``frf`` (receptances at nodes 2..5, any references) as a test system might: nodes renumbered.

    ``nodes`` maps each old node number to the file's; the records go in ``order`` (indices of the response
    DOFs, default the FRF's); with ``x_mm`` ({file node: x in mm}) the file is in millimetres (dataset 164,
    length factor 1000, FRFs in mm/N) with dataset 15 coordinates along x.
    """
    import pyuff

    from physics.io import parse_dof

    scale = 1.0 if x_mm is None else 1000.0
    sets = []
    if x_mm is not None:
        ids = list(x_mm)
        sets += [pyuff.prepare_164(units_code=9, units_description="mm user", temp_mode=1, length=1000.0, force=1.0,
                                   temp=1.0, temp_offset=273.15),
                 pyuff.prepare_15(node_nums=ids, def_cs=[0] * len(ids), disp_cs=[0] * len(ids), color=[1] * len(ids),
                                  x=[float(x_mm[k]) for k in ids], y=[0.0] * len(ids), z=[0.0] * len(ids))]
    for i in (range(len(frf.response_dofs)) if order is None else order):
        for j, ref in enumerate(frf.reference_dofs):
            sets.append(pyuff.prepare_58(
                binary=1, func_type=4, rsp_node=nodes[parse_dof(frf.response_dofs[i])[0]], rsp_dir=2,
                ref_node=nodes[parse_dof(ref)[0]], ref_dir=2, data=np.ascontiguousarray(frf.frf[i, j] * scale),
                x=frf.frequency_hz, abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=8,
                orddenom_spec_data_type=13))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def write_time_uff(path, t_s, channels):
    """Time records as binary UFF 58 (function type 1) through pyuff; returns ``path``.

    ``channels``: ``(node, signal, ordinate code[, units label])`` per record, +Z direction, no reference
    (ordinate codes 13 force, 8 displacement, 12 acceleration).
    """
    import pyuff

    sets = []
    for node, sig, code, *label in channels:
        units = {"abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": label[0]} if label else {}
        sets.append(pyuff.prepare_58(binary=1, func_type=1, rsp_node=int(node), rsp_dir=3, ref_node=0, ref_dir=0,
                                     data=np.ascontiguousarray(sig), x=t_s, abscissa_spacing=1,
                                     abscissa_spec_data_type=17, ordinate_spec_data_type=code,
                                     orddenom_spec_data_type=0, **units))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def big_endian_58b(raw: bytes) -> bytes:
    """A little-endian 58b file rewritten big-endian: byte-ordering field 2, every double byte-swapped."""
    import re

    out, pos = bytearray(), 0
    for m in re.finditer(rb"(?m)^ {4}58b[^\n]*\n", raw):
        end = m.start()
        for _ in range(12):  # the '58b' line and the 11 header records
            end = raw.index(b"\n", end) + 1
        rec7 = raw[m.start():end].split(b"\n")[7]
        n_values = int(rec7[10:20]) * (2 if int(rec7[0:10]) in (5, 6) else 1) * (2 - int(rec7[20:30]))
        data = np.frombuffer(raw[end:end + 8 * n_values], "<f8")
        line = raw[m.start():m.end()]
        out += raw[pos:m.start()] + line[:7] + b"     2" + line[13:] + raw[m.end():end] + data.astype(">f8").tobytes()
        pos = end + 8 * n_values
    return bytes(out + raw[pos:])
