"""Malformed-input corpus: every command of this branch on broken files and arguments.

Each case builds its input in a fresh folder and runs the command in-process. Required of every case:
exit code 2, exactly one line on stderr that names the file (or the flag) and what is wrong, nothing on
stdout, no output file left behind, no warning printed before the error, and a bounded run time.
``python tests/test_malformed.py`` prints the corpus table (cases per family and outcome).
"""

from __future__ import annotations

import atexit
import io
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from systems import write_time_uff  # before the path below drops this directory

if __name__ == "__main__":  # run as a script: tests/physics would shadow the physics package (CASES is built below)
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

DATA = Path(__file__).resolve().parent / "data"
TIME_LIMIT_S = 60.0


# --------------------------------------------------------------------------- builders
def _base_frf():
    from physics.thesis import simulated_beam5_test

    frf, _ = simulated_beam5_test(noise=0.0, seed=0, damping="heavy", df_hz=2.0)
    return frf


def _uff(path, h=None, binary=1, rsp_nodes=(2, 3, 4, 5), x=None, ordinate=8, func_type=4, **extra):
    import pyuff

    frf = _base_frf()
    f = frf.frequency_hz if x is None else x
    data = frf.frf[:, 0, :] if h is None else h
    sets = [pyuff.prepare_58(binary=binary, func_type=func_type, rsp_node=n, rsp_dir=2, ref_node=5, ref_dir=2,
                             data=np.ascontiguousarray(data[i]), x=f, abscissa_spacing=1,
                             abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate,
                             orddenom_spec_data_type=13, **extra)
            for i, n in enumerate(rsp_nodes)]
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def _good_uff(path):
    return _uff(path)


def _npz(path, **arrays):
    frf = _base_frf()
    base = dict(frequency_hz=frf.frequency_hz, frf=frf.frf, response_dofs=np.array(frf.response_dofs),
                reference_dofs=np.array(frf.reference_dofs), kind=np.array("receptance"), units=np.array("m/N"),
                metadata_json=np.array("{}"))
    base.update(arrays)
    base = {k: v for k, v in base.items() if v is not None}
    np.savez(path, **base)
    return path


def _csv(path, text):
    path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
    return path


def _modal(path, obj):
    path.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return path


def _thesis_modal():
    from physics.thesis import beam_state

    return beam_state("undamaged")


def _patch_uff_text(path, old, new, count=1):
    text = path.read_bytes()
    assert old in text, old
    path.write_bytes(text.replace(old, new, count))
    return path


# each case: (family, name, builder(tmp) -> argv list, expected substring of the error line)
def _frf_cases():
    frf = _base_frf()
    h = frf.frf[:, 0, :]
    n = h.shape[-1]
    cases = [
        ("uff", "empty file", lambda d: [_csv(d / "e.uff", "")], "empty"),
        ("uff", "random bytes", lambda d: [_csv(d / "r.uff", np.random.default_rng(0).bytes(5000))],
         "universal file"),
        ("uff", "truncated inside a record", lambda d: [_cut(_good_uff(d / "t.uff"), 0.57)], "truncated"),
        ("uff", "all-zero FRFs", lambda d: [_uff(d / "z.uff", h=np.zeros_like(h))], "zero"),
        ("uff", "denormal FRFs (1e-310)", lambda d: [_uff(d / "dn.uff", h=np.full_like(h, 1e-310 + 1e-310j))],
         "zero"),
        ("uff", "one value of 1e300", lambda d: [_uff(d / "big.uff", h=np.full_like(h, 1e300 + 0j))], "1e+300"),
        ("uff", "random bytes in 58b data", lambda d: [_scramble_58b(_good_uff(d / "s.uff"))], "s.uff"),
        ("uff", "real-valued ordinate", lambda d: [_uff(d / "real.uff", h=np.abs(h))], "real"),
        ("uff", "node field 'B'", lambda d: [_patch_node_b(_uff(d / "b.uff", binary=0))], "b.uff"),
        ("uff", "frequency axis decreasing", lambda d: [_uff(d / "dec.uff", x=frf.frequency_hz[::-1].copy())],
         "increasing"),
        ("uff", "two frequency lines", lambda d: [_uff(d / "two.uff", h=h[:, :2].copy(), x=frf.frequency_hz[:2])],
         "lines"),
        ("uff", "PSD records (function type 9)", lambda d: [_copy(d, "sample_dataset58_psd.uff")], "type 4"),
        ("uff", "geometry only (Test.Lab)", lambda d: [_copy(d, "TestLab_161_164_18_15_82.uff")], "no dataset 58"),
        ("uff", "unknown unit label", lambda d: [_uff(d / "u.uff", ordinate_axis_units_lab="furlong/s")],
         "furlong"),
        ("uff", "header claims 10^9 points", lambda d: [_patch_uff_text(_uff(d / "np.uff", binary=0),
                                                                       f"{n:10d}".encode(), b"1000000000")],
         "np.uff"),
        ("npz", "metadata JSON is a list", lambda d: [_npz(d / "m1.npz", metadata_json=np.array("[1, 2]"))],
         "metadata"),
        ("npz", "metadata JSON is null", lambda d: [_npz(d / "m2.npz", metadata_json=np.array("null"))],
         "metadata"),
        ("npz", "metadata JSON is a number", lambda d: [_npz(d / "m3.npz", metadata_json=np.array("3"))],
         "metadata"),
        ("npz", "metadata not JSON", lambda d: [_npz(d / "m4.npz", metadata_json=np.array("{oops"))], "metadata"),
        ("npz", "string-typed FRF", lambda d: [_npz(d / "s1.npz", frf=np.full(frf.frf.shape, "x"))], "frf"),
        ("npz", "string-typed frequencies", lambda d: [_npz(d / "s2.npz", frequency_hz=np.array(["a"] * n))],
         "frequency"),
        ("npz", "zip of non-npy members", lambda d: [_zip_junk(d / "zj.npz")], "zj.npz"),
        ("npz", "plain .npy named .npz", lambda d: [_npy_as_npz(d / "p.npz")], "p.npz"),
        ("npz", "header claims 5.8 TiB", lambda d: [_huge_npy_header(d / "huge.npz")], "huge.npz"),
        ("npz", "real-valued FRF", lambda d: [_npz(d / "rv.npz", frf=np.abs(frf.frf))], "complex"),
        ("npz", "float16 FRF", lambda d: [_npz(d / "f16.npz", frf=np.abs(frf.frf).astype(np.float16))], "complex"),
        ("npz", "complex frequency axis", lambda d: [_npz(d / "cf.npz", frequency_hz=frf.frequency_hz + 1j)],
         "frequency"),
        ("npz", "DOFs as the string 'abcd'", lambda d: [_npz(d / "dofs.npz", response_dofs=np.array("abcd"))],
         "dofs"),
        ("npz", "missing frf array", lambda d: [_npz(d / "miss.npz", frf=None)], "missing"),
        ("npz", "unknown kind", lambda d: [_npz(d / "k.npz", kind=np.array("inertance"))], "kind"),
        ("csv", "thousands separator 1_000", lambda d: [_csv(d / "u.csv", "frequency_hz,re(2:+Y),im(2:+Y)\n"
                                                                         "1_000,1,1\n2000,1,1\n3000,1,1\n")], "line 2"),
        ("csv", "not UTF-8", lambda d: [_csv(d / "b.csv", b"frequency_hz,re(2:+Y),im(2:+Y)\n\xff\xfe,1,1\n")],
         "UTF-8"),
        ("csv", "header only", lambda d: [_csv(d / "h.csv", "frequency_hz,re(2:+Y),im(2:+Y)\n")], "header"),
        ("csv", "NaN cell", lambda d: [_csv(d / "n.csv", "frequency_hz,re(2:+Y),im(2:+Y)\n1,nan,1\n2,1,1\n"
                                                       "3,1,1\n4,1,1\n")], "NaN"),
        ("csv", "frequency not increasing", lambda d: [_csv(d / "f.csv", "frequency_hz,re(2:+Y),im(2:+Y)\n"
                                                                       "2,1,1\n1,1,1\n3,1,1\n4,1,1\n")], "increasing"),
        ("csv", "all-zero FRF", lambda d: [_csv(d / "z.csv", "frequency_hz,re(2:+Y),im(2:+Y)\n"
                                                + "".join(f"{k},0,0\n" for k in range(1, 50)))], "zero"),
        ("csv", "JSON named .csv", lambda d: [_csv(d / "j.csv", '{"a": 1}')], "j.csv"),
        ("csv", "200k-line CSV of one mode", lambda d: [_big_csv(d / "big.csv")], "200000 lines"),
    ]
    return cases


