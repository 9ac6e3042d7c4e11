"""Which model mode each measured mode is, checked before any fit: a pairing that cannot be right stops the workflow
with its likely cause (a spurious pole, a mode below the band, a mode missed) instead of a calibration fitted to it.

The rule that pairs is given (:data:`PairingRule`): ``beam-damage discrepancy`` passes the one ``classify`` uses,
:func:`learn.pairs.measured.pair_modes_by_frequency` (frequency order kept, a pairing beyond a factor 1.35 never kept, a
MAC below 0.5 never kept with two or more sensors); without one, :func:`physics.discrepancy.model.pair_modes_by_mac`
pairs every measured mode (largest MAC, else nearest frequency after the median ratio).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from physics.errors import BeamDamageError
from physics.modal import mac
from physics.discrepancy.measurement import Measurement
from physics.discrepancy.model import Prediction, pair_modes_by_mac
from physics.ratio_trend import MIN_PAIR_MAC, RATIO_TOLERANCE, trend_picks

__all__ = ["ImplausibleTest", "Pairing", "PairingRule", "STOP_CHI2_PER_DOF", "failed_noise_check",
           "implausible_pairing", "pair_measured"]

#: ``rule(measured_hz (k,), model_hz (m,) ascending, shape_mac=(k, m) or None) -> (k,)`` 0-based model mode of each
#: measured mode, -1 for none.
PairingRule = Callable[..., np.ndarray]

#: A calibrated model whose chi^2/dof against its own noise exceeds this (two orders of magnitude) explains the data
#: no better than a wrong pairing or a wrong model would: no beam file is written.
STOP_CHI2_PER_DOF = 100.0


class ImplausibleTest(BeamDamageError):
    """The measured modes cannot be paired with the model's, or the calibrated model fails its own noise check by
    orders of magnitude: nothing is written. ``result`` holds the JSON-ready findings (``stopped``, ``causes``,
    ``pairing``)."""

    def __init__(self, message: str, result: dict):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class Pairing:
    """Measured modes paired with the nominal model's.

    Attributes
    ----------
    model_index : ndarray of int, shape (n_measured,)
        0-based model mode of each measured mode, -1 for none.
    measured_hz : ndarray, shape (n_measured,)
    model_hz : ndarray, shape (n_model,)
        The nominal model's bending frequencies the rule chose from (ascending).
    unpaired : tuple of str
        One line per measured mode no model mode explains (each stops the workflow).
    skipped : tuple of str
        One line per model mode below the highest paired one that no measured mode is (a mode below the band or
        missed; the fit goes on without it).
    """

    model_index: np.ndarray
    measured_hz: np.ndarray
    model_hz: np.ndarray
    unpaired: tuple = ()
    skipped: tuple = ()

    @property
    def plausible(self) -> bool:
        return not self.unpaired and int(np.sum(self.model_index >= 0)) >= 2

    def to_list(self) -> list[dict]:
        """``[{"measured_hz", "model_mode" (1-based or None), "model_hz", "error_pct"}]`` per measured mode."""
        out = []
        for f, j in zip(self.measured_hz, self.model_index):
            m = None if j < 0 else float(self.model_hz[j])
            out.append({"measured_hz": float(f), "model_mode": None if j < 0 else int(j) + 1, "model_hz": m,
                        "error_pct": None if m is None else 100 * (m / float(f) - 1)})
        return out


def pair_measured(meas: Measurement, pred: Prediction, rule: PairingRule | None = None, band_hz=None) -> Pairing:
    """The pairing of ``meas`` with the nominal prediction ``pred`` by ``rule`` (module docstring), and what in it
    cannot be right; an unpaired mode nearer than a model mode's partner to where the other pairs' ratio trend puts
    it (:func:`physics.ratio_trend.trend_picks`, classify's) names the partner the likelier spurious pole.

    Parameters
    ----------
    band_hz : (lo, hi), optional
        The band the modes were measured in (Hz): a model mode below it is named as such.
    """
    f = meas.frequencies_hz
    model_hz = np.asarray(pred.frequencies_hz, float)
    if rule is None:
        return Pairing(pair_modes_by_mac(meas, pred), f, model_hz)
    shape_mac = mac(meas.shapes, pred.shapes) if meas.shapes is not None else None
    idx = np.asarray(rule(f, model_hz, shape_mac=shape_mac), int)
    unpaired = []
    for k in np.flatnonzero(idx < 0):
        j = int(np.argmin(np.abs(np.log(model_hz / f[k]))))
        taken = np.flatnonzero(idx == j)
        near = (f"model mode {j + 1} at {model_hz[j]:.4g} Hz, {100 * (model_hz[j] / f[k] - 1):+.1f} %"
                + (f", is the measured mode at {f[taken[0]]:.4g} Hz" if taken.size else ""))
        ok = idx[:, None] == np.arange(model_hz.size)[None]               # (k, m) the pairs, k a second pole of j
        ok[k, j] = True
        picks, trend = trend_picks(f, model_hz, ok)
        spurious = (f"; {trend.basis(np.arange(1, model_hz.size + 1))} put mode {j + 1} at "
                    f"{trend.predicted_hz(model_hz[j]):.4g} Hz: {f[taken[0]]:.4g} Hz is the likelier spurious pole"
                    if taken.size and picks[j] == k and trend.anchors.size else "")
        within = abs(model_hz[j] / f[k] - 1) <= RATIO_TOLERANCE
        if within and shape_mac is not None and shape_mac[k, j] < MIN_PAIR_MAC:
            why = (f"{near}, but the shapes' MAC {shape_mac[k, j]:.2f} is below the pairing rule's "
                   f"{MIN_PAIR_MAC:g}): a mode the effect reshaped (a mass or a spring near the sensors), a spurious "
                   "pole, or sensors placed elsewhere than the file says; leaving the mode out of the file lets the "
                   "rest be fitted")
        else:
            why = (f"{near}; the pairing rule keeps none beyond {100 * RATIO_TOLERANCE:g} %): a spurious pole "
                   "(noise, the fixture, a torsion or in-plane mode) or a beam file far from the test")
        unpaired.append(f"measured mode at {f[k]:.4g} Hz pairs with no model mode (nearest: {why}" + spurious)
    paired = idx[idx >= 0]
    skipped = []
    if paired.size:
        lo = None if band_hz is None else float(band_hz[0])
        for j in sorted(set(range(int(paired.max()))) - set(paired.tolist())):
            if lo is not None and model_hz[j] < lo:
                skipped.append(f"model mode {j + 1} ({model_hz[j]:.4g} Hz) lies below the band "
                               f"{band_hz[0]:g}-{band_hz[1]:g} Hz")
            else:
                skipped.append(f"model mode {j + 1} ({model_hz[j]:.4g} Hz) has no measured mode: missed "
                               "(a node of it at the drive point or the sensor, or under the noise floor)")
    if paired.size < 2 and not unpaired:
        unpaired.append(f"only {paired.size} measured mode{'s' * (paired.size != 1)} pair with the model's")
    return Pairing(idx, f, model_hz, tuple(unpaired), tuple(skipped))


def implausible_pairing(pairing: Pairing) -> ImplausibleTest:
    """The error that stops the workflow on an implausible ``pairing``: one line naming every cause."""
    causes = list(pairing.unpaired) + list(pairing.skipped)
    msg = "the measured modes do not pair with the model's, nothing written: " + "; ".join(causes)
    return ImplausibleTest(msg, {"stopped": msg, "causes": causes, "pairing": pairing.to_list()})


def failed_noise_check(check, residuals, pairing: Pairing | None) -> dict | None:
    """``{"stopped", "causes"}`` when the calibrated model's ``check`` (:class:`physics.discrepancy.NoiseCheck`)
    gives chi^2/dof above :data:`STOP_CHI2_PER_DOF`, else None; the causes name the modes the pairing left out
    and the worst data block's worst mode (its ``residuals``, :class:`physics.discrepancy.ModeResiduals`)."""
    blocks = {k: b["chi2_per_dof"] for k, b in check.blocks.items() if np.isfinite(b["chi2_per_dof"])}
    worst = max(blocks, key=blocks.get) if blocks else "frequencies"
    overall = np.isfinite(check.chi2_per_dof) and check.chi2_per_dof > STOP_CHI2_PER_DOF
    if not (overall or (blocks and blocks[worst] > STOP_CHI2_PER_DOF)):   # a block's failure, however many
        return None                                                       # other residuals fit, fails too
    causes = list(pairing.skipped) if pairing is not None else []
    r = residuals
    if worst == "FRF" and r.frf_band_error_db is not None:
        j = int(np.nanargmax(r.frf_band_error_db))
        causes.append(f"the FRF's level around measured mode {j + 1} ({r.measured_hz[j]:.4g} Hz) differs from the "
                      f"model's by {r.frf_band_error_db[j]:.1f} dB rms (FRF block chi2/dof {blocks[worst]:.3g}): a "
                      "noise floor in that band, the drive point, the sensor's position or the file's units")
    elif worst in ("mode shapes", "complex shapes") and r.mac is not None:
        j = int(np.argmin(r.mac))
        causes.append(f"measured mode {j + 1}'s shape ({r.measured_hz[j]:.4g} Hz) has MAC {r.mac[j]:.2f} with the "
                      "model's: a mode paired with the wrong one, or the sensors placed elsewhere than the file says")
    else:
        j = int(np.argmax(np.abs(r.frequency_error_pct)))
        causes.append(f"measured mode {j + 1} ({r.measured_hz[j]:.4g} Hz) stays {r.frequency_error_pct[j]:+.2f} % "
                      "off the calibrated model: a mode paired with the wrong one, a spurious pole, or an effect no "
                      "candidate models")
    level = (f"chi2/dof {check.chi2_per_dof:.3g} > {STOP_CHI2_PER_DOF:g}" if overall else
             f"the {worst} block's chi2/dof {blocks[worst]:.3g} > {STOP_CHI2_PER_DOF:g}, {check.chi2_per_dof:.3g} "
             "over every residual")
    msg = (f"the calibrated model fails its own noise check by orders of magnitude ({level}), no beam file written; "
           "likely cause: " + "; ".join(causes))
    return {"stopped": msg, "causes": causes}
