"""What cutting held modes at a re-excitation changes: ``era`` with and without
:func:`~physics.identification.held_reexcitation.refit_held_re_excited`'s cut (its
:data:`~physics.identification.held_reexcitation.REEXCITE_OVER_RAMP` set below any ratio), record by record.

Run: ``python -m experiments.benches.bench_held_reexcitation [--cases sim,frame,real] [--seeds 20] [DIR]``

* **sim**: one accelerometer, 4 s at 1 kHz, a 1 %-damped 23-Hz mode and a 0.3 %-damped 61-Hz one hit at 0, the
  61-Hz mode alone hit again at 0.5-0.7 s with half (then a quarter of) its first amplitude, white noise of 1e-3
  of the record's std, ten records each (seeds 0-9); and five single decays (noise 3e-2). Per record, the 61-Hz
  error in its own sigmas without and with the cut.
* **frame**: the free-decay bench's frame records (:func:`experiments.benches.bench_free_decay.frame_case`: four
  channels, 8 s at 500 Hz, three hits of random times and gains), ``--seeds`` of them; each mode's error in its
  sigmas where the two runs differ.
* **real**: the pyFRF hits, the USC bridge's eight Mode 3 impacts (5-40 Hz), the DS5 board's baseline shocks 1-15
  (500-5500 Hz) and DROPBEAR state 2's dwells (15-300 Hz), read from ``DIR`` (default as
  :mod:`experiments.benches.real_sets`); the records whose frequencies differ between the two runs.

About 3 min for sim, 10 s a frame record, 5-10 min for real (one BLAS thread, an idle machine: much more when shared).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

import physics.identification.held_reexcitation as held_reexcitation
from experiments.benches.harness import parser
from experiments.benches.real_sets import REAL_DIRS, dropbear_roller, usc_bridge
from physics.errors import BeamDamageError
from physics.identification.free_decay import identify_era

__all__ = ["frame_records", "main", "real_records", "sim_records"]


def _decay(fs, n, fn, zeta, amps, t0, gain=1.0):
    """Closed-form impulse responses ``gain Re(a exp(lambda (t - t0)) / (i w))`` from ``t0`` (s), summed over the
    modes: shape (1, n)."""
    w = 2 * np.pi * np.asarray(fn, float)
    lam = -np.asarray(zeta) * w + 1j * w * np.sqrt(1 - np.asarray(zeta) ** 2)
    t = np.arange(n) / fs - t0
    on = t >= 0
    y = np.zeros(n)
    y[on] = gain * np.real(np.asarray(amps, float) @ (np.exp(np.outer(lam, t[on])) / (1j * lam.imag)[:, None]))
    return y[None, :]


def sim_records(seeds=range(10)):
    """``(label, record (1, 4000), 1000.0, truth Hz)``: the 61-Hz mode re-excited (gains 0.5 and 0.25) and single
    decays (see the module docstring)."""
    fs, n, out = 1000.0, 4000, []
    for gain, noise, label in [(0.5, 1e-3, "half"), (0.25, 1e-3, "quarter"), (0.0, 3e-2, "single")]:
        for s in (seeds if gain else list(seeds)[:5]):
            rng = np.random.default_rng(100 + s)
            t_hit = rng.uniform(0.5, 0.7)
            y = _decay(fs, n, [23.0, 61.0], [0.01, 0.003], [1.0, 0.3], 0.0)
            if gain:
                y = y + _decay(fs, n, [61.0], [0.003], [0.3], t_hit, gain)
            out.append((f"{label} {s}", y + noise * y.std() * rng.standard_normal(y.shape), fs, np.array([61.0])))
    return out


def frame_records(seeds):
    """``(label, record (4, 4096), 500.0, truth Hz)`` of the free-decay bench's frame case (the same draws)."""
    fs, n, out = 500.0, 4096, []
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        fn = rng.uniform(3.5, 6.0) * np.array([1.0, 3.1, 7.1, 10.7])
        zeta = rng.uniform(0.015, 0.02, 4)
        phi = rng.standard_normal((4, 4))
        hits = np.sort(rng.uniform(0.2, 6.5, 3))
        hits = hits if np.all(np.diff(hits) > 1.0) else np.array([0.3, 2.9, 5.6])
        gains = rng.uniform(0.5, 1.5, 3)
        clean = sum(np.concatenate([_decay(fs, n, fn, zeta, p, th, g) for p in phi]) for th, g in zip(hits, gains))
        noise = 0.02 * clean.std() * np.random.default_rng(seed).standard_normal(clean.shape)
        out.append((f"frame {seed}", clean + noise, fs, fn))
    return out


