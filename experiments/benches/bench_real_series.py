"""Benchmark: ``monitor`` against the plainest tests on real repeated-test series (the public sets of
``experiments/data/real/README.md``, kept outside the repository's commits; a set that is absent is skipped).

Run: ``python -m experiments.benches.bench_real_series [--data experiments/data/real] [--sets dropbear dropbear-2ch
ds5-shock ds5-impedance bridge ds11-b4.3 ds11-b4.4 ds11-b4.6 ds11-b3.4 ds11-b4.1 ds11-b4.5 ds11-b4.7 ds11-b4.8
ds11-b4.9 ds11-b4.10] [--quick] [--rate 0.01] [--statistics residual environment shift mode]
[--out out/bench_real_series] [--docs]``

Each set becomes a monitoring series: a baseline period (the first ``n_baseline`` tests) and later tests, each a
group (intact, a change of a known size, or a block of later shocks of unknown damage). Every test's record is
written as an NPZ time series (``signals``, ``sampling_frequency_hz``) into ``--out`` and the series is judged by
``monitor``'s own path (:func:`learn.monitor.monitor_series`: identification by ``era`` for a free decay, else
SSI-cov, the modes tracked, the normal model and the detector at ``--rate`` false alarms; the identifications are
cached in ``--out``/cache, so a second run takes seconds). Beside it, on the same records, the plainest tests on
the FFT peaks (:mod:`physics.identification.fft_peak`): the baseline's modes are the clusters
(:func:`learn.monitor.tracking.reference_modes`) of the clear peaks :func:`identify_fft_peaks` finds in the baseline
records; every test's frequency of a mode is the highest FFT peak (:func:`fft_peaks`) in the mode's window (half
the smaller log gap to its neighbouring modes either side, within the band). On those frequencies
(:func:`~experiments.benches.plain_tests.plain_alarms`, both sides, linear quantiles):

* ``plain shift``: the mean relative change of the modes from their baseline medians, alarmed below the baseline's
  ``rate / 2`` quantile or above its ``1 - rate / 2`` quantile (signed, both sides);
* ``plain per mode``: any mode's relative change beyond its baseline ``rate / (2 m)`` or ``1 - rate / (2 m)``
  quantile.

On the baseline rows each baseline test is judged against the thresholds of the other baseline tests
(:func:`~experiments.benches.plain_tests.held_out_plain_alarms`), as ``monitor``'s baseline rows are held out: a
quantile of 8-15 tests at ``rate / 2`` is their extreme, which a new healthy test passes far more often than
``rate``. The second table holds the same two tests to a false-alarm rate
(:func:`~experiments.benches.plain_tests.plain_p_values`: Gaussian prediction intervals of ``ln f``, each baseline
test held out) and reads them at ``--rate`` (``at the rate``) and at the threshold that flags as many of the
healthy tests (the held-out baseline and ``intact``) as ``monitor`` does (``matched``,
:func:`~experiments.benches.plain_tests.matched_alarms`: a point of their ROC curve at ``monitor``'s false alarms).

``monitor on FFT peaks`` is ``monitor`` fed those FFT-peak frequencies as modal data (``natural_frequencies_hz``
files): its detector without its identification. ``monitor`` estimates each mode's frequency by the more repeatable
over the baseline period of its identification and the record's FFT peak (:mod:`learn.monitor.estimator_choice`;
the choice is printed under the table); ``monitor, identification alone`` is ``monitor`` with every frequency its
identification's (``frequency_estimator="identification"``). Each test's modes and error are ``monitor``'s own
(its rows and :attr:`~learn.monitor.SeriesResult.tests`, the narrow-band re-identifications included); a refusal
or a crash of ``monitor`` is reported as the set's result, each test's modes then read from its identification
cache (:func:`~learn.monitor.identification.cached_identification`).

``monitor`` counts a test as flagged when its status is one of :data:`learn.monitor.alarms.FLAGGED_STATUSES`:
``alarm``, ``change or unseen conditions`` (the series are undated, so an extrapolated test alarmed by the
environmental statistics alone gets that status), ``mode moved`` or ``mode lost`` (a reference mode beyond its band
against the baseline's odds); a test it could not identify is not flagged (its status ``not identified`` is reported
apart). Where ``monitor`` misses a test a
plain test flags, the miss is split into ``not identified`` and ``below threshold`` (identified, judged normal).
Writes ``real_series.json`` and ``real_series.md`` in ``--out``.
"""

from __future__ import annotations

