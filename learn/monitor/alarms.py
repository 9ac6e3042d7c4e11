"""A series monitored: every test identified (cached), the baseline period's modes tracked, the normal variation
learnt on the baseline period and every test scored against the cross-validated threshold; what changed at an
alarm, mode by mode."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from learn.monitor.baseline_outliers import BASELINE_OUTLIER, exclude_baseline_outliers, outlier_novelty
from learn.monitor.baseline_state import held_out_cached
from learn.monitor.identification import IdentificationSettings, write_cache
from learn.monitor.pole_confirmation import confirm_far_poles
from learn.monitor.normal_models import DEFAULT_LATENT, NORMAL_MODELS, PCARemoval
from learn.monitor.series import SeriesInput, check_series, repeated_tests_warning
from learn.monitor.alarm_threshold import Threshold, minimum_baseline
from learn.monitor.charts import CHARTS, Charts, run_charts
from learn.monitor.seasons import covers_seasons, season_warning
from learn.monitor.statistics import (DEFAULT_STATISTICS, STATISTICS, Detection, detect, environmental,
                                     held_out_sessions, residual_threshold)
from learn.monitor.coverage import series_coverage
from learn.monitor.estimator_choice import FREQUENCY_ESTIMATORS, FrequencyChoice, choose_frequencies
from learn.monitor.fft_beyond import fft_peaks_beyond
from learn.monitor.beyond_band import BeyondBands, beyond_bands
from learn.monitor.tracking import (MIN_PRESENCE, MODE_LOST, MODE_MOVED, ReferenceModes, identified_by, narrow_bands_hz,
                                   reference_modes, refit_missing, track_modes)
from physics.errors import BeamDamageError, ConfigError
from physics.io import finite_or_none
from learn.monitor.workers import identify_files

__all__ = ["BASELINE_OUTLIER", "EXTRAPOLATED", "EXTRAPOLATED_ALARMS", "FLAGGED_STATUSES", "MODE_LOST", "MODE_MOVED",
           "STATUSES", "SeriesResult", "changed_text", "monitor_series", "readings_text", "what_changed"]


@dataclass
class SeriesResult:
    """A monitored series.

    Attributes
    ----------
    rows : list of dict              one per test (``file``, ``time``, ``baseline``, ``alarm``, ``novelty``,
                                     ``threshold``, ``frequencies_hz``, ``mode_z_scores``, ``change_pct``,
                                     ``identified``, ``status`` (:data:`STATUSES`), ``error``, ``missing_modes``,
                                     ``beyond_band``: the modes missing from their bands read as moved or lost
                                     (:meth:`learn.monitor.beyond_band.BeyondBands.readings`), ``beyond_band_text``,
                                     ``identified_by``: per mode the method that found its pole (or its
                                     frequency: ``fftpeak (the pole tracked: era)``), ``conditions``,
                                     ``record_crop``: response records clipped in their leading part identified
                                     from the samples after the clipping, which it names; None otherwise)
    reference : ReferenceModes
    frequencies_hz : ndarray (n, m)  tracked frequencies (NaN where missing)
    expected_hz : ndarray (n, m)     the baseline's frequencies at each test's conditions
    novelty : ndarray (n,)           NaN for tests not identified
    threshold : Threshold
    model : the fitted normal-variation estimator
    normal_variation : dict          ``model``, its factors or regression, ``per_mode_std`` (relative)
    sigma : ndarray (m,)             per-mode relative std of the normal variation (what the explanations weigh)
    tests : list of IdentifiedModes or None
    beyond : BeyondBands or None     the modes missing from their bands, moved or lost
    frequency_choice : FrequencyChoice or None    each mode's frequency estimator chosen over the baseline period
                                     (response records; :mod:`learn.monitor.estimator_choice`)
    """

    rows: list
    reference: ReferenceModes
    frequencies_hz: np.ndarray
    expected_hz: np.ndarray
    novelty: np.ndarray
    threshold: Threshold
    model: object
    normal_variation: dict
    sigma: np.ndarray
    tests: list = field(repr=False, default_factory=list)
    series: SeriesInput | None = None
    detection: Detection | None = None
    charts: Charts | None = None
    beyond: BeyondBands | None = None
    frequency_choice: FrequencyChoice | None = None

    @property
    def first_alarm(self) -> int | None:
        return next((i for i, r in enumerate(self.rows) if r["alarm"] and not r["baseline"]), None)


def monitor_series(series: SeriesInput, n_baseline: int, settings: IdentificationSettings, cache_dir=None,
                   false_alarm_rate: float = 0.01, normal_model: str | None = None, progress: bool = True,
                   chart: str = "ewma", statistics=DEFAULT_STATISTICS, workers=1,
                   extrapolated_alarms: str = "auto", frequency_estimator: str = "choose",
                   keep_baseline_outliers: bool = False) -> SeriesResult:
    """Monitor a series: identify every test (cached), track the baseline period's modes, learn the normal
    variation on the baseline period, and score every test against the cross-validated threshold.

    ``normal_model``: a key of :data:`NORMAL_MODELS`; default ``"regression"`` with measured conditions, else
    :data:`DEFAULT_LATENT`. A test alarms when any statistic of :mod:`learn.monitor.statistics` exceeds its
    threshold (``novelty`` and ``threshold`` of a row: the residual's); ``chart="ewma"`` adds the memory charts of
    :mod:`learn.monitor.charts` (``chart_alarm`` and ``onset`` of a row); ``statistics``: those combined (the
    residual always). ``workers``: processes identifying the tests, or a Dask client
    (:func:`learn.monitor.workers.identify_files`; the result does not depend on it). ``extrapolated_alarms``:
    ``separate`` gives a later test beyond the baseline's environment (:func:`learn.monitor.coverage.series_coverage`)
    alarmed only by the statistics of the environment itself (:func:`learn.monitor.statistics.environmental`) the status
    :data:`EXTRAPOLATED` instead of an alarm; ``alarm`` keeps it an alarm; ``auto`` (default) keeps them alarms when the
    baseline period is known to cover the seasons (:func:`learn.monitor.seasons.covers_seasons`: dated tests, a
    baseline period of at least :data:`~learn.monitor.seasons.SEASONS_DAYS` days), else separates them.
    ``frequency_estimator``: ``choose`` (default) estimates each mode's frequency of response records by the more
    repeatable over the baseline period of the identification and the record's FFT peak
    (:mod:`learn.monitor.estimator_choice`; the choice in ``normal_variation["frequency_estimators"]``),
    ``identification`` always by the identification. Raises
    :class:`BeamDamageError` on a baseline that cannot carry the model (too few tests: the message names the
    minimum; a baseline test of another kind, band or beam).

    A reference mode missing from its band in a test with poles is looked for beyond it
    (:func:`learn.monitor.beyond_band.beyond_bands`): moved (a pole no other mode claims within its reach; for a mode
    whose frequency is the FFT peak and which has none in its band, the FFT peak beyond it within its reach:
    :mod:`learn.monitor.fft_beyond`) or lost, each weighed by the baseline period's chance of that reading; a
    flagged one gives a test the detector did not alarm the status :data:`MODE_MOVED` or :data:`MODE_LOST`, counted
    beside the alarms; an alarm carries it in its row's ``beyond_band_text``. A test whose identification found
    poles, none in any reference mode's band, is always flagged so
    (:attr:`learn.monitor.beyond_band.BeyondBands.unplaced`): ``not identified`` is only a test without poles.

    A baseline test whose held-out residual index lies beyond the baseline's family-wise threshold
    (:mod:`learn.monitor.baseline_outliers`) is left out of the baseline period: status
    :data:`~learn.monitor.baseline_outliers.BASELINE_OUTLIER` (its ``novelty`` by the model fitted without it), a
    warning, ``normal_variation["baseline_outliers"]``; ``keep_baseline_outliers`` names it and keeps it.
    """
    n = len(series.files)
    C = series.conditions
    normal_model, q = _checked_request(series, n_baseline, false_alarm_rate, normal_model, chart, statistics)
    if frequency_estimator not in FREQUENCY_ESTIMATORS:
        raise ConfigError(f"--frequency-estimator {frequency_estimator}: expected one of "
                          f"{', '.join(FREQUENCY_ESTIMATORS)}")
    if extrapolated_alarms not in EXTRAPOLATED_ALARMS:
        raise ConfigError(f"--extrapolated-alarms {extrapolated_alarms}: expected one of "
                          f"{', '.join(EXTRAPOLATED_ALARMS)}")
    tests, errors, pending, foreign = _identified(series, n_baseline, settings, cache_dir, progress, workers)
    base = [t for t in tests[:n_baseline] if t is not None]
    ref = reference_modes(tests[:n_baseline])
    m = ref.frequencies_hz.size
    if m == 0:
        raise BeamDamageError(f"no mode is found in at least {MIN_PRESENCE:.0%} of the {len(base)} identified "
                              "baseline tests")
    need = minimum_baseline(m, q)
    if len(base) < need:
        raise BeamDamageError(f"--baseline-tests {n_baseline}: {len(base)} identified baseline tests for {m} tracked "
                              f"modes{f' and {q} condition' + 's' * (q != 1) if q else ''}; at least {need} are needed "
                              f"(modes + conditions + 6)")
    tests = refit_missing(tests, series.files, ref, settings, cache_dir, pending)
    tests = confirm_far_poles(tests, series.files, ref, settings, cache_dir, pending)
    write_cache(pending)                                    # the series is accepted: identifications kept
    F, Z, MAC, cols = track_modes(tests, ref)
    how = identified_by(tests, cols)
    choice = fft = None
    if frequency_estimator == "choose":
        choice = choose_frequencies(tests, series.files, ref, F, cols,
                                    [i for i in range(n_baseline) if i not in foreign], cache_dir, workers)
        if choice is not None:
            F, how = choice.frequencies_hz, choice.identified_by(how)
            fft = fft_peaks_beyond(tests, series.files, ref, choice.chosen, choice.fft_hz, cache_dir, workers)
    X = np.log(F)
    ok = np.array([t is not None for t in tests]) & np.isfinite(X).any(axis=1)
    if q:
        ok &= np.isfinite(C).all(axis=1)
    for i in np.flatnonzero(~ok):
        if errors[i] is None:
            errors[i] = ("no tracked mode identified" if tests[i] is not None else "not identified") if not q or \
                np.isfinite(C[i]).all() else "conditions not measured"
    b_idx = np.flatnonzero(ok[:n_baseline])
    Cq = C if q else None

    def fitted(rows):
        mdl = NORMAL_MODELS[normal_model](m, q).fit(X[rows], None if Cq is None else Cq[rows])
        return mdl, held_out_cached(mdl, X[rows], None if Cq is None else Cq[rows], cache_dir)  # kept beside the cache

    b_idx, model, held, outliers = exclude_baseline_outliers(fitted, b_idx, false_alarm_rate, need, q,
                                                             keep_baseline_outliers, Cq)
    if (why := outliers.warning(series.files)):
        warnings.warn(why)
    if isinstance(model, PCARemoval) and model.k is not None and model.k_ < model.k:
        warnings.warn(f"--normal-model {normal_model}: {m} tracked modes leave at most {model.k_} component(s) to "
                      f"remove (one must remain): {model.k_} removed")
    out_idx = np.array(outliers.indices if outliers.excluded else [], int)
    rest = np.flatnonzero(ok)
    rest = rest[rest >= n_baseline]
    det = detect(model, model.with_choices, X, Cq, b_idx, rest, false_alarm_rate, q, ("residual", *statistics),
                 held=held)
    thr = residual_threshold(det)
    sessions = held_out_sessions(X[b_idx], None if Cq is None else Cq[b_idx])      # held out a session at a time
    if (why := season_warning(series.times, series.time_values, n_baseline, det.names if not q else ())):
        warnings.warn(why)
    novelty = det.values[:, det.names.index("residual")]
    novelty[out_idx] = outlier_novelty(model, X, b_idx, out_idx, Cq)    # held out: the model did not see them
    charts = run_charts(det.vectors, b_idx, false_alarm_rate) if chart == "ewma" else None
    # per-mode normal variation: the residual about what the model explains (conditions, removed factors)
    Xb = X[b_idx]
    Cf = None if Cq is None else np.where(np.isfinite(Cq), Cq, np.nanmedian(Cq[b_idx], axis=0))
    expected_log = np.full(X.shape, np.nan)
    have = np.isfinite(X).any(axis=1)
    expected_log[have] = model.expected(X[have], None if Cf is None else Cf[have])
    resid_b = Xb - expected_log[b_idx]
    sigma = np.nanstd(resid_b, axis=0, ddof=1)
    z = (X - expected_log) / sigma
    change = 100 * (np.exp(X - expected_log) - 1)
    describe = model.describe(series.condition_names)
    normal = {**describe, "features": [f"ln f{r + 1}" for r in range(m)],
              "per_mode_std": sigma.tolist(), "per_mode_std_pct": (100 * sigma).tolist(),
              "reference_frequencies_hz": ref.frequencies_hz.tolist(), "tracking_tolerance": ref.tolerance.tolist(),
              "reference_presence": ref.presence.tolist(),
              "baseline_tests_used": int(b_idx.size), "baseline_outliers": outliers.to_dict(series.files),
              "baseline_sessions": None if sessions is None else sessions.to_dict([series.files[i] for i in b_idx]),
              "frequency_estimators": None if choice is None else choice.to_dict(),
              "missing_entries": "imputed by their conditional mean given the test's other features under the "
                                 "baseline's Gaussian (regression: about the conditions' prediction)"}
    series_base = [i for i in range(n_baseline) if i not in foreign]
    beyond = beyond_bands(tests, ref, cols, series_base, false_alarm_rate, fft)
    rows = []
    for i in range(n):
        readings = beyond.readings(i, ref)
        mode_missing = [r + 1 for r in range(m) if not np.isfinite(F[i, r])] if tests[i] is not None else []
        rows.append({
            "file": series.files[i], "time": series.times[i], "time_value": float(series.time_values[i]),
            "baseline": i < n_baseline, "identified": bool(ok[i]), "error": errors[i],
            "record_problem": getattr(errors[i], "record_problem", None) if tests[i] is None else None,
            "record_crop": (tests[i].record_crop or None) if tests[i] is not None else None,
            "status": _status(bool(ok[i]), bool(ok[i] and det.alarm[i]),
                              i in foreign or errors[i] == "conditions not measured", beyond.status(i)),
            "alarm": bool(ok[i] and det.alarm[i]), "novelty": finite_or_none(novelty[i]), "threshold": thr.value,
            "frequencies_hz": [finite_or_none(v) for v in F[i]], "damping_ratios": [finite_or_none(v) for v in Z[i]],
            "mode_z_scores": [finite_or_none(v) for v in z[i]], "change_pct": [finite_or_none(v) for v in change[i]],
            "mac": [finite_or_none(v) for v in MAC[i]] if ref.shapes is not None else None,
            "missing_modes": mode_missing, "beyond_band": readings,
            "beyond_band_text": readings_text(readings, ref), "identified_by": how[i],
            "conditions": None if C is None else dict(zip(series.condition_names, map(finite_or_none, C[i]))),
        })
        rows[-1].update(_detector_fields(det, charts, i, bool(ok[i])))
        if i in out_idx:
            rows[-1]["status"] = BASELINE_OUTLIER
    res = SeriesResult(rows, ref, F, np.exp(expected_log), novelty, thr, model, normal, sigma, tests, series, det,
                       charts, beyond, choice)
    series_coverage(res)                                    # every row's ``extrapolated``
    separate = extrapolated_alarms == "separate" or (
        extrapolated_alarms == "auto" and not covers_seasons(series.times, series.time_values, n_baseline))
    for i, r in enumerate(rows):
        if (separate and r["status"] == "alarm" and r["extrapolated"]
                and all(environmental(model, nm) for nm in r["alarmed_by"])):
            # a mode beyond its band is no statistic of the environment: its status stands
            r["status"], r["alarm"] = beyond.status(i) or EXTRAPOLATED, False
    return res


def readings_text(readings: list, ref: ReferenceModes) -> str:
    """The flagged readings in words, e.g. ``mode 2 moved +20.8 % (193.6 Hz, beyond its band 139.3-184.3 Hz);
    mode 3 lost (no pole within 372.3-492.3 Hz or beyond it within its reach; chance 0.0033 at the baseline's
    share)``; a moved mode flagged in a run adds ``; 2 tests in a row read so, chance 5.5e-05 at the baseline's
    share`` inside its brackets; a test flagged for its poles all lying beyond the bands
    (:attr:`BeyondBands.unplaced_flagged`) starts with ``no mode in its band:``."""
    bands = narrow_bands_hz(ref)
    unplaced = any(d.get("unplaced") for d in readings)
    parts = []
    for d in readings:
        if not d["flagged"]:
            continue
        lo, hi = bands[d["mode"] - 1]
        if d["reading"] == "moved":
            run = (f"; {d['run_tests']} tests in a row read so, chance {d['run_chance']:.2g} at the baseline's share"
                   if d.get("run_tests", 0) > 1 else "")
            parts.append(f"mode {d['mode']} moved {d['change_pct']:+.1f} % ({d['frequency_hz']:.4g} Hz, beyond its "
                         f"band {lo:.4g}-{hi:.4g} Hz{run})")
        else:
            odds = "" if unplaced else f"; chance {d['chance']:.2g} at the baseline's share"
            parts.append(f"mode {d['mode']} lost (no pole within {lo:.4g}-{hi:.4g} Hz or beyond it within its "
                         f"reach{odds})")
    text = "; ".join(parts)
    return f"no mode in its band: {text}" if unplaced and text else text


def _detector_fields(det: Detection, charts: Charts | None, i: int, ok: bool) -> dict:
    """A row's detector fields: each statistic (``statistics``), those alarmed
    (``alarmed_by``), the weighted mean frequency change (``shift_pct``), the charts' ``chart_alarm`` and the
    ``onset`` (test index) of the change behind it."""
    return {"statistics": {nm: finite_or_none(det.values[i, k]) for k, nm in enumerate(det.names)},
            "alarmed_by": det.alarmed_by(i) if ok else [], "shift_pct": finite_or_none(det.shift_pct[i]),
            "chart_alarm": None if charts is None else bool(ok and charts.alarm[i]),
            "onset": None if charts is None or charts.onset[i] < 0 else int(charts.onset[i])}


def _checked_request(series: SeriesInput, n_baseline: int, false_alarm_rate: float, normal_model: str | None,
                     chart: str = "ewma", statistics=DEFAULT_STATISTICS):
    """``(normal model, number of conditions it regresses on)`` of a request, or the one-line error of an argument
    or a baseline period that cannot carry it before any test is identified."""
    n = len(series.files)
    if not 0 < false_alarm_rate < 0.5:
        raise ConfigError(f"--false-alarm-rate {false_alarm_rate:g}: must lie in (0, 0.5)")
    if chart not in CHARTS:
        raise ConfigError(f"--chart {chart}: expected one of {', '.join(CHARTS)}")
    if set(statistics) - set(STATISTICS):
        raise ConfigError(f"--statistics {' '.join(statistics)}: expected some of {', '.join(STATISTICS)}")
    if not 0 < n_baseline <= n:
        raise ConfigError(f"--baseline-tests {n_baseline}: must be between 1 and the {n} tests given")
    C = series.conditions
    if normal_model is None:
        normal_model = "regression" if C is not None else DEFAULT_LATENT
    if normal_model not in NORMAL_MODELS:
        raise ConfigError(f"normal model {normal_model!r}: expected one of {', '.join(NORMAL_MODELS)}")
    if normal_model == "regression" and C is None:
        raise ConfigError("the regression on measured conditions needs --conditions CSV with condition columns")
    q = 0 if C is None or normal_model != "regression" else C.shape[1]
    if n_baseline < minimum_baseline(1, q):
        raise BeamDamageError(f"--baseline-tests {n_baseline}: at least {minimum_baseline(1, q)} baseline tests are "
                              f"needed even for one mode ({minimum_baseline(1, q)} = modes + conditions + 6)")
    if q and not np.all(np.isfinite(C[:n_baseline])):
        i = int(np.flatnonzero(~np.isfinite(C[:n_baseline]).all(axis=1))[0])
        lacking = [c for c, v in zip(series.condition_names, C[i]) if not np.isfinite(v)]
        where = f"{series.where[i]}: " if series.where else "conditions: "
        raise BeamDamageError(f"{where}baseline test {series.files[i]} lacks a measured condition ("
                              f"{', '.join(lacking)}: empty or NaN); the regression needs them on every baseline "
                              "test")
    return normal_model, q


def _identified(series: SeriesInput, n_baseline: int, settings: IdentificationSettings, cache_dir, progress: bool,
                workers=1):
    """``(tests, errors, pending cache entries, foreign)``: every test identified (or read from the cache), a test
    that does not belong to the baseline period's series None with the reason as its error (its index in the set
    ``foreign``)."""

    if (why := repeated_tests_warning(series.files, n_baseline)):
        warnings.warn(why)
    tests, errors, pending = identify_files(series.files, settings, cache_dir, workers, progress)
    if all(t is None for t in tests[:n_baseline]):
        first = next((str(e) for e in errors[:n_baseline] if e), "")
        raise BeamDamageError(f"none of the {n_baseline} baseline tests could be identified"
                              + (f"; the first: {first}" if first else ""))
    foreign = set()
    for i, why in enumerate(check_series(tests, n_baseline, series.files)):
        if why:
            tests[i], errors[i] = None, why
            foreign.add(i)
    return tests, errors, pending, foreign


#: The status of a later test beyond the baseline's environment alarmed only by the statistics of the environment
#: itself (the removed components' scores, the shift about the baseline mean): a change, or conditions the baseline
#: period did not see, which those statistics cannot tell apart (docs/monitoring.md: extrapolated tests).
EXTRAPOLATED = "change or unseen conditions"
#: What a row's ``status`` says: judged and alarmed; judged and within the normal variation; a test of the series
#: whose modes could not be identified (a change may be why: counted beside the alarms); a test that cannot be
#: judged against this baseline (another kind, band or beam; its conditions not measured); :data:`EXTRAPOLATED`;
#: a test the detector did not alarm whose reference mode moved beyond its band (:data:`MODE_MOVED`) or was lost
#: (:data:`MODE_LOST`) against the baseline period's odds (:func:`learn.monitor.beyond_band.beyond_bands`); a baseline
#: test left out of the baseline period as its outlier (:data:`BASELINE_OUTLIER`).
STATUSES = ("alarm", "no alarm", "not identified", "not judged", EXTRAPOLATED, MODE_MOVED, MODE_LOST,
            BASELINE_OUTLIER)
#: The statuses that flag a test: a change, or conditions the baseline did not see.
FLAGGED_STATUSES = ("alarm", EXTRAPOLATED, MODE_MOVED, MODE_LOST)
#: ``monitor_series``'s choices for an alarm of the environmental statistics on an extrapolated test.
EXTRAPOLATED_ALARMS = ("auto", "separate", "alarm")


def _status(judged: bool, alarm: bool, foreign: bool, beyond: str | None = None) -> str:
    """``alarm`` before a mode moved or lost beyond its band (``beyond``), then ``no alarm``, ``not judged`` and
    ``not identified``; a test whose conditions were not measured is still read for a mode beyond its band (no
    condition enters that reading; a test of another kind, band or beam holds no reading)."""
    if judged and alarm:
        return "alarm"
    if beyond:
        return beyond
    if judged:
        return "no alarm"
    return "not judged" if foreign else "not identified"


def what_changed(row: dict, sigma) -> list[dict]:
    """An alarmed test's modes by how far they lie from the baseline population, farthest first: ``mode``
    (1-based), ``change_pct`` and ``z`` (baseline standard deviations)."""
    out = [{"mode": r + 1, "frequency_hz": f, "change_pct": c, "z": z, "baseline_std_pct": 100 * float(s)}
           for r, (f, c, z, s) in enumerate(zip(row["frequencies_hz"], row["change_pct"], row["mode_z_scores"],
                                                 sigma))]
    return sorted(out, key=lambda d: -abs(d["z"]) if d["z"] is not None else 0.0)


def changed_text(changes: list[dict], top: int = 3) -> str:
    """E.g. ``mode 2 -3.1 % (-12.4 sd), mode 4 -1.0 % (-4.0 sd)``."""
    parts = [f"mode {d['mode']} {d['change_pct']:+.2f} % ({d['z']:+.1f} sd)" for d in changes[:top]
             if d["z"] is not None]
    missing = [str(d["mode"]) for d in changes if d["z"] is None]
    return ", ".join(parts) + (f"; mode(s) {', '.join(missing)} not found" if missing else "")
