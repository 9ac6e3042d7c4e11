"""Each channel of a multichannel response record in units of its own noise, for the output-only methods.

SSI-cov's SVD of the correlations, ERA's of the decays, FDD's singular-value spectrum, the free-response verdict's
energies and the FFT peaks of the summed channels all weigh a channel by its amplitude: a channel that reads mostly its
own noise at a level far above the others' (a low-sensitivity accelerometer beside a sensitive one, unscaled
voltages) fills their leading singular vectors with that noise, and the modes the quiet channels hold are not
found. :func:`noise_floor_weights` gives each channel the weight ``1 / sqrt(floor)``, its floor the median over the
band of its auto-spectral density (the level between spectral peaks: a mode's peak covers few lines), so that every
channel's noise has the same level (the diagonal noise whitening of a maximum-likelihood fit) and a channel counts by
how far its modes stand above its own noise, not by its units. Channels whose floors lie within
:data:`SPREAD_DB` of each other are identified as recorded (weights 1): no channel's noise then stands above another's
as far as a clear spectral peak stands above its floor, and a reweighting within that spread only moves the poles at
the edge of the selection (the real 4-channel record ``MPSTD_Set001``, floors within 1.9 dB, loses its weak 141-Hz
mode when weighted). :func:`weighted_record` applies the weights; :func:`unweighted_estimate` and
:func:`unweighted_diagram` return the shapes to the record's channels. One channel is identified as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from physics.identification.fdd import CLEAR_PEAK_DB, cross_spectra, unit_shapes
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.identification.poles import StabilisationDiagram
from physics.identification.record_checks import CheckedRecord

__all__ = ["FLOOR_LINES", "SPREAD_DB", "ChannelWeights", "WeightedChannels", "noise_floor_weights",
           "unweighted_diagram",
           "unweighted_estimate", "weighted_record"]

#: Channels whose floors lie within this many dB of each other are identified as recorded: the height of a clear
#: spectral peak above its floor (:data:`~physics.identification.fdd.CLEAR_PEAK_DB`).
SPREAD_DB = CLEAR_PEAK_DB
#: Spectral lines over the band the floor is read from (fewer when the record holds fewer than eight frames of
#: that resolution).
FLOOR_LINES = 256


@dataclass(frozen=True)
class ChannelWeights:
    """The weight of each channel of a record.

    Attributes
    ----------
    weights : ndarray, shape (n_channels,)
        ``1 / sqrt(floor)``, scaled to a geometric mean of 1 (all ones for one channel, and for floors within
        :data:`SPREAD_DB` of each other).
    floor : ndarray, shape (n_channels,)
        Median auto-spectral density of each channel over the band (unit^2/Hz; NaN for one channel, not read).
    """

    weights: np.ndarray
    floor: np.ndarray

    @property
    def spread_db(self) -> float:
        """How far apart the channels' floors lie: 10 log10(highest / lowest) (0 for one channel)."""
        f = self.floor
        return 0.0 if f.size < 2 or not np.all(np.isfinite(f)) else float(10 * np.log10(f.max() / f.min()))


def noise_floor_weights(checked: CheckedRecord, where="record") -> ChannelWeights:
    """Each channel's weight ``1 / sqrt(floor)`` (see the module docstring), geometric mean 1; all ones when the
    floors lie within :data:`SPREAD_DB` of each other.

    The floor is the median of the channel's Welch auto-spectral density (Hann, half-overlapping frames) over the
    lines of ``checked.band_hz``, at a resolution of :data:`FLOOR_LINES` lines over the band (coarser when the
    record holds fewer than eight frames of that length). A channel without a positive median (a record whose band
    holds a single line) takes its mean density over the band instead.

    Parameters
    ----------
    checked : CheckedRecord
    where : str
        Name of the record in error messages.

    Returns
    -------
    ChannelWeights
    """
    n_ch, n = checked.signals.shape
    if n_ch == 1:
        return ChannelWeights(np.ones(1), np.full(1, np.nan))
    fs, (lo, hi) = checked.sampling_frequency_hz, checked.band_hz
    L = int(2 ** np.ceil(np.log2(fs * FLOOR_LINES / max(hi - lo, fs / n))))
    L = max(16, min(L, int(2 ** np.floor(np.log2(max(n / 8, 16))))))
    f, G = cross_spectra(checked.signals, fs, L, mean=checked.mean, where=where)
    P = np.real(np.diagonal(G, axis1=1, axis2=2))                      # (n_lines, n_channels)
    inband = (f >= lo) & (f <= hi) & (f > 0)
    if not inband.any():                                                # a band narrower than a line
        inband = np.abs(f - 0.5 * (lo + hi)) == np.abs(f - 0.5 * (lo + hi)).min()
    floor = np.median(P[inband], axis=0)
    floor = np.where(floor > 0, floor, P[inband].mean(axis=0))
    floor = np.maximum(floor, np.finfo(float).tiny)
    as_recorded = ChannelWeights(np.ones(n_ch), floor)
    if as_recorded.spread_db <= SPREAD_DB:
        return as_recorded
    w = 1.0 / np.sqrt(floor)
    return ChannelWeights(w / np.exp(np.mean(np.log(w))), floor)


