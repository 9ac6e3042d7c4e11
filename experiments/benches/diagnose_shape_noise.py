"""Is the identified mode shapes' noise what limits the network on a catalogue beam? Two measurements.

Run: ``python -m experiments.benches.diagnose_shape_noise --beam steel-bar-ff-12s
--model out/beams/steel-bar-ff-12s/model-n20000-s0 [--n 40] [--seed 0] [--factors 1 8] [--identify 6]``

1. ``--identify K``: the first K pairs' baseline UFF files identified by the project's path (LSCF/LSFD,
   :func:`learn.pairs.measured.identify_modes`); per mode, the rms error of the shape against the simulator's exact one
   (relative to its largest entry, after the best complex scale) over the shape noise the training data draws for
   that FRF noise level and floor (``datagen/configs/modal_noise.json``, calibrated on the thesis's 4-sensor test;
   modes beyond 4 take mode 4's coefficients), before the training's ``modal_noise_scale`` of 0.5-4.
2. ``--factors``: the same pairs given to the network as modal data, the simulator's exact modes with the
   training's calibrated frequency noise and its shape noise times each factor: detection (all slits and those
   lowering no mode by 0.5 %), false alarms and the intact pairs' median training percentile.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from experiments.benches.harness import parser
from datagen.config import modal_noise_calibration
from experiments.second_sim import beams
from experiments.second_sim.beams import CATALOGUE
from learn.pairs.classify import classify_many
from learn.pairs.measured import identify_modes
from learn.network.model_dir import load_model
from physics.io import read_frf
from physics.io.types import ModalData
from physics.noise import complex_normal

__all__ = ["main", "modal_input_scores", "shape_error_ratios"]


def _per_mode(values, m: int) -> np.ndarray:
    v = list(values)
    return np.array(v + [v[-1]] * max(m - len(v), 0))[:m]


def _sigma(cal: dict, q: str, level: float, floor: float, m: int) -> np.ndarray:
    """The training's calibrated relative std of quantity ``q`` per mode."""
    return np.sqrt((_per_mode(cal[q], m) * level) ** 2 + (_per_mode(cal[f"{q}_per_floor"], m) * floor) ** 2
                   + (_per_mode(cal.get(f"{q}_floor", [0.0]), m)) ** 2)


def _exact_modes(cb, n: int, seed: int):
    """The pairs of ``cb`` and, per pair and day, ``(omega_rad_s, modal damping 1/s, shapes at the sensors)``."""
    captured = []
    receptance = beams.receptance

    def capture(asm, md, damping, freq_hz, dofs, ref):
        captured.append((md.omega_rad_s.copy(), damping.diagonal(md.omega_rad_s), md.phi[np.asarray(dofs)].copy()))
        return receptance(asm, md, damping, freq_hz, dofs, ref)

    beams.receptance = capture
    try:
        recs = beams.simulate_beam_pairs(cb, n, seed)
    finally:
        beams.receptance = receptance
    r0, m = beams._rigid_modes(cb.bc), cb.n_modes
    modes = [[(w[r0:r0 + m], d[r0:r0 + m], phi[:, r0:r0 + m]) for w, d, phi in captured[2 * k:2 * k + 2]]
             for k in range(len(recs))]
    return recs, modes


def shape_error_ratios(cb, recs, modes, k: int) -> np.ndarray:
    """(k', n_modes) identified-shape rms error over the training's calibrated shape std, baseline tests of the
    first ``k`` pairs (pairs whose identification misses a mode are left out)."""
    cal = modal_noise_calibration()
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        beams.write_beam_pairs(cb, recs[:k], tmp)
        for r, ((_, _, phi), _) in zip(recs[:k], modes[:k]):
            md = identify_modes(read_frf(Path(tmp) / f"pair-{r.pair:03d}_baseline.uff"),
                                fmax_hz=beams.band_hz(cb)[1], n_modes=cb.n_modes)
            psi = np.asarray(md.eigenvectors)
            if psi.shape[1] != cb.n_modes:
                continue
            err = []
            for j in range(cb.n_modes):
                v, p = psi[:, j], phi[:, j] / np.max(np.abs(phi[:, j]))
                a = np.vdot(v, p) / np.vdot(v, v)
                err.append(np.sqrt(np.mean(np.abs(a * v - p) ** 2)))
            t = r.truth
            out.append(np.array(err) / _sigma(cal, "shape", t["noise_level"], t["noise_floor"], cb.n_modes))
    return np.array(out)


def modal_input_scores(cb, recs, modes, model_dir, factor: float, seed: int = 11) -> dict:
    """The network on the pairs' exact modes with calibrated frequency noise and ``factor`` x calibrated shape noise."""
    cal = modal_noise_calibration()
    model = load_model(model_dir)
    rng = np.random.default_rng(seed)
    order = np.argsort(cb.sensors_x_m)                   # rows as the model's DOFs (by position)
    called, small, damaged, pct = [], [], [], []
    for r, days in zip(recs, modes):
        t, m = r.truth, cb.n_modes
        sf = _sigma(cal, "frequency", t["noise_level"], t["noise_floor"], m)
        ss = factor * _sigma(cal, "shape", t["noise_level"], t["noise_floor"], m)
        data = []
        for w, d, phi in days:
            w = w * (1 + sf * rng.standard_normal(m))
            lam = -d / 2 + 1j * np.sqrt(w ** 2 - d ** 2 / 4)
            phi = phi[order]
            noise = complex_normal(rng, phi.shape)
            data.append(ModalData(lam, phi + np.abs(phi).max(axis=0) * ss * noise, ()))
        v = classify_many(model, data[0], [data[1]])[0]
        called.append(bool((v.get("network") or {}).get("damaged")))
        damaged.append(bool(t["damaged"]))
        small.append(bool(t["damaged"]) and t["max_frequency_drop_rel"] < 0.005)
        pct.append(np.nan if v["training_percentile"] is None else v["training_percentile"])
    called, small, damaged, pct = map(np.array, (called, small, damaged, pct))
    return {"factor": factor, "detection": float(called[damaged].mean()), "damaged": int(damaged.sum()),
            "small_detected": int(called[small].sum()), "small": int(small.sum()),
            "false_alarms": int(called[~damaged].sum()), "intact": int((~damaged).sum()),
            "intact_percentile_median": float(np.nanmedian(pct[~damaged]))}


def main(argv=None) -> int:
    ap = parser(__file__, __doc__, seed=0)
    ap.add_argument("--beam", required=True)
    ap.add_argument("--model", required=True, help="the beam's trained model directory (study_beams)")
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--factors", type=float, nargs="+", default=[1.0, 8.0])
    ap.add_argument("--identify", type=int, default=6)
    a = ap.parse_args(argv)

    cb = next((c for c in CATALOGUE if c.name == a.beam), None)
    if cb is None or not (Path(a.model) / "config.json").is_file():
        print(f"diagnose_shape_noise: error: --beam must be one of {[c.name for c in CATALOGUE]} and --model a "
              f"model directory, got {a.beam!r} and {a.model!r}", file=sys.stderr)
        return 2
    recs, modes = _exact_modes(cb, a.n, a.seed)
    res = {"beam": cb.name}
    if a.identify:
        ratios = shape_error_ratios(cb, recs, modes, a.identify)
        res["identified_shape_error_over_calibrated_median"] = np.median(ratios, axis=0).round(2).tolist()
    res["modal_input"] = [modal_input_scores(cb, recs, modes, a.model, f) for f in a.factors]
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
