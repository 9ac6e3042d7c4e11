"""Identification of a :class:`~physics.io.MeasuredFRF` or an FRF file by a method of :data:`METHODS`."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from physics.errors import ConfigError, ConvergenceError, FileFormatError, ShapeError
from physics.identification.lscf import (CLEAR_PEAK_PROMINENCE, CLEAR_PEAK_TOLERANCE, highest_order,
                                         octave_median_peaks)
from physics.identification.methods import METHODS
from physics.identification.modes import ModalEstimate
from physics.identification.poles import StabilisationDiagram
from physics.identification.output_only import holds_response_records
from physics.io import FRF, TIME, MeasuredFRF, ModalData, format_of, prepare_measured, read, read_frf
from physics.io.timedata import read_uff_time_records
from physics.io.uff58 import UffFile, read_uff58
from physics import time_records                  # a module: time_records reads record_checks of this package

__all__ = ["DEFAULT_MAX_ORDER", "Identification", "force_band_top_hz", "identify_file", "identify_frf", "identify_frfs",
           "read_measured_frf", "reconstruction_error_db"]

#: The highest LSCF model order :func:`identify_frf` fits by default (fewer where the band's lines carry fewer).
DEFAULT_MAX_ORDER = 40


def reconstruction_error_db(measured, synthesised):
    """Median and 90th percentile over all lines and FRFs of ``|20 log10(|H_fit| / |H_meas|)|`` (dB).

    Lines where either magnitude is zero are left out.
    """
    m, s = np.abs(np.asarray(measured)).ravel(), np.abs(np.asarray(synthesised)).ravel()
    ok = (m > 0) & (s > 0)
    if not np.any(ok):
        return float("nan"), float("nan")
    err = np.abs(20 * np.log10(s[ok] / m[ok]))
    return float(np.median(err)), float(np.percentile(err, 90))


@dataclass(frozen=True)
class Identification:
    """An identification run on a :class:`~physics.io.MeasuredFRF`.

    Attributes
    ----------
    frf : MeasuredFRF
        The band-limited FRFs that were fitted, of the input's kind (SI units).
    estimate : ModalEstimate
    synthesised : ndarray, complex, shape like ``frf.frf``
        The identified model on the same lines, of the same kind and units.
    diagram : StabilisationDiagram or None
        LSCF only.
    drive : str or None
        Reference DOF label of the driving point that scaled the shapes.
    out_of_band_hz : ndarray
        Poles just outside the band that the fit used (LSCF only; not reported as modes).
    """

    frf: MeasuredFRF
    estimate: ModalEstimate
    synthesised: np.ndarray
    diagram: StabilisationDiagram | None
    drive: str | None
    out_of_band_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def modal_data(self) -> ModalData:
        """Eigenvalues and shapes over the response DOFs, for updating."""
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.frf.response_dofs)


def peaks_left_out(frf: MeasuredFRF, identified_hz, tolerance: float = CLEAR_PEAK_TOLERANCE) -> np.ndarray:
    """Frequencies (Hz) of plainly visible peaks of the FRFs' RMS magnitude with no identified mode within their
    reach: a few of the peak's own half-power bandwidths or frequency lines, at most ``tolerance`` (relative) or 1.5
    lines (:func:`physics.identification.lscf.octave_median_peaks`,
    :func:`~physics.identification.lscf.clear_peak_reach_hz`)."""
    mag = np.sqrt(np.mean(np.abs(np.asarray(frf.frf)) ** 2, axis=(0, 1)))
    return octave_median_peaks(frf.frequency_hz, mag, identified_hz, tolerance)


def identify_frf(frf: MeasuredFRF, method="lscf", band_hz=None, n_modes=None, max_order=None) -> Identification:
    """Identify modes of a :class:`~physics.io.MeasuredFRF` (band-limited, fitted in its own kind).

    The first driving point (a response DOF equal to a reference DOF) scales the
    shapes to unit modal A; without one the shapes are unscaled (a warning).
    The file is prepared by :func:`~physics.io.prepare_measured`: DOFs labelled with
    a negative sense are turned to the positive one, and a file whose references,
    not its responses, cover every DOF it names (a roving hammer) is read by
    reciprocity, so the shapes run over every DOF the test touched;
    ``Identification.frf`` is the matrix as identified.

    Parameters
    ----------
    frf : MeasuredFRF
    method : str
        A key of :data:`~physics.identification.METHODS`.
    band_hz : (float, float), optional
        ``(fmin, fmax)`` in Hz.
    n_modes : int, optional
        Modes to keep (default: all found).
    max_order : int, optional
        Highest LSCF model order (methods with ``"max_order"`` in their options); default
        :data:`DEFAULT_MAX_ORDER`, or the highest the band's lines carry where that is lower (a narrow band).

    Returns
    -------
    Identification
    """
    if method not in METHODS:
        raise ConfigError(f"method {method!r} must be one of {', '.join(METHODS)}")
    spec = METHODS[method]
    if spec.data != "frf":
        raise ConfigError(f"method {method!r} identifies response records output-only, not FRFs "
                          "(see physics.identification.identify_records)")
    frf = prepare_measured(frf).data
    if frf.frequency_hz[0] == 0:
        frf = frf.select_band(fmin_hz=np.nextafter(0.0, 1.0))
    if band_hz is not None:
        fmin, fmax = band_hz
        if not fmin < fmax:
            raise ConfigError(f"band_hz ({fmin}, {fmax}): the lower bound must be below the upper")
        frf = frf.select_band(fmin, fmax)
    elif (top := force_band_top_hz(frf)) is not None and top < frf.frequency_hz[-1]:
        frf = frf.select_band(fmax_hz=top)
        warnings.warn(f"{frf.metadata.get('source', 'FRFs')}: identified up to {top:.4g} Hz, the hammer's force band "
                      f"(its force spectrum falls {time_records.FORCE_DROP_DB:g} dB below its peak there; above it H1 "
                      "is the response's noise over a force that is not there); --band to read beyond it",
                      stacklevel=2)
    drives = frf.driving_points
    drive = drives[0] if drives else None
    if drive is None:
        warnings.warn("no driving point (response DOF equal to a reference DOF): mode shapes are not "
                      "unit-modal-A scaled, so FRFs synthesised from them have no absolute level ('update' scales "
                      "each mode's shape against its own mass and is not affected)", stacklevel=2)
    if max_order is None:
        n_o, n_i, n_lines = frf.frf.shape
        max_order = max(1, min(DEFAULT_MAX_ORDER, highest_order(n_lines, n_o, n_i)))
    options = {"max_order": max_order}
    est, synth, diagram, outside = spec.fit(frf, drive, n_modes, **{k: options[k] for k in spec.options})
    if n_modes is None:
        missed = peaks_left_out(frf, est.natural_frequencies_hz)
        if missed.size:
            warnings.warn(f"{method}: the FRFs show {'a peak' if missed.size == 1 else 'peaks'} at "
                          f"{', '.join(f'{x:.4g}' for x in missed)} Hz, at least {CLEAR_PEAK_PROMINENCE:g} times "
                          "their surroundings, that no identified mode explains; narrow the band around "
                          f"{'it' if missed.size == 1 else 'them'} (--band) or raise the model order", stacklevel=2)
    label = frf.reference_dofs[drive[1]] if drive else None
    return Identification(frf, est, synth, diagram, label, outside)


def force_band_top_hz(frf: MeasuredFRF) -> float | None:
    """The top of the force band an impact estimate stored in the FRFs' metadata (``force_band_hz``, written by
    :func:`physics.time_records.estimate_from_records`), or None without one."""
    band = frf.metadata.get("force_band_hz")
    if band is None:
        return None
    try:
        low, high = (float(b) for b in band)
    except (TypeError, ValueError):
        low = high = np.nan
    if not (np.isfinite(low) and np.isfinite(high) and 0 <= low < high):
        raise FileFormatError(f"{frf.metadata.get('source', 'FRFs')}: metadata 'force_band_hz' must be two finite "
                              f"frequencies (Hz) [low, high] with 0 <= low < high, got {band!r}")
    return high


def identify_frfs(frfs, method="lscf", band_hz=None, n_modes=None, max_order=None) -> list[Identification]:
    """:func:`identify_frf` on each of several :class:`~physics.io.MeasuredFRF` (same arguments for all).

    Files of one layout (the same frequency lines and band) share the LSCF basis and
    its QR factor, computed once (see :func:`~physics.identification.lscf`); results are in input order.

    Returns
    -------
    list of Identification
    """
    return [identify_frf(frf, method, band_hz, n_modes, max_order) for frf in frfs]


def identify_file(path, method="lscf", band_hz=None, n_modes=None, max_order=None) -> Identification:
    """:func:`identify_frf` on an FRF file (UFF 58, CSV or ``.npz``; see :func:`physics.io.read_frf`).

    A universal file of time records (force and responses, no FRF) is estimated
    first (:func:`physics.time_records.estimate_as_recorded`: H1, one block per hit
    of an impact test, random excitation otherwise), with a warning that says how.
    """
    frf = read_measured_frf(path)
    try:
        return identify_frf(frf, method, band_hz, n_modes, max_order)
    except ConvergenceError as exc:                 # identify_frf knows no file: the path is named here, once
        hint = (f"; FRFs estimated as {frf.metadata['estimated']}: for a hammer test, 'beam-damage estimate "
                "--excitation impact' first" if "random excitation" in frf.metadata.get("estimated", "") else "")
        raise ConvergenceError(f"{path}: {exc}{hint}", parameter=exc.parameter) from None
    except ShapeError as exc:                       # a band or an order the file's lines cannot carry
        raise ShapeError(f"{path}: {exc}", parameter=exc.parameter) from None


def read_measured_frf(path) -> MeasuredFRF:
    """FRFs of a file: read as FRFs, or estimated from time records of a force and responses (a universal file
    without FRF records, an NPZ or CSV time series with a force channel; with a warning saying how); a universal
    file is parsed once."""
    if format_of(path, FRF).name != "uff":
        if not (holds_response_records(path) and (rec := read(path, TIME)).forces):
            return read_frf(path)                   # FRFs, or response records: refused naming what they hold
        est = time_records.estimate_as_recorded(rec)
    else:
        uf = UffFile(path)
        if 4 in uf.function_types or 1 not in uf.function_types:   # FRF records, or nothing to estimate from
            return read_uff58(uf)
        est = time_records.estimate_as_recorded(read_uff_time_records(uf))
    warnings.warn(f"{path}: holds time records, not FRFs: estimated {est.description} before identifying",
                  stacklevel=2)
    return est.frf