class WeightedChannels:
    """A record's channels each multiplied by its weight, computed as its parts are read: a slice ``[rows, cols]``
    is read from the record (an array or a ``np.memmap``, read chunk by chunk as before) and weighted; ``np.asarray``
    weighs the whole record.

    Parameters
    ----------
    signals : array_like, shape (n_channels, n_samples)
    weights : ndarray, shape (n_channels,)
    """

    def __init__(self, signals, weights):
        self._signals = signals
        self._weights = np.broadcast_to(np.asarray(weights, float)[:, None], signals.shape)
        self.shape, self.ndim, self.size, self.dtype = signals.shape, 2, signals.size, np.dtype(np.float64)

    def __getitem__(self, key):
        return np.asarray(self._signals[key], dtype=np.float64) * self._weights[key]

    def __array__(self, dtype=None, copy=None):
        y = np.asarray(self._signals, dtype=np.float64) * self._weights
        return y if dtype is None else y.astype(dtype, copy=False)


def weighted_record(checked: CheckedRecord, weights: ChannelWeights) -> CheckedRecord:
    """The record with channel ``k`` multiplied by ``weights.weights[k]`` (its mean too; the samples as they are
    read, :class:`WeightedChannels`); the record itself when every weight is 1."""
    w = np.asarray(weights.weights, float)
    if np.all(w == 1.0):
        return checked
    return replace(checked, signals=WeightedChannels(checked.signals, w), mean=checked.mean * w)


def _unweighted_rows(x, w, axis):
    """``x`` with its rows (along ``axis``) divided by ``w``."""
    shape = [1] * x.ndim
    shape[axis] = w.size
    return x / w.reshape(shape)


def unweighted_estimate(estimate: ModalEstimate, weights: ChannelWeights) -> ModalEstimate:
    """An estimate identified on the weighted record, its shapes (unit norm, largest entry real positive), residues,
    residuals and MPC on the record's channels again; the estimate itself when every weight is 1."""
    w = np.asarray(weights.weights, float)
    if np.all(w == 1.0):
        return estimate
    shapes = np.asarray(estimate.shapes, complex)
    if shapes.shape[0] != w.size:
        return estimate
    out = unit_shapes(_unweighted_rows(shapes, w, 0)) if shapes.shape[1] else shapes
    changes = {"shapes": out, "mpc": modal_phase_collinearity(out) if out.shape[1] else estimate.mpc}
    for name in ("residues", "lower_residual", "upper_residual"):
        value = getattr(estimate, name)
        if value is not None and np.ndim(value) >= 1 and np.shape(value)[0] == w.size:
            changes[name] = _unweighted_rows(np.asarray(value), w, 0)
    return replace(estimate, **changes)


def unweighted_diagram(diagram: StabilisationDiagram | None, weights: ChannelWeights) -> StabilisationDiagram | None:
    """A stabilisation diagram of the weighted record, its participation vectors (unit norm) on the record's
    channels again; the diagram itself when every weight is 1 or its vectors are not per channel."""
    w = np.asarray(weights.weights, float)
    if diagram is None or np.all(w == 1.0) or diagram.participation.ndim != 2 \
            or diagram.participation.shape[1] != w.size:
        return diagram
    p = _unweighted_rows(np.asarray(diagram.participation, complex), w, 1)
    norm = np.linalg.norm(p, axis=1, keepdims=True)
    return replace(diagram, participation=p / np.where(norm > 0, norm, 1.0))
