"""The amplitudes of poles held fixed in their own bands of decays' transforms: the linear part of
:mod:`physics.identification.band_refine`'s band fit, for seeds and for judging the poles of a band fit that failed."""

from __future__ import annotations

import numpy as np

from physics.identification.band_refine import (BACKGROUND_ORDER, SWEEPS, band_data, decay_spectra, mode_bands,
                                                modes_on_lines, projected_band)

__all__ = ["band_amplitudes"]


def band_amplitudes(decays, sampling_frequency_hz, eigenvalues, background_order=BACKGROUND_ORDER) -> np.ndarray:
    """The amplitudes of poles held fixed: each group of close poles' linear least-squares fit (amplitudes and
    background, the poles not moved) in its own band (:func:`~physics.identification.band_refine.mode_bands`), swept as
    :func:`~physics.identification.band_refine.refine_in_bands` sweeps
    (from the second sweep on, each band's data less the other groups' transforms).

    Parameters
    ----------
    decays : sequence of ndarray, each shape (n_channels, n_samples_d)
        The decays, each from its own start, mean removed.
    sampling_frequency_hz : float
    eigenvalues : array_like, complex, shape (n_modes,)
        ``-sigma + i omega`` (rad/s).
    background_order : int

    Returns
    -------
    ndarray, complex, shape (n_decays, n_channels, n_modes)
        ``a`` of ``Re(a z^n)`` of each decay, channel and mode at the decay's first sample (0 where a decay holds
        too few lines of the mode's band).
    """
    fs = float(sampling_frequency_hz)
    lam = np.asarray(eigenvalues, complex)
    decays = [np.asarray(y, dtype=np.float64) for y in decays]
    n_ch = decays[0].shape[0]
    lengths = [y.shape[1] for y in decays]
    amps = np.zeros((len(decays), n_ch, lam.size), complex)
    if lam.size == 0:
        return amps
    spectra = decay_spectra(decays, fs, None)
    bands, group = mode_bands(lam, max(lengths) / fs, fs / 2)
    for _ in range(SWEEPS):                             # from the second on, less the other groups' transforms
        known = amps.copy()
        for g in np.unique(group):
            idx, others = np.flatnonzero(group == g), np.flatnonzero(group != g)
            m = idx.size
            data = [None if d is None else
                    (d[0], d[1], d[2] - modes_on_lines(d[1], d[3], fs, lam[others], known[j][:, others])
                     / np.sqrt(d[3]), d[3])
                    for j, d in enumerate(band_data(spectra, lengths, fs, bands[idx[0]]))]
            used = [j for j, d in enumerate(data) if d is not None]
            _, coef, _ = projected_band(data, fs, -lam[idx].real, lam[idx].imag, np.ones(n_ch), bands[idx[0]],
                                         background_order)
            for j, C in zip(used, coef):
                amps[j][:, idx] = 2 * (C[0:2 * m:2] + 1j * C[1:2 * m:2]).T * np.sqrt(lengths[j])
    return amps
