"""``beam-damage generate``: simulated slit datasets (truth -> measured -> Pilkey-updated models and FRFs)."""

from __future__ import annotations

import os

from datagen.config import load_config
from datagen.parallel import generate


def add_parser(subparsers):
    p = subparsers.add_parser(
        "generate", help="generate a dataset of damaged/undamaged specimens, updated models and FRFs",
        description="Simulate N specimens with slits (and their undamaged reference), measure their modes and FRFs "
                    "with noise, update damping and stiffness by Pilkey's iteration and write a sharded dataset "
                    "(manifest.json, samples.parquet, .npy shards). Re-running with the same arguments resumes an "
                    "interrupted run; results depend only on the config and seed, not on --workers/--scheduler.")
    p.add_argument("--n", type=int, required=True, help="number of samples")
    p.add_argument("--out", required=True, help="dataset directory (created, or resumed if it holds a manifest)")
    p.add_argument("--config", help="TOML file overriding the defaults (see README 'Generating datasets')")
    p.add_argument("--preset", help="beam preset (beam5, beam6, beam8); default beam5 or the config's")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--workers", type=int, default=1, help=f"local processes (this machine has {os.cpu_count()})")
    p.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (needs the 'dask' extra)")
    p.add_argument("--json", action="store_true", help="print the manifest summary as JSON")
    p.set_defaults(func=run)


def run(args) -> dict:
    cfg = load_config(args.config, preset=args.preset)
    m = generate(args.out, cfg, n=args.n, seed=args.seed, workers=args.workers, scheduler=args.scheduler,
                 progress=True)
    summary = {"out": str(args.out), "complete": m["complete"], "seed": m["seed"], "preset": cfg["preset"],
               "package_version": m["package_version"], "n_shards": m["n_shards"],
               "counts": m.get("counts", {}), "checksums": m.get("checksums", {})}
    if not args.json:
        c = summary["counts"]
        print(f"{args.out}: {c.get('samples', 0)} samples in {m['n_shards']} shards, "
              f"{c.get('not_converged', 0)} flagged as not converged (kept); seed {m['seed']}, preset {cfg['preset']}")
    return summary
