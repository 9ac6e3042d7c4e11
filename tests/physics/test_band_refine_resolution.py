"""The band refinement's resolution rule: two poles of one peak, closer than their half-power widths and than the
decay's main lobe, are one mode (the stronger, fitted alone), whose scatter over repeated decays is then below the
zero-padded FFT peak's; and the decays it reads: from each hit's onset, across the cuts that add no energy."""

import numpy as np
from impact_records import crb_frequency_std_hz, poles

from physics.identification.band_refine import RESOLVED_LINES, refine_in_bands
from physics.identification.decays import Decays
from physics.identification.free_decay import _band_spans

FS, N, F_INF, DF, ZETA, NOISE = 1000.0, 2000, 100.0, 0.8, 0.01, 0.01


def _softening_decay(seed):
    """One channel: a decay whose frequency rises by ``DF`` to ``F_INF`` as its amplitude falls (a softening
    mode), instantaneous frequency ``F_INF - DF exp(-sigma t)``, plus white noise: (1, N)."""
    t = np.arange(N) / FS
    sigma = ZETA * 2 * np.pi * F_INF
    phase = 2 * np.pi * (F_INF * t + DF * (np.exp(-sigma * t) - 1) / sigma)
    return (np.exp(-sigma * t) * np.cos(phase) + NOISE * np.random.default_rng(seed).standard_normal(N))[None]


def _fft_peak_hz(y, pad=64):
    """The zero-padded FFT's peak (Hz), the independent reference."""
    spectrum = np.abs(np.fft.rfft(y[0], pad * y.shape[1]))
    return np.argmax(spectrum) * FS / (pad * y.shape[1])


def test_two_poles_of_one_peak_are_one_mode_no_less_precise_than_the_fft_peak():
    # the starting poles 0.7 Hz apart (1.4 lines of the 2-s decay, under the 2 Hz of their half-power half-widths):
    # fitted as a pair, their split follows the noise (scatter 0.95x the FFT peak's); merged, the mode is 0.34x
    start = poles([99.4, 100.1], [ZETA, ZETA])
    assert abs(start[1].imag - start[0].imag) / (2 * np.pi) < RESOLVED_LINES * FS / N
    band_hz, fft_hz = [], []
    for seed in range(8):
        y = _softening_decay(seed)
        res = refine_in_bands([y], FS, start)
        kept = np.flatnonzero(res.converged & ~res.merged)
        assert kept.size == 1 and res.merged.sum() == 1, (res.natural_frequencies_hz, res.merged)
        band_hz.append(res.natural_frequencies_hz[kept[0]])
        fft_hz.append(_fft_peak_hz(y))
    band_std, fft_std = np.std(band_hz, ddof=1), np.std(fft_hz, ddof=1)
    assert band_std <= 0.5 * fft_std, (band_std, fft_std)
    assert abs(np.mean(band_hz) - np.mean(fft_hz)) < 0.1          # the peak the FFT reads, within a tenth of a line


def test_a_resolved_close_pair_is_kept():
    # 50.0 and 51.2 Hz at 1.5 % damping: closer than their half-power half-widths summed (1.5 Hz), but 4.8 lines of the
    # 4-s decay apart: both kept, each within 4 Cramer-Rao bounds
    fs, n, noise = 400.0, 1600, 0.01
    fn, zeta, amp = np.array([50.0, 51.2]), np.array([0.015, 0.015]), np.array([1.0, 0.7j])
    t = np.arange(n) / fs
    y = np.real(amp @ np.exp(np.outer(poles(fn, zeta), t)))
    y = (y + noise * np.random.default_rng(3).standard_normal(n))[None]
    res = refine_in_bands([y], fs, poles([49.9, 51.4], zeta))
    assert not res.merged.any() and res.converged.all()
    crb = crb_frequency_std_hz(fs, n, fn, zeta, amp, noise)
    assert np.all(np.abs(res.natural_frequencies_hz - fn) < 4 * crb), (res.natural_frequencies_hz - fn, crb)


def test_the_band_reads_a_decay_across_a_cut_that_adds_no_energy_and_not_across_a_missed_hit():
    # one decay from its hit at sample 100, cut at 600 by the time-domain fit (no energy added: the decay runs on)
    # and at 1500, where a second hit (twice the first's amplitude) the segmentation missed adds energy
    fs, n = 1000.0, 3000
    t = np.arange(n) / fs
    sigma, w = 2.0, 2 * np.pi * 40.0

    def ring(t0, a):
        s = np.clip(t - t0, 0.0, None)
        return np.where(t >= t0, a * np.exp(-sigma * s) * np.sin(w * s), 0.0)

    x = (ring(0.1, 1.0) + ring(1.5, 2.0))[None]
    decays = Decays(np.array([99]), np.array([110]), np.array([n]), 10.0, onsets=np.array([100]))
    pieces = [(100, 110, 600), (600, 602, 1500), (1500, 1502, n)]
    assert _band_spans(x, decays, pieces, 100) == [(100, 1500), (1500, n)]
    assert _band_spans(x, decays, pieces[1:], 100) == [(100, 1500), (1500, n)]      # a first piece left out
