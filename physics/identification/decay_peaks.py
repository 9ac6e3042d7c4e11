"""The clear peaks of a free decay's spectrum (:func:`~physics.identification.decays.decay_spectrum`): the
modes fftpeak reports for a free response and the modes ERA's model must hold.

A peak is clear when it stands :data:`~physics.identification.fdd.CLEAR_PEAK_DB` above the running floor, or
:data:`~physics.identification.fdd.CLEAR_PEAK_DB` above the valleys either side and above the level a noise line
passes with probability :data:`FALSE_PEAKS` over the band's lines (:func:`prominent_peak_db`). Where modes are
dense (a bridge, a plate) the running median rides on their flanks, so a mode clear to the eye stands less than
10 dB above it; its prominence over the valleys tells it from the flanks, and its height over the floor from the
noise.
"""

from __future__ import annotations

import numpy as np

from physics.identification.fdd import ClearPeaks, SingularValueSpectrum, clear_peaks

__all__ = ["FALSE_PEAKS", "decay_peaks", "noise_line_db", "prominent_peak_db"]

#: Expected number of noise lines of a free decay's band standing out as prominent peaks (:func:`decay_peaks`).
FALSE_PEAKS = 0.01


def noise_line_db(n_lines, false_peaks=FALSE_PEAKS, dof=3.0) -> float:
    """Height (dB) over the running median that a noise line of a three-line power average passes with probability
    ``false_peaks / n_lines``: the average of ``dof`` independent exponential line powers is Gamma(``dof``) (3 for
    white noise: the channels, seeing one structure, counted as one)."""
    from scipy import special  # scipy: only output-only identification

    p = min(0.5, false_peaks / max(int(n_lines), 1))
    return float(10 * np.log10(special.gammainccinv(dof, p) / special.gammainccinv(dof, 0.5)))


def _line_dof(over_db):
    """The independent lines (1 to 3) in a three-line average whose heights over the running median (dB) spread as
    ``over_db`` does: the interquartile range of ``10 log10`` of a Gamma(k) law, 3.6 dB for k = 3 (white noise)
    and 6.8 dB for k = 1 (lines as correlated as a decay of a fifth of the record's length makes them). Peaks
    widen the spread, so it errs on the side of fewer lines (a higher level)."""
    from scipy import special  # scipy: only output-only identification

    k = np.linspace(1.0, 3.0, 201)
    iqr = 10 * np.log10(special.gammaincinv(k, 0.75) / special.gammaincinv(k, 0.25))
    spread = float(np.subtract(*np.percentile(over_db, [75, 25]))) if over_db.size >= 8 else iqr[0]
    return float(k[np.argmin(np.abs(iqr - spread))])


def prominent_peak_db(sv: SingularValueSpectrum) -> float:
    """:func:`noise_line_db` of the lines of ``sv``'s band that may hold a peak, with the independent lines of its
    average estimated from their spread (:func:`_line_dof`): the height over the floor (dB) a prominent peak
    passes."""
    f = sv.frequency_hz
    lines = np.flatnonzero((f >= max(sv.band_hz[0], sv.lowest_hz)) & (f <= sv.band_hz[1]) & np.isfinite(sv.floor))
    over = 10 * np.log10(np.maximum(sv.singular_values[lines, 0], np.finfo(float).tiny) / sv.floor[lines])
    return noise_line_db(lines.size, dof=_line_dof(over))


def decay_peaks(sv: SingularValueSpectrum) -> ClearPeaks:
    """The clear peaks of a free decay's spectrum ``sv`` (see the module docstring)."""
    return clear_peaks(sv, prominent_above_db=prominent_peak_db(sv))