def real_records(directory):
    """``(label, record, fs, band)`` of the real sets found in ``directory`` (see the module docstring)."""
    d, out = Path(directory), []
    if (d / "pyfrf_hits.npz").is_file():
        z = np.load(d / "pyfrf_hits.npz")
        out += [(f"pyFRF hit {k + 1}", r[None].astype(float), float(z["sampling_frequency_hz"]), None)
                for k, r in enumerate(z["response"])]
    if (d / "usc_bridge_a_impacts.npz").is_file():
        b = usc_bridge(d / "usc_bridge_a_impacts.npz")
        g = next(g for g in b.groups if g.label == "Mode 3 layout")
        out += [(f"USC record {i}", b.records[i], b.sampling_frequency_hz, (5.0, 40.0)) for i in g.indices]
    if (d / "ds5_pcb_repeated_shock.npz").is_file():
        z = np.load(d / "ds5_pcb_repeated_shock.npz")
        out += [(f"DS5 shock {k + 1}", z["pcb_records"][k, 520:][None].astype(float),
                 float(z["pcb_sampling_frequency_hz"][k]), (500.0, 5500.0)) for k in range(15)]
    if (d / "dropbear_roller_steps.npz").is_file():
        r = dropbear_roller(d / "dropbear_roller_steps.npz")
        g = next(g for g in r.groups if g.label == "state 2")
        out += [(f"DROPBEAR dwell {i}", r.records[i], r.sampling_frequency_hz, (15.0, 300.0)) for i in g.indices]
    return out


def _era(y, fs, band, cut):
    """``era``'s frequencies and one sigmas (Hz) with the held modes' cut on or off; a refusal: None."""
    saved = held_reexcitation.REEXCITE_OVER_RAMP
    held_reexcitation.REEXCITE_OVER_RAMP = saved if cut else -np.inf
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est = identify_era(y, fs, band).estimate
        return est.natural_frequencies_hz, est.frequency_std_hz
    except BeamDamageError:
        return None
    finally:
        held_reexcitation.REEXCITE_OVER_RAMP = saved


def _sigmas(got, truth):
    f, s = got
    j = np.abs(f[:, None] - truth[None, :]).argmin(axis=0)
    return (f[j] - truth) / s[j]


def main(argv=None) -> int:
    p = parser(__file__, __doc__)
    p.add_argument("dir", nargs="?", default=None, help="folder of the real sets (default: as real_sets)")
    p.add_argument("--cases", default="sim,frame,real", help="comma-separated: sim, frame, real")
    p.add_argument("--seeds", type=int, default=20, help="frame records (default 20)")
    args = p.parse_args(argv)
    cases = args.cases.split(",")
    simulated = (sim_records() if "sim" in cases else []) + (frame_records(args.seeds) if "frame" in cases else [])
    for label, y, fs, truth in simulated:
        off, on = _era(y, fs, None, False), _era(y, fs, None, True)
        if off is None or on is None:
            print(f"{label}: refused ({'without' if off is None else 'with'} the cut)")
            continue
        e0, e1 = _sigmas(off, truth), _sigmas(on, truth)
        mark = "" if np.array_equal(off[0], on[0]) else "  cut"
        print(f"{label}: error (sigmas) without {np.round(e0, 2).tolist()}, with {np.round(e1, 2).tolist()}{mark}",
              flush=True)
    if "real" in cases:
        directory = args.dir or next((d for d in REAL_DIRS if d.is_dir()), REAL_DIRS[-1])
        records = real_records(directory)
        changed = 0
        for label, y, fs, band in records:
            off, on = _era(y, fs, band, False), _era(y, fs, band, True)
            same = (off is None and on is None) or (off is not None and on is not None and off[0].size == on[0].size
                                                    and np.allclose(off[0], on[0], rtol=0, atol=1e-9))
            if not same:
                changed += 1
                print(f"{label}: {None if off is None else np.round(off[0], 3).tolist()} -> "
                      f"{None if on is None else np.round(on[0], 3).tolist()}", flush=True)
        print(f"real: {changed} of {len(records)} records changed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
