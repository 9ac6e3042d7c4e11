"""Each reference mode's frequency estimated by the more repeatable of two estimators over the baseline period: the
series' identification (``era`` or ``ssi`` of response records) or the zero-padded FFT peak of the same record
(:func:`physics.identification.fft_peak.fft_peaks`), the identification kept only where it is the steadier.

The baseline period is repeated tests of an unchanged structure, so the scatter of a mode's frequency over it is
the precision of its estimator on these records. A modal identification resolves close modes and gives damping and
shapes; the FFT peak of a single dominant resonance can scatter less (a free decay's peak is read off the whole
record's transform, no model order or stabilisation enters it). Which one is the more precise depends on the
records, so the series decides it: per mode, over the baseline tests where both estimators read the mode, the
robust scatter (1.4826 MAD of ``ln f``) of each. The burden of proof is on the more complex estimator: the
identification's frequency is kept where its scatter over those tests is the smaller; elsewhere the FFT peak is
chosen, when it reads the mode in every baseline test the identification does, at least ``2 MIN_HALF`` tests hold
both (:data:`MIN_HALF` in each half) and it holds no more gross readings than the identification: readings more than
:data:`GROSS` of the estimator's own robust scatters from its median over those tests (a neighbouring peak or pole
read instead of the mode; Gaussian scatter puts one reading in 1.7 million there). The MAD does not see a few gross
readings, the detector does: its normal model and held-out thresholds are Gaussian, and a gross reading of a steady
estimator, held out against the others' small scatter, sets a threshold (:func:`gross_readings`).
The scatter over each half of those tests (the odd and the even ones in time
order) is reported beside it, how steady the comparison is (a MAD of ``n`` Gaussian values scatters by about
``1.17 / sqrt(n)`` of itself); it does not enter the choice, which would otherwise go to whichever estimator is the
default wherever the halves split, however the whole baseline compares them.
The two estimators read different quantities: the identification the natural frequency of the mode's pole
(``|lambda| / 2 pi``), the FFT peak the peak of the record's spectrum, which the recorded quantity (an
acceleration's peaks ``f_n zeta^2`` above ``f_n``), the force's spectrum and a neighbouring component added
coherently move by the same amount in every hit (``docs/identification.md``, bias: 0.1-0.9 Hz at 6 kHz on closed-form
hammer hits). The choice compares their scatters, never their values; a chosen mode's series is the FFT peak in every
test, baseline and later alike, so its normal model and alarms compare like with like; and its text and
:attr:`FrequencyChoice.offset_hz` state how far apart the two quantities lie on the baseline (the median of FFT peak
less identification), so a chosen mode's frequency is not read as the pole's.
A mode whose tracking band reaches past a neighbour told apart by shape (:data:`learn.monitor.tracking.APART_MAC`)
keeps the identification's frequency: its FFT peak, read within the band by frequency alone, cannot tell the two
apart, and a reading of the mode beyond that band (a close mode moved past half the gap to its neighbour) has none.
Damping, shapes and tracking stay the identification's: a chosen mode's frequency is the FFT peak only in a test
where the identification tracked the mode (elsewhere it is missing, as in the identification). A chosen mode with
no FFT peak in its band is read by its FFT peak beyond the band within its reach (:mod:`learn.monitor.fft_beyond`);
elsewhere the readings beyond the bands are the identification's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learn.monitor.tracking import ReferenceModes, narrow_bands_hz
from learn.monitor.workers import fft_peaks_of_files
from learn.pairs.noise_calibration import robust_std
from physics.io import finite_or_none

__all__ = ["FFT_PEAK", "FREQUENCY_ESTIMATORS", "GROSS", "MIN_HALF", "FrequencyChoice", "choose_estimators",
           "choose_frequencies", "fft_peak_frequencies", "gross_readings"]

#: The name of the FFT-peak estimator (the key of :data:`physics.identification.methods.METHODS`).
FFT_PEAK = "fftpeak"
#: ``monitor_series``'s choices: each mode's frequency by the more repeatable estimator over the baseline period, or
#: always by the series' identification.
FREQUENCY_ESTIMATORS = ("choose", "identification")
#: The fewest baseline tests in each half holding both estimates for the FFT peak to be chosen (``2 MIN_HALF`` in all;
#: a half's MAD of 3 values).
MIN_HALF = 3
#: A reading more than this many of its estimator's robust scatters (1.4826 MAD of ``ln f``) from the estimator's
#: median over the baseline is gross (:func:`gross_readings`).
GROSS = 5.0


@dataclass(frozen=True)
class FrequencyChoice:
    """Each reference mode's frequency estimator, chosen over the baseline period.

    Attributes
    ----------
    default : str                 the series' identification (e.g. ``"era"``; ``"era/ssi"`` when the tests differ)
    estimators : tuple of str     per mode, ``default`` or :data:`FFT_PEAK`
    scatter_hz : ndarray (m, 2)   robust scatter (Hz: ``f_ref`` times the 1.4826 MAD of ``ln f``) of the default
                                  estimator and of the FFT peak over the baseline tests holding both (NaN: none)
    halves_hz : ndarray (m, 2, 2) the same over each half (axis 1: odd, even tests; axis 2: default, FFT peak)
    n_tests : ndarray int (m,)    baseline tests holding both estimates
    complete : ndarray bool (m,)  the FFT peak read the mode in every baseline test the identification did
    fft_hz : ndarray (n, m)       each test's FFT peak in each mode's tracking band (NaN: none, or not records)
    frequencies_hz : ndarray (n, m)   the tracked frequencies with each chosen mode's replaced by its FFT peak
    gross : ndarray int (m, 2)    gross readings (:func:`gross_readings`) of the default estimator and of the FFT
                                  peak over the baseline tests holding both (None: not counted)
    offset_hz : ndarray (m,)      median over the baseline tests holding both of the FFT peak less the
                                  identification (Hz): how far the spectral peak lies from the pole's natural
                                  frequency (NaN: no such test; None: not computed)
    by_shape : ndarray bool (m,) or None    modes told apart from a neighbour by shape (a tracking band wider than
                                  the band by frequency alone): the identification's frequency kept (None: no such
                                  mode)
    """

    default: str
    estimators: tuple
    scatter_hz: np.ndarray
    halves_hz: np.ndarray
    n_tests: np.ndarray
    complete: np.ndarray
    fft_hz: np.ndarray
    frequencies_hz: np.ndarray
    gross: np.ndarray | None = None
    offset_hz: np.ndarray | None = None
    by_shape: np.ndarray | None = None

    @property
    def chosen(self) -> np.ndarray:
        """bool (m,): the modes whose frequency is the FFT peak."""
        return np.array([e == FFT_PEAK for e in self.estimators], bool)

    def texts(self) -> list:
        """Per mode, the choice in words, e.g. ``mode 3: FFT peak, scatter 2.6 Hz against era 9.28 Hz over the 15
        baseline tests (halves 2.52 / 2.1 against 8.83 / 9.1 Hz)``."""
        out = []
        for r, est in enumerate(self.estimators):
            d, f = self.scatter_hz[r]
            (hd1, hf1), (hd2, hf2) = self.halves_hz[r]
            n = int(self.n_tests[r])
            if est == FFT_PEAK:
                off = np.nan if self.offset_hz is None else self.offset_hz[r]
                out.append(f"mode {r + 1}: FFT peak, scatter {f:.3g} Hz against {self.default} {d:.3g} Hz over the "
                           f"{n} baseline tests (halves {hf1:.3g} / {hf2:.3g} against {hd1:.3g} / {hd2:.3g} Hz)"
                           + (f"; its readings the record's spectral peak, {off:+.3g} Hz from {self.default}'s pole "
                              "frequency at the baseline median" if np.isfinite(off) else ""))
            elif self.by_shape is not None and self.by_shape[r]:
                out.append(f"mode {r + 1}: {self.default}, told apart from a neighbour by its shape, which the FFT "
                           f"peak cannot (scatter {d:.3g} Hz against the FFT peak {f:.3g} Hz over the {n} baseline "
                           "tests)")
            elif not self.complete[r]:
                out.append(f"mode {r + 1}: {self.default}, the FFT peak missing it in a baseline test where "
                           f"{self.default} read it")
            elif n < 2 * MIN_HALF:
                out.append(f"mode {r + 1}: {self.default}, {n} baseline tests holding both estimates (fewer than "
                           f"{2 * MIN_HALF})")
            elif self.gross is not None and f <= d and self.gross[r, 1] > self.gross[r, 0]:
                out.append(f"mode {r + 1}: {self.default}, the FFT peak's scatter {f:.3g} Hz against {d:.3g} Hz over "
                           f"the {n} baseline tests but {self.gross[r, 1]} of its readings more than {GROSS:g} "
                           f"scatters from its median ({self.default}: {self.gross[r, 0]})")
            else:
                out.append(f"mode {r + 1}: {self.default}, scatter {d:.3g} Hz against the FFT peak {f:.3g} Hz over "
                           f"the {n} baseline tests (halves {hd1:.3g} / {hd2:.3g} against {hf1:.3g} / {hf2:.3g} Hz)")
        return out

    def identified_by(self, how: list) -> list:
        """Per test, per mode, how its frequency was found: ``how`` (:func:`learn.monitor.tracking.identified_by`)
        with a chosen mode's entry ``fftpeak (the pole tracked: era)``, None where its FFT peak is missing."""
        chosen = self.chosen
        return [[h if h is None or not chosen[r] else
                 (f"{FFT_PEAK} (the pole tracked: {h})" if np.isfinite(self.frequencies_hz[i, r]) else None)
                 for r, h in enumerate(row)] for i, row in enumerate(how)]

    def _pair(self, scatter_hz) -> dict:
        """``{default: Hz, "fftpeak": Hz}`` of one ``(default, FFT peak)`` pair of scatters (None for NaN)."""
        return {self.default: finite_or_none(scatter_hz[0]), FFT_PEAK: finite_or_none(scatter_hz[1])}

    def to_dict(self) -> dict:
        return {"default": self.default, "estimators": list(self.estimators),
                "scatter_hz": [self._pair(p) for p in self.scatter_hz],
                "halves_hz": [[self._pair(p) for p in h] for h in self.halves_hz],
                "baseline_tests": self.n_tests.tolist(), "fft_complete": self.complete.tolist(),
                "gross_readings": None if self.gross is None else
                [{self.default: int(a), FFT_PEAK: int(b)} for a, b in self.gross],
                "offset_hz": None if self.offset_hz is None else [finite_or_none(v) for v in self.offset_hz],
                **({} if self.by_shape is None else {"by_shape": self.by_shape.tolist()}), "texts": self.texts()}


