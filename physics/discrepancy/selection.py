"""Model selection: the score of a round, its decision, indistinguishable candidates and the chi^2 noise test."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from physics import effects as fx
from physics.beam import Beam
from physics.modal import undamped_modes
from physics.discrepancy.fitting import Fit
from physics.discrepancy.measurement import Measurement, Noise
from physics.discrepancy.model import aligned, predict

__all__ = ["BIC_SIGNIFICANT", "DISTINCT", "NOISE_DOF_MIN", "NoiseCheck", "P_NOISE", "Step", "decide",
           "estimate_noise_scale", "noise_check", "shape_positions"]


#: BIC drop that counts as significant ("strong evidence", Kass & Raftery 1995).
BIC_SIGNIFICANT = 6.0


#: Significant candidates whose fitted predictions differ from the winner's by less than this (sum of squared
#: differences in noise units, each block divided by the round's c_b) are indistinguishable: were one model true, the
#: other's expected chi^2 would exceed its own by about this much, so the data could not give strong evidence.
DISTINCT = BIC_SIGNIFICANT


@dataclass(frozen=True)
class Step:
    """One round of the search: the current model, every candidate fitted on top, the decision.

    Attributes
    ----------
    base : Fit
    candidates : tuple of Fit   (ascending score)
    named : str
        The effect named in this round, ``"none"`` when nothing is significant.
    indistinguishable_from : tuple of str
        Significant candidates whose fitted predictions of the measured
        quantities lie within the noise of the named one's (:data:`DISTINCT`).
    separating_measurement : str
        The measurement predicted to separate the named effect from the first of them.
    c_hat : dict
        Variance factor of each data block in the round (:func:`_round`):
        the noise scale squared (1, or below 1 with ``estimate_noise``) when the
        best fit's residual in the block is consistent with that noise, else
        its ``chi^2 / dof``.
    """

    base: Fit
    candidates: tuple
    named: str
    indistinguishable_from: tuple
    separating_measurement: str
    c_hat: dict = field(default_factory=dict)

    def score(self, fit: Fit) -> float:
        """``sum_b chi^2_b / c_b + k ln n`` (BIC with each block's noise inflated by ``c_b``; lower is better)."""
        chi2 = sum(v / self.c_hat.get(k, 1.0) for k, v in fit.chi2_blocks.items())
        return chi2 + fit.n_params * math.log(fit.n_obs)

    def distance(self, a: Fit, b: Fit) -> float:
        """Squared difference of two fits' whitened residuals (their predictions, in noise units), like chi^2."""
        return sum(float(np.sum((a.whitened[k] - b.whitened[k]) ** 2)) / self.c_hat.get(k, 1.0) for k in a.whitened)


@dataclass(frozen=True)
class NoiseCheck:
    """Is the residual of a fit consistent with the noise that whitened it?

    Attributes
    ----------
    chi2 : float
    dof : float   (FRF lines counted at their weight)
    chi2_per_dof : float
    p_value : float
        ``P(chi^2_dof >= chi2)``.
    consistent : bool
        ``P_LOW <= p_value <= 1 - P_LOW`` (two-sided, :data:`P_NOISE`).
    verdict : str
        ``"consistent"``, ``"residual larger than the noise"`` or ``"residual smaller than the noise"``.
    blocks : dict
        The same test per data block: ``{block: {"chi2", "dof", "chi2_per_dof", "p_value", "verdict"}}``.
    """

    chi2: float
    dof: int
    chi2_per_dof: float
    p_value: float
    consistent: bool
    verdict: str
    blocks: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"chi2": self.chi2, "dof": self.dof, "chi2_per_dof": self.chi2_per_dof, "p_value": self.p_value,
                "noise_consistent": self.consistent, "verdict": self.verdict, "blocks": self.blocks}


#: Two-sided level of the chi^2 test of the noise.
P_NOISE = 0.01


def _chi2_test(chi2: float, dof: int) -> tuple[float, str]:
    from scipy.stats import chi2 as chi2_dist

    if dof <= 0:
        return float("nan"), "no degrees of freedom left"
    p = float(chi2_dist.sf(chi2, dof))
    return p, ("residual larger than the noise" if p < P_NOISE / 2 else
               "residual smaller than the noise" if p > 1 - P_NOISE / 2 else "consistent")


def noise_check(fit: Fit) -> NoiseCheck:
    """chi^2 test of ``fit``'s whitened residual against its degrees of freedom, overall and per block."""
    p, verdict = _chi2_test(fit.chi2, fit.dof)
    blocks = {}
    for k, dof in fit.block_dof.items():
        pb, vb = _chi2_test(fit.chi2_blocks[k], dof)
        blocks[k] = {"chi2": fit.chi2_blocks[k], "dof": dof,
                     "chi2_per_dof": fit.chi2_blocks[k] / dof if dof > 0 else float("nan"), "p_value": pb,
                     "verdict": vb}
    consistent = verdict in ("consistent", "no degrees of freedom left")
    return NoiseCheck(fit.chi2, fit.dof, fit.chi2 / fit.dof if fit.dof > 0 else float("nan"), p, consistent,
                      verdict, blocks)


#: Fewest degrees of freedom of the fit whose chi^2/dof estimates the noise scale (``estimate_noise``): with
#: 10 the estimate of the variance has a relative std of ``sqrt(2/10) = 0.45``.
NOISE_DOF_MIN = 10


