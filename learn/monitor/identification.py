"""One test's modes, identified once: FRFs by LSCF/LSFD, response records by SSI-cov, modal data as read; the
result kept per file in a JSON cache keyed by the file's bytes and the identification settings, beside the record's
FFT peaks in the reference modes' bands (:func:`cached_fft_peaks`)."""

from __future__ import annotations

import hashlib
import json
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from learn.pairs.measured import IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, identify_modes
from physics.errors import BeamDamageError
from physics.identification import (DEFAULT_OUTPUT_ONLY, holds_response_records, identify_records,
                                    read_response_records, response_records)
from physics.identification.failures import identification_failure
from physics.identification.record_checks import check_records
from physics.identification.fft_peak import fft_peaks
from physics.identification.measured import read_measured_frf
from physics.io import (FRF, MODAL, TIME, atomic_write_text, finite_or_none, format_complex, modal_or_frf,
                        prepare_measured, read)
from physics.io.inputs import check_input_file
from physics.modal import modal_parameters, undamped_modes

__all__ = ["CACHE_FORMAT", "FFT_FORMAT", "NARROW_FORMAT", "Failure", "IdentificationSettings", "IdentifiedModes",
           "cached_fft_peaks", "cached_identification", "file_key", "identification_settings", "identify_test",
           "read_test", "record_problem", "with_narrow_band_poles", "write_cache"]

#: Format tag of a cache entry (a change of the identification or of the entry's fields changes it).
CACHE_FORMAT = "beam-damage-monitor-cache/18"
#: Format tag of a narrow-band re-identification's entry (:func:`cached_identification` with ``narrow_hz``), part of
#: its key beside :data:`CACHE_FORMAT`: a change of the identification of a mode known to lie in its band (SSI-cov's
#: ``mode_in_band``) changes it and re-identifies those entries alone.
NARROW_FORMAT = 9
#: Format tag of an FFT-peaks entry (:func:`cached_fft_peaks`), part of its key beside :data:`CACHE_FORMAT`: a change
#: of :func:`physics.identification.fft_peak.fft_peaks` changes it and reads those entries alone again.
FFT_FORMAT = 2


@dataclass(frozen=True)
class IdentificationSettings:
    """How every test of a series is identified: the band (Hz; None: the file's), the modes kept (None: all
    found), the highest model order of LSCF (FRFs) and of SSI-cov (response records: its state model spends
    states on the excitation's colour and the sensor noise; on the 60-s records of the independent monitoring series
    a 10-Hz mode at the bottom of a 5-400 Hz band is found in half of the tests at order 40, in all at 80), and the
    method of response records (:data:`~physics.identification.output_only.RECORDS_METHODS`; ``"auto"``: per
    record, ``era`` for a free response, else ``ssi``; a series known to be ambient, ``"ssi"``)."""

    band_hz: tuple | None = None
    n_modes: int | None = None
    max_order: int = 40
    records_max_order: int = 80
    records_method: str = DEFAULT_OUTPUT_ONLY

    def to_dict(self) -> dict:
        """The settings (``records_method`` only where it is not ``"auto"``: the cache keys of the per-record
        choice stay as they were)."""
        out = {"band_hz": None if self.band_hz is None else [float(b) for b in self.band_hz],
               "n_modes": self.n_modes, "max_order": self.max_order, "records_max_order": self.records_max_order}
        return out if self.records_method == DEFAULT_OUTPUT_ONLY else {**out, "records_method": self.records_method}


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
    narrow_band_hz : tuple      per pole, None for a pole of the identification over the series' band, ``(lo, hi)``
                                (Hz) for one that a narrow-band re-identification around a reference mode found
                                (:func:`with_narrow_band_poles`); empty: every pole of the first
    record_crop : str           response records clipped in their leading part: the clipped runs and the first
                                sample identified (:class:`~physics.identification.record_checks.RecordCrop`);
                                empty when the whole record was identified
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
    narrow_band_hz: tuple = ()
    record_crop: str = ""

    def identified_by(self, k: int) -> str:
        """How pole ``k`` was found, e.g. ``"lscf"`` or ``"lscf, narrow band 3.21-3.79 Hz"``."""
        band = self.narrow_band_hz[k] if self.narrow_band_hz else None
        return self.method if band is None else f"{self.method}, narrow band {band[0]:.4g}-{band[1]:.4g} Hz"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "method": self.method, "frequencies_hz": self.frequencies_hz.tolist(),
                "damping_ratios": self.damping_ratios.tolist(),
                "shapes": None if self.shapes is None else [[format_complex(z) for z in row] for row in self.shapes],
                "dofs": list(self.dofs), "references": list(self.references),
                "band_hz": None if self.band_hz is None else list(self.band_hz), "line_hz": self.line_hz,
                "narrow_band_hz": [None if b is None else list(b) for b in self.narrow_band_hz],
                "record_crop": self.record_crop}

    @classmethod
    def from_dict(cls, d: dict) -> "IdentifiedModes":
        shapes = d["shapes"]
        return cls(d["kind"], d["method"], np.asarray(d["frequencies_hz"], float),
                   np.asarray(d["damping_ratios"], float),
                   None if shapes is None else np.array([[complex(z) for z in row] for row in shapes], complex)
                   .reshape(len(shapes), len(d["frequencies_hz"])),
                   tuple(d["dofs"]), tuple(d["references"]), None if d["band_hz"] is None else tuple(d["band_hz"]),
                   d["line_hz"], tuple(None if b is None else tuple(b) for b in d.get("narrow_band_hz", ())),
                   d.get("record_crop", ""))


