"""Output-only identification of response records (no force) by a method of :data:`METHODS` with
``data == "records"``: the records of a file, :func:`identify_records` and its :class:`RecordsIdentification`."""

from __future__ import annotations

import warnings
import zipfile
from dataclasses import dataclass
from inspect import signature
from pathlib import Path

import numpy as np

from physics.io.inputs import MAX_BYTES, check_input_file
from physics.errors import ConfigError, ConvergenceError, FileFormatError, ShapeError
from physics.identification.channel_weights import (ChannelWeights, noise_floor_weights, unweighted_diagram,
                                                    unweighted_estimate, weighted_record)
from physics.identification.decays import (CHANCE_FALL_CAP_DB, FREE_DROP_DB, chance_fall_db, free_response,
                                          least_fall_db, slowest_mode)
from physics.identification.fft_peak import PEAK_EXPONENT, padded_spectrum
from physics.identification.methods import METHODS
from physics.identification.modes import ModalEstimate
from physics.identification.poles import StabilisationDiagram
from physics.identification.record_checks import RecordCrop, check_records
from physics.io import FRF, ModalData, TIME, format_of, read
from physics.io.timedata import TimeRecords
from physics.io.uff58 import UffFile
from physics.identification.setups import MergedSetups, merge_setups   # the multi-setup merge

__all__ = ["DEFAULT_OUTPUT_ONLY", "FREE_RESPONSE_METHOD", "RECORDS_METHODS", "SCALING", "STATIONARY_METHOD",
           "STATIONARY_METHODS", "MergedSetups", "RecordsIdentification", "holds_response_records",
           "identify_records", "merge_setups", "read_response_records", "response_records"]

#: The method ``identify`` takes for a file of response records without a force channel: ``"auto"`` picks
#: :data:`FREE_RESPONSE_METHOD` for a free response (decays after hits,
#: :func:`~physics.identification.decays.free_response`), :data:`STATIONARY_METHOD` otherwise.
DEFAULT_OUTPUT_ONLY = "auto"
FREE_RESPONSE_METHOD, STATIONARY_METHOD = "era", "ssi"
#: The output-only methods that assume a stationary response (warned of when named for a free response).
STATIONARY_METHODS = tuple(name for name, spec in METHODS.items() if spec.stationary)
#: What response records without a force can be identified by: ``"auto"`` and every method of :data:`METHODS` with
#: ``data == "records"``.
RECORDS_METHODS = (DEFAULT_OUTPUT_ONLY, *(name for name, spec in METHODS.items() if spec.data == "records"))
#: What modal.json says of output-only shapes.
SCALING = "unscaled (output-only: no force measured, so no modal mass)"


@dataclass(frozen=True)
class RecordsIdentification:
    """An output-only identification of response records.

    Attributes
    ----------
    records : TimeRecords
        The response channels identified (SI units of one quantity).
    estimate : ModalEstimate
        Unit-norm, unscaled shapes over ``records.dofs``.
    diagram : StabilisationDiagram or None
    method_choice : str
        Which method was picked and why (``"auto"``); empty for a method named by the caller.
    weights : ChannelWeights or None
        The weight of each channel in the identification (each in units of its own noise floor,
        :mod:`~physics.identification.channel_weights`; all ones for floors within its ``SPREAD_DB``); None for one
        channel, or ``weigh_channels=False``.
    crop : RecordCrop or None
        The leading samples left out for their clipped runs
        (:func:`~physics.identification.record_checks.check_records`): the modes are those of the samples from
        ``crop.first_sample`` on; None when identified from the whole record.
    """

    records: TimeRecords
    estimate: ModalEstimate
    diagram: StabilisationDiagram | None
    method_choice: str = ""
    weights: ChannelWeights | None = None
    crop: RecordCrop | None = None

    @property
    def modal_data(self) -> ModalData:
        """Eigenvalues and unit-norm shapes over the channels' DOFs."""
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.records.dofs)


#: The header of a CSV file is looked for in its first lines, each read up to a bounded length.
SNIFF_LINES, SNIFF_LINE_CHARS = 200, 1 << 16


#: What each format :func:`holds_response_records` reads holds, in its refusals.
_EXPECTED = {"npz": "an .npz of FRFs (frequency_hz, frf, response_dofs, reference_dofs) or of response time series "
                    "(signals, sampling_frequency_hz)"}


