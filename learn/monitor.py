"""A monitoring series: many tests of one beam, the normal variation learnt on a baseline period, a novelty index
per test with a cross-validated threshold (the library behind ``beam-damage monitor``).

Steps, one function each:

* :func:`identify_test` -- one test's modes (FRFs by LSCF/LSFD, response records by SSI-cov, modal data read);
  :func:`cached_identification` keeps the result per file in a JSON cache keyed by the file's bytes and the
  settings;
* :func:`reference_modes` and :func:`track_modes` -- the baseline period's modes (clustered, their median
  frequencies) and each test's poles assigned to them by frequency (and MAC with 2 or more sensors), a mode
  missing in a test NaN there;
* :data:`NORMAL_MODELS` -- the normal variation of the features (log natural frequencies): a regression on
  measured conditions, or a latent-variable model (PCA with factors removed, factor analysis, a Gaussian
  mixture); each gives a squared Mahalanobis distance of a test's residual (the novelty index);
* :func:`held_out_novelty` and :func:`threshold` -- every baseline test's index by a model that did not see it
  (leave-one-out or k-fold) and the threshold of a false-alarm rate from a scaled F distribution fitted to them;
* :func:`monitor_series` -- all of it on a series; :class:`SeriesResult` holds the rows.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import warnings
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from learn.classify import classify_many
from learn.hypotheses import FREQUENCY_CHANGE_STD, explain_many
from learn.measured import (IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, identify_modes, modal_pair, on_model_dofs,
                            pair_modes_by_frequency)
from learn.noise_calibration import robust_std
from physics.errors import BeamDamageError, ConfigError
from physics.identification import (DEFAULT_OUTPUT_ONLY, holds_response_records, identify_records,
                                    read_response_records)
from physics.identification.measured import read_measured_frf
from physics.io import (MODAL, TIME, ModalData, atomic_write_text, format_complex, modal_or_frf, prepare_measured,
                        read)
from physics.io.inputs import check_input_file
from physics.layout import RIGID_BODY_MODES
from physics.modal import eigenvalues_from_modal, modal_parameters, undamped_modes

__all__ = ["CACHE_FORMAT", "DEFAULT_LATENT", "MAC_MIN", "MIN_PRESENCE", "NORMAL_MODELS", "PCA_EXPLAINED",
           "alarm_verdicts", "cached_identification", "check_series", "FactorRemoval", "held_out_novelty",
           "identification_settings", "IdentificationSettings", "IdentifiedModes", "identify_test",
           "minimum_baseline", "missing_evidence", "Mixture", "monitor_series", "PCARemoval", "read_conditions",
           "reference_modes", "ReferenceModes", "Regression", "SeriesInput", "SeriesResult", "Threshold", "threshold",
           "track_modes", "write_cache"]

#: Format tag of a cache entry (a change of the identification or of the entry's fields changes it).
CACHE_FORMAT = "beam-damage-monitor-cache/1"
#: A reference mode is a cluster of baseline poles found in at least this share of the baseline tests.
MIN_PRESENCE = 0.5
#: Baseline poles closer than this (relative) in frequency fall into one cluster.
CLUSTER_GAP = 0.05
#: A pole is assigned to a reference mode within ``max(TOLERANCE_SIGMAS * std, MIN_TOLERANCE)`` of it in log
#: frequency (std: the baseline's robust scatter of the mode), never beyond ``NEIGHBOUR_SHARE`` of the log gap to
#: the next reference mode.
TOLERANCE_SIGMAS, MIN_TOLERANCE, NEIGHBOUR_SHARE = 10.0, math.log(1.15), 0.45
#: With 2 or more sensors, a pole is assigned only when its shape's MAC with the reference shape reaches this.
MAC_MIN = 0.6
#: Held-out indices by leave-one-out up to this many baseline tests, else by this many interleaved folds.
LOO_MAX, N_FOLDS = 200, 20
#: The latent-variable model used without measured conditions (chosen in docs/monitoring.md).
DEFAULT_LATENT = "pca"
#: Share of the baseline's variance the components :class:`PCARemoval` removes explain (its ``k=None``).
PCA_EXPLAINED = 0.95


# ---------------------------------------------------------------------------------------------------------------
# One test's identification, cached
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class IdentificationSettings:
    """How every test of a series is identified: the band (Hz; None: the file's), the modes kept (None: all
    found) and the highest model order of LSCF (FRFs) and of SSI-cov (response records: its state model spends
    states on the excitation's colour and the sensor noise; on the 60-s records of the independent monitoring series
    a 10-Hz mode at the bottom of a 5-400 Hz band is found in half of the tests at order 40, in all at 80)."""

    band_hz: tuple | None = None
    n_modes: int | None = None
    max_order: int = 40
    records_max_order: int = 80

    def to_dict(self) -> dict:
        return {"band_hz": None if self.band_hz is None else [float(b) for b in self.band_hz],
                "n_modes": self.n_modes, "max_order": self.max_order, "records_max_order": self.records_max_order}


@dataclass(frozen=True)
class IdentifiedModes:
    """The modes identified in one test.

    Attributes
    ----------
    kind : str                  ``"frf"``, ``"response records"`` or ``"modal"``
    method : str                the identification (``"lscf"``, ``"ssi"``, or ``"file"`` for modal data)
    frequencies_hz : ndarray (k,)
    damping_ratios : ndarray (k,)
    shapes : ndarray complex (s, k) or None
    dofs : tuple of str         rows of ``shapes``
    references : tuple of str   reference DOFs of FRFs (empty otherwise)
    band_hz : (lo, hi) or None  the frequency range of the data (FRF lines, or 0 to Nyquist of records)
    line_hz : float or None     the spacing of the FRF lines (records: 1 / duration)
    """

    kind: str
    method: str
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray | None
    dofs: tuple = ()
    references: tuple = ()
    band_hz: tuple | None = None
    line_hz: float | None = None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "method": self.method, "frequencies_hz": self.frequencies_hz.tolist(),
                "damping_ratios": self.damping_ratios.tolist(),
                "shapes": None if self.shapes is None else [[format_complex(z) for z in row] for row in self.shapes],
                "dofs": list(self.dofs), "references": list(self.references),
                "band_hz": None if self.band_hz is None else list(self.band_hz), "line_hz": self.line_hz}

    @classmethod
    def from_dict(cls, d: dict) -> "IdentifiedModes":
        shapes = d["shapes"]
        return cls(d["kind"], d["method"], np.asarray(d["frequencies_hz"], float),
                   np.asarray(d["damping_ratios"], float),
                   None if shapes is None else np.array([[complex(z) for z in row] for row in shapes], complex)
                   .reshape(len(shapes), len(d["frequencies_hz"])),
                   tuple(d["dofs"]), tuple(d["references"]), None if d["band_hz"] is None else tuple(d["band_hz"]),
                   d["line_hz"])


def identification_settings(band_hz=None, beam=None, model=None) -> IdentificationSettings:
    """The identification of a series: over ``band_hz`` (Hz) when given; else a trained model's (its test band,
    or up to :data:`learn.measured.IDENTIFICATION_BAND_FACTOR` times its nominal mode 4, the 4 lowest modes: what
    ``classify`` identifies); else a beam's (:class:`physics.beam.Beam`: its ``band_hz``, or the same rule on its
    nominal modes); else every mode LSCF finds over each file's band."""
    if band_hz is not None:
        return IdentificationSettings(tuple(float(b) for b in band_hz))
    if model is not None:
        test = model.beam.test
        if test is not None:
            k = model.beam.n_modes + 2                       # spare poles, as classify identifies another test
            return IdentificationSettings(tuple(test.band_hz), k, max(40, 10 * k))
        fmax = IDENTIFICATION_BAND_FACTOR * float(model.sensitivity.frequencies_hz[3])
        return IdentificationSettings((0.0, fmax), IDENTIFICATION["n_modes"])
    if beam is not None:
        if beam.band_hz is not None:
            return IdentificationSettings(tuple(beam.band_hz))

        fe = beam.fe_model(40)
        w = undamped_modes(np.asarray(fe.M), np.asarray(fe.K))[0]
        f4 = float(np.sort(np.abs(w))[RIGID_BODY_MODES[beam.bc] + 3]) / (2 * np.pi)
        return IdentificationSettings((0.0, IDENTIFICATION_BAND_FACTOR * f4), IDENTIFICATION["n_modes"])
    return IdentificationSettings()