def _cut(path, frac):
    raw = path.read_bytes()
    path.write_bytes(raw[: int(len(raw) * frac)])
    return path


def _copy(d, name):
    out = d / name
    out.write_bytes((DATA / name).read_bytes())
    return out


def _scramble_58b(path):
    raw = bytearray(path.read_bytes())
    rng = np.random.default_rng(1)
    start = raw.find(b"\n", raw.find(b"    58b") + 1)
    for _ in range(12):  # skip the 11 header lines
        start = raw.find(b"\n", start + 1)
    stop = raw.find(b"    -1", start)
    raw[start + 1: stop] = rng.bytes(stop - start - 1)
    path.write_bytes(bytes(raw))
    return path


def _patch_node_b(path):
    lines = path.read_text().splitlines(keepends=True)
    for i, line in enumerate(lines):  # record 6 of the first dataset: function type, ..., response node
        if line.startswith("    58") and not line.startswith("    58b"):
            rec6 = lines[i + 6]
            lines[i + 6] = rec6[:41] + "         B" + rec6[51:]  # the response node field, I10
            break
    path.write_text("".join(lines))
    return path


def _zip_junk(path):
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("frf.txt", "hello")
        z.writestr("frequency_hz.bin", b"\x00" * 16)
    return path


def _npy_as_npz(path):
    buf = io.BytesIO()
    np.save(buf, np.arange(10.0))
    path.write_bytes(buf.getvalue())
    return path


def _huge_npy_header(path):
    frf = _base_frf()
    _npz(path)
    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    raw = members["frf.npy"]
    hl = int.from_bytes(raw[8:10], "little")
    header = raw[10:10 + hl].decode("latin1")
    old = str(frf.frf.shape)
    new_header = header.replace(old, "(4, 1, 400000000000)")
    new_header = new_header.rstrip("\n").ljust(len(header) - 1) + "\n"
    members["frf.npy"] = raw[:10] + new_header.encode("latin1")[: hl] + raw[10 + hl:]
    with zipfile.ZipFile(path, "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    return path


def _big_csv(path):
    f = np.arange(1, 200_001) * 0.005
    w, wn = 2 * np.pi * f, 2 * np.pi * 300.0
    h = 1 / (wn**2 - w**2 + 2j * 0.01 * wn * w)
    rows = "\n".join(f"{a:.6f},{b.real:.6e},{b.imag:.6e}" for a, b in zip(f, h))
    path.write_text("frequency_hz,re(2:+Y),im(2:+Y)\n" + rows + "\n")
    return path


def _modal_cases():
    good = _thesis_modal()
    vec = good["eigenvectors"]
    zero_row = [row[:] for row in vec]
    zero_row[1] = ["0"] * len(zero_row[1])
    real_vecs = [[str(complex(z).real) for z in row] for row in vec]
    dup = dict(good, eigenvalues=[good["eigenvalues"][0]] * 2 + good["eigenvalues"][2:])
    lower = dict(good, eigenvalues=[str(complex(z).conjugate()) for z in good["eigenvalues"]])
    return [
        ("modal-json", "a list, not an object", lambda d: _upd(_modal(d / "l.json", [1, 2])), "object"),
        ("modal-json", "missing eigenvalues", lambda d: _upd(_modal(d / "m.json", {"dofs": []})), "eigenvalues"),
        ("modal-json", "zero eigenvector row", lambda d: _upd(_modal(d / "z.json", dict(good, eigenvectors=zero_row))),
         "eigenvectors"),
        ("modal-json", "string rows", lambda d: _upd(_modal(d / "s.json", dict(good, eigenvectors=["ab", "cd",
                                                                                               "ef", "gh"]))),
         "eigenvectors"),
        ("modal-json", "not UTF-8", lambda d: _upd(_bytes(d / "b.json", b'{"eigenvalues": ["\xff"]}')), "UTF-8"),
        ("modal-json", "nesting 100k deep", lambda d: _upd(_modal(d / "deep.json", "[" * 100_000 + "]" * 100_000)),
         "deep.json"),
        ("modal-json", "real eigenvectors", lambda d: _upd(_modal(d / "r.json", dict(good, eigenvectors=real_vecs))),
         "r.json"),
        ("modal-json", "duplicated eigenvalue", lambda d: _upd(_modal(d / "dup.json", dup)), "dup.json"),
        ("modal-json", "lower-half-plane eigenvalues (direct)",
         lambda d: _upd(_modal(d / "low.json", lower), "--method", "direct"), "low.json"),
        ("modal-json", "huge vectors (direct)",
         lambda d: _upd(_modal(d / "h.json", dict(good, eigenvectors=[["1e300+1e300j"] * 4] * 4)), "--method",
                        "direct"), "h.json"),
        ("modal-json", "not JSON", lambda d: _upd(_modal(d / "n.json", "{eigen")), "JSON"),
        ("modal-json", "missing file", lambda d: _upd(d / "absent.json"), "absent.json"),
    ]


def _bytes(path, b):
    path.write_bytes(b)
    return path


def _upd(path, *more):
    return ["update", "--modal", str(path), *more]


def _arg_cases():
    return [
        ("args", "identify --modes -2", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--modes", "-2"],
         "--modes"),
        ("args", "identify --modes 0", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--modes", "0"],
         "--modes"),
        ("args", "identify --max-order 2000", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--max-order",
                                                         "2000"], "--max-order"),
        ("args", "identify --max-order 0", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--max-order", "0"],
         "--max-order"),
        ("args", "identify --band reversed", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--band", "500",
                                                        "100"], "--band"),
        ("args", "identify --band outside the data", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--band",
                                                                "5000", "6000"], "band"),
        ("args", "identify --band nan", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--band", "nan", "100"],
         "--band"),
        ("args", "identify --out is a file", lambda d: ["identify", str(_good_uff(d / "g.uff")), "--out",
                                                        str(_csv(d / "f.txt", "x"))], "--out"),
        ("args", "model --elements 100000", lambda d: ["model", "--elements", "100000"], "--elements"),
        ("args", "model --elements 0", lambda d: ["model", "--elements", "0"], "--elements"),
        ("args", "update --tol -1", lambda d: ["update", "--modal", str(_modal(d / "ok.json", _thesis_modal())),
                                               "--tol", "-1"], "--tol"),
        ("args", "update --max-iter 0", lambda d: ["update", "--modal", str(_modal(d / "ok.json", _thesis_modal())),
                                                   "--max-iter", "0"], "--max-iter"),
        ("args", "estimate --averages 0", lambda d: ["estimate", str(d / "x.uff"), "--averages", "0"], "--averages"),
        ("args", "estimate --overlap 1.5", lambda d: ["estimate", str(d / "x.uff"), "--overlap", "1.5"], "--overlap"),
        ("args", "estimate --decay 0", lambda d: ["estimate", str(d / "x.uff"), "--decay", "0"], "--decay"),
        ("args", "estimate unknown --reference", lambda d: ["estimate", str(_impact_uff(d / "i.uff")), "--reference",
                                                            "9:+Z"], "9:+Z"),
        ("args", "estimate on an FRF file", lambda d: ["estimate", str(_good_uff(d / "g.uff"))], "time record"),
        ("args", "unknown command", lambda d: ["frobnicate"], "invalid choice"),
    ]


