"""The warning every output-only method with a clear-peak check gives: the clear peaks of the record's spectrum that
no identified mode explains (:func:`~physics.identification.fdd.unexplained_peaks`), named with their heights above
the floor and what to try."""

from __future__ import annotations

import warnings

import numpy as np

from physics.identification.fdd import ClearPeaks, peak_text, unexplained_peaks

__all__ = ["warn_unexplained_peaks"]


def warn_unexplained_peaks(peaks: ClearPeaks, frequencies_hz, where, remedy, stacklevel=3) -> np.ndarray:
    """Warn (one line) of the clear peaks ``peaks`` that no mode of ``frequencies_hz`` (Hz) explains.

    Parameters
    ----------
    peaks : ClearPeaks
        The clear peaks of the record's spectrum.
    frequencies_hz : array_like, shape (n_modes,)
        The identified modes' natural frequencies.
    where : str
        Name of the record (the warning's first word).
    remedy : str
        What to try, ending the line (``"a harmonic, or a mode to look for with --band around it"``).
    stacklevel : int
        Of :func:`warnings.warn`: 3 points at the caller of the function calling this one.

    Returns
    -------
    ndarray of bool, shape (n_peaks,)
        The unexplained peaks (none: no warning).
    """
    unexplained = unexplained_peaks(peaks, frequencies_hz)
    if unexplained.any():
        warnings.warn(f"{where}: clear spectral peak(s) without an identified mode: {peak_text(peaks, unexplained)} "
                      f"above the floor; {remedy}", UserWarning, stacklevel=stacklevel)
    return unexplained