def _modes_of(eigenvalues, shapes):

    lam = np.asarray(eigenvalues, complex)
    f, z = modal_parameters(lam)
    order = np.argsort(f)
    return (np.asarray(f, float)[order], np.asarray(z, float)[order],
            None if shapes is None else np.asarray(shapes, complex)[:, order])


def identify_test(path, settings: IdentificationSettings) -> IdentifiedModes:
    """One test's modes: an FRF file by LSCF/LSFD (:func:`learn.measured.identify_modes`, the identification
    ``classify`` runs), response records without a force by SSI-cov (as ``identify``), modal data as read.

    Raises :class:`BeamDamageError` (one line naming the file) when the file cannot be read or identified.
    """

    path = str(path)
    if modal_or_frf(path) == MODAL:
        md = prepare_measured(read(path, MODAL)).data
        f, z, shapes = _modes_of(md.eigenvalues, md.eigenvectors)
        return IdentifiedModes("modal", "file", f, z, shapes, tuple(md.dofs or ()))
    band = settings.band_hz
    if holds_response_records(path) and not read(path, TIME).forces:
        rec = read_response_records(path)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ident = identify_records(rec, DEFAULT_OUTPUT_ONLY, band, settings.n_modes,
                                         settings.records_max_order)
        except (np.linalg.LinAlgError, RuntimeError, ValueError) as exc:
            raise BeamDamageError(f"{path}: SSI-cov identification failed ({exc})") from None
        fs = rec.sampling_frequency_hz
        f, z, shapes = _modes_of(ident.estimate.eigenvalues, ident.estimate.shapes)
        return IdentifiedModes("response records", DEFAULT_OUTPUT_ONLY, f, z, shapes, tuple(rec.dofs), (),
                         (0.0, fs / 2), fs / rec.signals.shape[1])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frf = prepare_measured(read_measured_frf(path)).data
    lines = np.asarray(frf.frequency_hz, float)
    fmin, fmax = (0.0, None) if band is None else band
    if band is not None and (lines[-1] <= fmin or lines[0] >= fmax):
        raise BeamDamageError(f"{path}: its lines {lines[0]:g}-{lines[-1]:g} Hz miss the band {fmin:g}-{fmax:g} Hz")
    md = identify_modes(frf, fmax, path, settings.n_modes, fmin, settings.max_order)
    f, z, shapes = _modes_of(md.eigenvalues, md.eigenvectors)
    line = float(np.median(np.diff(lines))) if lines.size > 1 else None
    return IdentifiedModes("frf", "lscf", f, z, shapes, tuple(md.dofs), tuple(frf.reference_dofs),
                     (float(lines[0]), float(lines[-1])), line)