def _impact_uff(path):
    t = np.arange(4096) / 1024.0
    force = np.where(t % 1.0 < 0.002, 100.0, 0.0)
    return write_time_uff(path, t, [(1, force, 13), (2, np.sin(2 * np.pi * 40 * t) * np.exp(-3 * (t % 1.0)), 12)])


# --------------------------------------------------------------------------- datasets and models
_SHARED: dict = {}


def _shared(name, build):
    """``build(path)`` once per process into a temporary folder (removed at exit); returns the path."""
    if "tmp" not in _SHARED:
        _SHARED["tmp"] = Path(tempfile.mkdtemp(prefix="beam-damage-corpus-"))
        atexit.register(shutil.rmtree, _SHARED["tmp"], True)
    path = _SHARED["tmp"] / name
    if name not in _SHARED:
        build(path)
        _SHARED[name] = path
    return path


def _tiny_dataset():
    """A complete training-config dataset: 48 samples in 3 shards of 16, 64 FRF lines (about 2 s)."""
    def build(root):
        from datagen.config import load_config, merge
        from datagen.generation import generate

        cfg = merge({"measurement": {"lines": 64}, "output": {"shard_size": 16}}, base=load_config("training"))
        generate(root, cfg, n=48, seed=0, progress=False)
    return _shared("dataset", build)


def _tiny_model():
    """A classifier trained one epoch on :func:`_tiny_dataset` (modal route, about 3 s)."""
    def build(out):
        from learn.network.training import train

        train(_tiny_dataset(), out, epochs=1, seed=0)
    return _shared("model", build)


def _copy_tree(src, dst, damage=None):
    """A fresh copy of a shared folder, damaged by ``damage(dst)``."""
    shutil.copytree(src, dst)
    if damage is not None:
        damage(dst)
    return dst


def _ds_copy(d, damage=None):
    return _copy_tree(_tiny_dataset(), d / "ds", damage)


def _model_copy(d, damage=None):
    return _copy_tree(_tiny_model(), d / "model", damage)


def _flip(path, offset=-5):
    raw = bytearray(path.read_bytes())
    raw[offset] ^= 0xFF  # same size: only the checksum sees it
    path.write_bytes(bytes(raw))


def _garble_npy_header(path):
    raw = bytearray(path.read_bytes())
    raw[10:20] = b"{'zzzzz': "  # same size, header no longer a dict of descr/shape
    path.write_bytes(bytes(raw))


def _edit_manifest(root, edit):
    m = json.loads((root / "manifest.json").read_text())
    m = edit(m)
    (root / "manifest.json").write_text(m if isinstance(m, str) else json.dumps(m))


def _no_finished_shard(root):
    def edit(m):
        for k in ("counts", "checksums", "columns"):
            m.pop(k, None)
        return dict(m, shards=[], complete=False)
    _edit_manifest(root, edit)
    (root / "samples.parquet").unlink()
    shutil.rmtree(root / "shards")


SHARD = "shards/shard-000001"

#: (name, damage(root), expected substring of the error line)
DAMAGE = [
    ("flipped data byte in a shard .npy", lambda r: _flip(r / SHARD / "eigenvalues_measured.npy"),
     "shard-000001/eigenvalues_measured.npy"),
    ("flipped byte in omega_rad_s.npy", lambda r: _flip(r / "omega_rad_s.npy", -3), "omega_rad_s.npy"),
    ("truncated shard samples.parquet", lambda r: _cut(r / SHARD / "samples.parquet", 0.5),
     "shard-000001/samples.parquet"),
    ("deleted shard file", lambda r: (r / "shards/shard-000002/K_updated.npy").unlink(),
     "shard-000002/K_updated.npy"),
    ("missing shard directory", lambda r: shutil.rmtree(r / SHARD), "shard-000001"),
    ("manifest is a list", lambda r: _edit_manifest(r, lambda m: "[1, 2]"), "manifest.json"),
    ("manifest lacks shards", lambda r: _edit_manifest(r, lambda m: {k: v for k, v in m.items() if k != "shards"}),
     "shards"),
    ("manifest shard entry is a string", lambda r: _edit_manifest(r, lambda m: dict(m, shards=["shard-000000"])),
     "shards"),
    ("manifest not JSON", lambda r: (r / "manifest.json").write_text("{oops"), "manifest.json"),
    ("manifest not UTF-8", lambda r: (r / "manifest.json").write_bytes(b'{"format": "\xff"}'), "UTF-8"),
    ("no finished shard", _no_finished_shard, "incomplete"),
    ("bad .npy header in a shard", lambda r: _garble_npy_header(r / SHARD / "truth_poles.npy"),
     "shard-000001/truth_poles.npy"),
    ("bad .npy header of omega_rad_s.npy", lambda r: _garble_npy_header(r / "omega_rad_s.npy"), "omega_rad_s.npy"),
    ("top-level samples.parquet truncated", lambda r: _cut(r / "samples.parquet", 0.5), "ds/samples.parquet"),
    ("shard entry of another seed", lambda r: _edit_manifest(r, lambda m: dict(m, shards=[
        dict(e, identity=dict(e["identity"], seed=99)) if e["index"] == 1 else e for e in m["shards"]])),
     "shard-000001: belongs to another dataset"),
    ("shard entry without identity", lambda r: _edit_manifest(r, lambda m: dict(m, shards=[
        {k: v for k, v in e.items() if k != "identity"} if e["index"] == 1 else e for e in m["shards"]])),
     "shard-000001: belongs to another dataset"),
]

#: Commands that read datasets: name -> argv(dataset dir, case dir).
READERS = {
    "inspect": lambda ds, d: ["inspect", str(ds)],
    "train": lambda ds, d: ["train", "--data", str(ds), "--out", str(d / "model-out"), "--epochs", "1"],
    "export": lambda ds, d: ["export", str(ds), "--samples", "0,17,40", "--out", str(d / "export-out")],
    "evaluate": lambda ds, d: ["evaluate", "--model", str(_tiny_model()), "--data", str(ds), "--out",
                               str(d / "eval-out")],
}


def _dataset_cases():
    return [("dataset", f"{cmd}: {name}", (lambda d, f=damage, a=argv: a(_ds_copy(d, f), d)), expect)
            for name, damage, expect in DAMAGE for cmd, argv in READERS.items()]


def _gen(d, *more):
    return ["generate", "--n", "4", "--out", str(d / "gen"), *more]


def _toml(path, text):
    path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
    return str(path)


def _modal_arg(d, name="m.json"):
    return str(_modal(d / name, _thesis_modal()))


def _cls(d, *more, model=None):
    return ["classify", "--model", str(model or _tiny_model()), "--baseline", _modal_arg(d, "b.json"),
            _modal_arg(d, "c.json"), "--json", *more]


def _measured():
    from physics.discrepancy import EXAMPLE

    return str(EXAMPLE)


def _dsc(*more):
    return ["discrepancy", "--beam", "beam5", "--measured", _measured(), *more]