import json
import os
import time
import traceback
import warnings
from dataclasses import dataclass
from functools import partial
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from experiments.benches.harness import parser, publish, table  # noqa: E402
from experiments.benches.plain_tests import (held_out_plain_alarms, matched_alarms, matched_threshold,  # noqa: E402
                                             plain_p_values)
from learn.monitor import (IdentificationSettings, IdentifiedModes, SeriesInput, monitor_series,  # noqa: E402
                           reference_modes)
from learn.monitor.alarms import BASELINE_OUTLIER, FLAGGED_STATUSES  # noqa: E402
from learn.monitor.identification import cached_identification  # noqa: E402
from learn.monitor.statistics import DEFAULT_STATISTICS, STATISTICS  # noqa: E402
from physics.errors import BeamDamageError  # noqa: E402
from physics.identification.fft_peak import fft_peaks, identify_fft_peaks  # noqa: E402
from physics.io import atomic_write_text, finite_or_none  # noqa: E402

__all__ = ["DS11_LENGTH", "DS11_SKIP", "LOADERS", "MATCHED", "METHODS", "ONE_ESTIMATOR", "RealSeries",
           "fft_frequencies", "group_scores", "main", "matched_markdown", "mode_windows_hz", "reference_fft_modes"]

DATA = str(Path(__file__).resolve().parents[1] / "data" / "real")


@dataclass(frozen=True)
class RealSeries:
    """A monitoring series of real records.

    Attributes
    ----------
    name : str
    records : list of ndarray (n_channels, n_samples)   one per test, in monitoring order
    sampling_frequency_hz : ndarray (n,)
    n_baseline : int                  the first tests, the baseline period
    groups : tuple of str             per test: ``"baseline"``, ``"intact"`` or the later group it belongs to
    band_hz : (lo, hi)                the band identified (monitor) and searched (FFT peaks)
    labels : tuple of str             per test: where the record comes from
    known : bool                      whether the later groups are known changes (else: unlabelled, first alarms)
    how : str                         the series' make-up, for the report
    """

    name: str
    records: list
    sampling_frequency_hz: np.ndarray
    n_baseline: int
    groups: tuple
    band_hz: tuple
    labels: tuple
    known: bool
    how: str


#: DROPBEAR: mode 1's mean FFT-peak change of each support state from state 0 (the set's description: 25.99,
#: 28.09, 30.79, 33.87, 37.60, 41.88 Hz).
DROPBEAR_MODE1_PCT = (8.1, 18.5, 30.3, 44.7, 61.1)


def _dropbear(path: Path, quick: bool, channels: int = 1) -> RealSeries:
    """DROPBEAR (roller support moved in 5 steps): baseline the state-0 dwells of tests 0-5, later the state-0 dwells
    of tests 6-10 (intact) and every dwell of states 1-5 (the changes). Each dwell's first 2842 samples (0.568 s,
    the shortest dwell) of the low-g accelerometer, band 20-600 Hz (at a 300-Hz upper edge SSI-cov decimates the
    record to 59 block rows, fewer than ``monitor``'s model order 80); ``channels=2``: with the shock accelerometer
    too (unscaled voltages: it reads mostly its own noise, far above the low-g channel's level in the quiet dwells),
    the same band, so that the two series differ by the second channel alone."""
    z = np.load(path)
    fs = float(z["sampling_frequency_hz"])
    st, test, start = z["segment_state"], z["segment_test"], z["segment_start"]
    n = int((z["segment_stop"] - start).min())
    base = np.flatnonzero((st == 0) & (test <= 5))
    intact = np.flatnonzero((st == 0) & (test > 5))
    later = [(f"state {s} (mode 1 +{DROPBEAR_MODE1_PCT[s - 1]:g} %)", np.flatnonzero(st == s)) for s in range(1, 6)]
    if quick:
        intact = intact[::2]
        later = [(g, i[::3]) for g, i in later]
    order = [(i, "baseline") for i in base] + [(i, "intact") for i in intact] + [(i, g) for g, ii in later
                                                                                  for i in ii]
    recs = [z["records"][test[i], :channels, start[i]:start[i] + n] for i, _ in order]
    name, band = ("dropbear" if channels == 1 else "dropbear-2ch"), (20.0, 600.0)
    return RealSeries(name, recs, np.full(len(recs), fs), base.size, tuple(g for _, g in order), band,
                      tuple(f"test {test[i]} dwell {i % 11} state {st[i]}" for i, _ in order), True,
                      f"baseline: the {base.size} state-0 dwells of tests 0-5; intact: the state-0 dwells of tests "
                      "6-10; changes: every dwell of states 1-5 (roller moved); "
                      + ("the low-g accelerometer" if channels == 1 else "both accelerometers") + ", 0.568 s each")