def holds_response_records(path) -> bool:
    """Whether a file holds time records rather than FRFs: a universal file with time records and no FRF, an
    ``.npz`` with a ``signals`` field, or a CSV whose header starts with ``time_s``."""
    if not Path(path).is_file():
        return False                                  # the FRF reader names what is missing
    fmt = format_of(path, FRF, TIME)
    check_input_file(path, fmt.name if fmt.name in MAX_BYTES else "csv", what=_EXPECTED.get(fmt.name))
    if fmt.name == "uff":
        types = UffFile(path).function_types
        return 1 in types and 4 not in types
    if fmt.name == "npz":

        try:
            with zipfile.ZipFile(path) as zf:
                return "signals.npy" in zf.namelist()
        except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
            raise FileFormatError(f"{path}: not a readable .npz ({type(exc).__name__}: "
                                  f"{' '.join(str(exc).split())[:150]}); expected {_EXPECTED['npz']}") from None
    if fmt.name == "csv":
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            lines = (fh.readline(SNIFF_LINE_CHARS) for _ in range(SNIFF_LINES))   # bounded: no newline in 2 GB
            first = next((s.strip() for s in lines if s.strip() and not s.lstrip().startswith("#")), "")
        return first.lower().startswith("time_s")
    return False


def read_response_records(path) -> TimeRecords:
    """The response channels of a time-record file (forces dropped); one quantity over all channels."""
    return response_records(read(path, TIME), path)


def response_records(rec, path) -> TimeRecords:
    """The response channels of ``rec``, the time records read from ``path`` (forces dropped); one quantity over
    all channels."""
    resp = rec.responses
    if not resp:
        raise FileFormatError(f"{path}: no response channel" + (", only forces" if rec.dofs else
                                                                ": 'signals' holds no channel"))
    quantities = sorted({rec.quantities[i] for i in resp})
    if len(quantities) > 1:
        raise FileFormatError(f"{path}: response channels of several quantities ({', '.join(quantities)}); "
                              "output-only shapes need one quantity over all channels")
    return TimeRecords(rec.time_step_s, rec.signals[resp], tuple(rec.dofs[i] for i in resp),
                       tuple(rec.quantities[i] for i in resp), rec.metadata)


def _tried(error, why: str):
    """``error`` (a :class:`ConvergenceError` or :class:`ShapeError` of the method picked) with the pick and what the
    other method gave appended, so that the refusal names the methods tried."""
    extra = {"iterations": error.iterations, "residual": error.residual} if isinstance(error, ConvergenceError) else {}
    return type(error)(f"{error} ({why})", parameter=error.parameter, **extra)