def file_key(path, settings: IdentificationSettings) -> str:
    """SHA-256 of the file's bytes, the identification settings and :data:`CACHE_FORMAT`."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    h.update(json.dumps([CACHE_FORMAT, settings.to_dict()], sort_keys=True).encode())
    return h.hexdigest()


def cached_identification(path, settings: IdentificationSettings, cache_dir=None, pending: list | None = None):
    """``(IdentifiedModes or None, error text or None, from_cache)`` of one test.

    With ``cache_dir``, the result (or the error of a file that cannot be identified) is read from
    ``cache_dir/<key>.json`` (:func:`file_key`) or, once identified, written there atomically; with ``pending`` (a
    list) the entry to write is appended to it as ``(path, text)`` instead (written when the series is accepted).
    """
    try:
        check_input_file(path, "npz", BeamDamageError, "a test file")
        key = file_key(path, settings) if cache_dir else None
    except (BeamDamageError, OSError) as exc:
        return None, _error_text(exc, path), False
    entry = Path(cache_dir) / f"{key}.json" if cache_dir else None
    if entry is not None and entry.is_file():
        try:
            d = json.loads(entry.read_text())
            if d.get("format") == CACHE_FORMAT:
                return (None if d["modes"] is None else IdentifiedModes.from_dict(d["modes"])), d["error"], True
        except (ValueError, KeyError, TypeError):
            pass                                            # a damaged entry: identified again
    try:
        modes, error = identify_test(path, settings), None
    except (BeamDamageError, OSError) as exc:
        modes, error = None, _error_text(exc, path)
    if entry is not None:
        text = json.dumps({"format": CACHE_FORMAT, "file": str(path), "settings": settings.to_dict(),
                           "modes": None if modes is None else modes.to_dict(), "error": error})
        if pending is None:
            write_cache([(entry, text)])
        else:
            pending.append((entry, text))
    return modes, error, False


def write_cache(entries) -> None:
    """Write cache entries ``(path, text)`` atomically."""
    for path, text in entries:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, text)


def _error_text(exc, path) -> str:
    text = " ".join(str(getattr(exc, "strerror", None) or exc).split())
    return text if str(path) in text else f"{path}: {text}"


# ---------------------------------------------------------------------------------------------------------------
# The series: order, times, conditions; consistency of the tests
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SeriesInput:
    """The tests of a series in time order.

    Attributes
    ----------
    files : list of str
    times : list              as given (ISO dates or numbers); None without times
    time_values : ndarray (n,)    days since the first test for dates, the numbers as given, else 0..n-1
    conditions : ndarray (n, q) or None     measured conditions (NaN where not measured)
    condition_names : tuple of str
    """

    files: list
    times: list
    time_values: np.ndarray
    conditions: np.ndarray | None = None
    condition_names: tuple = ()

    @classmethod
    def from_files(cls, files) -> "SeriesInput":
        files = [str(f) for f in files]
        return cls(files, [None] * len(files), np.arange(len(files), dtype=float))


def _time_value(text: str, where: str):

    try:
        return float(text), False
    except ValueError:
        pass
    try:
        t = datetime.fromisoformat(text.strip())
    except ValueError:
        raise BeamDamageError(f"{where}: time {text!r} is neither a number nor an ISO date (2024-03-01 or "
                              "2024-03-01T12:00)") from None
    return t.timestamp() / 86400.0 if t.tzinfo else (t - datetime(1970, 1, 1)).total_seconds() / 86400.0, True


def read_conditions(csv_path) -> SeriesInput:
    """A series from a CSV file: columns ``file`` (relative to the CSV or absolute), ``time`` (an ISO date or a
    number) and any measured conditions (numbers, e.g. ``temperature_c``); rows sorted by time (stable)."""
    path = check_input_file(csv_path, "csv", BeamDamageError, "a CSV of file,time[,condition...]")
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        raise BeamDamageError(f"{csv_path}: no rows; expected a header file,time[,condition...] and one row per test")
    head = list(rows[0].keys())
    missing = [c for c in ("file", "time") if c not in head]
    if missing:
        raise BeamDamageError(f"{csv_path}: column(s) {', '.join(missing)} missing; expected file,time"
                              f"[,condition...], got {','.join(map(str, head))}")
    names = tuple(c for c in head if c not in ("file", "time") and c)
    files, times, values, conds, dates = [], [], [], [], set()
    for k, r in enumerate(rows, 2):
        where = f"{csv_path} line {k}"
        if None in r or not r["file"]:
            raise BeamDamageError(f"{where}: expected {len(head)} fields with a file name")
        f = Path(r["file"])
        files.append(str(f if f.is_absolute() else Path(csv_path).parent / f))
        times.append(r["time"])
        v, is_date = _time_value(r["time"], where)
        values.append(v)
        dates.add(is_date)
        row = []
        for c in names:
            text = (r[c] or "").strip()
            try:
                row.append(float(text) if text else math.nan)
            except ValueError:
                raise BeamDamageError(f"{where}: {c} = {text!r} is not a number") from None
        conds.append(row)
    if len(dates) > 1:
        raise BeamDamageError(f"{csv_path}: column time mixes ISO dates and numbers")
    order = np.argsort(np.asarray(values), kind="stable")
    t = np.asarray(values)[order]
    if dates == {True}:
        t = t - t[0]
    C = np.asarray(conds, float)[order] if names else None
    return SeriesInput([files[i] for i in order], [times[i] for i in order], t, C, names)


def _layout(m: IdentifiedModes) -> dict:
    return {"kind": m.kind, "dofs": tuple(sorted(m.dofs)), "references": tuple(sorted(m.references))}


def check_series(tests: list, n_baseline: int, files: list) -> list:
    """Per test, None or why it does not belong to the series of the first identified baseline test: another kind
    (FRF, response records, modal data), band (a band edge more than 2 lines away) or beam (other measured or
    reference DOFs). Raises :class:`BeamDamageError` when a baseline test differs (the baseline must be one
    beam's)."""
    first = next((i for i, t in enumerate(tests[:n_baseline]) if t is not None), None)
    if first is None:
        raise BeamDamageError(f"none of the {n_baseline} baseline tests could be identified")
    ref = tests[first]
    lay = _layout(ref)
    out = []
    for i, t in enumerate(tests):
        why = None
        if t is not None:
            other = _layout(t)
            if other["kind"] != lay["kind"]:
                why = f"mixed kinds: {files[i]} holds {t.kind}, {files[first]} {ref.kind}"
            elif other["dofs"] != lay["dofs"] or other["references"] != lay["references"]:
                why = (f"mixed beams: {files[i]} measures DOFs {', '.join(t.dofs)} (references "
                       f"{', '.join(t.references) or 'none'}), {files[first]} {', '.join(ref.dofs)} (references "
                       f"{', '.join(ref.references) or 'none'})")
            elif ref.band_hz is not None and t.band_hz is not None:
                line = 2 * max(ref.line_hz or 0.0, t.line_hz or 0.0)
                if max(abs(a - b) for a, b in zip(ref.band_hz, t.band_hz)) > line:
                    why = (f"mixed bands: {files[i]} spans {t.band_hz[0]:g}-{t.band_hz[1]:g} Hz, {files[first]} "
                           f"{ref.band_hz[0]:g}-{ref.band_hz[1]:g} Hz")
        if why and i < n_baseline:
            raise BeamDamageError(f"baseline test {why}")
        out.append(why)
    return out


# ---------------------------------------------------------------------------------------------------------------
# Modes tracked across the tests
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ReferenceModes:
    """The baseline period's modes.

    Attributes
    ----------
    frequencies_hz : ndarray (m,)     median over the baseline tests
    log_std : ndarray (m,)            robust std of ``ln f`` over the baseline tests (1.4826 MAD)
    tolerance : ndarray (m,)          largest ``|ln(f / f_ref)|`` of an assigned pole
    shapes : ndarray complex (s, m) or None    dominant shape over the baseline tests (unit norm)
    dofs : tuple of str               rows of ``shapes``
    presence : ndarray (m,)           share of the baseline tests holding the mode
    """

    frequencies_hz: np.ndarray
    log_std: np.ndarray
    tolerance: np.ndarray
    shapes: np.ndarray | None
    dofs: tuple
    presence: np.ndarray


def _rows(t: IdentifiedModes, dofs: tuple):
    """``t.shapes`` with rows in the order ``dofs`` (None without shapes or with fewer than 2 sensors)."""
    if t.shapes is None or len(dofs) < 2 or set(t.dofs) != set(dofs):
        return None
    return t.shapes[[t.dofs.index(d) for d in dofs]]


def _mac(a, b) -> np.ndarray:
    """MAC between columns of ``a`` (s, k) and ``b`` (s, m): (k, m)."""
    num = np.abs(a.conj().T @ b) ** 2
    return num / np.maximum(np.sum(np.abs(a) ** 2, 0)[:, None] * np.sum(np.abs(b) ** 2, 0)[None], 1e-300)


def reference_modes(tests: list) -> ReferenceModes:
    """Reference modes from the baseline tests (identified ones; None entries skipped).

    The baseline poles' ``ln f`` are pooled and split where consecutive ones lie more than :data:`CLUSTER_GAP`
    apart (a cluster holding on average 1.5 poles per test or more is split again at its widest gap); a cluster
    found in at least :data:`MIN_PRESENCE` of the tests is a reference mode, its frequency the median of each
    test's pole nearest the cluster's median.
    """
    tests = [t for t in tests if t is not None]
    n = len(tests)
    logf = np.concatenate([np.log(t.frequencies_hz) for t in tests]) if n else np.zeros(0)
    who = np.concatenate([np.full(t.frequencies_hz.size, i) for i, t in enumerate(tests)]) if n else np.zeros(0, int)
    col = np.concatenate([np.arange(t.frequencies_hz.size) for t in tests]) if n else np.zeros(0, int)
    order = np.argsort(logf)
    logf, who, col = logf[order], who[order], col[order]
    cuts = [0, *(np.flatnonzero(np.diff(logf) > math.log1p(CLUSTER_GAP)) + 1), logf.size]
    clusters = [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
    done = []
    while clusters:
        a, b = clusters.pop()
        tests_in = np.unique(who[a:b]).size
        if b - a >= 1.5 * tests_in and b - a > 1:
            k = a + 1 + int(np.argmax(np.diff(logf[a:b])))
            clusters += [(a, k), (k, b)]
        else:
            done.append((a, b))
    done.sort()
    dofs = tests[0].dofs if n else ()
    freqs, stds, presence, shapes = [], [], [], []
    for a, b in done:
        centre = np.median(logf[a:b])
        pick = {}
        for j in range(a, b):
            i = int(who[j])
            if i not in pick or abs(logf[j] - centre) < abs(logf[pick[i]] - centre):
                pick[i] = j
        if len(pick) < MIN_PRESENCE * n:
            continue
        v = logf[list(pick.values())]
        freqs.append(float(np.exp(np.median(v))))
        stds.append(robust_std(v))
        presence.append(len(pick) / n)
        rows = [_rows(tests[i], dofs) for i in pick]
        if all(r is not None for r in rows):
            S = np.stack([r[:, col[j]] for r, (i, j) in zip(rows, pick.items())], axis=1)   # (s, n_picked)
            S = S / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
            shapes.append(np.linalg.svd(S, full_matrices=False)[0][:, 0])
        else:
            shapes.append(None)
    f = np.asarray(freqs, float)
    s = np.asarray(stds, float)
    tol = np.maximum(TOLERANCE_SIGMAS * s, MIN_TOLERANCE)
    if f.size > 1:
        gaps = np.diff(np.log(f))
        neighbour = np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf])
        tol = np.minimum(tol, NEIGHBOUR_SHARE * neighbour)
    with_shapes = bool(shapes) and all(x is not None for x in shapes)
    return ReferenceModes(f, s, tol, np.stack(shapes, axis=1) if with_shapes else None,
                          tuple(dofs) if with_shapes else (), np.asarray(presence, float))