class Failure(str):
    """Why a test was not identified: the error text (this ``str``), and ``record_problem``, why its file holds no
    usable record (:func:`record_problem`'s text, found while identifying it: its file is read once), or None when
    the record reads and only its identification failed."""

    record_problem: str | None

    def __new__(cls, text: str, record_problem: str | None = None):
        self = super().__new__(cls, text)
        self.record_problem = record_problem
        return self

    def __reduce__(self):
        return Failure, (str(self), self.record_problem)


def identification_settings(band_hz=None, beam=None, model=None) -> IdentificationSettings:
    """The identification of a series: over ``band_hz`` (Hz) when given; else a trained model's (its test band,
    or up to :data:`learn.pairs.measured.IDENTIFICATION_BAND_FACTOR` times its nominal mode 4, the 4 lowest modes: what
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
        f4 = float(np.sort(np.abs(w))[beam.support.rigid_body_modes + 3]) / (2 * np.pi)
        return IdentificationSettings((0.0, IDENTIFICATION_BAND_FACTOR * f4), IDENTIFICATION["n_modes"])
    return IdentificationSettings()


def _modes_of(eigenvalues, shapes):

    lam = np.asarray(eigenvalues, complex)
    f, z = modal_parameters(lam)
    order = np.argsort(f)
    return (np.asarray(f, float)[order], np.asarray(z, float)[order],
            None if shapes is None else np.asarray(shapes, complex)[:, order])


def read_test(path) -> tuple:
    """``(kind, data)`` of one test file as :func:`identify_test` reads it, before any identification: ``(MODAL,
    modal data)``, ``(TIME, response records without a force)`` or ``(FRF, measured FRFs)``, each checked by its
    reader (finite samples, a channel that varies, the fields and shapes of its format).

    Raises :class:`BeamDamageError` (one line naming the file) when the file cannot be read."""
    path = str(path)
    if modal_or_frf(path) == MODAL:
        return MODAL, prepare_measured(read(path, MODAL)).data
    if holds_response_records(path) and not (rec := read(path, TIME)).forces:
        return TIME, response_records(rec, path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FRF, prepare_measured(read_measured_frf(path)).data


def record_problem(path) -> str | None:
    """Why the file of a test holds no usable record (unreadable, truncated, missing fields: :func:`read_test`
    refuses it; response records with NaN samples, a constant channel or one clipped beyond its leading part:
    :func:`physics.identification.record_checks.check_records` refuses them), or None when the record reads (and
    only its identification may fail). A test whose record is not usable says nothing of the structure: it is not
    counted among the tests whose identification was lost (:func:`learn.monitor.events.identification_change`).
    Modal data come from an identification run elsewhere: a modal file that cannot be used is that
    identification's failure, and counts (None here). :func:`cached_identification` gives it of a file it read
    (:attr:`Failure.record_problem`)."""
    try:
        test = read_test(path)
    except (BeamDamageError, OSError) as exc:
        return _unreadable(exc, path).record_problem
    return _records_problem(test, path)


def _unreadable(exc, path) -> Failure:
    """The failure of a test whose file :func:`read_test` refused with ``exc``: a record problem unless it is a
    modal-data file."""
    text = _error_text(exc, path)
    try:
        modal = modal_or_frf(path) == MODAL
    except (BeamDamageError, OSError):
        modal = False
    return Failure(text, None if modal else text)


def _records_problem(test, path) -> str | None:
    """Why the response records of a test read by :func:`read_test` (``(kind, data)``) are not usable
    (:func:`~physics.identification.record_checks.check_records` over the default band), or None."""
    kind, data = test
    if kind == TIME:
        try:
            check_records(data.signals, data.sampling_frequency_hz, where=str(path))
        except (BeamDamageError, OSError) as exc:
            return _error_text(exc, path)
    return None


def identify_test(path, settings: IdentificationSettings, narrow_hz=None, test=None) -> IdentifiedModes:
    """One test's modes: an FRF file by LSCF/LSFD (:func:`learn.pairs.measured.identify_modes`, the identification
    ``classify`` runs), response records without a force by SSI-cov (as ``identify``; records clipped in their
    leading part from the samples after the clipping, ``record_crop``), modal data as read.

    With ``narrow_hz`` (lo, hi) (Hz), the same method over that band alone and every mode it finds there (no
    ``settings.n_modes``): the narrow-band re-identification around a reference mode that the identification over
    the series' band missed (its poles' ``narrow_band_hz`` that band; modal data are read as they are).

    ``test``: ``(kind, data)`` of :func:`read_test` when the file was read already (None: read here).

    Raises :class:`BeamDamageError` (one line naming the file) when the file cannot be read or identified,
    including an exception of :data:`physics.identification.failures.PER_RECORD_ERRORS` in the identification (named
    by its class; :func:`~physics.identification.failures.identification_failure`).
    """

    path = str(path)
    kind, data = read_test(path) if test is None else test
    if kind == MODAL:
        f, z, shapes = _modes_of(data.eigenvalues, data.eigenvectors)
        return IdentifiedModes("modal", "file", f, z, shapes, tuple(data.dofs or ()))
    band = settings.band_hz if narrow_hz is None else tuple(float(b) for b in narrow_hz)
    n_modes = settings.n_modes if narrow_hz is None else None
    if kind == TIME:
        rec = data
        how = (f"{DEFAULT_OUTPUT_ONLY}: era for a free response, else ssi" if settings.records_method ==
               DEFAULT_OUTPUT_ONLY else f"{settings.records_method}, named for the series")
        with identification_failure(f"{path}: output-only identification ({how})"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ident = identify_records(rec, settings.records_method, band, n_modes, settings.records_max_order,
                                     mode_in_band=narrow_hz is not None)
        fs, crop = rec.sampling_frequency_hz, ident.crop
        f, z, shapes = _modes_of(ident.estimate.eigenvalues, ident.estimate.shapes)
        n = rec.signals.shape[1] - (0 if crop is None else crop.first_sample)
        return IdentifiedModes("response records", ident.estimate.method, f, z, shapes, tuple(rec.dofs), (),
                               (0.0, fs / 2), fs / n, _narrow(narrow_hz, f.size), "" if crop is None else crop.text)

    frf = data
    lines = np.asarray(frf.frequency_hz, float)
    fmin, fmax = (0.0, None) if band is None else band
    if band is not None and (lines[-1] <= fmin or lines[0] >= fmax):
        raise BeamDamageError(f"{path}: its lines {lines[0]:g}-{lines[-1]:g} Hz miss the band {fmin:g}-{fmax:g} Hz")
    with identification_failure(f"{path}: identification of its FRFs (lscf)"):
        md = identify_modes(frf, fmax, path, n_modes, fmin, settings.max_order)
    f, z, shapes = _modes_of(md.eigenvalues, md.eigenvectors)
    line = float(np.median(np.diff(lines))) if lines.size > 1 else None
    return IdentifiedModes("frf", "lscf", f, z, shapes, tuple(md.dofs), tuple(frf.reference_dofs),
                           (float(lines[0]), float(lines[-1])), line, _narrow(narrow_hz, f.size))


def _narrow(narrow_hz, k: int) -> tuple:
    return () if narrow_hz is None else (tuple(float(b) for b in narrow_hz),) * k


def with_narrow_band_poles(test: IdentifiedModes, found: IdentifiedModes, keep) -> IdentifiedModes:
    """``test`` with the poles ``keep`` (indices) of a narrow-band re-identification ``found`` added (frequency
    order); shapes kept when both carry them on the same DOFs, else dropped."""
    keep = np.asarray(keep, int)
    if keep.size == 0:
        return test
    f = np.r_[test.frequencies_hz, found.frequencies_hz[keep]]
    z = np.r_[test.damping_ratios, found.damping_ratios[keep]]
    bands = (test.narrow_band_hz or (None,) * test.frequencies_hz.size) + tuple(found.narrow_band_hz[k]
                                                                                 for k in keep)
    shapes = None
    if test.shapes is not None and found.shapes is not None and tuple(found.dofs) == tuple(test.dofs):
        shapes = np.c_[test.shapes, found.shapes[:, keep]]
    order = np.argsort(f, kind="stable")
    return replace(test, frequencies_hz=f[order], damping_ratios=z[order],
                   shapes=None if shapes is None else shapes[:, order],
                   dofs=test.dofs if shapes is not None else (), narrow_band_hz=tuple(bands[k] for k in order))


def file_key(path, settings: IdentificationSettings | None, extra=None) -> str:
    """SHA-256 of the file's bytes, the identification settings (None: an entry no setting changes), ``extra`` (a
    JSON value: the narrow band, the FFT peaks' bands) and :data:`CACHE_FORMAT`."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    what = [CACHE_FORMAT, None if settings is None else settings.to_dict()]
    if extra is not None:
        what.append(extra)
    h.update(json.dumps(what, sort_keys=True).encode())
    return h.hexdigest()


