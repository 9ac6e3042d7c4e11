"""How far a free-decay mode's frequency moves over its decay (its glide): the mode refitted alone in its band over
the first and over the second half of each decay.

A mode whose stiffness depends on its amplitude (a clamped plate or board stiffening as it swings, a joint that
softens) decays with a frequency that moves as its envelope falls; a fit of one damped exponential reads a
frequency weighted towards the loud start, and the time-domain stage may split the peak between two poles, which
the band refinement then merges (:attr:`~physics.identification.band_refine.BandFit.merged`). The glide is measured
on the decays themselves: each decay ``y[0:N]`` is cut at ``N // 2`` and the pole refitted in its band
(:func:`~physics.identification.band_refine.refine_in_bands`) over the first pieces and over the second pieces, the
other modes held fixed (their closed-form transforms subtracted; a fixed mode's amplitude at the second piece's first
sample is ``a z^(N // 2)``). On a linear decay the two fits agree within their one sigmas; a glide is
significant when they differ by more than :data:`GLIDE_SIGMAS` of their difference's one sigma (the noise of the two
halves is independent).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.identification.band_refine import refine_in_bands

__all__ = ["GLIDE_SIGMAS", "Glide", "mode_glide"]

#: A glide is significant beyond this many one sigmas of the difference of the two halves' frequencies.
GLIDE_SIGMAS = 3.0


@dataclass(frozen=True)
class Glide:
    """One mode's natural frequency over the first and over the second half of its decays.

    Attributes
    ----------
    early_hz, late_hz : float
        The pole refitted over the first and over the second halves (Hz).
    early_std_hz, late_std_hz : float
        Their one sigmas (Hz).
    """

    early_hz: float
    late_hz: float
    early_std_hz: float
    late_std_hz: float

    @property
    def relative(self) -> float:
        """``(late - early) / early``: the glide as a fraction (negative: the frequency falls as the decay dies)."""
        return (self.late_hz - self.early_hz) / self.early_hz

    @property
    def significant(self) -> bool:
        """The two halves differ by more than :data:`GLIDE_SIGMAS` one sigmas of their difference."""
        return bool(abs(self.late_hz - self.early_hz) > GLIDE_SIGMAS * np.hypot(self.early_std_hz, self.late_std_hz))


def mode_glide(decays, sampling_frequency_hz, eigenvalues, amplitudes, k) -> Glide | None:
    """The glide of mode ``k`` over ``decays`` (see the module docstring).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        Each from its own start, mean removed (as :func:`refine_in_bands` takes them).
    sampling_frequency_hz : float
    eigenvalues : array_like, complex, shape (n_modes,)
        Every mode of the decays (rad/s), ``k`` among them.
    amplitudes : array_like, complex, shape (n_decays, n_channels, n_modes)
        ``a`` of ``Re(a z^n)`` at each decay's first sample (:attr:`BandFit.amplitudes`).
    k : int

    Returns
    -------
    Glide or None
        None when either half's fit fails (too few lines of the band, or no converged pole).
    """
    fs = float(sampling_frequency_hz)
    lam = np.asarray(eigenvalues, complex)
    amps = np.asarray(amplitudes, complex)
    others = np.flatnonzero(np.arange(lam.size) != k)
    cut = [np.asarray(y).shape[1] // 2 for y in decays]
    late_amps = amps[:, :, others] * np.exp(np.outer(cut, lam[others]) / fs)[:, None, :]
    out = []
    for pieces, fixed_amps in (([np.asarray(y)[:, :c] for y, c in zip(decays, cut)], amps[:, :, others]),
                               ([np.asarray(y)[:, c:] for y, c in zip(decays, cut)], late_amps)):
        fit = refine_in_bands(pieces, fs, lam[[k]], fixed=(lam[others], fixed_amps))
        if not fit.converged[0] or not np.isfinite(fit.frequency_std_hz[0]):
            return None
        out.append((float(fit.natural_frequencies_hz[0]), float(fit.frequency_std_hz[0])))
    (early, s_early), (late, s_late) = out
    return Glide(early, late, s_early, s_late)