def track_modes(tests: list, ref: ReferenceModes):
    """Each test's poles assigned to the reference modes: ``(frequencies (n, m), damping (n, m), mac (n, m),
    column (n, m))``, NaN (column -1) where a test holds no pole within the mode's tolerance (and, with shapes of 2
    or more sensors, MAC >= :data:`MAC_MIN`). Poles and modes are paired one to one, minimising the sum of
    ``(ln(f / f_ref) / tolerance)^2 + (1 - MAC) / (1 - MAC_MIN)``; a pole beyond every tolerance is never
    assigned."""
    from scipy.optimize import linear_sum_assignment

    n, m = len(tests), ref.frequencies_hz.size
    F, Z, M = np.full((n, m), np.nan), np.full((n, m), np.nan), np.full((n, m), np.nan)
    cols = np.full((n, m), -1)
    ln_ref = np.log(ref.frequencies_hz)
    for i, t in enumerate(tests):
        if t is None or t.frequencies_hz.size == 0 or m == 0:
            continue
        d = (np.log(t.frequencies_hz)[:, None] - ln_ref[None]) / ref.tolerance[None]      # (k, m)
        cost = d**2
        ok = np.abs(d) <= 1.0
        S = _rows(t, ref.dofs) if ref.shapes is not None else None
        mac = _mac(S, ref.shapes) if S is not None else None
        if mac is not None:
            cost = cost + (1 - mac) / (1 - MAC_MIN)
            ok &= mac >= MAC_MIN
        cost = np.where(ok, cost, 1e9)
        r, c = linear_sum_assignment(cost)
        keep = ok[r, c]
        r, c = r[keep], c[keep]
        F[i, c], Z[i, c], cols[i, c] = t.frequencies_hz[r], t.damping_ratios[r], r
        if mac is not None:
            M[i, c] = mac[r, c]
    return F, Z, M, cols


# ---------------------------------------------------------------------------------------------------------------
# Normal variation: models of the features, their novelty index
# ---------------------------------------------------------------------------------------------------------------

def _impute(X, mean, cov):
    """``X`` with each row's NaN entries replaced by their conditional mean given the row's finite entries under
    ``N(mean, cov)`` (``mean`` (n, p) or (p,)); rows without a finite entry get the mean."""
    X = np.array(X, float)
    mean = np.broadcast_to(mean, X.shape)
    miss = ~np.isfinite(X)
    for pattern in {tuple(r) for r in miss[miss.any(axis=1)]}:
        mk = np.asarray(pattern)
        rows = np.flatnonzero((miss == mk).all(axis=1))
        o = ~mk
        if not o.any():
            X[np.ix_(rows, mk)] = mean[np.ix_(rows, mk)]
            continue
        gain = cov[np.ix_(mk, o)] @ np.linalg.pinv(cov[np.ix_(o, o)])                       # (miss, obs)
        X[np.ix_(rows, mk)] = mean[np.ix_(rows, mk)] + (X[np.ix_(rows, o)] - mean[np.ix_(rows, o)]) @ gain.T
    return X


def _start(X):
    """NaN entries replaced by their column's median (the first pass of a fit)."""
    X = np.array(X, float)
    med = np.nanmedian(X, axis=0)
    miss = ~np.isfinite(X)
    X[miss] = np.take(med, np.nonzero(miss)[1])
    return X