def _command_arg_cases():
    """Argument families of generate, train, classify, evaluate, export, discrepancy, inspect, demo."""
    f = lambda d: str(_csv(d / "f.txt", "x"))  # noqa: E731 - a plain file where a directory is expected
    bad_weights = lambda m: (m / "weights-modal.npz").write_bytes(np.random.default_rng(0).bytes(300))  # noqa: E731
    return [(fam, name, b, expect) for fam, name, b, expect in [
        ("generate", "--seed -1", lambda d: _gen(d, "--seed", "-1"), "--seed"),
        ("generate", "--n 0", lambda d: ["generate", "--n", "0", "--out", str(d / "gen")], "--n"),
        ("generate", "--n -5", lambda d: ["generate", "--n", "-5", "--out", str(d / "gen")], "--n"),
        ("generate", "--n 10^15 (no disk holds it)", lambda d: ["generate", "--n", str(10**15), "--out",
                                                                str(d / "gen")], "--n"),
        ("generate", "--workers 0", lambda d: _gen(d, "--workers", "0"), "--workers"),
        ("generate", "--scheduler 'not a url'", lambda d: _gen(d, "--scheduler", "not a url"), "--scheduler"),
        ("generate", "--scheduler unknown scheme", lambda d: _gen(d, "--scheduler", "foo://host:1"), "--scheduler"),
        ("generate", "--config unknown name", lambda d: _gen(d, "--config", "no-such-config"), "no-such-config"),
        ("generate", "--config not UTF-8", lambda d: _gen(d, "--config", _toml(d / "c.toml", b"[mesh]\n# \xff\n")),
         "UTF-8"),
        ("generate", "--config malformed TOML", lambda d: _gen(d, "--config", _toml(d / "c.toml", "[mesh\n")), "TOML"),
        ("generate", "--config unknown key", lambda d: _gen(d, "--config", _toml(d / "c.toml", "[mesh]\nfoo = 1\n")),
         "mesh.foo"),
        ("generate", "--config lines = 0", lambda d: _gen(d, "--config", _toml(d / "c.toml",
                                                                                "[measurement]\nlines = 0\n")),
         "measurement.lines"),
        ("generate", "--config is a directory", lambda d: _gen(d, "--config", str(d)), "directory"),
        ("generate", "--beam missing file", lambda d: _gen(d, "--beam", str(d / "absent.toml")), "absent.toml"),
        ("generate", "--beam malformed TOML", lambda d: _gen(d, "--beam", _toml(d / "b.toml", "[beam\n")), "TOML"),
        ("generate", "--beam not UTF-8", lambda d: _gen(d, "--beam", _toml(d / "b.toml", b"name = '\xff'\n")),
         "UTF-8"),
        ("generate", "--beam and --preset", lambda d: _gen(d, "--beam", "beam5", "--preset", "beam6"), "--beam"),
        ("generate", "--out is a file", lambda d: ["generate", "--n", "4", "--out", f(d)], "f.txt"),
        ("generate", "--out a folder of other files", lambda d: ["generate", "--n", "4", "--out",
                                                                 str(_csv(d / "x.csv", "x").parent)], "not empty"),
        ("train", "--data not a dataset", lambda d: ["train", "--data", str(d), "--out", str(d / "m")],
         "not a dataset"),
        ("train", "--data does not exist", lambda d: ["train", "--data", str(d / "nope"), "--out", str(d / "m")],
         "nope"),
        ("train", "--epochs 0", lambda d: ["train", "--data", str(_ds_copy(d)), "--out", str(d / "m"), "--epochs",
                                           "0"], "--epochs"),
        ("train", "--threads 0", lambda d: ["train", "--data", str(_ds_copy(d)), "--out", str(d / "m"), "--threads",
                                            "0"], "--threads"),
        ("train", "--seed -1", lambda d: ["train", "--data", str(_ds_copy(d)), "--out", str(d / "m"), "--seed", "-1",
                                          "--epochs", "1"], "--seed"),
        ("train", "--out is a file", lambda d: ["train", "--data", str(_ds_copy(d)), "--out", f(d), "--epochs", "1"],
         "--out"),
        ("train", "--route bogus", lambda d: ["train", "--data", str(d), "--out", str(d / "m"), "--route", "bogus"],
         "invalid choice"),
        ("classify", "missing model directory", lambda d: _cls(d, model=d / "nomodel"), "nomodel"),
        ("classify", "model config.json not JSON", lambda d: _cls(d, model=_model_copy(
            d, lambda m: (m / "config.json").write_text("{oops"))), "config.json"),
        ("classify", "model config.json not UTF-8", lambda d: _cls(d, model=_model_copy(
            d, lambda m: (m / "config.json").write_bytes(b'{"format": "\xff"}'))), "config.json"),
        ("classify", "model config.json a list", lambda d: _cls(d, model=_model_copy(
            d, lambda m: (m / "config.json").write_text("[1]"))), "config.json"),
        ("classify", "model config.json lacks route", lambda d: _cls(d, model=_model_copy(
            d, lambda m: _edit_json(m / "config.json", lambda c: {k: v for k, v in c.items() if k != "route"}))),
         "route"),
        ("classify", "model config.json a link to /dev/zero", lambda d: _cls(d, model=_model_copy(
            d, lambda m: ((m / "config.json").unlink(), (m / "config.json").symlink_to("/dev/zero")))),
         "character device"),
        ("classify", "weights file missing", lambda d: _cls(d, model=_model_copy(
            d, lambda m: (m / "weights-modal.npz").unlink())), "weights-modal.npz"),
        ("classify", "weights file random bytes", lambda d: _cls(d, model=_model_copy(d, bad_weights)),
         "weights-modal.npz"),
        ("classify", "weights file truncated", lambda d: _cls(d, model=_model_copy(
            d, lambda m: _cut(m / "weights-modal.npz", 0.5))), "weights-modal.npz"),
        ("classify", "weights of another network (an empty dict)", lambda d: _cls(d, model=_model_copy(
            d, lambda m: np.savez(m / "weights-modal.npz"))), "weights-modal.npz"),
        ("classify", "config.json network without params", lambda d: _cls(d, model=_model_copy(
            d, lambda m: _edit_json(m / "config.json", lambda c: dict(c, networks={"modal": {}})))),
         "weights-modal.npz"),
        ("classify", "missing baseline file", lambda d: ["classify", "--model", str(_tiny_model()), "--baseline",
                                                        str(d / "absent.uff"), str(_good_uff(d / "g.uff"))],
         "absent.uff"),
        ("classify", "missing measured file", lambda d: ["classify", "--model", str(_tiny_model()), "--baseline",
                                                        str(_good_uff(d / "g.uff")), str(d / "absent.uff")],
         "absent.uff"),
        ("classify", "--out is a file", lambda d: _cls(d, "--out", f(d)), "f.txt"),
        ("evaluate", "missing model directory", lambda d: ["evaluate", "--model", str(d / "nomodel"), "--data",
                                                           str(_ds_copy(d))], "nomodel"),
        ("evaluate", "--data not a dataset", lambda d: ["evaluate", "--model", str(_tiny_model()), "--data", str(d)],
         "not a dataset"),
        ("evaluate", "corrupt weights", lambda d: ["evaluate", "--model", str(_model_copy(d, bad_weights)), "--data",
                                                   str(_ds_copy(d))], "weights-modal.npz"),
        ("evaluate", "--out is a file", lambda d: ["evaluate", "--model", str(_tiny_model()), "--data",
                                                   str(_ds_copy(d)), "--out", f(d)], "f.txt"),
        ("export", "--samples 5,x", lambda d: ["export", str(_ds_copy(d)), "--samples", "5,x", "--out",
                                               str(d / "e")], "--samples"),
        ("export", "--samples 99999", lambda d: ["export", str(_ds_copy(d)), "--samples", "99999", "--out",
                                                 str(d / "e")], "--samples"),
        ("export", "--samples ','", lambda d: ["export", str(_ds_copy(d)), "--samples", ",", "--out", str(d / "e")],
         "--samples"),
        ("export", "--samples 0,,1", lambda d: ["export", str(_ds_copy(d)), "--samples", "0,,1", "--out",
                                                str(d / "e")], "--samples"),
        ("export", "--format bogus", lambda d: ["export", str(_ds_copy(d)), "--samples", "0", "--format", "bogus",
                                                "--out", str(d / "e")], "invalid choice"),
        ("export", "--out inside a file", lambda d: ["export", str(_ds_copy(d)), "--samples", "0", "--out",
                                                     f(d) + "/sub"], "f.txt"),
        ("export", "not a dataset", lambda d: ["export", str(d), "--samples", "0", "--out", str(d / "e")],
         "not a dataset"),
        ("discrepancy", "--measured missing", lambda d: _dsc_m(d / "absent.json"), "absent.json"),
        ("discrepancy", "--measured not JSON", lambda d: _dsc_m(_modal(d / "n.json", "{oops")), "JSON"),
        ("discrepancy", "--measured not UTF-8", lambda d: _dsc_m(_bytes(d / "u.json", b'{"a": "\xff"}')), "UTF-8"),
        ("discrepancy", "--measured a list", lambda d: _dsc_m(_modal(d / "l.json", [1, 2])), "l.json"),
        ("discrepancy", "--measured empty frequencies", lambda d: _dsc_m(_modal(
            d / "e.json", {"natural_frequencies_hz": []})), "e.json"),
        ("discrepancy", "--measured negative frequency", lambda d: _dsc_m(_modal(
            d / "neg.json", {"natural_frequencies_hz": [-10.0, 60.0, 170.0]})), "neg.json"),
        ("discrepancy", "--measured FRF file truncated", lambda d: _dsc_m(_cut(_good_uff(d / "t.uff"), 0.57)),
         "t.uff"),
        ("discrepancy", "--beam missing file", lambda d: ["discrepancy", "--beam", str(d / "absent.toml"),
                                                          "--measured", _measured()], "absent.toml"),
        ("discrepancy", "--beam malformed TOML", lambda d: ["discrepancy", "--beam", _toml(d / "b.toml", "[x\n"),
                                                            "--measured", _measured()], "TOML"),
        ("discrepancy", "--elements 0", lambda d: _dsc("--elements", "0"), "--elements"),
        ("discrepancy", "--elements 100000", lambda d: _dsc("--elements", "100000"), "--elements"),
        ("discrepancy", "--max-effects -1", lambda d: _dsc("--max-effects", "-1"), "--max-effects"),
        ("discrepancy", "--frequency-noise nan", lambda d: _dsc("--frequency-noise", "nan"), "--frequency-noise"),
        ("discrepancy", "--out is a file", lambda d: _dsc("--out", f(d)), "f.txt"),
        ("inspect", "not a dataset", lambda d: ["inspect", str(d)], "not a dataset"),
        ("inspect", "does not exist", lambda d: ["inspect", str(d / "nope")], "nope"),
        ("inspect", "a file", lambda d: ["inspect", f(d)], "f.txt"),
        ("inspect", "--out inside a file", lambda d: ["inspect", str(_ds_copy(d)), "--out", f(d) + "/sub"], "f.txt"),
        ("demo", "--samples -1", lambda d: ["demo", "--samples", "-1", "--out", str(d / "demo")], "--samples"),
        ("demo", "--samples 0", lambda d: ["demo", "--samples", "0", "--out", str(d / "demo")], "--samples"),
        ("demo", "--workers 0", lambda d: ["demo", "--workers", "0", "--out", str(d / "demo")], "--workers"),
        ("demo", "--out is a file", lambda d: ["demo", "--quick", "--out", f(d)], "f.txt"),
    ]]


