"""The plainest frequency estimator, the baseline every identification method is compared with: the peaks of the
zero-padded FFT magnitude of the whole record.

For a record ``y`` of ``n_channels`` channels and ``n`` samples, the spectrum is the sum over channels of
``|FFT(w y_c)|^2`` on ``pad x n`` points (zero padding interpolates the DTFT; it adds no information, it only
samples the same transform more finely). Each peak is the local maximum of that power on the fine grid, refined by
the vertex of the parabola fitted (least squares) to the log magnitude over the peak's top (+-
:data:`TOP_FRACTION` of its half-power half-width, at least the maximum and its two neighbours): near its top the
log of a peak is close to a parabola, so the vertex lies far below the grid spacing from the peak, and fitting the
whole top rather than three lines keeps a wide peak's noise ripple from moving it. A peak's asymmetry (the
negative-frequency image, the flanks of other modes) moves the vertex by about ``b^2 / (2 f)`` for a half-power
half-width ``b``: the same on every test of a structure, so a bias, not a scatter.

What the peak is: the peak of ``|Y(f)|``, the transform of the record as recorded. A hit's whole response has
``Y = H_q(f) P(f)``: the FRF of the recorded quantity ``q`` (receptance, mobility or accelerance for displacement,
velocity or acceleration) times the force's spectrum ``P``, summed over the modes. One mode's ``|H_q|`` peaks at
``f_n (1 - 2 zeta^2)^(k / 2)`` (``k = 1, 0, -1`` for displacement, velocity, acceleration; ``f_n = |lambda| / 2 pi``,
:data:`PEAK_EXPONENT`); its analytic decay alone (the positive-frequency term) peaks at the damped frequency
``f_d = f_n sqrt(1 - zeta^2)``. ``P``'s slope across the peak moves it by ``b^2 d ln|P| / df`` and a neighbouring
mode's transform, added coherently (the same phase in every hit), by up to about its level relative to the peak's
times ``b``: a bias a zero-padded peak cannot remove without the force or a model of the neighbour
(``experiments/benches/bench_bias.py`` measures both, ``docs/identification.md`` gives its table).
``natural_frequencies_hz`` converts the peak by the recorded quantity's exponent where it is given (``quantity``),
else as the damped frequency of the analytic decay, ``f_peak / sqrt(1 - zeta^2)``; both only where the half-power
width gives a damping ratio (the correction is ``zeta^2 f`` in size: 4e-4 of the frequency at 2 % damping).

The window (``window="auto"``):

* **none** (rectangular) for a *free response* (decays after hits,
  :func:`~physics.identification.decays.free_response`, the rule ``identify`` picks ERA by): the decay is its
  own taper; a Hann window would weight the first, most informative samples by
  nearly zero and widen the peak.
* **Hann** for a *stationary* record (ambient response): its -31 dB side lobes (against -13 dB) keep a strong
  mode's leakage from moving a weak neighbour's peak.

The peaks are found either near given frequencies (the highest local maximum whose vertex lies within a tolerance)
or at the clear peaks (:func:`~physics.identification.fdd.clear_peaks`, the peaks every output-only method answers
for) of the record's spectrum: for a free decay, the whole record's FFT power averaged over three lines
(:func:`~physics.identification.decays.decay_spectrum`; a peak 10 dB above its valleys and above the level a
noise line passes by chance over the band is clear too, :func:`~physics.identification.decay_peaks.decay_peaks`);
for a stationary record, the averaged singular-value spectrum FDD reads. Each is refined on the fine grid. A free
decay's spectrum peaks near the damped frequency ``f_d`` (above: where exactly); where the half-power width gives a
damping ratio, the natural frequency reported is the peak converted by the quantity's exponent (above). The damping
ratio is the half-power (-3 dB) half-width over the frequency, NaN where that width is under
:data:`MIN_WIDTH_LOBES` times the window's own half-power half-width (:data:`WINDOW_HALF_WIDTH` over the record's
length: the peak is then the window's, not the mode's). The shapes are the complex FFT values of each channel at
the peak's line, unit norm.

This is a frequency estimator, not a modal model: no poles, no residues, and on a stationary record the raw
periodogram is not averaged (its peak scatters by a fraction of the half-power width however long the record).
:func:`identify_fft_peaks` gives a stationary record's modes no damping (NaN) and their peak as the natural
frequency: the raw periodogram's half-power width is one random line's, and that of the averaged spectrum is biased
narrow by its ripple (0.54-0.76 of 1 % damping at 357 Hz, 60 s at 2 kHz; ``efdd`` and ``ssi`` give the damping).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from physics.errors import ConvergenceError, ShapeError
from physics.identification.decay_peaks import decay_peaks, prominent_peak_db
from physics.identification.fdd import CLEAR_PEAK_DB, clear_peaks, singular_value_spectrum, unit_shapes
from physics.identification.decays import decay_spectrum, free_response
from physics.identification.half_power import half_power_bandwidth_hz
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.record_checks import check_periods, check_records
from physics.modal import eigenvalues_from_modal

__all__ = ["MIN_WIDTH_LOBES", "PAD", "PEAK_EXPONENT", "TOP_FRACTION", "WINDOW_HALF_WIDTH", "FFTPeaks", "fft_peaks",
           "identify_fft_peaks", "natural_from_peak", "padded_spectrum"]

#: Zero padding: the FFT length is the next power of two of at least ``PAD`` times the record's samples.
PAD = 8
#: The window's half-power half-width of its main lobe, in units of ``1 / T`` (record length ``T``).
WINDOW_HALF_WIDTH = {"none": 0.443, "hann": 0.72}
#: The parabola through the log magnitude is fitted over +- this fraction of the peak's half-power half-width (at
#: least one line either side): a wide peak spans many lines of the padded grid, and the three lines around its
#: highest one follow the noise's ripple rather than the peak.
TOP_FRACTION = 0.5
#: A half-power width under this many times the window's is the window's (damping NaN).
MIN_WIDTH_LOBES = 2.0
#: One mode's ``|H|`` of the recorded quantity peaks at ``f_n (1 - 2 zeta^2)^(PEAK_EXPONENT / 2)``.
PEAK_EXPONENT = {"displacement": 1, "velocity": 0, "acceleration": -1}


@dataclass(frozen=True)
class FFTPeaks:
    """Peaks of a record's zero-padded FFT.

    Attributes
    ----------
    frequency_hz : ndarray, shape (n_peaks,)
        Peak frequency (the parabola's vertex); NaN where no local maximum's vertex lies within the tolerance.
    natural_frequencies_hz : ndarray, shape (n_peaks,)
        Where the damping ratio is finite, ``frequency_hz (1 - 2 zeta^2)^(-k / 2)`` for the recorded quantity's
        exponent ``k`` (:data:`PEAK_EXPONENT`), or ``frequency_hz / sqrt(1 - zeta^2)`` (the analytic decay's damped
        frequency) where the quantity is not given; else ``frequency_hz``.
    damping_ratios : ndarray, shape (n_peaks,)
        Half-power half-width over the frequency; NaN where the width is the window's.
    values : ndarray, complex, shape (n_channels, n_peaks)
        Each channel's FFT value at the peak's line (unit^2 summed over channels is the peak's power).
    window : str
        ``"none"`` or ``"hann"``.
    resolution_hz : float
        ``fs / n``: the record's own resolution (``1 / T``).
    grid_hz : float
        Line spacing of the zero-padded FFT.
    line_hz : ndarray, shape (n_peaks,)
        The local maximum's line of the zero-padded grid (Hz) whose vertex is the peak; NaN where there is none.
    """

    frequency_hz: np.ndarray
    natural_frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    values: np.ndarray
    window: str
    resolution_hz: float
    grid_hz: float
    line_hz: np.ndarray | None = None


def _window(checked, window):
    """``window``, ``"auto"`` resolved: ``"none"`` for a free response
    (:func:`~physics.identification.decays.free_response`), ``"hann"`` otherwise."""
    if window != "auto":
        return window
    return "none" if free_response(checked).free else "hann"


def padded_spectrum(y, sampling_frequency_hz, window="auto", pad=PAD):
    """The zero-padded FFT of every channel and the summed power.

    Parameters
    ----------
    y : ndarray, shape (n_channels, n_samples)
        Mean removed by the caller (or not: the 0 Hz line is never a peak).
    sampling_frequency_hz : float
    window : {"auto", "none", "hann"}
        ``"auto"``: none for a free response (:func:`_window`), Hann otherwise.
    pad : int

    Returns
    -------
    frequency_hz : ndarray, shape (n_fft // 2 + 1,)
    X : ndarray, complex, shape (n_channels, n_fft // 2 + 1)
    power : ndarray, shape (n_fft // 2 + 1,)
    window : str
        The window used.
    """
    from scipy import fft as sfft  # scipy.fft: about 1 s to import, only output-only identification

    n = y.shape[1]
    window = _window(check_records(y, sampling_frequency_hz), window)
    if window not in WINDOW_HALF_WIDTH:
        raise ShapeError(f"window {window!r}: expected one of auto, {', '.join(WINDOW_HALF_WIDTH)}")
    w = np.ones(n) if window == "none" else 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)
    n_fft = int(2 ** np.ceil(np.log2(max(pad, 1) * n)))
    X = sfft.rfft(y * w, n_fft, axis=1)
    return np.arange(n_fft // 2 + 1) * sampling_frequency_hz / n_fft, X, np.sum(np.abs(X) ** 2, axis=0), window


def _vertex(logp, lines, half_span):
    """Vertex (in lines) of the least-squares parabola through ``logp`` on ``line +- half_span`` of each peak line;
    the three-point parabola where the fit is not concave or its vertex leaves the span."""
    out = np.empty(lines.size)
    for j, (k, m) in enumerate(zip(lines, half_span)):    # one small fit per mode
        m = int(min(m, k, logp.size - 1 - k))
        x = np.arange(-m, m + 1, dtype=np.float64)
        c2, c1, _ = np.polyfit(x, logp[k - m:k + m + 1], 2)
        p = -c1 / (2 * c2) if c2 < 0 else np.inf
        if not abs(p) <= m:
            a, b, c = logp[k - 1], logp[k], logp[k + 1]
            p = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
        out[j] = k + p
    return out


def natural_from_peak(peak_hz, damping_ratio, quantity=None):
    """The natural frequency of a mode whose record's spectrum peaks at ``peak_hz`` (module docstring):
    ``peak_hz (1 - 2 zeta^2)^(-k / 2)`` for ``quantity`` of :data:`PEAK_EXPONENT` (``k``), ``peak_hz /
    sqrt(1 - zeta^2)`` for None (the analytic decay's damped frequency); ``peak_hz`` where ``damping_ratio`` is NaN.

    Parameters
    ----------
    peak_hz, damping_ratio : array_like, shape (n,)
    quantity : {None, "displacement", "velocity", "acceleration"}

    Returns
    -------
    ndarray, shape (n,)
    """
    if quantity is not None and quantity not in PEAK_EXPONENT:
        raise ShapeError(f"quantity {quantity!r}: expected one of {', '.join(PEAK_EXPONENT)} or None")
    fp = np.asarray(peak_hz, dtype=np.float64)
    z = np.minimum(np.nan_to_num(np.asarray(damping_ratio, dtype=np.float64)), 0.5)
    factor = 1 / np.sqrt(1 - z ** 2) if quantity is None else (1 - 2 * z ** 2) ** (-PEAK_EXPONENT[quantity] / 2)
    return np.where(np.isfinite(damping_ratio), fp * factor, fp)


def fft_peaks(signals, sampling_frequency_hz, frequencies_hz, tolerance_hz, window="auto", pad=PAD,
              where="record", quantity=None) -> FFTPeaks:
    """Peaks of the zero-padded FFT magnitude near given frequencies (see the module docstring).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    frequencies_hz : array_like, shape (n_peaks,)
        Where to look.
    tolerance_hz : float or array_like, shape (n_peaks,)
        Half-width of the window around each frequency: the peak is the highest local maximum of the FFT power
        (the highest, not the nearest: on a stationary record's unaveraged periodogram the nearest maximum is often
        a ripple on the resonance's flank) whose vertex lies in the window, so that the window holds the frequency
        returned (a wide, skewed peak's highest line can lie a third of its half-width from its vertex: on either
        side of the window's edge); none: NaN.
    window : {"auto", "none", "hann"}
    pad : int
        Zero-padding factor (FFT length: next power of two of ``pad x n_samples``).
    where : str
    quantity : {None, "displacement", "velocity", "acceleration"}
        The recorded quantity, for :attr:`FFTPeaks.natural_frequencies_hz` (:func:`natural_from_peak`).

    Returns
    -------
    FFTPeaks
    """
    checked = check_records(signals, sampling_frequency_hz, where=where)
    fs = checked.sampling_frequency_hz
    y = np.asarray(checked.signals, dtype=np.float64) - checked.mean[:, None]
    f, X, power, window = padded_spectrum(y, fs, _window(checked, window), pad)
    df = float(f[1])
    target = np.atleast_1d(np.asarray(frequencies_hz, dtype=np.float64))
    tol = np.broadcast_to(np.asarray(tolerance_hz, dtype=np.float64), target.shape)
    logp = np.log(np.maximum(power, np.finfo(float).tiny))
    maxima = np.nonzero((logp[1:-1] > logp[:-2]) & (logp[1:-1] >= logp[2:]))[0] + 1
    lo = np.searchsorted(f[maxima], target - 2 * tol, side="left")
    hi = np.searchsorted(f[maxima], target + 2 * tol, side="right")
    lobe_hz = WINDOW_HALF_WIDTH[window] * fs / y.shape[1]
    k, fp, hw = np.ones(target.size, int), np.full(target.size, np.nan), np.full(target.size, np.nan)
    for j, (a, b) in enumerate(zip(lo, hi)):            # one window per peak: its highest maximum whose vertex
        cand = maxima[a:b]                              # lies in it, among the maxima within twice the window
        for c in cand[np.argsort(-logp[cand], kind="stable")]:
            h = half_power_bandwidth_hz(f, power, [c], ratio=2.0, one_side="nan")[0] / 2
            span = max(1, int(TOP_FRACTION * (h if np.isfinite(h) else lobe_hz) / df))
            v = _vertex(logp, np.array([c]), np.array([span]))[0] * df
            if abs(v - target[j]) <= tol[j]:
                k[j], fp[j], hw[j] = c, v, h
                break
    found = np.isfinite(fp)
    zeta = hw / fp
    zeta = np.where(hw >= MIN_WIDTH_LOBES * WINDOW_HALF_WIDTH[window] * fs / y.shape[1], zeta, np.nan)
    fn = natural_from_peak(fp, zeta, quantity)
    values = np.where(found[None, :], X[:, k], np.nan)
    return FFTPeaks(fp, fn, zeta, values, window, fs / y.shape[1], df, np.where(found, k * df, np.nan))


def identify_fft_peaks(signals, sampling_frequency_hz, band_hz=None, n_modes=None, window="auto", pad=PAD,
                       where="record", quantity=None) -> tuple[ModalEstimate, FFTPeaks]:
    """Modes at the clear peaks of a record's singular-value spectrum, each frequency refined on the zero-padded
    FFT of the whole record (see the module docstring).

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    sampling_frequency_hz : float
    band_hz : (float, float), optional
        Default: 0 to 0.4 of the sampling rate.
    n_modes : int, optional
        Keep the ``n_modes`` highest clear peaks (default: every clear peak).
    window : {"auto", "none", "hann"}
    pad : int
    where : str
    quantity : {None, "displacement", "velocity", "acceleration"}
        The recorded quantity (:func:`fft_peaks`).

    Returns
    -------
    estimate : ModalEstimate
        Method ``"fftpeak"``; unit-norm, unscaled shapes; no residues; no uncertainty (NaN).
    peaks : FFTPeaks

    Raises
    ------
    ShapeError
        A record :func:`~physics.identification.record_checks.check_records` refuses, or shorter than ten periods
        of its lowest peak.
    ConvergenceError
        No clear peak, or none with a local maximum of the FFT within its tolerance.
    """
    checked = check_records(signals, sampling_frequency_hz, band_hz, where)
    window = _window(checked, window)
    decay = window == "none"
    sv = decay_spectrum(checked) if decay else singular_value_spectrum(checked, where=where)
    band = checked.band_hz
    peaks = decay_peaks(sv) if decay else clear_peaks(sv)
    if peaks.lines.size == 0 and decay:
        raise ConvergenceError(f"{where}: no peak of the free decay's spectrum stands {CLEAR_PEAK_DB:g} dB above its "
                               f"floor, nor {CLEAR_PEAK_DB:g} dB above its valleys and {prominent_peak_db(sv):.3g} dB "
                               f"above its floor, in {band[0]:g}-{band[1]:g} Hz")
    if peaks.lines.size == 0:
        raise ConvergenceError(f"{where}: no peak of the first singular value stands {CLEAR_PEAK_DB:g} dB above "
                               f"its floor in {band[0]:g}-{band[1]:g} Hz")
    check_periods(checked.duration_s, peaks.frequency_hz[0], "the lowest peak", where)
    keep = np.sort(np.argsort(-peaks.height_db, kind="stable")[:n_modes]) if n_modes is not None \
        else np.arange(peaks.lines.size)
    res = fft_peaks(checked if band_hz is None else checked.signals, checked.sampling_frequency_hz,
                    peaks.frequency_hz[keep], peaks.tolerance_hz[keep], window, pad, where, quantity)
    if not decay:                       # a stationary record: no damping (module docstring)
        res = replace(res, damping_ratios=np.full(res.frequency_hz.size, np.nan),
                      natural_frequencies_hz=res.frequency_hz.copy())
    ok = np.isfinite(res.frequency_hz)
    _, first = np.unique(np.where(ok, res.frequency_hz, -1.0), return_index=True)
    ok &= np.isin(np.arange(ok.size), first)            # two clear peaks refined to one FFT peak: one mode
    if not np.any(ok):
        raise ConvergenceError(f"{where}: no local maximum of the FFT lies within the tolerance of the clear peaks "
                               f"at {', '.join(f'{v:.4g}' for v in peaks.frequency_hz[keep])} Hz")
    order = np.argsort(res.natural_frequencies_hz[ok])
    fn = res.natural_frequencies_hz[ok][order]
    zeta = res.damping_ratios[ok][order]
    shapes = unit_shapes(res.values[:, ok][:, order])
    nan = np.full(fn.size, np.nan)
    est = ModalEstimate(fn, zeta, eigenvalues_from_modal(fn, np.nan_to_num(zeta)), shapes,
                        np.zeros((shapes.shape[0], 0, fn.size), complex), nan, nan,
                        modal_phase_collinearity(shapes), "fftpeak", False)
    return est, res