def _filled(X, passes: int = 2):
    """``(X filled, mean, cov)``: the missing entries at their column median, then ``passes`` times at their
    conditional mean under the Gaussian of the filled rows (:func:`_impute`)."""
    X0 = _start(X)
    for _ in range(passes):
        X0 = _impute(X, X0.mean(axis=0), _cov(X0))
    return X0, X0.mean(axis=0), _cov(X0)


def _cov(X):
    return np.cov(X, rowvar=False).reshape(X.shape[1], X.shape[1])


def _mahalanobis(R, cov):
    P = np.linalg.pinv(cov)
    return np.einsum("ij,jk,ik->i", R, P, R)


class Regression:
    """Linear regression of every feature on the measured conditions, the residuals' covariance; the index is the
    residual's squared Mahalanobis distance (``p`` degrees of freedom)."""

    name = "regression"

    def fit(self, X, C):
        C = np.asarray(C, float)
        self.n_conditions = C.shape[1]
        A = np.c_[np.ones(len(C)), C]
        X0 = _start(X)
        for _ in range(2):                                  # missing entries: conditional mean, refitted once
            self.coef_ = np.linalg.lstsq(A, X0, rcond=None)[0]
            R = X0 - A @ self.coef_
            self.cov_ = R.T @ R / max(len(X0) - A.shape[1], 1)
            X0 = _impute(X, A @ self.coef_, self.cov_)
        tot = np.var(X0, axis=0)
        self.r2_ = 1 - np.var(X0 - A @ self.coef_, axis=0) / np.where(tot > 0, tot, np.nan)
        self.dof_ = X0.shape[1]
        return self

    def with_choices(self):
        return Regression()

    def expected(self, X, C):
        """The features the normal variation predicts for each test (its conditions' prediction), (n, p)."""
        return np.c_[np.ones(len(C)), np.asarray(C, float)] @ self.coef_

    def novelty(self, X, C):
        mean = self.expected(X, C)
        return _mahalanobis(_impute(X, mean, self.cov_) - mean, self.cov_)

    def describe(self, names) -> dict:
        return {"model": self.name, "conditions": list(names), "r2": self.r2_.tolist(),
                "slope_per_condition": self.coef_[1:].T.tolist(), "intercept": self.coef_[0].tolist()}


class PCARemoval:
    """PCA of the baseline features with the ``k`` leading components (the environment's factors) removed (Yan et
    al. 2005); the index is the squared Mahalanobis distance in the remaining ``p - k`` components.

    ``k=None``: the fewest leading components that explain :data:`PCA_EXPLAINED` of the baseline's variance, leaving
    at least two (one with two features): the environment's factors dominate a baseline period's variation, the
    identification noise and what is left are the rest, and a change is told from them by its pattern over at least
    two remaining directions (docs/monitoring.md: on the output-only series one direction left found 1 of 31
    damaged tests, two 10)."""

    name = "pca"

    def __init__(self, k: int | None = None):
        self.k = k

    def fit(self, X, C=None):
        X0, self.mean_, self.cov_ = _filled(X)
        lam, V = np.linalg.eigh(self.cov_)
        order = np.argsort(lam)[::-1]
        self.var_, self.components_ = lam[order], V[:, order]
        k, p = self.k, X0.shape[1]
        if k is None:
            share = np.cumsum(self.var_) / max(self.var_.sum(), 1e-300)
            k = min(int(np.searchsorted(share, PCA_EXPLAINED) + 1), p - 2 if p >= 3 else p - 1)
        self.k_ = min(k, p - 1)
        self.dof_ = X0.shape[1] - self.k_
        return self

    def with_choices(self):
        """An unfitted copy keeping the number of components chosen here."""
        return PCARemoval(self.k_)

    def expected(self, X, C=None):
        """The mean plus the removed components' part of each test: what the environment's factors explain."""
        U = self.components_[:, :self.k_]
        return self.mean_ + (_impute(X, self.mean_, self.cov_) - self.mean_) @ U @ U.T

    def novelty(self, X, C=None):
        scores = (_impute(X, self.mean_, self.cov_) - self.mean_) @ self.components_[:, self.k_:]
        return np.sum(scores**2 / np.maximum(self.var_[self.k_:], 1e-300), axis=1)

    def describe(self, names=()) -> dict:
        total = self.var_.sum()
        return {"model": self.name, "factors_removed": self.k_,
                "explained_variance_ratio": (self.var_ / total).tolist() if total > 0 else None,
                "removed_components": self.components_[:, :self.k_].T.tolist()}


class FactorRemoval:
    """Factor analysis with ``k`` factors; the index is the residual left after the factors' expected contribution,
    squared and weighted by the specific (noise) variances, ``sum_j e_j^2 / psi_j`` (the residual's full
    Mahalanobis distance would be the features' own: removing the factors' posterior mean is an invertible linear
    map)."""

    name = "factor"

    def __init__(self, k: int = 1, seed: int = 0):
        self.k, self.seed = k, seed

    def fit(self, X, C=None):
        from sklearn.decomposition import FactorAnalysis

        X0, self.mean_, self.cov_ = _filled(X)
        self.scale_ = np.where(X0.std(axis=0) > 0, X0.std(axis=0), 1.0)
        self.fa_ = FactorAnalysis(n_components=min(self.k, X0.shape[1] - 1), random_state=self.seed)
        self.fa_.fit((X0 - self.mean_) / self.scale_)
        self.dof_ = X0.shape[1] - int(self.fa_.n_components)
        return self

    def with_choices(self):
        return FactorRemoval(self.k, self.seed)

    def expected(self, X, C=None):
        """The mean plus the factors' expected contribution to each test."""
        Y = (_impute(X, self.mean_, self.cov_) - self.mean_) / self.scale_
        return self.mean_ + self.fa_.transform(Y) @ self.fa_.components_ * self.scale_

    def novelty(self, X, C=None):
        Y = (_impute(X, self.mean_, self.cov_) - self.mean_) / self.scale_
        R = Y - self.fa_.transform(Y) @ self.fa_.components_
        return np.sum(R**2 / np.maximum(self.fa_.noise_variance_, 1e-12), axis=1)

    def describe(self, names=()) -> dict:
        return {"model": self.name, "factors": int(self.fa_.n_components),
                "loadings": (self.fa_.components_ * self.scale_).tolist(),
                "noise_variance": (self.fa_.noise_variance_ * self.scale_**2).tolist()}


