"""A mode's frequency at a stated amplitude: its backbone (:func:`~physics.identification.backbone.fit_backbone`)
fitted with the components beside it found in the decay itself, and read at that amplitude.

The neighbours are found by a model-order test on the band. The band is the mode's own
(:func:`~physics.identification.band_refine.mode_bands`) grown by
:data:`~physics.identification.band_refine.MERGE_FACTOR` about it: the reach within which the band refinement
fits two modes of a model together, and so the reach within which a component no model holds is no smooth
background. The backbone is fitted alone; then, up to :data:`MAX_NEIGHBOURS` times, a damped exponential is
started at the largest line of the fit's residual that lies further than
:data:`~physics.identification.band_refine.RESOLVED_LINES` lines from the mode and from the neighbours already
kept, and the backbone fitted again with it. The neighbour is kept when the fit converges, it lowers the Bayesian
information criterion of the band's lines, the neighbour is resolved from the mode (further apart than their
half-power half-widths summed and than ``RESOLVED_LINES`` lines, as
:func:`~physics.identification.band_refine.refine_in_bands` resolves two poles) and it is a peak of the band, not
its background (half-power half-width at most :data:`MAX_NEIGHBOUR_WIDTH` of the band's half-width), and it takes
at least :data:`MIN_RESIDUAL_DROP` of the band's residual energy. The search stops at the first candidate refused;
with no neighbour kept the result is the backbone fitted alone in the mode's own band.

The estimand is the undamped natural frequency at the envelope amplitude ``a_ref`` (the record's units)
``sqrt((f0 + c a_ref / |A|)^2 + (sigma / 2 pi)^2)``, the backbone's ``f0 + c exp(-sigma t)`` read where its
envelope ``|A| exp(-sigma t)`` is ``a_ref`` (``a_ref = 0``: the zero-amplitude limit, the backbone's ``f0``). It is
the same quantity from hits of any strength when the mode's frequency is linear in its amplitude, where a linear
fit (one damped exponential) reads a frequency weighted towards the loud start of each decay and so follows the
hit. The extrapolation costs variance (on linear decays ``f0`` scatters 1.7-4.4 times the linear band fit's), so no
identification method reports it: it is a diagnostic of one mode (``docs/identification.md``, precision over
repeated tests, gives its scatter over repeated hits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConfigError, ConvergenceError, ShapeError
from physics.identification.backbone import Backbone, fit_backbone
from physics.identification.band_refine import BACKGROUND_ORDER, MERGE_FACTOR, RESOLVED_LINES, RESOLVED_WIDTHS

__all__ = ["MAX_NEIGHBOURS", "MAX_NEIGHBOUR_WIDTH", "MIN_RESIDUAL_DROP", "AmplitudeFrequency",
           "backbone_with_neighbours", "frequency_at_amplitude", "read_at_amplitude"]

#: Most neighbours fitted beside the mode.
MAX_NEIGHBOURS = 1
#: A neighbour's half-power half-width is at most this fraction of the band's half-width (wider: background).
MAX_NEIGHBOUR_WIDTH = 0.25
#: A neighbour takes at least this fraction of the band's residual energy (sum of squares over its lines).
MIN_RESIDUAL_DROP = 0.5


@dataclass(frozen=True)
class AmplitudeFrequency:
    """One mode's natural frequency at a stated amplitude (see the module docstring).

    Attributes
    ----------
    natural_frequency_hz : float
        At ``reference_amplitude`` (Hz).
    frequency_std_hz : float
        One sigma, from the covariance of ``f0`` and ``c`` (``|A|`` taken as known).
    reference_amplitude : float
        ``a_ref`` (the record's units).
    backbone : Backbone
        The fit it is read from, neighbours included.
    """

    natural_frequency_hz: float
    frequency_std_hz: float
    reference_amplitude: float
    backbone: Backbone


def _reference(amplitude) -> float:
    a_ref = float(amplitude)
    if not (np.isfinite(a_ref) and a_ref >= 0):
        raise ConfigError(f"reference_amplitude: expected a finite amplitude >= 0, got {amplitude}")
    return a_ref


def _rss(b: Backbone) -> float:
    return max(float(np.sum(np.abs(b.residual) ** 2)), np.finfo(float).tiny)


def _bic(b: Backbone) -> float:
    m = 2 * b.residual.size
    return m * np.log(_rss(b) / m) + b.n_parameters * np.log(m)


def _kept(b: Backbone, previous: Backbone, n, fs, half_hz) -> bool:
    """Whether the neighbour ``b`` added to ``previous`` is kept (module docstring)."""
    nb = b.neighbours[-1]
    f_nb, s_nb = nb.imag / (2 * np.pi), -nb.real / (2 * np.pi)
    poles_hz = np.concatenate([[b.frequency_hz], b.neighbours[:-1].imag / (2 * np.pi)])
    widths_hz = np.concatenate([[b.decay_rate], -b.neighbours[:-1].real]) / (2 * np.pi)
    apart = np.abs(poles_hz - f_nb)
    resolved = np.all((apart > RESOLVED_LINES * fs / n) & (apart > RESOLVED_WIDTHS * (widths_hz + s_nb)))
    return bool(resolved and s_nb <= MAX_NEIGHBOUR_WIDTH * half_hz and _bic(b) < _bic(previous)
                and _rss(b) <= (1 - MIN_RESIDUAL_DROP) * _rss(previous))


def backbone_with_neighbours(decay, sampling_frequency_hz, eigenvalue, max_neighbours=MAX_NEIGHBOURS,
                             background_order=BACKGROUND_ORDER) -> Backbone:
    """The mode's backbone fitted with the neighbours the model-order test keeps (module docstring).

    Parameters
    ----------
    decay, sampling_frequency_hz, background_order
        As :func:`~physics.identification.backbone.fit_backbone` takes them.
    eigenvalue : complex
        Starting pole ``-sigma + i omega`` (rad/s), e.g. the linear fit's; the band is grown about it.
    max_neighbours : int

    Returns
    -------
    Backbone
        Its :attr:`~physics.identification.backbone.Backbone.neighbours` are those kept (possibly none).

    Raises
    ------
    ShapeError, ConfigError, ConvergenceError
        As :func:`~physics.identification.backbone.fit_backbone` raises them for the mode fitted alone.
    """
    if int(max_neighbours) < 0:
        raise ConfigError(f"max_neighbours: expected a count >= 0, got {max_neighbours}")
    fs, lam = float(sampling_frequency_hz), complex(eigenvalue)
    own = fit_backbone(decay, fs, lam, background_order=background_order)     # validates the decay and the pole
    x = np.asarray(decay, dtype=np.float64)
    n = x.size
    centre, half = lam.imag / (2 * np.pi), MERGE_FACTOR * 0.5 * (own.band_hz[1] - own.band_hz[0])
    wide = (max(centre - half, 0.0), min(centre + half, fs / 2))
    if not max_neighbours:
        return own
    try:
        best = fit_backbone(x, fs, lam, band_hz=wide, background_order=background_order)
    except ConvergenceError:
        return own
    for _ in range(int(max_neighbours)):
        poles_hz = np.concatenate([[best.frequency_hz], best.neighbours.imag / (2 * np.pi)])
        far = np.all(np.abs(best.lines_hz[:, None] - poles_hz[None, :]) > RESOLVED_LINES * fs / n, axis=1)
        if not np.any(far):
            break
        line = best.lines_hz[np.argmax(np.where(far, np.abs(best.residual), -1.0))]
        seed = -2 * np.pi * fs / n + 2j * np.pi * line                # half-power half-width of one line
        try:
            trial = fit_backbone(x, fs, lam, band_hz=wide, background_order=background_order,
                                 neighbours=np.concatenate([best.neighbours, [seed]]))
        except (ConvergenceError, ShapeError):                    # too few lines for one more pole, or no fit
            break
        if not _kept(trial, best, n, fs, 0.5 * (wide[1] - wide[0])):
            break
        best = trial
    return best if best.neighbours.size else own


def read_at_amplitude(backbone: Backbone, reference_amplitude=0.0) -> AmplitudeFrequency:
    """A fitted backbone's undamped natural frequency at the envelope amplitude ``reference_amplitude``.

    Parameters
    ----------
    backbone : Backbone
    reference_amplitude : float
        ``a_ref >= 0``, the decay's units; 0 the zero-amplitude limit.

    Returns
    -------
    AmplitudeFrequency
    """
    a_ref, b = _reference(reference_amplitude), backbone
    r = a_ref / max(abs(b.amplitude), np.finfo(float).tiny)
    f = b.frequency_hz + b.shift_hz * r
    var = b.frequency_std_hz ** 2 + (r * b.shift_std_hz) ** 2 \
        + 2 * r * np.nan_to_num(b.correlation) * b.frequency_std_hz * b.shift_std_hz
    return AmplitudeFrequency(float(np.hypot(f, b.decay_rate / (2 * np.pi))), float(np.sqrt(max(var, 0.0))), a_ref, b)


def frequency_at_amplitude(decay, sampling_frequency_hz, eigenvalue, reference_amplitude=0.0,
                           max_neighbours=MAX_NEIGHBOURS) -> AmplitudeFrequency:
    """One mode's undamped natural frequency at the envelope amplitude ``reference_amplitude`` (module docstring):
    :func:`read_at_amplitude` of :func:`backbone_with_neighbours`.

    Parameters
    ----------
    decay, sampling_frequency_hz, eigenvalue, max_neighbours
        As :func:`backbone_with_neighbours` takes them.
    reference_amplitude : float
        As :func:`read_at_amplitude` takes it.

    Returns
    -------
    AmplitudeFrequency
    """
    a_ref = _reference(reference_amplitude)                              # refused before any fit
    return read_at_amplitude(backbone_with_neighbours(decay, sampling_frequency_hz, eigenvalue, max_neighbours), a_ref)