def identify_records(records: TimeRecords, method=DEFAULT_OUTPUT_ONLY, band_hz=None, n_modes=None,
                     max_order=None, weigh_channels=True, mode_in_band=False) -> RecordsIdentification:
    """Identify modes of response records by an output-only method of :data:`METHODS`.

    Parameters
    ----------
    records : TimeRecords
        Response channels only (see :func:`read_response_records`).
    method : str
        A key of :data:`METHODS` with ``data == "records"``, or ``"auto"``: :data:`FREE_RESPONSE_METHOD` for a
        free response (:func:`~physics.identification.decays.free_response`: decays after hits),
        :data:`STATIONARY_METHOD` otherwise; when the picked method finds no mode, the other is tried, and
        :attr:`RecordsIdentification.method_choice` says so (SSI-cov tried so on a free response keeps its own
        poles, unrefined in the decays' bands: ``identify_ssi(refine_decays=False)``). A record free by its lead
        alone (its decays falling less than :data:`~physics.identification.decays.FREE_DROP_DB`) is read by
        :data:`STATIONARY_METHOD` first, and kept so when its decays fall more than that short of what the modes
        found would (:func:`~physics.identification.decays.least_fall_db`: a stationary response started
        quiet, whose start leads like a hit's decay).
    band_hz : (float, float), optional
    n_modes : int, optional
    max_order : int, optional
        Highest model order of SSI/ERA (state dimension; default sized to the record's spectrum).
    weigh_channels : bool
        With several channels whose noise floors over the band lie more than
        :data:`~physics.identification.channel_weights.SPREAD_DB` apart, identify each in units of its own floor
        (:func:`~physics.identification.channel_weights.noise_floor_weights`; the shapes returned on the recorded
        channels): the choice of method and every method see a channel by how far its modes stand above its noise,
        not by its units. False: the channels as recorded.
    mode_in_band : bool
        A mode is known to lie in the band (a reference mode re-identified in its own band), passed to a method
        whose fit takes it (SSI-cov: :func:`~physics.identification.ssi.identify_ssi`).

    A method of :data:`STATIONARY_METHODS` named for a free response is warned of (its averaged spectra or
    correlations dilute the decays); ``ssi`` then refines its poles in their bands of the decays.

    The channels' common quantity (``records.quantities``: displacement, velocity or acceleration; None when they
    differ) goes to a method whose fit takes it (``fftpeak``: the conversion of its spectral peak to the natural
    frequency, :func:`~physics.identification.fft_peak.natural_from_peak`).

    A record clipped in its leading part (an impact's hit) is identified, by every method, from the samples after
    its clipped runs (:func:`~physics.identification.record_checks.check_records`), warned of and named by
    :attr:`RecordsIdentification.crop`.

    Returns
    -------
    RecordsIdentification
    """
    if method not in RECORDS_METHODS:
        raise ConfigError(f"method {method!r}: response records without a force are identified output-only, by "
                          f"{', '.join(RECORDS_METHODS[1:])} (or {DEFAULT_OUTPUT_ONLY})")
    if band_hz is not None and not band_hz[0] < band_hz[1]:
        raise ConfigError(f"band_hz ({band_hz[0]}, {band_hz[1]}): the lower bound must be below the upper")
    where = str(records.metadata.get("source", "records"))
    fs = records.sampling_frequency_hz
    kinds = set(records.quantities)
    quantity = kinds.pop() if len(kinds) == 1 and kinds <= set(PEAK_EXPONENT) else None

    def fit(name, signals, refine_decays=None, free=None):
        spec = METHODS[name]
        options = {k: {"max_order": max_order}[k] for k in spec.options}
        if mode_in_band and "mode_in_band" in signature(spec.fit).parameters:
            options["mode_in_band"] = True
        if refine_decays is not None and "refine_decays" in signature(spec.fit).parameters:
            options["refine_decays"] = refine_decays          # the verdict judged once, here
        if free is not None and "free" in signature(spec.fit).parameters:
            options["free"] = free
        if "quantity" in signature(spec.fit).parameters:          # the peak's conversion to f_n (fftpeak)
            options["quantity"] = quantity
        return spec.fit(signals, fs, band_hz, n_modes, where, **options)

    checked = check_records(records.signals, fs, band_hz, where)     # read once: the methods take it as checked
    if checked.crop is not None:
        warnings.warn(f"{where}: {checked.crop.text}", UserWarning, stacklevel=2)
    weights = noise_floor_weights(checked, where) if weigh_channels and checked.signals.shape[0] > 1 else None
    if weights is not None:
        checked = weighted_record(checked, weights)

    def result(est, diagram, why=""):
        if weights is not None:
            est, diagram = unweighted_estimate(est, weights), unweighted_diagram(diagram, weights)
        return RecordsIdentification(records, est, diagram, why, weights, checked.crop)

    if method not in ("auto", FREE_RESPONSE_METHOD, *STATIONARY_METHODS):
        return result(*fit(method, checked))
    verdict = free_response(checked)
    if method == FREE_RESPONSE_METHOD:
        if verdict.free:
            return result(*fit(method, checked))
        hint = _not_free_hint(verdict, method)
        try:
            est, diagram = fit(method, checked)
        except (ConvergenceError, ShapeError) as exc:
            raise _tried(exc, hint) from None
        warnings.warn(f"{where}: {hint}", UserWarning, stacklevel=2)
        return result(est, diagram)
    if method != "auto":
        if verdict.free:
            effect = ("modes may be missed (the poles it keeps are refined in their bands of the decays, as era's "
                      "are)" if method == "ssi" else "modes may be missed and damping overestimated")
            warnings.warn(f"{where}: {verdict.text}; {method} assumes a stationary response: its spectra or "
                          f"correlations averaged over the whole record dilute the decays, so {effect}; --method "
                          "era or fftpeak read free decays", UserWarning, stacklevel=2)
        return result(*fit(method, checked, refine_decays=verdict.free, free=verdict.free))
    picked = FREE_RESPONSE_METHOD if verdict.free else STATIONARY_METHOD
    why = (f"picked {picked}: response records without a force channel, {verdict.text}"
           + ("" if verdict.free else " (identified as a stationary response)"))
    d = verdict.decays
    if verdict.free and d.drop_db < max(FREE_DROP_DB, CHANCE_FALL_CAP_DB):
        # free by its lead alone, or by a fall a stationary response may reach by chance: a stationary response
        # started quiet leads its start as a hit's decay does; its modes, read as a stationary response's, tell
        # whether its decays fall as theirs would, and how far they fall by chance
        try:
            est, diagram = fit(STATIONARY_METHOD, checked, refine_decays=False, free=False)
        except (ConvergenceError, ShapeError):
            pass
        else:
            f, z = est.natural_frequencies_hz, est.damping_ratios
            least, chance = least_fall_db(d, f, z, fs), chance_fall_db(d, f, z, fs)
            if d.drop_db < max(FREE_DROP_DB, chance if chance <= CHANCE_FALL_CAP_DB else 0.0) \
                    and least - d.drop_db > FREE_DROP_DB \
                    and _holds_strongest_peak(checked, d, f):
                k = slowest_mode(f, z)
                what = ("a stationary response started quiet" if d.drop_db < FREE_DROP_DB else
                        f"a stationary response, whose quarters' energies differ by up to {chance:.0f} dB by chance")
                why = (f"picked {STATIONARY_METHOD}: response records without a force channel, {verdict.text}, "
                       f"but the modes {STATIONARY_METHOD} finds in them would fall at least "
                       f"{least:.0f} dB (the slowest: {f[k]:.4g} Hz, {100 * z[k]:.2g} % "
                       f"damping): {what} (identified as a stationary response)")
                return result(est, diagram, why)
    try:
        # SSI-cov picked for a stationary record has no decays to refine on; tried where era found no mode on a
        # free one, it keeps its own poles (docs/identification.md)
        est, diagram = fit(picked, checked, refine_decays=False, free=verdict.free)
    except (ConvergenceError, ShapeError) as first:
        other = STATIONARY_METHOD if verdict.free else FREE_RESPONSE_METHOD
        if other == FREE_RESPONSE_METHOD and not verdict.decays.starts.size:
            raise _tried(first, f"{why}; {other} not tried: the record holds no decay") from None
        try:
            est, diagram = fit(other, checked, refine_decays=False, free=verdict.free)
        except (ConvergenceError, ShapeError):
            raise _tried(first, f"{why}; {other} found no mode either") from None
        why = f"{why}; {picked} found no mode ({first}), so {other}"
        if other == FREE_RESPONSE_METHOD and not verdict.free:
            warnings.warn(f"{where}: {_not_free_hint(verdict, other)}", UserWarning, stacklevel=2)
    return result(est, diagram, why)