class Mixture:
    """A Gaussian mixture of the features (1 to ``max_components`` components by BIC); the index is the squared
    Mahalanobis distance to the component most responsible for the test."""

    name = "mixture"

    def __init__(self, max_components: int = 3, seed: int = 0, n_components: int | None = None):
        self.max_components, self.seed, self.n_components = max_components, seed, n_components

    def with_choices(self):
        """An unfitted copy keeping the number of components chosen here."""
        return Mixture(self.max_components, self.seed, int(self.gm_.n_components))

    def fit(self, X, C=None):
        from sklearn.mixture import GaussianMixture

        X0, self.mean_, self.cov_ = _filled(X)
        best = None
        for c in ([self.n_components] if self.n_components else range(1, self.max_components + 1)):
            if c > 1 and len(X0) < 3 * c * (X0.shape[1] + 1):
                break
            g = GaussianMixture(c, covariance_type="full", random_state=self.seed, reg_covar=1e-10, n_init=2)
            g.fit(X0)
            bic = g.bic(X0)
            if best is None or bic < best[0]:
                best = (bic, g)
        self.gm_ = best[1]
        self.dof_ = X0.shape[1]
        return self

    def expected(self, X, C=None):
        """The mean of the component most responsible for each test."""
        return self.gm_.means_[self.gm_.predict(_impute(X, self.mean_, self.cov_))]

    def novelty(self, X, C=None):
        X0 = _impute(X, self.mean_, self.cov_)
        g = self.gm_
        d = np.stack([_mahalanobis(X0 - g.means_[j], g.covariances_[j]) for j in range(g.n_components)], axis=1)
        return d[np.arange(len(X0)), np.argmax(g.predict_proba(X0), axis=1)]

    def describe(self, names=()) -> dict:
        return {"model": self.name, "components": int(self.gm_.n_components), "weights": self.gm_.weights_.tolist()}


#: Normal-variation models by name: a factory ``(n_features, n_conditions) -> estimator`` (``fit(X, C)``,
#: ``novelty(X, C)``, ``expected(X, C)``, ``describe(names)``, ``with_choices()``: an unfitted copy keeping what
#: the fit chose from the data, so that every held-out fit is the same model).
NORMAL_MODELS = {
    "regression": lambda p, q: Regression(),
    "pca": lambda p, q: PCARemoval(None),
    "pca0": lambda p, q: PCARemoval(0),
    "pca1": lambda p, q: PCARemoval(1),
    "pca2": lambda p, q: PCARemoval(2),
    "factor": lambda p, q: FactorRemoval(1),
    "mixture": lambda p, q: Mixture(),
}


def minimum_baseline(n_features: int, n_conditions: int = 0) -> int:
    """Fewest baseline tests for ``n_features`` features and ``n_conditions`` regressors: every held-out index
    comes from a model fitted on the others, whose residual covariance then keeps at least 4 degrees of freedom
    beyond the features (the F distribution of the index has a finite variance)."""
    return n_features + n_conditions + 6


def _folds(n: int):
    if n <= LOO_MAX:
        return [np.array([i]) for i in range(n)]
    return [np.arange(k, n, N_FOLDS) for k in range(N_FOLDS)]


def missing_evidence(X, X_train) -> np.ndarray:
    """``-2 ln P`` of each test's missing modes (NaN features of ``X``, (n, p)) under the training tests' share
    missing them (``(count + 1) / (n_train + 2)`` per mode, independent): a mode the baseline period always held adds
    ``2 ln(n_train + 2)`` to the index when a test lacks it, a mode often lost adds little. The features of the
    missing modes are filled from the others (:func:`_impute`), so the index would otherwise never see a mode
    that a change has moved beyond its tracking tolerance."""
    miss = ~np.isfinite(np.asarray(X, float))
    train = ~np.isfinite(np.asarray(X_train, float))
    log_p = np.log((train.sum(axis=0) + 1.0) / (train.shape[0] + 2.0))        # (p,)
    return -2.0 * (miss * log_p).sum(axis=1)


def held_out_novelty(make_model, X, C=None) -> np.ndarray:
    """Every baseline test's novelty index (plus :func:`missing_evidence`) by a model fitted on the other
    baseline tests (leave-one-out up to :data:`LOO_MAX` tests, else :data:`N_FOLDS` interleaved folds): the index of
    a test is never computed by a model that saw it."""
    X = np.asarray(X, float)
    out = np.empty(len(X))
    for held in _folds(len(X)):
        train = np.setdiff1d(np.arange(len(X)), held)
        model = make_model().fit(X[train], None if C is None else C[train])
        out[held] = (model.novelty(X[held], None if C is None else C[held])
                     + missing_evidence(X[held], X[train]))
    return out


@dataclass(frozen=True)
class Threshold:
    """The novelty threshold of a false-alarm rate and how it was set.

    ``value = max(law_value, empirical_quantile)``: ``law_value = scale * F.ppf(1 - rate; dof_num, dof_den)``,
    the held-out indices taken to follow ``scale * F(dof_num, dof_den)`` (the exact law of a held-out squared
    Mahalanobis distance with Gaussian residuals, Hotelling's prediction region, up to the scale) with the scale
    fitted to them by maximum likelihood; ``empirical_quantile`` the held-out indices' own ``1 - rate`` quantile
    (linear interpolation).
    """

    value: float
    rate: float
    law_value: float
    scale: float
    dof_num: int
    dof_den: int
    empirical_quantile: float
    held_out_rate: float

    def to_dict(self) -> dict:
        return {"value": self.value, "false_alarm_rate": self.rate,
                "method": "the larger of a scaled F law fitted to the held-out baseline indices (maximum likelihood) "
                          "and their empirical quantile", "law_value": self.law_value, "scale": self.scale,
                "dof": [self.dof_num, self.dof_den], "empirical_quantile_of_held_out": self.empirical_quantile,
                "held_out_false_alarm_rate": self.held_out_rate}


