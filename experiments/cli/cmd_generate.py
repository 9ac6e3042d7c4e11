"""``beam-damage generate``: simulated datasets of damaged beams (truth -> measured -> Pilkey-updated models; FRFs
on read)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from datagen.config import load_config, merge, named_configs
from datagen.generation import generate
from datagen.setup import generated_test, truth_beam_of
from datagen.truth_beam import APPLIED_EFFECTS, beam_mapping
from learn.network.mode_count import require_test_modes
from learn.pairs.noise_calibration import calibrate_test
from learn.pairs.output_only_calibration import calibrate_output_only
from physics.beam import load_beam
from physics.errors import BeamDamageError
from physics.io import read_json
from physics.properties import PRESETS

__all__ = ["CALIBRATED_KEYS", "add_parser", "recorded_calibration", "run"]


def add_parser(subparsers):
    p = subparsers.add_parser(
        "generate",
        description="Simulate N specimens, each tested on two days (baseline, then current: damage of the "
                    "config's damage.kind (slits, or masses added or lost), temperature, "
                    "re-clamping), measure their modes and FRFs with noise, update damping and stiffness by "
                    "Pilkey's iteration and write a sharded dataset (manifest.json, samples.parquet, .npy shards "
                    "of what defines each sample: modes, updated M, C, K, noise seeds; FRFs are synthesised when "
                    "read). Re-running with the same arguments resumes an interrupted run and regenerates damaged "
                    "shards; results depend only on the config and seed, not on --workers/--scheduler.")
    p.add_argument("--n", type=int, required=True, help="number of samples")
    p.add_argument("--out", required=True, help="dataset directory (created, or resumed if it holds a manifest)")
    p.add_argument("--config", help=f"a named config ({', '.join(named_configs())}) or a TOML file overriding the "
                                    "defaults; a file may start from a named one with `base = \"training\"`")
    p.add_argument("--beam", help="the truth beam: a preset (beam5, beam6, beam8) or a beam file (TOML, physics.beam; "
                                  f"effects applied: {', '.join(APPLIED_EFFECTS)}), e.g. one `discrepancy` "
                                  "calibrated")
    p.add_argument("--preset", help="beam preset (beam5, beam6, beam8); default beam5 or the config's (same as --beam "
                                    "PRESET; kept for old scripts)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--workers", type=int, default=1, help=f"local processes (this machine has {os.cpu_count()})")
    p.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (needs the 'dask' extra; "
                                       "--out must be on a filesystem the client can write)")
    p.add_argument("--store-frf", action="store_true",
                   help="also write the measured and updated FRFs into the shards (128 kB per sample; identical to "
                        "what reading synthesises)")
    p.add_argument("--modal-noise", choices=("test", "shipped", "output-only"), default="test",
                   help="the training pairs' modal noise: 'test' (default) with a beam file whose test is not the "
                        "thesis's and the calibrated modal noise calibrates it on that test first "
                        "(learn.pairs.noise_calibration: LSCF/LSFD of 144 simulated FRF files, about 15-60 s), "
                        "'shipped' keeps the thesis test's coefficients, 'output-only' calibrates it on the test's "
                        "output-only identification instead (learn.pairs.output_only_calibration: SSI-cov of 144 "
                        "simulated response records under white random force, sensor noise 0.5-3 %% of the RMS, "
                        "2-15 min; about 1 min) and draws each sample's sensor noise and record length "
                        "(measurement.sensor_noise, record_length_s), for tests that 'classify' reads as the "
                        "modal.json of 'identify' on response records. A calibration is recorded in the dataset's "
                        "config and reused on resume")
    p.add_argument("--json", action="store_true", help="print the manifest summary as JSON")
    p.set_defaults(func=run, flags={"n": "--n", "seed": "--seed", "workers": "--workers", "scheduler": "--scheduler"})


def run(args) -> dict:
    beam = getattr(args, "beam", None)
    if beam is not None and args.preset is not None:
        raise BeamDamageError("give --beam or --preset, not both")
    if beam in PRESETS:
        args.preset, beam = beam, None
    cfg = load_config(args.config, preset=args.preset)
    if beam is not None:
        truth = load_beam(beam)
        test = generated_test(truth, beam)      # the test it describes, refused here naming the file
        cfg = merge({"beam": beam_mapping(truth)}, base=cfg)
        if not test.thesis and cfg["measurement"]["modal_noise"] == "calibrated" and args.modal_noise == "test":
            cfg = _calibrated(cfg, args.out, "calibrated", f"{beam}: calibrating the modal noise on this test "
                                                           f"({test.n_sensors} sensors, modes "
                                                           f"{', '.join(map(str, test.modes))})")
    source = beam or ("config key 'beam'" if cfg["beam"] else f"preset {cfg['preset']!r}")
    test = generated_test(truth_beam_of(cfg), source) if beam is None else test
    require_test_modes(None if test.thesis else test, source)     # before hours of samples classify cannot read
    if args.modal_noise == "output-only":
        cfg = _calibrated(cfg, args.out, "output-only", f"{beam or cfg['preset']}: calibrating the modal noise on "
                                                        "this test's output-only identification (SSI-cov)")
    if args.store_frf:
        cfg["output"]["store_frf"] = True
    m = generate(args.out, cfg, n=args.n, seed=args.seed, workers=args.workers, scheduler=args.scheduler,
                 progress=True)
    summary = {"out": str(args.out), "complete": m["complete"], "seed": m["seed"],
               "beam": cfg["beam"].get("name") if cfg["beam"] else cfg["preset"],
               "config": args.config or "defaults", "format": m["format"], "identity": m.get("identity"),
               "package_version": m["package_version"], "n_shards": m["n_shards"],
               "counts": m.get("counts", {}), "checksums": m.get("checksums", {})}
    if not args.json:
        c = summary["counts"]
        flagged = {k: v for k, v in c.get("status", {}).items() if k != "ok" and v}
        kept = (f"{sum(flagged.values())} flagged and kept ({', '.join(f'{v} {k}' for k, v in flagged.items())}: "
                "the samples table's column 'status')" if flagged else "none flagged")
        print(f"{args.out}: {c.get('samples', 0)} samples in {m['n_shards']} shards, {kept}; seed {m['seed']}, "
              f"beam {summary['beam']}, config {summary['config']}")
    return summary


#: The ``measurement`` keys a modal-noise calibration sets.
CALIBRATED_KEYS = ("modal_noise",) + tuple(f"{q}{s}" for q in ("frequency", "damping", "shape")
                                           for s in ("_noise", "_noise_per_floor", "_noise_floor"))


def recorded_calibration(out, cfg: dict, mode: str) -> dict | None:
    """The ``measurement`` keys of the calibration recorded in ``out/manifest.json``, when that dataset's config is
    ``cfg`` calibrated the same way (``modal_noise == mode``), else None: a resumed run reuses its calibration."""
    try:
        stored = read_json(Path(out) / "manifest.json").get("config")
        meas = {k: stored["measurement"][k] for k in CALIBRATED_KEYS}
        if meas["modal_noise"] != mode or merge({"measurement": meas}, base=cfg) != stored:
            return None
    except (BeamDamageError, OSError, KeyError, TypeError, AttributeError):
        return None
    return meas


def _calibrated(cfg: dict, out, mode: str, message: str) -> dict:
    """``cfg`` with the modal noise calibrated by ``mode`` ("calibrated": LSCF/LSFD of FRF files, "output-only":
    SSI-cov of response records), the calibration of a dataset being resumed at ``out`` reused."""
    meas = recorded_calibration(out, cfg, mode)
    if meas is not None:
        print(f"{out}: reusing the modal-noise calibration recorded in its manifest", file=sys.stderr)
    elif mode == "output-only":
        print(message, file=sys.stderr)
        meas = calibrate_output_only(cfg)
    else:
        print(message, file=sys.stderr)
        meas = calibrate_test(cfg)
    return merge({"measurement": meas}, base=cfg)