def _dsc_m(path):
    return ["discrepancy", "--beam", "beam5", "--measured", str(path)]


def _edit_json(path, edit):
    path.write_text(json.dumps(edit(json.loads(path.read_text()))))


# --------------------------------------------------------------------------- boundary classes (issue 18)
def _with(**changes):
    return dict(_thesis_modal(), **changes)


def _vectors(edit):
    vec = [row[:] for row in _thesis_modal()["eigenvectors"]]
    return edit(vec) or vec


def _scaled(factor):
    return [[str(complex(z) * factor) for z in row] for row in _thesis_modal()["eigenvectors"]]


def _dup_column(vec):
    for row in vec:
        row[1] = row[0]


#: Modal data that break the updating's linear algebra: (name, modal JSON mapping, expected substring).
_ILL_CONDITIONED = [
    ("digit-string rows '1234'", _with(eigenvectors=["1234", "5678", "1357", "2468"]), "row 1 is a str"),
    ("all-ones eigenvectors (rank 1)", _with(eigenvectors=[[1, 1, 1, 1]] * 4), "linearly dependent"),
    ("duplicated row", _with(eigenvectors=_vectors(lambda v: v.__setitem__(1, v[0]))), "linearly dependent"),
    ("duplicated column", _with(eigenvectors=_vectors(_dup_column)), "linearly dependent"),
    ("dependent integer rows", _with(eigenvectors=[[1, 2, 3, 4], [2, 3, 4, 5], [5, 1, 2, 3], [1, 0, 1, 2]]),
     "linearly dependent"),
    ("shapes of 1e-300", _with(eigenvectors=[["1e-300"] * 4] * 4), "eigenvectors"),
    ("one mode scaled by 1e-300", _with(eigenvectors=[[str(complex(z) * (1e-300 if j == 2 else 1))
                                                       for j, z in enumerate(row)]
                                                      for row in _thesis_modal()["eigenvectors"]]), "column 3"),
    ("eigenvalues of 1e-300 rad/s", _with(eigenvalues=[str(complex(z) * 1e-300)
                                                      for z in _thesis_modal()["eigenvalues"]]), "eigenvalues"),
    ("real-number rows 1.5", _with(eigenvectors=[1.5, 2.5, 3.5, 4.5]), "row 1 is a float"),
    ("real-valued shapes inconsistent with the mass", _with(eigenvectors=[[1.5, 2.5, 3.5, 4.5], [0.5, -1, 2, 3],
                                                                          [1, 1, -2, 0.3], [2, -3, 1, 1]]),
     "does not reproduce the measured modes"),
    ("one row scaled by 1e-300", _with(eigenvectors=[[str(complex(z) * (1e-300 if i == 2 else 1)) for z in row]
                                                     for i, row in enumerate(_thesis_modal()["eigenvectors"])]),
     "linearly dependent"),
    ("non-numeric strings 'abc'", _with(eigenvectors=[["abc"] * 4] * 4), "complex strings"),
]

_MODAL_FIELDS = [
    ("damping ratio -5", {"natural_frequencies_hz": [21.5, 129.7, 346.1, 634.1], "damping_ratios": [-5, 0.002, 0.003,
                                                                                                   0.004]},
     "damping_ratios"),
    ("damping ratio 1", {"natural_frequencies_hz": [21.5, 129.7, 346.1, 634.1], "damping_ratios": [1, 0.002, 0.003,
                                                                                                  0.004]},
     "damping_ratios"),
    ("boolean frequency", {"natural_frequencies_hz": [True, 129.7, 346.1, 634.1], "damping_ratios": [0.001] * 4},
     "natural_frequencies_hz"),
    ("frequency 1e-300 Hz", {"natural_frequencies_hz": [1e-300, 129.7, 346.1, 634.1], "damping_ratios": [0.001] * 4},
     "natural_frequencies_hz"),
    ("frequencies and damping of unequal length", {"natural_frequencies_hz": [21.5, 129.7],
                                                   "damping_ratios": [0.001] * 3}, "damping_ratios"),
    ("dofs labels 'a'..'d'", _with(dofs=["a", "b", "c", "d"]), "dofs"),
    ("dofs labels as numbers", _with(dofs=[2, 3, 4, 5]), "dofs"),
    ("eigenvectors an object", _with(eigenvectors={"a": 1}), "is a dict"),
    ("eigenvectors a string", _with(eigenvectors="abc"), "is a str"),
    ("eigenvalues a string", _with(eigenvalues="-0.2+135j"), "eigenvalues"),
]