def threshold(held_out, rate: float, dof_num: int, n_train: int, n_conditions: int = 0) -> Threshold:
    """The threshold of the novelty index at false-alarm rate ``rate`` from the held-out indices of the baseline
    tests (:func:`held_out_novelty`), each from a model fitted on ``n_train`` tests.

    A small baseline period cannot give a 1 % quantile empirically (it needs 100 tests to reach it, and more to
    trust it); the F law of a held-out squared Mahalanobis distance, ``d (n+1)(n-1) / (n (n-d)) F(d, n-d)`` for
    ``d`` features and ``n`` training tests, extrapolates its tail from all of them. Its scale is fitted to the
    held-out indices (one parameter: a residual that is not Gaussian, or a model that leaves some variation,
    widens it) rather than taken from the formula. The law's tail is that of Gaussian residuals; an environment
    whose effect is bounded but not linear (a mass re-placed along a curved mode shape) gives held-out indices
    with a heavier tail, which their own quantile shows: the threshold is the larger of the two (on a baseline of
    fewer than ``1 / rate`` tests that quantile lies between its two largest indices).
    """
    from scipy import optimize, stats  # scipy.stats/optimize: heavy, only where a threshold is fitted

    s = np.asarray(held_out, float)
    s = s[np.isfinite(s)]
    d1 = max(int(dof_num), 1)
    d2 = max(int(n_train) - d1 - int(n_conditions), 1)
    law = stats.f(d1, d2)
    pos = np.maximum(s, 1e-300)

    def nll(log_c):
        return -np.sum(law.logpdf(pos / math.exp(log_c))) + pos.size * log_c

    start = math.log(max(np.median(pos) / law.median(), 1e-300))
    c = math.exp(optimize.minimize_scalar(nll, bracket=(start - 1, start + 1)).x)
    law_value = float(c * law.ppf(1 - rate))
    empirical = float(np.quantile(s, 1 - rate)) if s.size else math.nan
    value = max(law_value, empirical) if s.size else law_value
    return Threshold(value, rate, law_value, c, d1, d2, empirical, float(np.mean(s > value)))


# ---------------------------------------------------------------------------------------------------------------
# The series
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class SeriesResult:
    """A monitored series.

    Attributes
    ----------
    rows : list of dict              one per test (``file``, ``time``, ``baseline``, ``alarm``, ``novelty``,
                                     ``threshold``, ``frequencies_hz``, ``mode_z_scores``, ``change_pct``,
                                     ``identified``, ``error``, ``missing_modes``, ``conditions``)
    reference : ReferenceModes
    frequencies_hz : ndarray (n, m)  tracked frequencies (NaN where missing)
    expected_hz : ndarray (n, m)     the baseline's frequencies at each test's conditions
    novelty : ndarray (n,)           NaN for tests not identified
    threshold : Threshold
    model : the fitted normal-variation estimator
    normal_variation : dict          ``model``, its factors or regression, ``per_mode_std`` (relative)
    sigma : ndarray (m,)             per-mode relative std of the normal variation (what the explanations weigh)
    tests : list of IdentifiedModes or None
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

    @property
    def first_alarm(self) -> int | None:
        return next((i for i, r in enumerate(self.rows) if r["alarm"] and not r["baseline"]), None)


def monitor_series(series: SeriesInput, n_baseline: int, settings: IdentificationSettings, cache_dir=None,
                   false_alarm_rate: float = 0.01, normal_model: str | None = None, progress: bool = True
                   ) -> SeriesResult:
    """Monitor a series: identify every test (cached), track the baseline period's modes, learn the normal
    variation on the baseline period, and score every test against the cross-validated threshold.

    ``normal_model``: a key of :data:`NORMAL_MODELS`; default ``"regression"`` with measured conditions, else
    :data:`DEFAULT_LATENT`. Raises :class:`BeamDamageError` on a baseline that cannot carry the model (too few
    tests: the message names the minimum; a baseline test of another kind, band or beam).
    """
    from tqdm import tqdm

    n = len(series.files)
    if not 0 < false_alarm_rate < 0.5:
        raise ConfigError(f"--false-alarm-rate {false_alarm_rate:g}: must lie in (0, 0.5)")
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
        bad = series.files[int(np.flatnonzero(~np.isfinite(C[:n_baseline]).all(axis=1))[0])]
        raise BeamDamageError(f"conditions: baseline test {bad} lacks a measured condition ("
                              f"{', '.join(series.condition_names)}); the regression needs them on every baseline "
                              "test")
    tests, errors, pending = [], [], []
    bar = tqdm(series.files, desc="identify", unit="test", disable=not progress, leave=False)
    for path in bar:
        t, err, _ = cached_identification(path, settings, cache_dir, pending)
        tests.append(t)
        errors.append(err)
    mixed = check_series(tests, n_baseline, series.files)
    for i, why in enumerate(mixed):
        if why:
            tests[i], errors[i] = None, why
    base = [t for t in tests[:n_baseline] if t is not None]
    ref = reference_modes(tests[:n_baseline])
    m = ref.frequencies_hz.size
    if m == 0:
        raise BeamDamageError(f"no mode is found in at least {MIN_PRESENCE:.0%} of the {len(base)} identified "
                              "baseline tests")
    need = minimum_baseline(m, q)
    if len(base) < need:
        raise BeamDamageError(f"--baseline-tests {n_baseline}: {len(base)} identified baseline tests for {m} tracked "
                              f"modes{f' and {q} conditions' if q else ''}; at least {need} are needed "
                              f"(modes + conditions + 6)")
    write_cache(pending)                                    # the series is accepted: identifications kept
    F, Z, MAC, _ = track_modes(tests, ref)
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
    model = NORMAL_MODELS[normal_model](m, q).fit(X[b_idx], None if Cq is None else Cq[b_idx])
    held = held_out_novelty(model.with_choices, X[b_idx], None if Cq is None else Cq[b_idx])
    thr = threshold(held, false_alarm_rate, model.dof_, len(b_idx) - (1 if len(b_idx) <= LOO_MAX else
                                                                        len(b_idx) // N_FOLDS), q)
    novelty = np.full(n, np.nan)
    rest = np.flatnonzero(ok)
    rest = rest[rest >= n_baseline]
    if rest.size:
        novelty[rest] = (model.novelty(X[rest], None if Cq is None else Cq[rest])
                         + missing_evidence(X[rest], X[b_idx]))
    novelty[b_idx] = held
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
              "baseline_tests_used": int(b_idx.size),
              "missing_entries": "imputed by their conditional mean given the test's other features under the "
                                 "baseline's Gaussian (regression: about the conditions' prediction)"}
    rows = []
    for i in range(n):
        mode_missing = [r + 1 for r in range(m) if not np.isfinite(F[i, r])] if tests[i] is not None else []
        rows.append({
            "file": series.files[i], "time": series.times[i], "time_value": float(series.time_values[i]),
            "baseline": i < n_baseline, "identified": bool(ok[i]), "error": errors[i],
            "alarm": bool(ok[i] and novelty[i] > thr.value), "novelty": _num(novelty[i]), "threshold": thr.value,
            "frequencies_hz": [_num(v) for v in F[i]], "damping_ratios": [_num(v) for v in Z[i]],
            "mode_z_scores": [_num(v) for v in z[i]], "change_pct": [_num(v) for v in change[i]],
            "mac": [_num(v) for v in MAC[i]] if ref.shapes is not None else None,
            "missing_modes": mode_missing,
            "conditions": None if C is None else dict(zip(series.condition_names, map(_num, C[i]))),
        })
    return SeriesResult(rows, ref, F, np.exp(expected_log), novelty, thr, model, normal, sigma, tests, series)


def _num(v):
    v = float(v)
    return v if math.isfinite(v) else None


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


# ---------------------------------------------------------------------------------------------------------------
# Verdicts of the alarms
# ---------------------------------------------------------------------------------------------------------------

def _modal_data(freqs_hz, damping, shapes, dofs):

    keep = np.isfinite(freqs_hz)
    z = np.where(np.isfinite(damping), damping, 0.01)[keep]
    return ModalData(eigenvalues_from_modal(np.asarray(freqs_hz)[keep], z),
                     None if shapes is None else np.asarray(shapes)[:, keep], tuple(dofs) if shapes is not None else ())


def _test_shapes(result: SeriesResult, i: int, cols) -> np.ndarray | None:
    ref = result.reference
    t = result.tests[i]
    S = _rows(t, ref.dofs) if (t is not None and ref.shapes is not None) else None
    if S is None:
        return None
    out = np.full((S.shape[0], cols.size), np.nan + 0j)
    have = cols >= 0
    out[:, have] = S[:, cols[have]]
    return out


def baseline_nearest_median(result: SeriesResult) -> int:
    """The baseline test whose frequencies lie nearest the baseline's (smallest sum of squared z-scores among those
    holding every reference mode; else the one holding most)."""
    best, key = None, None
    for i, r in enumerate(result.rows):
        if not (r["baseline"] and r["identified"]):
            continue
        z = np.array([np.nan if v is None else v for v in r["mode_z_scores"]], float)
        k = (-int(np.isfinite(z).sum()), float(np.nansum(z**2)))
        if key is None or k < key:
            best, key = i, k
    return best


def alarm_verdicts(result: SeriesResult, model=None, beam_x_m=None) -> dict:
    """Per alarmed test after the baseline period (row index -> dict): what changed mode by mode against the
    baseline population (``what_changed``, ``summary``), and with a trained model the competing explanations
    weighed with the measured per-mode scatter (``hypotheses``, ``hypotheses_summary``, ``frequency_change_std``)
    and the network's verdict against the baseline period (``network``, :func:`_network_verdicts`)."""
    alarms = [i for i, r in enumerate(result.rows) if r["alarm"] and not r["baseline"]]
    changed = {i: what_changed(result.rows[i], result.sigma) for i in alarms}
    out = {i: {"what_changed": changed[i], "summary": changed_text(changed[i]), "hypotheses": None,
               "hypotheses_summary": None, "frequency_change_std": None, "network": None,
               "network_baselines": None, "network_baseline": None, "network_error": None} for i in alarms}
    if model is None or not alarms:
        return out

    ref = result.reference
    sens = model.sensitivity
    n_all = len(model.beam.modes)
    which = pair_modes_by_frequency(ref.frequencies_hz, sens.frequencies_hz[:n_all])
    sigma_model = np.full(n_all, FREQUENCY_CHANGE_STD)
    sigma_model[which[which >= 0]] = result.sigma[which >= 0]
    _, _, _, cols = track_modes(result.tests, ref)
    Zb = np.array([[np.nan if v is None else v for v in r["damping_ratios"]] for r in result.rows
                   if r["baseline"] and r["identified"]], float)
    base = _modal_data(ref.frequencies_hz, np.nanmedian(Zb, axis=0), ref.shapes, ref.dofs)
    try:
        base_m = on_model_dofs(base, model.beam, beam_x_m, "the baseline median")[0]
        pairs, idx = [], []
        for i in alarms:
            r = result.rows[i]
            f = result.frequencies_hz[i] * ref.frequencies_hz / result.expected_hz[i]   # at the baseline's conditions
            cur = _modal_data(f, np.array([np.nan if v is None else v for v in r["damping_ratios"]], float),
                              _test_shapes(result, i, cols[i]) if ref.shapes is not None else None, ref.dofs)
            cur_m = on_model_dofs(cur, model.beam, beam_x_m, r["file"])[0]
            pairs.append(modal_pair(base_m, cur_m, model.beam, sens.frequencies_hz, ("baseline median", r["file"])))
            idx.append(i)
        for i, e in zip(idx, explain_many(model, pairs, sigma_model)):
            out[i].update(e)
    except BeamDamageError as exc:
        for i in alarms:
            out[i]["hypotheses_summary"] = f"no explanations: {exc}"
    out = _network_verdicts(result, model, beam_x_m, alarms, out)
    return out