def _ds5_shock(path: Path, quick: bool, n_baseline: int = 15) -> RealSeries:
    """DS5 repeated shocks: the PCB channel from 20 samples after the clipped peak (sample 500) to the end;
    baseline the first 15 shocks, later blocks of 12 shocks (unlabelled damage)."""
    z = np.load(path)
    y = z["pcb_records"][:, 520:]
    fs = np.asarray(z["pcb_sampling_frequency_hz"], float)
    idx = np.arange(y.shape[0])
    if quick:
        idx = np.r_[idx[:n_baseline], idx[n_baseline::2]]
    groups = tuple("baseline" if k < n_baseline else _block(k, n_baseline, 12, y.shape[0]) for k in idx)
    return RealSeries("ds5-shock", [y[k][None] for k in idx], fs[idx], n_baseline, groups, (500.0, 5500.0),
                      tuple(f"shock {k + 1} (a{z['trial_number'][k]})" for k in idx), False,
                      f"baseline: shocks 1-{n_baseline}; later: shocks {n_baseline + 1}-{y.shape[0]} in blocks "
                      "(damage accumulates, unlabelled); PCB channel after the clipped shock, 0.1 s")


def _ds5_impedance(path: Path, quick: bool, n_baseline: int = 10) -> RealSeries:
    """DS5 shock-impedance board: the PCB channel, 8192 samples (0.16 s) from 20 samples after its absolute peak;
    tests flagged bad (17, 24) left out; baseline the first 10 tests, later blocks of 8."""
    z = np.load(path)
    keep = np.flatnonzero(~z["acquisition_flagged_bad"])
    if quick:
        keep = np.r_[keep[:n_baseline], keep[n_baseline::2]]
    fs = float(z["sampling_frequency_hz"])
    recs = []
    for k in keep:
        y = z["records"][k, 1]
        a = int(np.argmax(np.abs(y))) + 20
        recs.append(y[None, a:a + 8192])
    num = z["test_number"][keep]
    block = (num - 1) // 8
    span = {b: f"tests {num[(block == b) & later].min()}-{num[(block == b) & later].max()}"
            for later in [np.arange(num.size) >= n_baseline] for b in np.unique(block[later])}
    groups = tuple("baseline" if j < n_baseline else span[b] for j, b in enumerate(block))
    return RealSeries("ds5-impedance", recs, np.full(len(recs), fs), n_baseline, groups, (3800.0, 6600.0),
                      tuple(f"test {t}" for t in num), False,
                      f"baseline: tests 1-{num[n_baseline - 1]}; later: tests {num[n_baseline]}-{num[-1]} (17 and 24 "
                      "flagged bad, left out; damage accumulates, unlabelled); PCB channel after the shock, 0.16 s")


def _bridge(path: Path, quick: bool, n_baseline: int = 8) -> RealSeries:
    """USC bridge A: the 12 impacts in time order (all intact), the 3 channels from 0.05 s after the impact, as long
    as the shortest; band 10-20 Hz (two modes: the 12 records carry a baseline for two, not for six)."""
    z = np.load(path)
    fs = float(z["sampling_frequency_hz"])
    order = np.argsort(z["start_time"], kind="stable")
    starts = [int(np.argmax(np.abs(z["records"][k].sum(axis=0)))) + int(0.05 * fs) for k in order]
    n = min(z["records"].shape[2] - a for a in starts)
    recs = [z["records"][k][:, a:a + n] for k, a in zip(order, starts)]
    groups = tuple("baseline" if j < n_baseline else "intact" for j in range(len(recs)))
    return RealSeries("bridge", recs, np.full(len(recs), fs), n_baseline, groups, (10.0, 20.0),
                      tuple(f"TestBridge_{z['test_number'][k]} ({z['sensor_layout'][k]})" for k in order), True,
                      f"baseline: the first {n_baseline} impacts; intact: the last {len(recs) - n_baseline} (all "
                      f"intact); 3 channels, {n / fs:.1f} s each")


#: Dataset-11: samples (of 200 kHz) skipped after the board channel's largest deviation, and the samples kept.
DS11_SKIP, DS11_LENGTH = 200, 14000
#: A Dataset-11 record holds a hit when its largest deviation from its first sample is at least this fraction of the
#: board's median largest deviation (the 5 kg drop's hits: thousands of units; a record of noise alone: under 30).
DS11_HIT_FRACTION = 0.1