def _boundary_modal_cases():
    cases = [("modal-json", f"{name}{' (direct)' if direct else ''}",
              lambda d, o=obj, m=direct: _upd(_modal(d / "m.json", o), *(["--method", "direct"] if m else [])),
              expect)
             for name, obj, expect in _ILL_CONDITIONED for direct in (False, True)]
    cases += [("modal-json", name, lambda d, o=obj: _upd(_modal(d / "m.json", o)), expect)
              for name, obj, expect in _MODAL_FIELDS]
    cases += [
        ("discrepancy", "--measured nested 100k deep",
         lambda d: _dsc_m(_modal(d / "deep.json", "[" * 100_000 + "]" * 100_000)), "deep.json"),
        ("discrepancy", "--measured boolean frequency",
         lambda d: _dsc_m(_modal(d / "b.json", {"natural_frequencies_hz": [True, 60.0, 170.0]})),
         "natural_frequencies_hz"),
        ("discrepancy", "--measured shapes of 1e-300",
         lambda d: _dsc_m(_modal(d / "t.json", _with(eigenvectors=[["1e-300"] * 4] * 4))), "eigenvectors"),
        ("discrepancy", "--measured dofs 'a'..'d'",
         lambda d: _dsc_m(_modal(d / "a.json", _with(dofs=["a", "b", "c", "d"]))), "dofs"),
        ("classify", "measured digit-string rows",
         lambda d: ["classify", "--model", str(_tiny_model()), "--baseline", _modal_arg(d, "b.json"),
                    str(_modal(d / "c.json", _with(eigenvectors=["1234"] * 4))), "--json"], "c.json"),
        ("classify", "baseline damping ratio -5",
         lambda d: ["classify", "--model", str(_tiny_model()), "--baseline", str(_modal(d / "b.json", dict(
             _MODAL_FIELDS[0][1], eigenvectors=_thesis_modal()["eigenvectors"]))), _modal_arg(d, "c.json"),
                    "--json"], "b.json"),
    ]
    return cases


#: Numeric fields of a dataset 58 header: (line after the '58' line, -1 = that line; first, last column; name).
_UFF_FIELDS = [
    (-1, 8, 13, "byte ordering"), (-1, 14, 19, "floating-point format"), (-1, 20, 31, "ASCII header lines"),
    (-1, 32, 43, "binary bytes"),
    (5, 1, 5, "function type"), (5, 6, 15, "function id"), (5, 16, 20, "version number"), (5, 21, 30, "load case"),
    (5, 42, 51, "response node"), (5, 52, 55, "response direction"), (5, 67, 76, "reference node"),
    (5, 77, 80, "reference direction"),
    (6, 1, 10, "ordinate data type"), (6, 11, 20, "number of points"), (6, 21, 30, "abscissa spacing"),
    (6, 31, 43, "abscissa minimum"), (6, 44, 56, "abscissa increment"), (6, 57, 69, "z-axis value"),
    *((7 + k, a, b, f"{axis} {name}") for k, axis in enumerate(("abscissa", "ordinate", "ordinate denominator",
                                                                "z-axis"))
      for a, b, name in ((1, 10, "data type"), (11, 15, "length exponent"), (16, 20, "force exponent"),
                         (21, 25, "temperature exponent"))),
]


def _patch_field(path, line, first, last, text):
    """Write ``text`` (right-aligned) into columns ``first``-``last`` of a header line of the first dataset 58."""
    lines = path.read_bytes().split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(b"    58")) + (0 if line == -1 else 1 + line)
    old = lines[i].decode("latin1").rstrip("\r").ljust(80)
    lines[i] = (old[:first - 1] + text.rjust(last - first + 1) + old[last:]).encode("latin1")
    path.write_bytes(b"\n".join(lines))
    return path


def _uff_field_cases():
    cases = [("uff-header", f"{name} field 'x'",
              lambda d, ln=line, a=first, b=last: [_patch_field(_uff(d / "h.uff", binary=int(ln == -1)), ln, a, b,
                                                                "x")], name)
             for line, first, last, name in _UFF_FIELDS]
    codes = [(-1, 8, 13, "3", "byte ordering"), (-1, 14, 19, "3", "floating-point format"),
             (6, 1, 10, "3", "ordinate data type"), (6, 21, 30, "2", "abscissa spacing")]
    cases += [("uff-header", f"{name} code {text}",
               lambda d, ln=line, a=first, b=last, t=text: [_patch_field(_uff(d / "c.uff", binary=int(ln == -1)), ln,
                                                                         a, b, t)], name)
              for line, first, last, text, name in codes]
    bad = lambda d, name="h.uff": _patch_field(_uff(d / name, binary=0), 6, 11, 20, "4OO")  # noqa: E731
    cases += [
        ("uff-header", "warning (unknown dataset) before the error",
         lambda d: [_prepend_unknown_set(bad(d))], "number of points"),
        ("uff-header", "update --modal", lambda d: ["update", "--modal", str(bad(d))], "number of points"),
        ("uff-header", "classify --baseline", lambda d: ["classify", "--model", str(_tiny_model()), "--baseline",
                                                         str(bad(d)), str(_good_uff(d / "g.uff")), "--json"],
         "number of points"),
        ("uff-header", "discrepancy --measured", lambda d: _dsc_m(bad(d)), "number of points"),
        ("uff-header", "estimate (time records)", lambda d: ["estimate", str(_patch_field(
            _impact_uff(d / "i.uff"), 5, 42, 51, "B"))], "response node"),
        ("uff-header", "estimate 58b byte ordering 0", lambda d: ["estimate", str(_patch_field(
            _impact_uff(d / "i.uff"), -1, 8, 13, "0"))], "byte ordering"),
    ]
    return cases


def _geometry_uff(path):
    """An FRF file with units (164, mm) and nodes (15) before the dataset 58 records."""
    import pyuff

    pyuff.UFF(str(path)).write_sets([
        pyuff.prepare_164(units_code=5, units_description="mm", temp_mode=1, length=1000.0, force=1.0, temp=1.0,
                          temp_offset=273.15),
        pyuff.prepare_15(node_nums=[2, 3, 4, 5], def_cs=[0] * 4, disp_cs=[0] * 4, color=[1] * 4,
                         x=[152.4, 304.8, 457.2, 609.6], y=[0.0] * 4, z=[0.0] * 4)], mode="add")
    raw = path.read_bytes()
    _uff(path, ordinate_axis_units_lab="mm/N")
    path.write_bytes(raw + path.read_bytes()[len(raw):])
    return path


def _patch_set_line(path, dataset, line, old, new):
    """Replace ``old`` by ``new`` in the ``line``-th line after the number line of the first ``dataset`` block."""
    lines = path.read_bytes().split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.strip() == str(dataset).encode()) + line
    assert old in lines[i], (lines[i], old)
    lines[i] = lines[i].replace(old, new, 1)
    path.write_bytes(b"\n".join(lines))
    return path