def _network_verdicts(result: SeriesResult, model, beam_x_m, alarms: list, out: dict) -> dict:
    """The network's verdicts of the alarms (``network``) by :func:`learn.classify.classify_many` against the
    whole baseline period (its scatter the normal variation; ``network_baselines``: how many tests), else, when
    classify refuses that, against the baseline test nearest the baseline median (``network_baseline``)."""

    base = [i for i, r in enumerate(result.rows) if r["baseline"] and r["identified"]]
    nearest = baseline_nearest_median(result)
    if not base:
        return out

    def md(i):
        t = result.tests[i]
        return on_model_dofs(_modal_data(t.frequencies_hz, t.damping_ratios, t.shapes, t.dofs), model.beam, beam_x_m,
                             result.rows[i]["file"])[0]

    keys = ("damaged", "probability_damaged", "location_x_m", "location_zone", "size",
            "verdict_from", "in_distribution", "out_of_distribution_reasons", "hypotheses_summary", "warnings")
    methods = [None if t is None else t.method if t.method in ("lscf", "ssi") else None for t in result.tests]
    rate = result.threshold.rate

    def run(group, baselines):
        names = [result.rows[i]["file"] for i in (*baselines, *group)]
        vs = classify_many(model, [md(i) for i in baselines], [md(i) for i in group], names=names,
                           methods=[methods[i] for i in (*baselines, *group)], false_alarm_rate=rate)
        for i, v in zip(group, vs):
            out[i].update(network={k: v.get(k) for k in keys}, network_baselines=len(baselines),
                          network_baseline=result.rows[baselines[0]]["file"] if len(baselines) == 1 else None)

    for baselines in (base, [nearest]):
        try:
            run(alarms, baselines)                           # one network call for every alarm
            return out
        except BeamDamageError:
            pass
    for i in alarms:                                         # one alarm's error apart
        try:
            run([i], [nearest])
        except BeamDamageError as exc:
            out[i].update(network_error=str(exc), network_baseline=result.rows[nearest]["file"])
    return out