def cached_identification(path, settings: IdentificationSettings, cache_dir=None, pending: list | None = None,
                          narrow_hz=None):
    """``(IdentifiedModes or None, Failure or None, from_cache)`` of one test (with ``narrow_hz``: its
    narrow-band re-identification, :func:`identify_test`); the :class:`Failure` of a test not identified carries
    its :func:`record_problem`, found from the file read for the identification.

    With ``cache_dir``, the result (or the failure of a file that cannot be identified) is read from
    ``cache_dir/<key>.json`` (:func:`file_key`) or, once identified, written there atomically; with ``pending`` (a
    list) the entry to write is appended to it as ``(path, text)`` instead (written when the series is accepted).
    """
    try:
        check_input_file(path, "npz", BeamDamageError, "a test file")
        narrow = None if narrow_hz is None else [*(float(b) for b in narrow_hz), NARROW_FORMAT]
        key = file_key(path, settings, narrow) if cache_dir else None
    except (BeamDamageError, OSError) as exc:
        return None, Failure(_error_text(exc, path), record_problem(path)), False
    entry = Path(cache_dir) / f"{key}.json" if cache_dir else None
    try:
        if (d := _entry(entry)) is not None:
            return (None if d["modes"] is None else IdentifiedModes.from_dict(d["modes"]),
                    None if d["error"] is None else Failure(d["error"], d["record_problem"]), True)
    except (ValueError, KeyError, TypeError):
        pass                                                # a damaged entry: identified again
    modes, error = None, None
    try:
        test = read_test(path)
    except (BeamDamageError, OSError) as exc:
        error = _unreadable(exc, path)
    else:
        try:
            modes = identify_test(path, settings, narrow_hz, test)
        except (BeamDamageError, OSError) as exc:
            error = Failure(_error_text(exc, path), _records_problem(test, path))
    if entry is not None:
        text = json.dumps({"format": CACHE_FORMAT, "file": str(path), "settings": settings.to_dict(),
                           "narrow_band_hz": None if narrow_hz is None else [float(b) for b in narrow_hz],
                           "modes": None if modes is None else modes.to_dict(), "error": error,
                           "record_problem": None if error is None else error.record_problem})
        if pending is None:
            write_cache([(entry, text)])
        else:
            pending.append((entry, text))
    return modes, error, False