def _context_cases():
    geo = lambda d, *a: [_patch_set_line(_geometry_uff(d / "g.uff"), *a)]  # noqa: E731
    return [
        ("uff-header", "geometry file is read (then --max-iter 0)",
         lambda d: ["update", "--modal", str(_geometry_uff(d / "g.uff")), "--max-iter", "0"], "--max-iter"),
        ("uff-header", "164 units code 'x'", lambda d: geo(d, 164, 1, b"         5", b"         x"), "units code"),
        ("uff-header", "164 length factor with O for 0", lambda d: geo(d, 164, 2, b"1.00000", b"1.O0000"),
         "length factor"),
        ("uff-header", "164 temperature offset 'zz'", lambda d: geo(d, 164, 3, b"2.7", b"zz"), "temperature offset"),
        ("uff-header", "15 node label '2B'", lambda d: geo(d, 15, 1, b"         2", b"        2B"), "node label"),
        ("uff-header", "15 x coordinate with O", lambda d: geo(d, 15, 2, b"3.04800E+02", b"3.048O0E+02"),
         "x coordinate"),
        ("uff-header", "15 y coordinate 'x'", lambda d: geo(d, 15, 4, b"0.00000E+00", b"          x"),
         "y coordinate"),
    ]


_BAD_EFFECTS = [("local dashpot 1e9 N s/m", "[effects.local_damping]\nc_Ns_m = 1e9\n", "overdamped"),
                ("added mass 1e12 kg", "[effects.added_mass]\nmass_kg = 1e12\n", "positive definite"),
                ("root spring 1e-12 N m/rad", "[effects.root_flexibility]\nk_theta_Nm_rad = 1e-12\n",
                 "positive definite")]


def _beam_file_cases():
    beam = lambda d, text: _toml(d / "b.toml", 'preset = "beam5"\n' + text)  # noqa: E731
    commands = {
        "model": lambda b, d: ["model", "--beam", b],
        "update": lambda b, d: ["update", "--beam", b, "--modal", _modal_arg(d)],
        "discrepancy": lambda b, d: ["discrepancy", "--beam", b, "--measured", _measured(), "--max-effects", "0"],
        "generate": lambda b, d: _gen(d, "--beam", b),
    }
    return [("beam-file", f"{cmd}: {name}", lambda d, t=text, c=argv: c(beam(d, t), d), expect)
            for name, text, expect in _BAD_EFFECTS for cmd, argv in commands.items()]


def _prepend_unknown_set(path):
    path.write_bytes(b"    -1\n   999\nfoo\n    -1\n" + path.read_bytes())
    return path


def _label_cases():
    frf = _base_frf()
    n = frf.frequency_hz.size
    rows = "".join(f"{k + 1},1e-3,1e-4\n" for k in range(n))
    return [
        ("csv", "header label 'a'", lambda d: [_csv(d / "a.csv", "frequency_hz,re(a/b),im(a/b)\n" + rows)], "'a'"),
        ("csv", "header label '2' (no direction)", lambda d: [_csv(d / "n.csv", "frequency_hz,re(2/5),im(2/5)\n"
                                                                   + rows)], "'2'"),
        ("csv", "response label 'ref'", lambda d: [_csv(d / "r.csv", "frequency_hz,re(ref),im(ref)\n" + rows)],
         "r.csv: line 1: column 2 're(ref)': DOF label 'ref' must look like 'NODE:+DIR'"),
        ("csv", "header direction Q", lambda d: [_csv(d / "q.csv", "frequency_hz,re(2:+Q),im(2:+Q)\n" + rows)],
         "2:+Q"),
        ("csv", "header labels not DOFs (update)", lambda d: ["update", "--modal", str(_csv(
            d / "u.csv", "frequency_hz,re(a/b),im(a/b)\n" + rows))], "u.csv"),
        ("npz", "DOF labels 'a'..'d'", lambda d: [_npz(d / "l.npz", response_dofs=np.array(["a", "b", "c", "d"]))],
         "response_dofs"),
        ("npz", "reference label '5'", lambda d: [_npz(d / "r.npz", reference_dofs=np.array(["5"]))],
         "reference_dofs"),
    ]


def _time_uff(path, force=1.0, response=1.0, hits_every_s=1.0):
    """Force (node 1) and acceleration (node 2) time records, scaled; half-sine hits every ``hits_every_s``."""
    t = np.arange(4096) / 1024.0
    tau = t % hits_every_s
    pulse = np.where(tau < 0.004, np.sin(np.pi * tau / 0.004), 0.0) * 100.0 * force
    return write_time_uff(path, t, [(1, pulse, 13), (2, np.sin(2 * np.pi * 40 * t) * np.exp(-3 * tau) * response, 12)])


def _estimate_cases():
    est = lambda d, *more, **kw: ["estimate", str(_time_uff(d / "t.uff", **kw)), *more]  # noqa: E731
    return [
        ("estimate", "zero force (random)", lambda d: est(d, force=0.0), "force channel 1:+Z"),
        ("estimate", "zero force (impact)", lambda d: est(d, "--excitation", "impact", force=0.0),
         "force channel 1:+Z"),
        ("estimate", "force of 1e-300 N", lambda d: est(d, force=1e-300), "force channel 1:+Z"),
        ("estimate", "force of 1e300 N", lambda d: est(d, force=1e300), "magnitude"),
        ("estimate", "response of 1e300", lambda d: est(d, response=1e300), "magnitude"),
        ("estimate", "response of 1e-310", lambda d: est(d, response=1e-310), "t.uff"),
        ("estimate", "impact: every hit clipped", lambda d: [
            "estimate", str(_impact_uff(d / "i.uff")), "--excitation", "impact"],
         "overloads ['1:+Z in block 0', '1:+Z in block 1', '1:+Z in block 2', '1:+Z in block 3']"),
        ("estimate", "impact: clipped hits, no hit in the other blocks", lambda d: [
            "estimate", str(_impact_uff(d / "i.uff")), "--excitation", "impact", "--averages", "8"],
         "no hit in blocks [1, 3, 5, 7]"),
    ]


def _config_range_cases():
    cfg = lambda d, text: _gen(d, "--config", _toml(d / "c.toml", text))  # noqa: E731
    return [
        ("generate", "slit damping 1 s", lambda d: cfg(d, "[damage]\nslit_damping_s = [1.0, 1.0]\n"),
         "damage.slit_damping_s"),
        ("generate", "slits of depth [0, 0]", lambda d: cfg(d, "[damage]\ndepth_m = [0.0, 0.0]\n"), "damage.depth_m"),
        ("generate", "slits of EI loss [0, 0]", lambda d: cfg(d, "[damage]\nei_loss = [0.0, 0.0]\n"),
         "damage.ei_loss"),
        ("generate", "root spring 0.001 k_r L/EI", lambda d: cfg(
            d, "[specimen]\nroot_spring_relative = [0.001, 0.001]\n"), "specimen.root_spring_relative"),

        ("generate", "slit damping [0, 1] s", lambda d: cfg(d, "[damage]\nslit_damping_s = [0.0, 1.0]\n"),
         "damage.slit_damping_s"),
        ("generate", "slit damping beyond the band's loss factor", lambda d: cfg(
            d, "[damage]\nslit_damping_s = [0.0, 1e-4]\n[measurement]\nband_rad_s = [1.0, 50000.0]\n"),
         "damage.slit_damping_s"),
        ("generate", "calibrated FRF noise 0.5", lambda d: cfg(
            d, "[measurement]\nmodal_noise = 'calibrated'\nfrf_noise = 0.5\n"), "measurement.frf_noise"),
        ("generate", "training + FRF noise [0.1, 0.5]", lambda d: cfg(
            d, "base = 'training'\n[measurement]\nfrf_noise = [0.1, 0.5]\n"), "measurement.frf_noise"),
        ("generate", "FRF noise 0.6", lambda d: cfg(d, "[measurement]\nfrf_noise = 0.6\n"), "measurement.frf_noise"),
        ("generate", "fixed frequency noise per mode 100", lambda d: cfg(
            d, "[measurement]\nfrequency_noise = [0.001, 0.001, 0.001, 100]\n"), "measurement.frequency_noise"),
        ("generate", "fixed damping noise per mode 0.9", lambda d: cfg(
            d, "[measurement]\ndamping_noise = [0.9, 0.1, 0.1, 0.1]\n"), "measurement.damping_noise"),
        ("generate", "damping ratio 0.2", lambda d: cfg(d, "[specimen]\ndamping_ratios = [0.2]\n"),
         "specimen.damping_ratios"),
        ("generate", "intact fraction 1.5", lambda d: cfg(d, "[damage]\nintact_fraction = 1.5\n"),
         "damage.intact_fraction"),
        ("generate", "slit width 0", lambda d: cfg(d, "[damage]\nwidth_m = [0.0, 0.01]\n"), "damage.width_m"),
        ("generate", "negative face thickness", lambda d: cfg(d, "[section]\nface_thickness_m = -0.001\n"),
         "section.face_thickness_m"),
    ]


