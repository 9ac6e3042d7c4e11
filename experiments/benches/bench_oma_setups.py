"""Multi-setup output-only identification of a tall building's ambient test: partial modes, references checked.

Records: 22 sensors along a building's height, modes at 1.23, 1.29, 1.45, 3.87, 4.25 and 5.39 Hz (damping 1.5 %,
real shapes: sines along the height times a fixed random draw), each under independent white modal forces (exact
ZOH modal filters), 2 % sensor noise. Four setups of 7 channels at 40 Hz for 5.5 min: 5 roving sensors, then the
2 references (sensors 1 and 2). Each setup is written as ``.npz`` with DOF labels, and once more without them
(channels ``1:+Z``.. ``7:+Z`` by position), and merged by ``beam-damage identify S1 --setup S2 --setup S3 --setup S4
--band 0.5 6.5 --max-order 80 --json`` (``experiments.cli.main`` in this process).

Run ``python -m experiments.benches.bench_oma_setups [--seed 20]``.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser
from experiments.cli import main

__all__ = ["building_shapes", "record", "run"]

FREQUENCIES_HZ = np.array([1.23, 1.29, 1.45, 3.87, 4.25, 5.39])
N_SENSORS, FS_HZ, SECONDS, ZETA, NOISE = 22, 40.0, 330.0, 0.015, 0.02


def building_shapes(seed=0):
    """Real unit-norm shapes (N_SENSORS, 6)."""
    rng = np.random.default_rng(seed)
    h = np.arange(1, N_SENSORS + 1) / N_SENSORS
    order = np.array([1, 1, 1, 2, 2, 3])
    phi = np.sin((order - 0.5)[None, :] * np.pi * h[:, None]) * (1 + 0.5 * rng.standard_normal((N_SENSORS, 6)))
    return phi / np.linalg.norm(phi, axis=0)


def record(phi, seed):
    """Responses (channels, samples) of the modes under white modal forces, plus sensor noise."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    n = int(SECONDS * FS_HZ)
    q = np.empty((FREQUENCIES_HZ.size, n))
    for r, f in enumerate(FREQUENCIES_HZ):
        w = 2 * np.pi * f
        num, den, _ = signal.cont2discrete(([1.0], [1, 2 * ZETA * w, w ** 2]), 1 / FS_HZ, "zoh")
        q[r] = w ** 2 * signal.lfilter(num.ravel(), den, rng.standard_normal(n))
    y = phi @ q
    return y + NOISE * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


def run(seed=20) -> dict:

    phi = building_shapes()
    channels = [list(range(2 + 5 * s, 7 + 5 * s)) + [0, 1] for s in range(4)]
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for labelled in (True, False):
            files = []
            for s, ch in enumerate(channels):
                path = Path(tmp) / f"setup{s + 1}{'' if labelled else '_unlabelled'}.npz"
                extra = {"dofs": np.array([f"{c + 1}:+Z" for c in ch])} if labelled else {}
                np.savez(path, signals=record(phi[ch], seed + s), sampling_frequency_hz=np.array(FS_HZ),
                         quantity=np.array("acceleration"), **extra)
                files.append(str(path))
            argv = ["identify", files[0], *sum((["--setup", f] for f in files[1:]), []), "--band", "0.5", "6.5",
                    "--max-order", "80", "--json"]
            so, se = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
                code = main(argv)
            key = "labelled" if labelled else "unlabelled"
            if code:
                out[key] = {"exit_code": code, "error": se.getvalue().strip()}
                continue
            res = json.loads(so.getvalue())
            rows = [int(d.split(":")[0]) - 1 for d in res["dofs"]]
            fn = np.array([m["frequency_hz"] for m in res["modes"]])
            true = np.argmin(np.abs(FREQUENCIES_HZ[None, :] - fn[:, None]), axis=1)
            macs = []
            for j, m in enumerate(res["modes"]):
                z = np.array([np.nan if v is None else complex(v) for v in m["shape"]])
                ok = np.isfinite(z)
                a = phi[rows][ok, true[j]]
                macs.append(float(np.abs(np.vdot(a, z[ok])) ** 2 / (np.vdot(a, a).real * np.vdot(z[ok], z[ok]).real)))
            rm = np.array([[np.nan if x is None else x for x in row] for row in res["reference_mac"]], float)
            out[key] = {"exit_code": 0, "frequencies_hz": fn.round(4).tolist(),
                        "partial": [(p["frequency_hz"], len(p["setups"])) for p in res["partial_modes"]],
                        "nan_entries": [sum(v is None for v in m["shape"]) for m in res["modes"]],
                        "mac_with_truth": np.round(macs, 4).tolist(),
                        "least_reference_mac": float(np.nanmin(np.where(rm == 1.0, np.nan, rm))),
                        "in_every_setup": int(sum(len(p["setups"]) == 4 for p in res["partial_modes"])
                                              + len(res["modes"]) - len(res["partial_modes"])),
                        "warnings": res["warnings"]}
    return out


if __name__ == "__main__":
    ap = parser(__file__, __doc__, seed=20)
    print(json.dumps(run(ap.parse_args().seed), indent=1))