def _round(base: Fit, fits, scale2: float = 1.0) -> "Step":
    """A round's variance inflation per data block, from its best-fitting model.

    ``c_b`` is that model's ``chi^2_b / dof_b`` where the chi^2 test rejects the
    block's residual as larger than its noise times ``sqrt(scale2)``
    (quasi-likelihood, Burnham & Anderson 2002), else ``scale2``: a block the
    models cannot fit to its noise weighs by its actual scatter.
    """
    best = min([base, *fits], key=lambda f: f.chi2)
    c_hat = {}
    for k, dof in best.block_dof.items():
        _, verdict = _chi2_test(best.chi2_blocks[k] / scale2, dof)
        c_hat[k] = best.chi2_blocks[k] / dof if verdict == "residual larger than the noise" else scale2
    return Step(base, (), "none", (), "", c_hat)


def estimate_noise_scale(base: Fit, fits) -> tuple[float, int, str]:
    """``(s^2, dof, source)``: the variance factor from round 1's best-fitting model (:func:`analyse`)."""
    best = min([base, *fits], key=lambda f: f.chi2)
    if best.dof < NOISE_DOF_MIN:
        return 1.0, 0, (f"not estimated: the best-fitting model ({best.effect}) has {best.dof} degrees of freedom, "
                        f"fewer than {NOISE_DOF_MIN}")
    s2 = best.chi2 / best.dof
    p, verdict = _chi2_test(best.chi2, best.dof)
    src = f"chi2/dof {s2:.3g} of round 1's best-fitting model ({best.effect}) on {best.dof} dof, p = {p:.3g}"
    if verdict != "residual smaller than the noise":
        return 1.0, best.dof, src + "; the noise given is not rejected as too large and is kept"
    return s2, best.dof, src


def decide(ctx: dict, base: Fit, fits: list, scale2: float) -> "Step":
    """One round's decision: the best candidate named when significant, with its indistinguishable rivals."""
    probe = _round(base, fits, scale2)
    fits = sorted(fits, key=probe.score)
    best = fits[0]
    # an effect needs data left over to be tested: more observations than parameters and a held-out check
    testable = best.n_obs > best.n_params and np.isfinite(best.lomo)
    lomo_ok = testable and (not np.isfinite(base.lomo) or best.lomo <= base.lomo)
    significant = probe.score(best) <= probe.score(base) - BIC_SIGNIFICANT and lomo_ok
    if not significant:
        return replace(probe, candidates=tuple(fits))
    # indistinguishable: also significant, and predicting the measured quantities within the noise of the
    # winner's predictions (the data could not give strong evidence for one over the other)
    ties = tuple(f.effect for f in fits[1:]
                 if probe.score(f) <= probe.score(base) - BIC_SIGNIFICANT and probe.distance(f, best) < DISTINCT)
    sep = ""
    if ties:
        other = next(f for f in fits if f.effect == ties[0])
        sep = _separating_measurement(best, other, ctx["meas"], ctx["noise"], ctx["n_elements"])
    return replace(probe, candidates=tuple(fits), named=best.effect, indistinguishable_from=ties,
                   separating_measurement=sep)


def _separating_measurement(a: Fit, b: Fit, meas: Measurement, noise: Noise, n_elements: int) -> str:
    """The measurement where the two fitted models differ most, relative to its noise.

    Mode shapes are compared at the beam's measured positions, or at its quarter points when it has fewer than
    two (one sensor compares no shape)."""
    n = meas.n_modes
    xs, where = shape_positions(a.beam)
    probe = replace(meas, shapes=np.zeros((len(xs), n)), shape_x_m=xs, frf=None,
                    frf_frequency_hz=None, frf_response_x_m=(), frf_reference_x_m=())
    pa = predict(a.beam, probe, n_elements, n + 1)
    pb = predict(b.beam, probe, n_elements, n + 1)
    sf = float(np.max(np.asarray(noise.frequency)))
    options = []
    dn = abs(pa.frequencies_hz[n] / pb.frequencies_hz[n] - 1)
    options.append((dn / sf, f"natural frequency of mode {n + 1} ({100 * dn:.2g} % apart: "
                             f"{pa.frequencies_hz[n]:.1f} vs {pb.frequencies_hz[n]:.1f} Hz)"))
    ds = max(np.max(np.abs(aligned(pa.shapes[:, j], pb.shapes[:, j]))) for j in range(n))
    options.append((ds / noise.shape, f"mode shapes at {where} (largest normalised difference {ds:.2g})"))
    x_ref = a.beam.measured_x_m[0]
    anti = [_antiresonances_hz(f.beam, x_ref, n_elements, n - 1) for f in (a, b)]
    da = float(np.max(np.abs(anti[0] / anti[1] - 1)))
    options.append((da / sf, f"antiresonances of the driving-point FRF at x = {x_ref:.4g} m "
                             f"(up to {100 * da:.2g} % apart)"))
    return max(options)[1]


def shape_positions(beam: Beam) -> tuple[tuple, str]:
    """Positions (m) where two models' mode shapes are compared, and how to name them: the beam's measured
    positions, or its quarter points when it has fewer than two."""
    if len(beam.measured_x_m) >= 2:
        return tuple(beam.measured_x_m), "the measured points"
    return tuple(beam.length_m * k / 4 for k in range(1, 5)), "the quarter points (more sensors than the one measured)"


def _antiresonances_hz(beam: Beam, x_m: float, n_elements: int, n: int) -> np.ndarray:
    """Antiresonances of the driving-point receptance at ``x_m``: the frequencies with ``w(x_m)`` held at zero
    (of the bending modes)."""
    model = beam.fe_model(n_elements)
    t = fx.interpolation_matrix(model, [x_m])[0]
    # constrain t^T u = 0 by a null-space basis
    q, _ = np.linalg.qr(np.column_stack([t, np.eye(t.size)]))
    z = q[:, 1:]
    w, _ = undamped_modes(z.T @ model.M @ z, z.T @ model.K @ z)
    skip = max(beam.support.rigid_body_modes - 1, 0)   # a free-free beam held at x keeps its pitch about x
    return w[skip:skip + n] / (2 * np.pi)