def fft_peak_frequencies(tests: list, files: list, ref: ReferenceModes, cache_dir=None, workers=1) -> np.ndarray:
    """``(n, m)``: each test's zero-padded FFT peak (Hz) in each reference mode's tracking band by frequency alone
    (:func:`learn.monitor.tracking.narrow_bands_hz`; a peak has no shape): the highest local maximum of the record's
    FFT power there (:func:`learn.monitor.identification.cached_fft_peaks`, kept in ``cache_dir`` beside the
    identifications; over ``workers`` processes); NaN where none lies there, for a test that is not response
    records, or one whose record is refused."""
    out = np.full((len(tests), ref.frequencies_hz.size), np.nan)
    rows = [i for i, t in enumerate(tests) if t is not None and t.kind == "response records"]
    if out.size and rows:
        out[rows] = fft_peaks_of_files([files[i] for i in rows], narrow_bands_hz(ref, by_frequency=True), cache_dir,
                                       workers)
    return out


def gross_readings(est_hz) -> int:
    """How many of the readings ``est_hz`` (k,) (Hz; NaN ignored) lie more than :data:`GROSS` robust scatters
    (1.4826 MAD of ``ln f``) from their median: an estimator reading a neighbouring peak or pole now and then (with
    a scatter of zero, every reading off the median)."""
    x = np.log(np.asarray(est_hz, float))
    x = x[np.isfinite(x)]
    if x.size == 0:
        return 0
    dev = np.abs(x - np.median(x))
    return int(np.sum(dev > GROSS * robust_std(x)))


