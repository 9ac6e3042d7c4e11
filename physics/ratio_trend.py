"""Where a mode lies, read from the modes a test holds one pole of: the trend of the measured/model frequency
ratios, which picks among several poles within one mode's pairing band.

A beam model's frequencies drift from the measured ones smoothly with frequency: a stiffness or mass error moves
every ``ln(f / f_model)`` alike, shear and rotary inertia (which an Euler-Bernoulli model leaves out) lower it by
``(beta r)^2``, in proportion to the mode's frequency. So ``ln(f / f_model) = a + b f_model`` fitted on the modes
whose pairing band holds one pole (the anchors) predicts where each other mode lies. On a one-accelerometer
cantilever (modes 22.6/139.2/379.9/725.9 Hz against the model's 22.1/138.3/384.9/755.2 Hz) it puts mode 5 at
1158 Hz (the model's 1257 Hz): of the test's 1166 Hz (mode 5) and 1227 Hz (a spurious pole), the nearer the model
is the spurious one, the nearer the prediction is mode 5. ``classify`` pairs by it, the discrepancy stop names the
likelier spurious pole by it (:func:`learn.pairs.measured.pair_modes_by_frequency`, ``pair_measured``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MIN_PAIR_MAC", "RATIO_TOLERANCE", "RatioTrend", "choice_texts", "ratio_trend", "trend_picks"]

#: Tolerance on the measured frequency ratios ``f_k / f_1`` against the model's nominal beam: wide enough for
#: another stiffness, root or shear flexibility (shear lowers f4/f1 by about 10 %), narrow against a missing or
#: spurious mode (which moves a ratio by a factor of 2.6 or more).
RATIO_TOLERANCE = 0.35

#: Least MAC between an identified shape and a nominal mode's shape at the sensors for the two to pair (two or
#: more sensors): a slit or a support change leaves the MAC of a mode with its nominal shape above 0.9; a
#: spurious pole (a mains line, a fixture's resonance) has a shape of its own.
MIN_PAIR_MAC = 0.5


@dataclass(frozen=True)
class RatioTrend:
    """``ln(f / f_model) = intercept + slope_per_hz * f_model``, fitted on the anchor modes.

    Attributes
    ----------
    anchors : ndarray, int, shape (a,)   0-based modes fitted: those whose pairing band holds exactly one pole
                                         (none: the trend is the model itself, 0 and 0)
    intercept : float                    ``ln`` ratio at 0 Hz (one anchor: its ``ln`` ratio; the slope is then 0)
    slope_per_hz : float                 1/Hz
    """

    anchors: np.ndarray
    intercept: float
    slope_per_hz: float

    def basis(self, modes, of: str = "the model") -> str:
        """What the trend rests on, ``"the ratios of modes 1, 2, 3, 4 to {of}"`` or ``"no mode holds one pole alone:
        {of}"`` (``modes``: the 1-based mode numbers, shape (m,); ``of``: what the nominal frequencies are)."""
        if self.anchors.size == 0:
            return f"no mode holds one pole alone: {of}"
        names = ", ".join(str(modes[j]) for j in self.anchors)
        return f"the ratios of mode{'s' * (self.anchors.size > 1)} {names} to {of}"

    def predicted_hz(self, nominal_hz) -> np.ndarray:
        """Where each mode of ``nominal_hz`` (Hz, shape (m,)) lies by the trend (Hz, shape (m,))."""
        f = np.asarray(nominal_hz, float)
        return f * np.exp(self.intercept + self.slope_per_hz * f)


def ratio_trend(frequencies_hz, nominal_hz, admissible) -> RatioTrend:
    """The trend of ``ln(f / f_model)`` over the modes whose band holds one pole (a least-squares line in
    ``f_model``; a constant with one such mode; the model itself with none).

    Parameters
    ----------
    frequencies_hz : array, shape (k,)      a test's poles (Hz)
    nominal_hz : array, shape (m,)          the model's modes (Hz)
    admissible : bool array, shape (k, m)   which pole may pair with which mode (its pairing band; with shapes,
                                            its MAC): :func:`learn.pairs.measured.pair_modes_by_frequency`'s rule
    """
    f, nominal = np.asarray(frequencies_hz, float), np.asarray(nominal_hz, float)
    ok = np.asarray(admissible, bool).reshape(f.size, nominal.size)
    anchors = np.flatnonzero(ok.sum(axis=0) == 1)
    if anchors.size == 0:
        return RatioTrend(anchors, 0.0, 0.0)
    x = nominal[anchors]
    y = np.log(f[np.argmax(ok[:, anchors], axis=0)] / x)
    if anchors.size == 1 or np.ptp(x) == 0.0:
        return RatioTrend(anchors, float(np.mean(y)), 0.0)
    slope, intercept = np.polyfit(x, y, 1)
    return RatioTrend(anchors, float(intercept), float(slope))


def trend_picks(frequencies_hz, nominal_hz, admissible) -> tuple[np.ndarray, RatioTrend]:
    """For each mode whose pairing band holds two or more poles, the pole nearest (in ``|ln f|``) where the
    :func:`ratio_trend` of the others puts it: ``(picks, trend)``, ``picks`` int (m,), the pole's index, -1 for a
    mode with one pole or none (the nearest pole to the model's frequency then is the only candidate or nothing)."""
    f, nominal = np.asarray(frequencies_hz, float), np.asarray(nominal_hz, float)
    ok = np.asarray(admissible, bool).reshape(f.size, nominal.size)
    trend = ratio_trend(f, nominal, ok)
    picks = np.full(nominal.size, -1)
    contested = np.flatnonzero(ok.sum(axis=0) >= 2)
    if contested.size:
        gap = np.where(ok[:, contested], np.abs(np.log(f[:, None] / trend.predicted_hz(nominal[contested])[None])),
                       np.inf)                                           # (k, c)
        picks[contested] = np.argmin(gap, axis=0)
    return picks, trend


def choice_texts(frequencies_hz, nominal_hz, admissible, which, modes, of: str = "the model") -> dict[int, str]:
    """Why each pole paired with a mode whose band holds several poles is that mode, by the pole's index:
    ``"of 1166.2, 1226.8 Hz in its band; the ratios of modes 1, 2, 3, 4 to the model put it at 1153 Hz (the
    model: 1257 Hz)"``. ``which``: each pole's 0-based mode (-1 none); ``modes``: the 1-based mode numbers (m,);
    ``of``: what ``nominal_hz`` are (``"the baselines"``: their modes)."""
    f, nominal = np.asarray(frequencies_hz, float), np.asarray(nominal_hz, float)
    ok = np.asarray(admissible, bool).reshape(f.size, nominal.size)
    trend = ratio_trend(f, nominal, ok)
    out = {}
    for i, j in enumerate(np.asarray(which, int)):
        if j >= 0 and ok[:, j].sum() >= 2:
            band = ", ".join(f"{x:.5g}" for x in np.sort(f[ok[:, j]]))
            out[i] = (f"of {band} Hz in its band; {trend.basis(modes, of)} put it at "
                      f"{trend.predicted_hz(nominal[j]):.4g} Hz ({of}: {nominal[j]:.4g} Hz)")
    return out
