"""``beam-damage estimate``: FRFs (H1/H2/Hv with coherence) from force and response time records."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from physics.errors import ConfigError
from physics.io import FRF, TIME, accepted, read, writable
from physics.time_records import ESTIMATORS, EXCITATIONS, FORCE_DROP_DB, estimate_from_records, segment_window

__all__ = ["add_parser", "run"]


def run(args) -> dict:
    if args.averages is not None and args.averages < 1:
        raise ConfigError(f"--averages {args.averages}: must be >= 1")
    if not 0 <= args.overlap < 1:
        raise ConfigError(f"--overlap {args.overlap:g}: must be in [0, 1)")
    if args.decay is not None and not 0 < args.decay <= 1:
        raise ConfigError(f"--decay {args.decay:g}: must be in (0, 1]")
    if args.fmax is not None and not args.fmax > 0:
        raise ConfigError(f"--fmax {args.fmax:g}: must be > 0")
    segment_window(args.window)
    writer, ext = None, ""
    if args.out:
        ext = Path(args.out).suffix.lower()
        writer = next((f.writer for f in writable(FRF).values() if ext in f.extensions), None)
        if writer is None:
            raise ConfigError(f"--out {args.out}: the extension names the format to write, one of "
                              f"{accepted(FRF)}")
    records = read(args.file, TIME)
    est = estimate_from_records(records, args.reference, args.estimator, args.excitation, args.averages,
                                args.overlap, args.window, args.decay, args.fmax)
    coh = est.coherence
    tau = 1.0 / est.added_decay_rate_1_s if est.added_decay_rate_1_s > 0 else None
    out = {"file": str(args.file), "estimator": est.estimator, "excitation": est.excitation,
           "description": est.description, "n_averages": est.n_averages,
           "reference": est.frf.reference_dofs[0], "dofs": list(est.frf.response_dofs), "kind": est.frf.kind,
           "units": est.frf.units, "lines": int(est.frf.frequency_hz.size),
           "band_hz": [float(est.frf.frequency_hz[0]), float(est.frf.frequency_hz[-1])],
           "coherence_median": np.median(coh, axis=-1)[:, 0].tolist(),
           "added_decay_rate_1_s": est.added_decay_rate_1_s, "exp_window_tau_s": tau,
           "exp_window_end_value": est.window_end_value, "warnings": []}
    out["force_band_hz"] = None if est.force_band_hz is None else list(est.force_band_hz)
    if est.hits is not None:
        out["double_hits"] = list(est.hits.double_hits)
        out["overloads"] = [{"block": b, "dof": d} for b, d in est.hits.overloads]
    if args.out:
        writer(args.out, est.frf)
        out["outputs"] = {"frf": str(args.out)}
    if not args.json:
        print(f"{args.file}: {est.description}")
        for d, c in zip(out["dofs"], out["coherence_median"]):
            print(f"  {d}/{out['reference']}: median coherence {c:.3f}")
        if est.hits is not None and (est.hits.double_hits or est.hits.overloads):
            print(f"  left out: double hits in blocks {out['double_hits']}, overloads "
                  + ", ".join(f"{o['dof']} in block {o['block']}" for o in out["overloads"]))
        if tau is not None:
            print(f"  exponential window tau {tau:.6g} s: " + (
                "stored in the file; 'beam-damage identify' removes its decay from the modes" if ext == ".npz"
                else f"'beam-damage identify --exp-window-tau {tau:.6g}' removes its decay from the modes"))
        if est.force_band_hz is not None:
            low, high = est.force_band_hz
            print(f"  force band {low:.4g}-{high:.4g} Hz (the force within {FORCE_DROP_DB:g} dB of its peak): " + (
                "stored in the file; 'beam-damage identify' stays in it" if ext == ".npz"
                else f"'beam-damage identify --band {low:.4g} {high:.4g}' stays in it"))
        if args.out:
            print(f"wrote {args.out}")
    return out


def add_parser(sub):
    p = sub.add_parser("estimate",
                       description="Read the time records (dataset 58, function type 1) of a force and "
                                   "responses and estimate FRFs. Random excitation: Welch averaging of overlapped "
                                   "windowed segments. Impact tests: one block per hit, from just before it (or "
                                   "--averages equal blocks); force and exponential windows; blocks with a double "
                                   "hit or an overload (clipping) are flagged and left out.")
    p.add_argument("file", metavar="FILE", help=f"time records (force and responses): {accepted(TIME)}")
    p.add_argument("--reference", metavar="DOF", help="DOF of the force channel, e.g. 1:+Z (default: the only force)")
    p.add_argument("--estimator", choices=ESTIMATORS, default="h1", help="h1 (noise on responses, default), "
                                                                         "h2 (noise on the force), hv (both)")
    p.add_argument("--excitation", choices=EXCITATIONS, default="random", help="random (default) or impact")
    p.add_argument("--averages", type=int, default=None,
                   help="segments (random, default 8) or equal impact blocks (default: one block per hit, from just "
                        "before it, as long as the hits' shortest spacing)")
    p.add_argument("--overlap", type=float, default=0.5, help="segment overlap for random excitation (default 0.5)")
    p.add_argument("--window", default="hann", help="window of random-excitation segments: a scipy.signal window "
                                                    "name, or a name and its parameters, e.g. kaiser,8.6 "
                                                    "(default hann)")
    p.add_argument("--decay", type=float, default=None,
                   help="impact: exponential window value at the block end (1 = none; default: the weakest window "
                        "that brings every response to 1 %% of its loudest by the block end, none where the "
                        "responses end there already)")
    p.add_argument("--fmax", type=float, help="highest line to keep (Hz)")
    p.add_argument("--out", metavar="FILE", help="write the FRFs in the format its extension names: "
                                                 f"{accepted(FRF)} (UFF: dataset 58, function type 4); .npz "
                                                 "keeps the exponential window's tau, which 'identify' then "
                                                 "removes from the modes' damping")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