def choose_estimators(F, G, baseline, reference_hz):
    """The choice over the baseline period (module docstring) from the default estimates ``F`` (n, m) and the FFT
    peaks ``G`` (n, m) (Hz; NaN: missing); ``baseline``: indices of the baseline tests in time order.

    Returns ``(chosen bool (m,), scatter_hz (m, 2), halves_hz (m, 2, 2), n_tests int (m,), complete bool (m,),
    gross int (m, 2))``.
    """
    F, G = np.asarray(F, float), np.asarray(G, float)
    base = np.asarray(baseline, int)
    f_ref = np.asarray(reference_hz, float)
    m = F.shape[1]
    scatter, halves = np.full((m, 2), np.nan), np.full((m, 2, 2), np.nan)
    n_tests, complete, chosen = np.zeros(m, int), np.zeros(m, bool), np.zeros(m, bool)
    gross = np.zeros((m, 2), int)
    for r in range(m):
        fb, gb = F[base, r], G[base, r]
        complete[r] = bool(np.all(np.isfinite(gb[np.isfinite(fb)])))
        both = np.flatnonzero(np.isfinite(fb) & np.isfinite(gb))
        n_tests[r] = both.size
        if both.size == 0:
            continue
        est = np.log(np.stack([fb[both], gb[both]], axis=1))            # (k, 2)
        scatter[r] = [f_ref[r] * robust_std(est[:, j]) for j in range(2)]
        gross[r] = [gross_readings(np.exp(est[:, j])) for j in range(2)]
        for h in range(2):                                              # the odd and the even tests
            halves[r, h] = [f_ref[r] * robust_std(est[h::2, j]) for j in range(2)]
        chosen[r] = (complete[r] and both[1::2].size >= MIN_HALF        # the identification kept where steadier
                     and not bool(scatter[r, 0] < scatter[r, 1]) and gross[r, 1] <= gross[r, 0])
    return chosen, scatter, halves, n_tests, complete, gross