def _fifo(path):
    os.mkfifo(path)
    return path


def _sparse(path, size=2 << 30):
    with open(path, "wb") as f:
        f.truncate(size)
    return path


def _input_cases():
    """Inputs that are not regular files of bounded size: refused from ``stat`` before anything is read."""
    return [
        ("inputs", "identify /dev/zero", lambda d: ["identify", "/dev/zero"], "character device"),
        ("inputs", "update --modal /dev/urandom", lambda d: ["update", "--modal", "/dev/urandom"], "character device"),
        ("inputs", "generate --config /dev/zero", lambda d: ["generate", "--config", "/dev/zero", "--n", "4", "--out",
                                                             str(d / "ds")], "character device"),
        ("inputs", "model --beam /dev/urandom", lambda d: ["model", "--beam", "/dev/urandom"], "character device"),
        ("inputs", "identify a FIFO", lambda d: ["identify", str(_fifo(d / "pipe.uff"))], "FIFO"),
        ("inputs", "update --modal a FIFO", lambda d: ["update", "--modal", str(_fifo(d / "pipe.json"))], "FIFO"),
        ("inputs", "identify a 2 GB sparse UFF", lambda d: ["identify", str(_sparse(d / "big.uff"))], "MiB"),
        ("inputs", "identify a 2 GB sparse CSV", lambda d: ["identify", str(_sparse(d / "big.csv"))], "MiB"),
        ("inputs", "estimate a 2 GB sparse UFF", lambda d: ["estimate", str(_sparse(d / "big.uff"))], "MiB"),
        ("inputs", "update --modal a 2 GB sparse JSON", lambda d: ["update", "--modal", str(_sparse(d / "m.json"))],
         "MiB"),
        ("inputs", "model --beam a 2 MB TOML", lambda d: ["model", "--beam", str(_sparse(d / "b.toml", 2 << 20))],
         "MiB"),
        ("inputs", "identify a name with a newline", lambda d: ["identify", str(_bytes(d / "a\nb.uff", b"x\n"))],
         "a\\nb.uff"),
    ]


CASES = [*_input_cases(), *_frf_cases(), *_modal_cases(), *_arg_cases(), *_command_arg_cases(), *_dataset_cases(),
         *_boundary_modal_cases(), *_uff_field_cases(), *_label_cases(), *_config_range_cases(), *_estimate_cases(),
         *_context_cases(), *_beam_file_cases()]


def _argv(builder, d):
    out = builder(d)
    if out and isinstance(out[0], Path):  # a file for identify (the FRF families)
        return ["identify", str(out[0]), "--out", str(d / "identify-out")]
    return out


def run_case(builder, d, capsys=None):
    """Run one case; returns (exit code, stdout, stderr, seconds, files created)."""
    from experiments.cli import main

    d.mkdir(parents=True, exist_ok=True)
    argv = _argv(builder, d)
    before = {p for p in d.rglob("*")}
    out_buf, err_buf = io.StringIO(), io.StringIO()
    old = sys.stdout, sys.stderr
    t0 = time.perf_counter()

    def _timeout(signum, frame):
        raise TimeoutError(f"still running after {TIME_LIMIT_S:g} s")

    import signal

    previous = signal.signal(signal.SIGALRM, _timeout)
    signal.alarm(int(TIME_LIMIT_S))
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = lambda m, c, f, ln, file=None, line=None: sys.stderr.write(
            warnings.formatwarning(m, c, f, ln))
        sys.stdout, sys.stderr = out_buf, err_buf
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
        except BaseException as exc:  # a traceback: report it as such
            code = f"traceback {type(exc).__name__}: {str(exc)[:120]}"
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)
            sys.stdout, sys.stderr = old
    dt = time.perf_counter() - t0
    created = sorted(str(p.relative_to(d)) for p in set(d.rglob("*")) - before)
    return code, out_buf.getvalue(), err_buf.getvalue(), dt, created


#: Cases that fail in commands other branches own (reported to them, not fixed here).
OTHERS = {}


def _params():
    for c in CASES:
        marks = [pytest.mark.xfail(reason=OTHERS[c[1]], strict=False)] if c[1] in OTHERS else []
        yield pytest.param(*c, marks=marks, id=f"{c[0]}: {c[1]}")


def test_the_readme_states_the_corpus_size():
    """README.md's count of the corpus is ``len(CASES)``, the number ``python tests/test_malformed.py`` runs."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    assert f"malformed-input corpus ({len(CASES)} cases" in readme


@pytest.mark.parametrize("family, name, builder, expect", list(_params()))
def test_malformed_input_gives_one_line_and_exit_2(tmp_path, family, name, builder, expect):
    code, out, err, dt, created = run_case(builder, tmp_path / "case")
    assert code == 2, f"exit {code!r}; stderr: {err!r}"
    assert err.count("\n") == 1 and err.endswith("\n"), f"stderr must be one line: {err!r}"
    assert expect.lower() in err.lower(), err
    assert out == "", out
    assert created == [], f"partial output: {created}"
    assert dt < TIME_LIMIT_S


def corpus_table():
    """Run the corpus; rows of (family, cases, clean one-line errors, tracebacks, other failures)."""
    import tempfile

    rows, problems = {}, []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (family, name, builder, expect) in enumerate(CASES):
            code, out, err, dt, created = run_case(builder, Path(tmp) / f"c{k}")
            r = rows.setdefault(family, {"cases": 0, "clean": 0, "traceback": 0, "other": 0, "max_s": 0.0})
            r["cases"] += 1
            r["max_s"] = max(r["max_s"], dt)
            ok = code == 2 and err.count("\n") == 1 and expect.lower() in err.lower() and out == "" and not created
            if isinstance(code, str):
                r["traceback"] += 1
                problems.append((family, name, code))
            elif ok:
                r["clean"] += 1
            else:
                r["other"] += 1
                problems.append((family, name, f"exit {code}, stderr {err.strip()[:150]!r}, created {created}"))
    return rows, problems


if __name__ == "__main__":
    rows, problems = corpus_table()
    print(f"{'family':<12}{'cases':>6}{'clean':>7}{'traceback':>11}{'other':>7}{'max s':>8}")
    for fam, r in rows.items():
        print(f"{fam:<12}{r['cases']:>6}{r['clean']:>7}{r['traceback']:>11}{r['other']:>7}{r['max_s']:>8.1f}")
    for p in problems:
        print("  ", *p)
