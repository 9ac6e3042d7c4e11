"""Output-only identification of free responses: the decays after impacts (or plucks) recorded without the force.

The decays after each hit are :func:`~physics.identification.decays.find_decays`'s.

:func:`identify_era` identifies the decays jointly (common poles, amplitudes of each decay its own): the
Eigensystem Realisation Algorithm (Kung's shift invariance) on the block Hankel matrix of the decay samples of all
channels gives a model of every order from one eigen-decomposition, the stabilisation diagram's physical poles
are selected by :func:`~physics.identification.poles.select_poles` (as for SSI-cov and LSCF), then refined by the
nonlinear least-squares fit of damped sinusoids to the samples
(:func:`~physics.identification.damped_sinusoids.fit_damped_sinusoids`; it splits decays where a missed hit
shows and decides which poles carry energy). Each kept pole is then refined in its own narrow band of the decays'
Fourier transforms at the record's rate, from each hit's onset, across the cuts of missed hits that add no energy
(:func:`~physics.identification.band_refine.refine_in_bands`: the closed-form transform of truncated damped
exponentials and a smooth background, close modes together), so that the other modes, the unmodelled ones and the
hit itself do not enter a mode's fit; its covariance gives the one-sigma frequency and damping. The frequency returned
is the natural frequency ``|lambda| / 2 pi`` of each mode's pole (its damped frequency is ``Im(lambda) / 2 pi``). A
mode fitted as one pole for poles of one peak that the refinement merged (closer than the record resolves) is named
in a warning: one equivalent pole for the peak's unresolved components; where its frequency moves over its decays
(refitted over their first and their second halves, :func:`~physics.identification.glide.mode_glide`, more than
:data:`~physics.identification.glide.GLIDE_SIGMAS` sigma apart), the warning names its glide: a mode whose
frequency moves with its amplitude, read over the whole decay. A clear peak of the
record's spectrum (:func:`~physics.identification.decay_peaks.decay_peaks`, the peaks ``fftpeak`` reports) that no
kept pole holds (a weak mode beyond the model's order, or a diagram with no pole stable enough) is started at its
peak and refined in its band, the kept poles held fixed (:mod:`~physics.identification.peak_seeds`). A peak still
without a mode then that is clear by SSI-cov's rule (:func:`~physics.identification.fdd.clear_peaks`: 10 dB above the
running floor) is named in a warning, as SSI-cov names its own
(:func:`~physics.identification.peak_warning.warn_unexplained_peaks`): a sinusoid that does not decay, a mode whose
seed's fit failed, or one ``n_modes`` left out. Shapes: the dominant direction of each mode's complex amplitudes over
the decays, unit-norm and unscaled (no force measured).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.band_refine import RESOLUTION_LINES, RESOLVED_LINES, BandFit, refine_in_bands
from physics.identification.damped_sinusoids import DampedSinusoidFit, fit_damped_sinusoids, mode_snr
from physics.identification.decay_peaks import decay_peaks
from physics.identification.decays import Decays, adds_energy, decay_spectrum, find_decays
from physics.identification.fdd import clear_peaks, unit_shapes
from physics.identification.glide import GLIDE_SIGMAS, mode_glide
from physics.identification.held_reexcitation import refit_held_re_excited
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.peak_seeds import SeededModes, dominant_shapes, seed_unheld_peaks
from physics.identification.peak_warning import warn_unexplained_peaks
from physics.identification.poles import MAX_DAMPING, StabilisationDiagram, select_poles
from physics.identification.record_checks import CheckedRecord, check_periods, check_records, modes_with_periods
from physics.identification.ssi import MIN_MAX_ORDER, ORDERS_PER_PEAK
from physics.identification.subspace import subspace_diagram

__all__ = ["ERAIdentification", "identify_era"]

#: Largest block Hankel dimension (block rows x channels) of the ERA.
MAX_HANKEL_ROWS = 160
#: A refined pole is kept when its energy over the decays is at least this many noise variances
#: (:func:`~physics.identification.damped_sinusoids.mode_snr`; a pole fitted to white noise alone reaches about
#: 2 ln(n_samples)).
MIN_MODE_SNR = 50.0
#: A decay is cut where the fit's residual energy rises this many times over a window (a hit the segmentation
#: missed; a cut in a free decay costs only its amplitudes), and fitted again; at most this many rounds.
SPLIT_RISE, MAX_SPLIT_ROUNDS = 4.0, 2
#: A decay holds at least this many times the Hankel's block rows (shorter decays are left out).
MIN_DECAY_ROWS = 3
#: Least stability code (:data:`~physics.identification.poles.STABILITY_CODES`) of a pole the selection clusters:
#: stable in frequency, damping and shape (the damping is then refined by the least-squares fit).
MIN_STATUS = 4




@dataclass(frozen=True)
class ERAIdentification:
    """A free-decay identification (see the module docstring).

    Attributes
    ----------
    estimate : ModalEstimate
        Unit-norm, unscaled shapes; ``frequency_std_hz``/``damping_std`` from the least-squares fit.
    diagram : StabilisationDiagram
    fit : DampedSinusoidFit or None
        The refinement of every selected pole (the estimate keeps those in the band); None when no pole of the
        stabilisation diagram was stable enough (the estimate then holds the seeded modes alone).
    decays : Decays
        In samples of the record as given.
    decimation : int
    block_rows : int
    n_fitted : int
        Decays fitted: those of ``decays`` long enough, split where the fit's residual showed a hit they missed.
    bands : BandFit or None
        The narrow-band refinement of the poles kept (before ``n_modes``), on the fitted decays at the record's
        rate from their hits' onsets, joined across the cuts that add no energy (:func:`_band_spans`); the estimate
        holds its poles where it converged, the time-domain fit's elsewhere.
    seeded : SeededModes or None
        The modes of the record's clear peaks that no kept pole held, each started at its peak and refined in its
        band (:func:`~physics.identification.peak_seeds.refine_seeds`); the estimate holds them too, flagged
        ``weakly_stable``.
    unexplained_hz : ndarray, shape (n_unexplained,)
        The clear peaks of the record's spectrum (SSI-cov's rule,
        :func:`~physics.identification.fdd.clear_peaks`) that no mode of the estimate explains (named in a warning).
    """

    estimate: ModalEstimate
    diagram: StabilisationDiagram
    fit: DampedSinusoidFit | None
    decays: Decays
    decimation: int
    block_rows: int
    n_fitted: int = 0
    bands: BandFit | None = None
    seeded: SeededModes | None = None
    unexplained_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _decimated(checked, q, decays):
    """Each decay low-pass filtered (zero phase) and decimated by ``q``: a list of (n_channels, n_d) arrays, and
    each one's ``(onset, first, stop)`` in samples of the record (its free response's first sample, the sample of
    its own first one, one past its last)."""
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    spans = list(zip(decays.onsets.tolist(), decays.starts.tolist(), decays.stops.tolist()))
    if q == 1:
        return [x[:, a:b] for _, a, b in spans], spans
    from scipy import signal  # scipy.fft/signal/ndimage: about 1 s to import, only output-only identification

    x = signal.sosfiltfilt(signal.butter(8, 0.8 / q, output="sos"), x, axis=1)
    margin = 4 * q                                   # the filter's response to the hit, decimated samples
    spans = [(o, a + margin, b) for o, a, b in spans if b - a > margin]
    return [x[:, a:b:q] for _, a, b in spans], spans


def _model_peaks(parts, fs_dec, band, record_peaks):
    """The modes the model must hold: frequencies (Hz) and tolerances (Hz) of the clear peaks in ``band`` of the
    longest decimated decay's spectrum (:func:`decay_spectrum`, peaks by
    :func:`~physics.identification.decay_peaks.decay_peaks`: close modes resolved as finely as the decays allow)
    and of the record's (``record_peaks``, the whole record at its rate: a mode above the decimated decay's floor
    there), each once."""
    y = max(parts, key=lambda p: p.shape[1])
    fine = decay_peaks(decay_spectrum(CheckedRecord(y, fs_dec, tuple(band), y.mean(axis=1))))
    f, tol = record_peaks.frequency_hz, record_peaks.tolerance_hz
    new = (f >= band[0]) & (f <= band[1]) & np.all(np.abs(f[:, None] - fine.frequency_hz[None, :])
                                                    > np.maximum(tol[:, None], fine.tolerance_hz[None, :]), axis=1)
    f, tol = np.concatenate([fine.frequency_hz, f[new]]), np.concatenate([fine.tolerance_hz, tol[new]])
    order = np.argsort(f)
    return f[order], tol[order]


def _hankel_basis(parts, rows):
    """Left singular vectors and values of the block Hankel matrix of the decays (``rows`` samples per column)."""
    n_ch = parts[0].shape[0]
    G = np.zeros((rows * n_ch, rows * n_ch))
    for y in parts:
        H = np.lib.stride_tricks.sliding_window_view(y, rows, axis=1)       # (n_ch, n_cols, rows)
        H = H.transpose(1, 2, 0).reshape(H.shape[1], rows * n_ch)
        G += H.T @ H
    ev, U = np.linalg.eigh(G)
    order = np.argsort(ev)[::-1]
    return U[:, order], np.sqrt(np.maximum(ev[order], 0))


def _split_missed_hits(parts, spans, q, residuals, window):
    """The decays cut where the fit's residual rises sharply (a hit the segmentation missed): the residual's
    energy (channels scaled by their median) over the next ``window`` samples :data:`SPLIT_RISE` times that over
    the window before and than the quietest tenth of the windows; the cut at the first sample past that level.
    The parts and their spans (as :func:`_decimated` gives them; ``q`` the decimation)."""
    out, out_spans = [], []
    for y, (o, a, b), r in zip(parts, spans, residuals):
        e = np.sum(r ** 2 / np.maximum(np.median(r ** 2, axis=1, keepdims=True), np.finfo(float).tiny), axis=0)
        c = np.concatenate([[0.0], np.cumsum(e)]) / window
        k = np.arange(window, e.size - window)
        before, after = c[k] - c[k - window], c[k + window] - c[k]
        floor = np.percentile(c[window:] - c[:-window], 10) if e.size > window else 0.0
        rise = np.flatnonzero((after >= SPLIT_RISE * before) & (after >= SPLIT_RISE * floor))
        if not rise.size:
            out.append(y)
            out_spans.append((o, a, b))
            continue
        t = k[rise[0]]
        loud = np.flatnonzero(e[t:t + window] >= SPLIT_RISE * floor)
        cut = t + (int(loud[0]) if loud.size else window // 2)
        out += [y[:, :cut], y[:, cut + 2:]]
        out_spans += [(o, a, a + cut * q), (a + cut * q, a + (cut + 2) * q, b)]
    return out, out_spans


def _band_spans(x, decays, fitted_spans, window):
    """The decays the band refinement reads, a list of ``(first, stop)`` samples of the record ``x`` (mean removed):
    each decay from its hit's onset, its fitted pieces (``fitted_spans``, as :func:`_split_missed_hits` gives them)
    joined across every cut that adds no energy (:func:`adds_energy` over ``window`` samples: a missed hit adds
    energy like any hit; a cut without is the fit's misfit, and the decay runs on across it)."""
    out = []
    for onset, stop in zip(decays.onsets.tolist(), decays.stops.tolist()):
        firsts = sorted(o for o, _, _ in fitted_spans if onset <= o < stop)
        if not firsts:
            continue
        cuts = np.array([o for o in firsts if o > onset], int)
        hits = cuts[adds_energy(x, cuts, cuts, window)] if cuts.size else cuts
        edges = [onset, *hits.tolist(), stop]
        out += [(a, b) for a, b in zip(edges[:-1], edges[1:]) if any(a <= o < b for o in firsts)]
    return out


def _warn_merges(full, fs, bands: BandFit, live, band, hi, where):
    """Warn of each mode in ``band[0]``-``hi`` (Hz) that stands for poles merged into it (:attr:`BandFit.merged_into`):
    one peak holding components the record does not resolve, fitted as one equivalent pole. Where its frequency
    glides significantly over its decays (:func:`~physics.identification.glide.mode_glide`, the other live poles held
    fixed), the warning names the glide: one peak of a mode whose frequency moves with its amplitude."""
    into = bands.merged_into
    if not np.any(into >= 0):
        return
    keep = np.flatnonzero(live & ~bands.merged)
    for j in np.unique(into[into >= 0]):
        f = float(bands.natural_frequencies_hz[j])
        if j not in keep or not band[0] <= f <= hi:
            continue
        glide = mode_glide(full, fs, bands.eigenvalues[keep], bands.amplitudes[:, :, keep],
                           int(np.flatnonzero(keep == j)[0]))
        parts = np.flatnonzero(into == j)
        at = np.r_[bands.natural_frequencies_hz[parts], bands.merged_with_hz[parts]]
        split = (f"{where}: era's mode at {f:.6g} Hz is one peak the fit split between poles from {at.min():.6g} to "
                 f"{at.max():.6g} Hz (closer than their half-power half-widths summed and than {RESOLVED_LINES:g} "
                 f"lines 1/T, or than {RESOLUTION_LINES:g} line 1/T), fitted as one pole")
        if glide is None or not glide.significant:
            warnings.warn(f"{split}: the peak holds components the record does not resolve, reported as one "
                          "equivalent pole (the peak's frequency, not one component's)", stacklevel=3)
            continue
        warnings.warn(f"{split}; its frequency glides {100 * glide.relative:+.2f} % over the decay "
                      f"({glide.early_hz:.6g} Hz over the first half of the decays, {glide.late_hz:.6g} Hz over the "
                      f"second; more than {GLIDE_SIGMAS:g} sigma): a mode whose frequency moves with its amplitude, or "
                      "components the record does not resolve beating, read over the whole decay, weighted towards "
                      "its loud start", stacklevel=3)


def _within(lam, f_lo_hz, f_hi_hz, max_damping, where) -> np.ndarray:
    """Mask (shape like ``lam``) of the refined poles still in the band and damped below ``max_damping``: a band fit
    that carried a pole beyond either is no mode of the decays' band; those left out are named in a warning."""
    f = np.abs(lam) / (2 * np.pi)
    zeta = -lam.real / np.maximum(np.abs(lam), 1e-300)
    keep = (f >= f_lo_hz) & (f <= f_hi_hz) & (zeta < max_damping)
    if not keep.all():
        out = ", ".join(f"{a:.5g} Hz ({100 * b:.3g} %)" for a, b in zip(f[~keep], zeta[~keep]))
        warnings.warn(f"{where}: left out {out}: refined in their bands of the decays to beyond {f_lo_hz:g}-"
                      f"{f_hi_hz:.4g} Hz or to a damping ratio of {max_damping:g} or more, no mode of the band",
                      UserWarning, stacklevel=3)
    return keep


def identify_era(signals, sampling_frequency_hz, band_hz=None, n_modes=None, max_order=None, max_damping=MAX_DAMPING,
                 where="record") -> ERAIdentification:
    """Free-decay identification of a record of impact (or pluck) responses (see the module docstring).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples), or CheckedRecord
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Modes kept (Hz); the decays are decimated to it. Default: 0 to 0.4 of the sampling rate, the decays
        decimated so that the Hankel's :data:`MAX_HANKEL_ROWS` rows span about one period of the lowest clear
        peak of the spectrum, but no further than keeps the highest clear peak below 0.4 of the decimated rate
        (where the band then ends).
    n_modes : int, optional
        Modes to keep (default: every stable cluster; with it, the steadiest).
    max_order : int, optional
        Highest model order (state dimension; default :data:`ORDERS_PER_PEAK` per clear peak, at least
        :data:`MIN_MAX_ORDER`, at most the Hankel's rows less one block).
    max_damping : float
    where : str

    Returns
    -------
    ERAIdentification

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, no decay, or decays too short
        for a model; shorter than ten periods of the lowest mode.
    ConvergenceError
        No stable pole, or a singular fit.
    """
    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    fs, band = checked.sampling_frequency_hz, checked.band_hz
    n_ch = checked.signals.shape[0]
    sv = decay_spectrum(checked)
    peaks = clear_peaks(sv)                                     # as SSI-cov's clear peaks
    lowest = band[0] if band[0] > 0 else (peaks.frequency_hz[0] if peaks.frequency_hz.size else None)
    decays = find_decays(checked, lowest_hz=lowest)
    if decays.starts.size == 0:
        raise ShapeError(f"{where}: no free decay found (no hit followed by enough samples, nor a decaying "
                         "record); identify a stationary response with --method ssi")
    rows_wanted = MAX_HANKEL_ROWS // n_ch
    q = max(1, int(fs // (2.5 * band[1])))
    if band_hz is None and peaks.frequency_hz.size:     # oversampled: rows span one period of the lowest peak,
        q = max(1, min(int(fs // (peaks.frequency_hz[0] * rows_wanted)),      # every clear peak kept in the band
                       int(fs // (2.5 * peaks.frequency_hz[peaks.frequency_hz <= band[1]].max(initial=0.0)))
                       if np.any(peaks.frequency_hz <= band[1]) else fs))
    hi = min(band[1], fs / (2.5 * q))
    fs_dec = fs / q
    parts, spans = _decimated(checked, q, decays)
    longest = max((p.shape[1] for p in parts), default=0)
    rows = min(rows_wanted, longest // MIN_DECAY_ROWS)
    if rows < 2:
        need = 2 * MIN_DECAY_ROWS * q + (4 * q if q > 1 else 0)
        raise ShapeError(f"{where}: its longest decay holds {int(np.max(decays.stops - decays.starts))} samples at "
                         f"{fs:g} Hz; a decay needs at least {need} samples ({need / fs:.3g} s) for a free-decay model")
    long_enough = [j for j, p in enumerate(parts) if p.shape[1] >= MIN_DECAY_ROWS * rows]
    parts, spans = [parts[j] for j in long_enough], [spans[j] for j in long_enough]   # shorter decays left out
    # the modes the model must hold: in a band given, every mode the decays show; without one, the record's clear
    # peaks up to ``hi`` (a default band at the full rate can hold hundreds of the decays' peaks, each a costly mode
    # of the refinement)
    if band_hz is not None:
        peaks_hz, peak_tol_hz = _model_peaks(parts, fs_dec, (band[0], hi), peaks)
    else:
        inside = peaks.frequency_hz <= hi
        peaks_hz, peak_tol_hz = peaks.frequency_hz[inside], peaks.tolerance_hz[inside]
    p_max = max_order or max(MIN_MAX_ORDER, ORDERS_PER_PEAK * peaks_hz.size)
    p_max = 2 * (min(p_max, (rows - 1) * n_ch) // 2)
    if p_max < 2:
        if max_order is not None and max_order < 2:
            raise ShapeError(f"{where}: a model order of {max_order} holds no mode (a mode is a pair of poles): the "
                             "highest model order must be at least 2")
        raise ShapeError(f"{where}: the decays are too short for a model of order 2 ({rows} block rows of "
                         f"{n_ch} channel(s))")
    record_peaks = decay_peaks(sv)                              # the peaks fftpeak reports a mode at
    sel = fit = None
    for _ in range(1 + MAX_SPLIT_ROUNDS):
        U, s = _hankel_basis(parts, rows)
        diagram = subspace_diagram(U, s, n_ch, np.arange(2, p_max + 1, 2), fs_dec, (0.0, hi), max_damping)
        try:
            sel = select_poles(diagram, min_status=MIN_STATUS, peaks_hz=peaks_hz, peak_tol_hz=peak_tol_hz)
        except ConvergenceError:
            if peaks_hz.size:
                check_periods(checked.duration_s, peaks_hz[0], "the lowest peak", where)
            if fit is not None:                         # a split decay's model lost its poles: the last fit stands
                break
            if record_peaks.frequency_hz.size:          # the clear peaks alone start the band refinement
                fitted_spans = spans
                break
            raise ConvergenceError(f"{where}: no pole of the free decays is stable over enough model orders: raise "
                                   "--max-order, widen --band, or try --method ssi") from None
        try:
            fit, fitted, fitted_spans = fit_damped_sinusoids(parts, fs_dec, sel.eigenvalues), parts, spans
        except np.linalg.LinAlgError:
            at = ", ".join(f"{v:.4g}" for v in sel.natural_frequencies_hz)
            raise ConvergenceError(f"{where}: the damped-sinusoid fit of the free decays diverged from the "
                                   f"stabilisation diagram's poles at {at} Hz; narrow the band or try --method ssi") \
                from None
        split, split_spans = _split_missed_hits(parts, spans, q, fit.residuals, rows)
        kept = [j for j, p in enumerate(split) if p.shape[1] >= MIN_DECAY_ROWS * rows]
        if len(split) == len(parts) or not kept:       # no missed hit, or only pieces too short for the model
            break
        parts, spans = [split[j] for j in kept], [split_spans[j] for j in kept]
    x = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    full = [x[:, a:b] for a, b in _band_spans(x, decays, fitted_spans, decays.energy_window)]
    idx, bands = np.zeros(0, int), None
    lam = f_std = z_std = np.zeros(0)
    amps = []                                           # each mode's amplitudes, (n_decays, n_channels)
    merged = np.zeros(0, bool)
    if fit is not None:
        keep = (fit.natural_frequencies_hz >= band[0]) & (fit.natural_frequencies_hz <= hi) \
            & (fit.damping_ratios > 0) & (fit.damping_ratios < max_damping) \
            & (mode_snr(fit, [p.shape[1] for p in fitted], fs_dec) >= MIN_MODE_SNR)
        idx = np.flatnonzero(keep)
    if idx.size:
        bands = refine_in_bands(full, fs, fit.eigenvalues[idx])
        ok = bands.converged
        held = refit_held_re_excited(full, fs, bands, max_damping)     # re-excited within a decay: cut at the step
        lam = np.where(ok, held.eigenvalues, fit.eigenvalues[idx])
        f_std = np.where(ok, held.frequency_std_hz, fit.frequency_std_hz[idx])
        z_std = np.where(ok, held.damping_std, fit.damping_std[idx])
        amps = [held.amplitudes[:, :, j] if ok[j] else fit.amplitudes[:, :, i] for j, i in enumerate(idx)]
        merged = np.asarray(bands.merged, bool)        # a pole merged into a stronger one of its peak is none
        _warn_merges(full, fs, bands, ok & ~held.refitted, band, hi, where)
    # the clear peaks no mode holds: each started at its peak and refined in its band, the modes held fixed
    # NaN: a failed fit, or a refit on cut decays (its first piece's amplitudes do not hold past the re-excitation)
    held_amps = np.where(ok & ~held.refitted, bands.amplitudes, np.nan)[:, :, ~merged] if idx.size else None
    seeded = seed_unheld_peaks(full, fs, lam[~merged], record_peaks, band, max_damping, held_amplitudes=held_amps)
    if idx.size - merged.sum() + seeded.eigenvalues.size == 0:
        raise ConvergenceError(f"{where}: no refined pole of the free decays lies in {band[0]:g}-{hi:.4g} Hz, nor "
                               "a mode at a clear peak of their spectrum")
    lam = np.concatenate([lam, seeded.eigenvalues])
    f_std = np.concatenate([f_std, seeded.frequency_std_hz])
    z_std = np.concatenate([z_std, seeded.damping_std])
    amps += list(np.moveaxis(seeded.amplitudes, 2, 0))
    weak = np.concatenate([np.asarray(sel.weakly_stable, bool)[idx] if idx.size else np.zeros(0, bool),
                           np.ones(seeded.eigenvalues.size, bool)])
    sub = np.flatnonzero(np.concatenate([~merged, np.ones(seeded.eigenvalues.size, bool)]))
    if n_modes is not None:                             # ERA's steadiest clusters first, the seeded modes last
        rank = sorted(sub, key=lambda j: (j >= idx.size, bool(weak[j]),
                                          -int(sel.count[idx[j]]) if j < idx.size else 0))
        sub = np.sort(np.array(rank[:n_modes], int))
    sub = sub[np.argsort(np.abs(lam[sub]), kind="stable")]     # the refinements may reorder poles
    sub = sub[_within(lam[sub], band[0], band[1], max_damping, where)]
    sub = sub[modes_with_periods(checked.duration_s, np.abs(lam[sub]) / (2 * np.pi), where)]
    wn = np.abs(lam[sub])
    # shapes: the dominant direction of each mode's amplitudes over the decays
    shapes = unit_shapes(dominant_shapes(np.stack([amps[j] for j in sub], axis=2)))
    est = ModalEstimate(wn / (2 * np.pi), -lam[sub].real / wn, lam[sub], shapes,
                        np.zeros((n_ch, 0, sub.size), complex), f_std[sub], z_std[sub],
                        modal_phase_collinearity(shapes), "era", False, weakly_stable=weak[sub])
    unexplained = warn_unexplained_peaks(
        peaks, est.natural_frequencies_hz, where,
        "a sinusoid that does not decay (mains hum, a harmonic), or a mode to look for with --band around it"
        + (" or more --modes" if n_modes is not None else " or a higher --max-order"))
    return ERAIdentification(est, diagram, fit, decays, q, rows, len(fitted_spans), bands, seeded,
                             peaks.frequency_hz[unexplained])