def choose_frequencies(tests: list, files: list, ref: ReferenceModes, F, cols, baseline, cache_dir=None,
                       workers=1) -> FrequencyChoice | None:
    """Each reference mode's frequency by the more repeatable estimator over the baseline period (module docstring).

    ``tests``: each test's :class:`~learn.monitor.identification.IdentifiedModes` (None: not identified);
    ``files``: their paths; ``F`` (n, m) and ``cols`` (n, m): the tracked frequencies and the poles' columns of
    :func:`learn.monitor.tracking.track_modes`; ``baseline``: indices of the baseline tests; ``cache_dir`` and
    ``workers``: :func:`fft_peak_frequencies`'. None when the baseline tests are not response records (FRFs, modal
    data: their frequencies stay as identified).
    """
    base = [int(i) for i in baseline]
    kinds = {tests[i].kind for i in base if tests[i] is not None}
    if kinds != {"response records"}:
        return None
    F = np.asarray(F, float)
    cols = np.asarray(cols, int)
    G = fft_peak_frequencies(tests, files, ref, cache_dir, workers)
    chosen, scatter, halves, n_tests, complete, gross = choose_estimators(F, G, base, ref.frequencies_hz)
    by_shape = ref.by_frequency < ref.tolerance
    chosen &= ~by_shape
    by_shape = by_shape if by_shape.any() else None
    names = sorted({tests[i].method for i in base if tests[i] is not None})
    default = "/".join(names)
    out = F.copy()
    out[:, chosen] = np.where(cols[:, chosen] >= 0, G[:, chosen], np.nan)
    diff = G[base] - F[base]
    offset = np.array([np.median(c[np.isfinite(c)]) if np.any(np.isfinite(c)) else np.nan for c in diff.T])
    return FrequencyChoice(default, tuple(FFT_PEAK if c else default for c in chosen), scatter, halves, n_tests,
                           complete, G, out, gross, offset, by_shape)