def _holds_strongest_peak(checked, decays, frequencies_hz) -> bool:
    """Whether a mode of ``frequencies_hz`` lies at the strongest peak of the longest decay's zero-padded FFT in the
    band (within 2 % or two of its lines): the modes then speak for the decay's energy. A stationary method misses a
    slow mode that a short record holds only a few dozen cycles of, and the decay, which falls as that mode does,
    is no evidence of a stationary response."""
    k = int(np.argmax(decays.stops - decays.starts))
    a, b = int(decays.starts[k]), int(decays.stops[k])
    y = np.asarray(checked.signals[:, a:b], float)
    y = y - y.mean(axis=1, keepdims=True)
    f, _, power, _ = padded_spectrum(y, checked.sampling_frequency_hz, window="none")
    band = (f >= max(checked.band_hz[0], 2 * checked.sampling_frequency_hz / (b - a))) & (f <= checked.band_hz[1])
    if not band.any() or not np.size(frequencies_hz):
        return True
    peak = f[band][int(np.argmax(power[band]))]
    tolerance = max(0.02 * peak, 2 * checked.sampling_frequency_hz / (b - a))
    return bool(np.any(np.abs(np.asarray(frequencies_hz, float) - peak) <= tolerance))


def _not_free_hint(verdict, method: str) -> str:
    """Why ``method`` (a free decays' fit) on a record that is not a free response may read noise as modes."""
    return (f"{verdict.text}; {method} fits free decays (the response after each hit): on a stationary response the "
            f"random ripple of its spectrum's peaks passes for modes; --method {STATIONARY_METHOD} reads a "
            "stationary response")
