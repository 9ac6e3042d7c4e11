"""``beam-damage export``: materialise chosen samples' FRFs as files for modal software (the FRF formats of
:data:`physics.io.FORMATS` with a writer)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from datagen.dataset import Dataset
from datagen.store import STATES
from datagen.synth import DATASET_FRFS
from physics.errors import BeamDamageError
from physics.io import FRF, MeasuredFRF, writable

__all__ = ["add_parser", "run"]

def add_parser(subparsers):
    writers = writable(FRF)
    p = subparsers.add_parser(
        "export",
        description="Synthesise the FRFs of the chosen samples (measured: truth + noise; updated: the Pilkey-updated "
                    "model) and write one file per sample, state (baseline, current) and kind, named "
                    "sample-ID_STATE_KIND.EXT, receptance (m/N), responses at the measured DOFs, drive at the first.")
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--samples", required=True, help="comma-separated sample ids, e.g. 0,17,299 (a repeated id is "
                                                     "written once)")
    p.add_argument("--format", choices=sorted(writers), default="uff",
                   help="file format (default uff): " + "; ".join(f"{f.name}: {f.description}"
                                                                  for f in writers.values()))
    p.add_argument("--kind", choices=[*DATASET_FRFS, "both"], default="both",
                   help="which FRFs (default both; measured only for a dataset without an updated model)")
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--json", action="store_true", help="print the list of written files as JSON")
    p.set_defaults(func=run, flags={"samples": "--samples"})


def _sample_ids(text: str) -> list[int]:
    try:
        ids = [int(t) for t in text.split(",")]
    except ValueError:
        raise BeamDamageError(f"--samples must be comma-separated integers such as 0,17,299, got {text!r}") from None
    unique = list(dict.fromkeys(ids))
    if len(unique) < len(ids):
        warnings.warn(f"--samples names {len(ids) - len(unique)} id(s) more than once; each sample is written once")
    return unique


def _uff_dof(name: str) -> str:
    node, d = name.split(":")
    return f"{node}:+{d.upper()}"


def _labels(manifest: dict) -> tuple:
    """``(response DOFs, (reference DOF,), metadata)`` of a dataset's FRFs as the readers place them: a sensor at a
    quarter point takes the node of the 4-element convention (node ``N`` at ``(N - 1) L / 4``, which every reader
    assumes without node geometry); one elsewhere keeps its truth-mesh node, and the positions go into the metadata's
    node geometry (an NPZ keeps it; a CSV or universal file does not: a warning says so)."""
    schema, layout = manifest["schema"], manifest.get("layout")
    labels = [*schema["measured_dofs"], schema["frf_reference_dof"]]
    if not layout:                                            # the thesis's test: the convention's nodes already
        return tuple(_uff_dof(d) for d in labels[:-1]), (_uff_dof(labels[-1]),), {}
    length = float(layout["length_m"])
    x_of = dict(zip(sorted({int(d.split(":")[0]) for d in schema["measured_dofs"]}),
                    sorted(float(x) for x in layout["measured_x_m"])))
    x_of.setdefault(int(schema["frf_reference_dof"].split(":")[0]), float(layout["drive_x_m"]))
    quarter = {n: 4 * x / length for n, x in x_of.items()}
    on_grid = all(abs(q - round(q)) < 1e-9 for q in quarter.values())
    node = {n: int(round(q)) + 1 if on_grid else n for n, q in quarter.items()}
    out = [_uff_dof(f"{node[int(n)]}:{d}") for n, d in (label.split(":") for label in labels)]
    if not on_grid:
        warnings.warn("the sensors do not all sit at the quarter points: the labels keep the dataset's truth-mesh "
                      "nodes, and their positions are in the node geometry of an NPZ export only; for a CSV or a "
                      "universal file give the beam file's measured_x_m to 'update' and 'discrepancy'")
    geometry = {"geometry": {"nodes_m": {str(node[n]): [x, 0.0, 0.0] for n, x in x_of.items()},
                             "source": "the dataset's sensor layout"}}
    return tuple(out[:-1]), (out[-1],), geometry


def run(args) -> dict:
    ids = _sample_ids(args.samples)
    ds = Dataset(args.dir)
    if not ds.shards:
        raise BeamDamageError(f"{args.dir}: incomplete dataset with no finished shard; run or resume its "
                              f"`beam-damage generate` command")
    sid = ds.table(["sample_id"])["sample_id"].to_numpy()
    pos = {int(s): i for i, s in enumerate(sid)}
    missing = [i for i in ids if i not in pos]
    if missing:
        raise BeamDamageError(f"{args.dir}: no sample(s) {missing}; the dataset holds ids {sid.min()}..{sid.max()}",
                              parameter="samples")
    rows = [pos[i] for i in ids]
    resp, ref, geometry = _labels(ds.manifest)
    f_hz = ds.omega_rad_s / (2 * np.pi)
    fmt = writable(FRF)[args.format]
    out = Path(args.out)
    kinds = (DATASET_FRFS if ds.has_updated_model else ("measured",)) if args.kind == "both" else (args.kind,)
    frfs = {kind: ds.frf(kind, rows).astype(complex) for kind in kinds}  # read (and verify) all before writing
    for kind, H in frfs.items():
        for j, i in enumerate(ids):
            for s, state in enumerate(STATES):
                if not np.all(np.isfinite(H[j, s])):
                    raise BeamDamageError(f"sample {i}: the {kind} FRF of the {state} state is not finite "
                                          f"(updating did not converge); choose another sample or --kind measured")
    out.mkdir(parents=True, exist_ok=True)
    written, new = [], []
    try:
        for kind, H in frfs.items():
            for j, i in enumerate(ids):
                for s, state in enumerate(STATES):
                    path = out / f"sample-{i:06d}_{state}_{kind}{fmt.extensions[0]}"
                    data = MeasuredFRF(f_hz, H[j, s][:, None, :], resp, ref, kind="receptance",
                                       metadata={"id1": f"beam-damage sample {i} {state} {kind}",
                                                 "dataset": str(args.dir), "sample_id": i, "state": state,
                                                 "frf": kind, **geometry})
                    existed = path.exists()
                    fmt.writer(path, data)
                    written.append(str(path))
                    if not existed:
                        new.append(path)
    except (BeamDamageError, OSError):  # e.g. a full disk: the files this run created go again
        for p in new:
            p.unlink(missing_ok=True)
        raise
    if not args.json:
        print(f"wrote {len(written)} {args.format} files to {out}")
    return {"files": written, "samples": ids, "format": args.format, "kinds": list(kinds)}