def cached_fft_peaks(path, bands_hz, cache_dir=None) -> np.ndarray:
    """Shape (m,): a response record's zero-padded FFT peak (Hz) in each of ``bands_hz`` ((m, 2), Hz), the fitted
    vertex of the highest local maximum of its FFT power whose vertex lies there
    (:func:`physics.identification.fft_peak.fft_peaks`, its window chosen by the record); NaN where none does, or
    for a record that is refused.

    With ``cache_dir``, read from ``cache_dir/<key>.json`` (:func:`file_key` of the file, the bands and
    :data:`FFT_FORMAT`) or, once computed, written there atomically.
    """
    bands = np.asarray(bands_hz, float).reshape(-1, 2)
    what = "fftpeak_bands_hz"
    entry = None
    try:
        if cache_dir:
            entry = Path(cache_dir) / f"{file_key(path, None, {what: bands.tolist(), 'rule': FFT_FORMAT})}.json"
        if (d := _entry(entry)) is not None:
            return np.array([np.nan if v is None else v for v in d["fft_hz"]], float)
    except (OSError, ValueError, KeyError, TypeError):
        pass                                                # no file (refused below), or a damaged entry
    try:
        rec = read_response_records(path)
        peaks = fft_peaks(rec.signals, rec.sampling_frequency_hz, bands.mean(axis=1),
                          0.5 * (bands[:, 1] - bands[:, 0]), where=str(path))
        out = peaks.frequency_hz
    except (BeamDamageError, OSError):
        out = np.full(bands.shape[0], np.nan)
    if entry is not None:
        write_cache([(entry, json.dumps({"format": CACHE_FORMAT, "file": str(path), what: bands.tolist(),
                                         "fft_hz": [finite_or_none(v) for v in out]}))])
    return out


def _entry(path) -> dict | None:
    """The cache entry at ``path`` (None: no cache, no entry, or one of another :data:`CACHE_FORMAT`)."""
    if path is None or not path.is_file():
        return None
    d = json.loads(path.read_text())
    return d if d.get("format") == CACHE_FORMAT else None


def write_cache(entries) -> None:
    """Write cache entries ``(path, text)`` atomically."""
    for path, text in entries:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, text)


def _error_text(exc, path) -> str:
    text = " ".join(str(getattr(exc, "strerror", None) or exc).split())
    return text if str(path) in text else f"{path}: {text}"