def _ds11(path: Path, quick: bool, board: str = "4.6", n_baseline: int = 15, block: int = 15) -> RealSeries:
    """Dataset-11, one board's impacts to failure: the board channel from 1 ms after its largest deviation, 70 ms;
    a record without a hit left out: its largest deviation under :data:`DS11_HIT_FRACTION` of the board's median
    (noise alone: 3.4's ``_01``, 4.5's and 4.8's ``_00``, 5-8 units against hits of thousands) or too late for the
    70 ms (boards 4.3, 4.4 and 4.6's ``_00`` and 4.6's ``_01``, no hit before 75 ms); baseline the first 15 impacts
    kept, later blocks of 15 impacts (damage accumulates, unlabelled) and the last impact, at which the resistor's
    circuit opened."""
    z = np.load(path)
    sel = np.flatnonzero(z["board"] == board)
    y = z["records"][sel, 1]
    deviation = np.abs(y - y[:, :1])
    peak = np.argmax(deviation, axis=1)
    size = deviation[np.arange(len(peak)), peak]
    keep = np.flatnonzero((peak + DS11_SKIP + DS11_LENGTH <= y.shape[1])
                          & (size >= DS11_HIT_FRACTION * np.median(size)))
    num, failed = z["impact_number"][sel], z["open_circuit"][sel]
    last = num[keep][~failed[keep]].max()
    if quick:
        keep = np.r_[keep[:n_baseline], keep[n_baseline:-1][::2], keep[-1:]]

    def group(j: int, k: int) -> str:
        if j < n_baseline:
            return "baseline"
        if failed[k]:
            return f"impact {num[k]} (circuit open)"
        a = int(num[keep[n_baseline]]) + block * ((int(num[k]) - int(num[keep[n_baseline]])) // block)
        return f"impacts {a}-{min(a + block - 1, last)}"

    recs = [y[k][None, peak[k] + DS11_SKIP:peak[k] + DS11_SKIP + DS11_LENGTH] for k in keep]
    fs = float(z["sampling_frequency_hz"])
    return RealSeries(f"ds11-b{board}", recs, np.full(len(recs), fs), n_baseline,
                      tuple(group(j, k) for j, k in enumerate(keep)), (400.0, 6000.0),
                      tuple(f"board {board} impact {num[k]}" for k in keep), False,
                      f"baseline: impacts {num[keep[0]]}-{num[keep[n_baseline - 1]]}; later: impacts "
                      f"{num[keep[n_baseline]]}-{last} in blocks (damage accumulates, unlabelled) and impact "
                      f"{num[keep[-1]]}, the circuit open; board channel from 1 ms after the hit, 70 ms")


def _block(k: int, start: int, size: int, total: int) -> str:
    a = start + size * ((k - start) // size)
    return f"shocks {a + 1}-{min(a + size, total)}"


#: Each set: its file in ``--data`` and the function making its series (``quick``: fewer later tests).
LOADERS = {"dropbear": ("dropbear_roller_steps.npz", _dropbear),
           "dropbear-2ch": ("dropbear_roller_steps.npz", partial(_dropbear, channels=2)),
           "ds5-shock": ("ds5_pcb_repeated_shock.npz", _ds5_shock),
           "ds5-impedance": ("ds5_pcb_shock_impedance.npz", _ds5_impedance),
           "bridge": ("usc_bridge_a_impacts.npz", _bridge),
           **{f"ds11-b{b}": ("ds11_pcb_impacts_to_failure.npz", partial(_ds11, board=b))
              for b in ("4.3", "4.4", "4.6")},
           **{f"ds11-b{b}": ("ds11_more_boards.npz", partial(_ds11, board=b))
              for b in ("3.4", "4.1", "4.5", "4.7", "4.8", "4.9", "4.10")}}
#: Sets held but not monitored, and why.
NOT_SERIES = {"pyfrf_hits.npz": "5 hammer hits: fewer than the 7 tests a baseline of one mode needs, none left "
                                "to judge",
              "hct_setups.npz": "4 ambient setups with different sensors: not repeated tests of one layout"}


def reference_fft_modes(records, sampling_frequency_hz, band_hz) -> np.ndarray:
    """The baseline's modes (Hz, ascending) on the FFT peaks: the clusters :func:`reference_modes` finds among the
    clear peaks of :func:`identify_fft_peaks` of each record (a record without a clear peak skipped)."""
    found = []
    for y, fs in zip(records, sampling_frequency_hz):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                est, _ = identify_fft_peaks(y, float(fs), band_hz)
        except BeamDamageError:
            continue
        f = np.asarray(est.natural_frequencies_hz, float)
        found.append(IdentifiedModes("response records", "fftpeak", f, np.zeros(f.size), None))
    if not found:
        return np.zeros(0)
    return np.asarray(reference_modes(found).frequencies_hz, float)


def mode_windows_hz(reference_hz, band_hz) -> np.ndarray:
    """``(m, 2)`` window of each mode (Hz): ``f exp(-+w)``, ``w`` half the smaller log gap to its neighbouring modes
    (the band for a single mode), within the band."""
    f = np.asarray(reference_hz, float)
    if f.size == 1:
        return np.array([[float(band_hz[0]), float(band_hz[1])]])
    gap = np.diff(np.log(f))
    w = 0.5 * np.minimum(np.r_[gap[0], gap], np.r_[gap, gap[-1]])
    return np.c_[np.maximum(f * np.exp(-w), band_hz[0]), np.minimum(f * np.exp(w), band_hz[1])]


def fft_frequencies(records, sampling_frequency_hz, windows_hz) -> np.ndarray:
    """``(n, m)`` frequency (Hz) of each mode in each record: the highest local maximum of the zero-padded FFT
    power in the mode's window (:func:`fft_peaks`, its window chosen by the record), NaN where none lies there."""
    w = np.asarray(windows_hz, float)
    centre, half = w.mean(axis=1), 0.5 * (w[:, 1] - w[:, 0])
    out = np.full((len(records), w.shape[0]), np.nan)
    for i, (y, fs) in enumerate(zip(records, sampling_frequency_hz)):
        try:
            out[i] = fft_peaks(y, float(fs), centre, half).frequency_hz
        except BeamDamageError:
            pass
    return out


def group_scores(groups, flags: dict, identified, n_baseline: int, known: bool, against=None) -> list:
    """One row per group of later tests (and one for the baseline): its size ``n``, each method's flagged share
    (``flags``: method -> bool (n,)), the tests the first method identified, and its misses of tests one of the
    methods ``against`` (default: every other) flags, split into ``not identified`` and ``below threshold``; with
    ``known=False`` the first flagged later test of each method as well (index into the series)."""
    groups = np.asarray(groups)
    ident = np.asarray(identified, bool)
    names = list(flags)
    first = names[0]
    rows = []
    for g in dict.fromkeys(groups):
        sel = groups == g
        others = np.zeros(sel.size, bool)
        for nm in (names[1:] if against is None else against):
            others |= flags[nm]
        miss = sel & ~flags[first] & others
        rows.append({"group": str(g), "n": int(sel.sum()), "identified": int((sel & ident).sum()),
                     **{nm: float(flags[nm][sel].mean()) for nm in names},
                     "missed, not identified": int((miss & ~ident).sum()),
                     "missed, below threshold": int((miss & ident).sum())})
    if not known:
        later = np.arange(groups.size) >= n_baseline
        rows.append({"group": "first flagged later test",
                     **{nm: (int(np.flatnonzero(flags[nm] & later)[0]) if (flags[nm] & later).any() else None)
                        for nm in names}})
    return rows


def _write_records(series: RealSeries, folder: Path) -> list:
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for k, (y, fs) in enumerate(zip(series.records, series.sampling_frequency_hz)):
        path = folder / f"test_{k:03d}.npz"
        if not path.is_file():                  # the same bytes every run: the cache keys on them
            tmp = folder / f".test_{k:03d}.tmp.npz"
            np.savez(tmp, signals=np.asarray(y, np.float64), sampling_frequency_hz=np.float64(fs))
            os.replace(tmp, path)
        files.append(str(path))
    return files


def _crash_text(exc: Exception) -> str:
    tb = traceback.extract_tb(exc.__traceback__)[-1]
    return f"crashed: {type(exc).__name__}: {exc} ({Path(tb.filename).name}:{tb.lineno} {tb.name})"


def _monitor(files, n_baseline: int, settings: IdentificationSettings, cache, rate: float,
             statistics=DEFAULT_STATISTICS, frequency_estimator: str = "choose") -> tuple:
    """``(statuses, reference frequencies (Hz), per-test errors, per-test modes, refusal or None, choice)`` of
    ``monitor`` on ``files``: its rows, its tests and its frequency estimators (a dict, or None); when it refuses or
    crashes, each test's identification from the cache."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = monitor_series(SeriesInput.from_files(files), n_baseline, settings, cache, rate, progress=False,
                                 chart="none", statistics=statistics, frequency_estimator=frequency_estimator)
    except BeamDamageError as exc:
        why = str(exc)
    except Exception as exc:                    # a crash of monitor on real records is a result to report
        why = _crash_text(exc)
    else:
        return ([r["status"] for r in res.rows], [float(v) for v in res.reference.frequencies_hz],
                [r["error"] for r in res.rows], list(res.tests), None,
                None if res.frequency_choice is None else res.frequency_choice.to_dict())
    tests, errors = [], []
    for f in files:
        try:
            t, e, _ = cached_identification(f, settings, cache)
        except Exception as exc:                # a crash of the identification on this record
            t, e = None, f"{f}: {_crash_text(exc)}"
        tests.append(t)
        errors.append(e)
    return ["refused"] * len(files), [], errors, tests, why, None


def _write_modal(F, folder: Path) -> list:
    """Each test's FFT-peak frequencies (the finite ones) as modal data: ``monitor`` on the plain tests' input."""
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for k, f in enumerate(F):
        path = folder / f"test_{k:03d}.json"
        atomic_write_text(path, json.dumps({"natural_frequencies_hz": [float(v) for v in f[np.isfinite(f)]]}))
        files.append(str(path))
    return files


def _flagged(status) -> np.ndarray:
    return np.array([s in FLAGGED_STATUSES for s in status])


def run_set(series: RealSeries, out: Path, rate: float, statistics=DEFAULT_STATISTICS) -> dict:
    """``monitor`` (on the records, and on the FFT-peak frequencies as modal data; ``statistics`` combined) and the
    plain tests on one series: the per-test flags and the per-group scores."""
    t0 = time.perf_counter()
    files = _write_records(series, out / "records" / series.name)
    settings = IdentificationSettings(tuple(series.band_hz))
    status, mon_ref, errors, tests, mon_error, choice = _monitor(files, series.n_baseline, settings, out / "cache",
                                                                 rate, statistics)
    t_mon = time.perf_counter() - t0
    one_status, _, _, _, one_error, _ = _monitor(files, series.n_baseline, settings, out / "cache", rate, statistics,
                                                 "identification")
    nb = series.n_baseline
    ref = reference_fft_modes(series.records[:nb], series.sampling_frequency_hz[:nb], series.band_hz)
    F = fft_frequencies(series.records, series.sampling_frequency_hz, mode_windows_hz(ref, series.band_hz)) \
        if ref.size else np.full((len(files), 0), np.nan)
    none = {k: np.zeros(len(files), bool) for k in ("plain shift", "plain per mode")}
    plain = held_out_plain_alarms(F, nb, rate, sides=2, method="linear") if ref.size else none
    fft_status, fft_ref, _, _, fft_error, _ = _monitor(_write_modal(F, out / "fft_modal" / series.name), nb,
                                                 IdentificationSettings(), None, rate, statistics)
    flags = {"monitor": _flagged(status), **plain, "monitor on FFT peaks": _flagged(fft_status),
             ONE_ESTIMATOR: _flagged(one_status)}
    identified = np.array([t is not None and t.frequencies_hz.size > 0 for t in tests]) if mon_error \
        else np.array([s not in ("not identified", "not judged") for s in status])
    rows = group_scores(series.groups, flags, identified, nb, series.known, against=("plain shift", "plain per mode"))
    healthy = np.isin(np.asarray(series.groups), ("baseline", "intact"))
    allowed = int(flags["monitor"][healthy].sum())
    p = plain_p_values(F, nb) if ref.size else {k: np.full(len(files), np.nan) for k in none}
    fair = {"monitor": flags["monitor"], "monitor on FFT peaks": flags["monitor on FFT peaks"],
            **{f"{k} at the rate": v < rate for k, v in p.items()},
            **{f"{k}, matched": matched_alarms(v, healthy, allowed) for k, v in p.items()}}
    fair_rows = group_scores(series.groups, fair, identified, nb, series.known, against=())
    thresholds = {k: finite_or_none(matched_threshold(v, healthy, allowed)) for k, v in p.items()}
    base_med = np.nanmedian(F[:nb], axis=0) if ref.size else np.zeros(0)
    for r in rows:
        if r["group"] in series.groups and ref.size:
            sel = np.asarray(series.groups) == r["group"]
            r["mode 1 change %"] = float(100 * np.nanmedian(F[sel, 0] / base_med[0] - 1))
            r["fft found"] = int(np.isfinite(F[sel]).all(axis=1).sum())
    return {"set": series.name, "how": series.how, "band_hz": list(series.band_hz), "n": len(files),
            "n_baseline": nb, "monitor_error": mon_error, "monitor_reference_hz": mon_ref,
            "frequency_estimators": choice, "identification_alone_error": one_error,
            "identification_alone_status": one_status,
            "monitor_on_fft_error": fft_error,
            "monitor_on_fft_reference_hz": fft_ref, "monitor_on_fft_status": fft_status,
            "fft_reference_hz": ref.tolist(), "status": status, "errors": errors, "identified_hz":
                [None if t is None else [float(v) for v in t.frequencies_hz] for t in tests],
            "labels": list(series.labels), "groups": list(series.groups), "fft_frequencies_hz": F.tolist(),
            "flags": {k: v.tolist() for k, v in flags.items()}, "rows": rows,
            "plain_p_values": {k: v.tolist() for k, v in p.items()}, "matched": {
                "healthy": int(healthy.sum()), "monitor_flagged": allowed, "p_thresholds": thresholds,
                "flags": {k: v.tolist() for k, v in fair.items()}, "rows": fair_rows},
            "seconds": time.perf_counter() - t0,
            "monitor_seconds": t_mon}


def _no_answer(error: str) -> str:
    return "failed" if error.startswith("crashed") else "refused"


def _pct(v) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


#: ``monitor`` with every mode's frequency by the identification (``frequency_estimator="identification"``).
ONE_ESTIMATOR = "monitor, identification alone"
METHODS = ("monitor", ONE_ESTIMATOR, "monitor on FFT peaks", "plain shift", "plain per mode")


#: The second table's methods: ``monitor`` beside the plain tests held to a false-alarm rate
#: (:func:`~experiments.benches.plain_tests.plain_p_values`): at ``--rate``, and matched to ``monitor``'s alarms on
#: the held-out healthy tests (:func:`~experiments.benches.plain_tests.matched_alarms`).
MATCHED = ("monitor", "monitor on FFT peaks", "plain shift at the rate", "plain per mode at the rate",
           "plain shift, matched", "plain per mode, matched")


def matched_markdown(results: list, rate: float) -> str:
    """The second docs table: per set and group, ``monitor`` and the plain tests at matched false alarms (baseline
    rows: every method's held-out alarms), with each set's healthy tests, ``monitor``'s alarms among them and the
    matched p-value thresholds under it."""
    head = ["set", "tests", "n", *MATCHED]
    lines, notes = [], []
    for res in results:
        m = res["matched"]
        refused = {"monitor": res["monitor_error"], "monitor on FFT peaks": res["monitor_on_fft_error"]}
        for k, r in enumerate(m["rows"]):
            name = res["set"] if k == 0 else ""
            if r["group"] == "first flagged later test":
                cells = [_no_answer(refused[c]) if refused.get(c) else res["labels"][r[c]] if r[c] is not None
                         else "never" for c in MATCHED]
                lines.append([name, "first flagged later test", "", *cells])
                continue
            cells = [_no_answer(refused[c]) if refused.get(c) else _pct(r[c]) for c in MATCHED]
            lines.append([name, "baseline (held out)" if r["group"] == "baseline" else r["group"], r["n"], *cells])
        th = m["p_thresholds"]
        notes.append(f"{res['set']}: monitor flags {m['monitor_flagged']} of the {m['healthy']} healthy "
                     "tests; matched: p below " + ", ".join(
                         f"{'all' if v is None else f'{v:.3g}'} ({k})" for k, v in th.items()))
    return table(head, lines) + "\n\n" + "; ".join(notes) + (
        f"\n\nThe plain tests held to a rate: Gaussian prediction intervals of the FFT peaks' `ln f` (the shift: the "
        f"mean over the modes; per mode: Bonferroni over the modes), two-sided, each baseline test held out; `at "
        f"the rate`: p below {rate:g}; `matched`: p below the largest threshold that flags no more healthy tests "
        "(the held-out baseline and `intact`) than `monitor` does.")


def markdown(results: list, rate: float) -> str:
    """The docs table: per set and group, the tests identified, each method's share flagged and monitor's misses
    (``refused``: monitor refused the series, ``failed``: it crashed; the notes under the table say why)."""
    head = ["set", "tests", "n", "first mode's change (FFT, median)", "identified: monitor / FFT", *METHODS,
            "monitor misses: not identified / below threshold"]
    lines = []
    for res in results:
        refused = {"monitor": res["monitor_error"], "monitor on FFT peaks": res["monitor_on_fft_error"],
                   ONE_ESTIMATOR: res["identification_alone_error"]}
        for k, r in enumerate(res["rows"]):
            name = res["set"] if k == 0 else ""
            if r["group"] == "first flagged later test":
                cells = [_no_answer(refused[m]) if refused.get(m) else res["labels"][r[m]] if r[m] is not None
                         else "never" for m in METHODS]
                lines.append([name, "first flagged later test", "", "", "", *cells, ""])
                continue
            base = r["group"] == "baseline"
            size = "" if base or "mode 1 change %" not in r else f"{r['mode 1 change %']:+.2f} %"
            cells = [_no_answer(refused[m]) if refused.get(m) else _pct(r[m]) for m in METHODS]
            miss = "" if base or refused["monitor"] else f"{r['missed, not identified']} / " \
                                                          f"{r['missed, below threshold']}"
            lines.append([name, "baseline (held out)" if base else r["group"], r["n"], size,
                          f"{r['identified']} / {r.get('fft found', 0)}", *cells, miss])
    notes = [f"{res['set']}: {what} {'failed' if res[key].startswith('crashed') else 'refused'}: {res[key]}"
             for res in results for what, key in (("monitor", "monitor_error"),
                                                  ("monitor on FFT peaks", "monitor_on_fft_error")) if res[key]]
    notes += [f"{res['set']}: " + "; ".join(res["frequency_estimators"]["texts"]) for res in results
              if res.get("frequency_estimators")]
    for res in results:
        left = {what: [res["labels"][i] for i, st in enumerate(res[key] or []) if st == BASELINE_OUTLIER]
                for what, key in (("monitor", "status"), (ONE_ESTIMATOR, "identification_alone_status"),
                                  ("monitor on FFT peaks", "monitor_on_fft_status"))}
        if any(left.values()):
            notes.append(f"{res['set']}: baseline outliers left out: "
                         + "; ".join(f"{what} {', '.join(v) or 'none'}" for what, v in left.items()))
    return table(head, lines) + "".join(f"\n\n{n}" for n in notes) + (
        f"\n\nShare of each group's tests flagged at {rate:g} false alarms (`intact`: false alarms; baseline: "
        "each method's held-out alarms, each baseline test judged against the others).\n\n"
        "Plain tests at matched false alarms:\n\n" + matched_markdown(results, rate)
        + "\n\n`python -m experiments.benches.bench_real_series --docs`")


def main(argv=None) -> int:
    p = parser(__file__, __doc__, docs="monitoring.md", out="out/bench_real_series")
    p.add_argument("--data", default=DATA, help=f"folder of the real sets (default {DATA})")
    p.add_argument("--sets", nargs="+", choices=list(LOADERS), default=list(LOADERS))
    p.add_argument("--quick", action="store_true", help="a third to a half of the later tests")
    p.add_argument("--rate", type=float, default=0.01, help="false-alarm rate (default 0.01)")
    p.add_argument("--statistics", nargs="+", choices=STATISTICS, default=list(DEFAULT_STATISTICS),
                   help=f"the detector's statistics (default: monitor's, {' '.join(DEFAULT_STATISTICS)})")
    a = p.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for name in a.sets:
        file, load = LOADERS[name]
        path = Path(a.data) / file
        if not path.is_file():
            print(f"{name}: {path} absent, skipped")
            continue
        res = run_set(load(path, a.quick), out, a.rate, tuple(a.statistics))
        print(f"{name}: {res['n']} tests, {res['seconds']:.0f} s (monitor {res['monitor_seconds']:.0f} s)"
              + (f"; monitor {_no_answer(res['monitor_error'])}: {res['monitor_error']}" if res["monitor_error"]
                 else ""), flush=True)
        results.append(res)
    for file, why in NOT_SERIES.items():
        if (Path(a.data) / file).is_file():
            print(f"{file}: not monitored ({why})")
    md = markdown(results, a.rate)
    print(md)
    atomic_write_text(out / "real_series.json", json.dumps({"rate": a.rate, "quick": a.quick, "sets": results},
                                                            indent=1))
    atomic_write_text(out / "real_series.md", md + "\n")
    publish(a, "real-series", md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
