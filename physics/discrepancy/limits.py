"""Detection limits: how large an effect that was not named would have to be to be named."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from physics import effects as fx
from physics.beam import Beam
from physics.discrepancy.candidates import Param, effect_params, has_position
from physics.discrepancy.fitting import Fit, Problem, model_params
from physics.discrepancy.measurement import Measurement, Noise
from physics.discrepancy.model import dashpot_damping_per_c, pair_modes_by_mac, predict
from physics.discrepancy.selection import BIC_SIGNIFICANT

__all__ = ["DETECTION_POWER", "SIZES", "DetectionLimit", "detection_limits"]

#: Probability that an effect at its detection limit is named (one less the false-negative rate, as for a limit
#: of detection): below the limit an effect may be present and unnamed.
DETECTION_POWER = 0.9


#: effect -> (dimensionless size reported, its parameter, True when a *smaller* value is the stronger effect).
SIZES = {
    "shear_deformation": ("kGA_L2_over_EI", "kGA_N", True),
    "rotary_inertia": ("rho_I_over_m_h2_12", "rho_I_kg_m", False),
    "root_flexibility": ("k_L_over_EI", "k_theta_Nm_rad", True),
    "clamp_flexibility": ("k_L_over_EI", "k_theta_Nm_rad", True),
    "bearing_flexibility": ("k_L_over_EI", "k_theta_Nm_rad", False),
    "suspension": ("k_L3_over_EI", "k_y_N_m", False),
    "added_mass": ("mass_fraction_of_m_L", "mass_kg", False),
    "local_damping": ("added_damping_ratio", "c_Ns_m", False),
}


@dataclass(frozen=True)
class DetectionLimit:
    """How large an effect that was not named would have to be to be named with these data and this noise.

    The effect's noise-free signature, after the refit of every other
    parameter of the final model (globals, named effects) has absorbed what
    it can (linearised), has a squared norm ``lambda`` in noise units (each
    block divided by the last round's ``c_b``). Fitting its ``k`` parameters
    then lowers chi^2 by a noncentral ``chi^2_k(lambda)``, and the effect is
    named when the drop reaches ``BIC_SIGNIFICANT + k ln n``. The limit is the
    size whose ``lambda`` makes that happen with probability
    :data:`DETECTION_POWER`. The leave-one-mode-out check is not part of it.

    Attributes
    ----------
    effect : str
    quantity : str
        The dimensionless size (:data:`SIZES`): ``k_L_over_EI`` (clamp and bearing springs),
        ``k_L3_over_EI`` (suspension springs), ``kGA_L2_over_EI``,
        ``mass_fraction_of_m_L``, ``rho_I_over_m_h2_12`` or ``added_damping_ratio``
        (a dashpot's first-order added damping ratio ``c phi_r(x)^2 / (2 w_r)``,
        largest over the measured modes, mass-normalised ``phi``).
    named_below : bool
        True when the effect is named for a size *below* the limit (a clamp
        spring or shear rigidity: softer is stronger), else above (a bearing
        or suspension spring: stiffer is stronger).
    limit : float or None
        At the most sensitive measured position for position-bearing effects;
        None when not detectable anywhere within the candidate's bounds.
    limit_by_x_m : dict
        Position (m) -> limit (None: not detectable there), for added mass and local damping.
    threshold_chi2 : float
        The chi^2 drop the score requires.
    noncentrality : float
        ``lambda`` at the limit.
    """

    effect: str
    quantity: str
    named_below: bool
    limit: float | None
    limit_by_x_m: dict = field(default_factory=dict)
    threshold_chi2: float = float("nan")
    noncentrality: float = float("nan")

    def below_limit(self, size: float, x_m: float | None = None) -> bool:
        """True when an effect of ``size`` (at ``x_m``, nearest measured position) is too weak to be named."""
        lim = self.limit
        if x_m is not None and self.limit_by_x_m:
            lim = self.limit_by_x_m[min(self.limit_by_x_m, key=lambda x: abs(x - x_m))]
        if lim is None:
            return True
        return size > lim if self.named_below else size < lim

    def text(self) -> str:
        side = "<=" if self.named_below else ">="
        if self.limit is None:
            return f"{self.effect}: not detectable within its bounds with these data and this noise"
        where = ""
        if self.limit_by_x_m:
            best = min((x for x, v in self.limit_by_x_m.items() if v is not None),
                       key=lambda x: self.limit_by_x_m[x] * (-1 if self.named_below else 1))
            others = ", ".join(f"{v:.3g} at {x:.3g} m" if v is not None else f"none at {x:.3g} m"
                               for x, v in self.limit_by_x_m.items() if x != best)
            where = f" at x = {best:.3g} m" + (f" ({others})" if others else "")
        return f"{self.effect}: named only for {self.quantity} {side} {self.limit:.3g}{where}"

    @classmethod
    def from_dict(cls, effect: str, d: dict) -> "DetectionLimit":
        """The limit of :meth:`to_dict`'s form (e.g. read back from ``--json``)."""
        return cls(effect, d["quantity"], d["named_when"] == "below", d["limit"],
                   {float(x): v for x, v in d["limit_by_x_m"].items()}, d["threshold_chi2"], d["noncentrality"])

    def to_dict(self) -> dict:
        return {"quantity": self.quantity, "named_when": "below" if self.named_below else "above",
                "limit": self.limit, "limit_by_x_m": {f"{x:.6g}": v for x, v in self.limit_by_x_m.items()},
                "threshold_chi2": self.threshold_chi2, "noncentrality": self.noncentrality,
                "power": DETECTION_POWER, "text": self.text()}


def detection_limits(beam: Beam, meas: Measurement, noise: Noise, final: Fit, c_hat: dict, effects,
                     *, fixed=None, named=(), positions=None, n_elements: int = 40, pairs=None) -> dict:
    """:class:`DetectionLimit` of each of ``effects`` on top of the ``final`` model.

    Parameters
    ----------
    beam : Beam
        The nominal beam the fits started from.
    final : Fit
        The model with the named effects (its parameters are the linearisation point).
    c_hat : dict
        Variance inflation per data block of the last round (:class:`Step`).
    effects : sequence of str
        Candidates not named.
    fixed, named, positions, n_elements, pairs
        As in the search: the beam's own effects, the named effects, their
        discrete positions, the fitted mesh and the mode pairing.
    """
    fixed = {k: dict(v) for k, v in (fixed or {}).items()}
    positions = dict(positions or {})
    pairs = pair_modes_by_mac(meas, predict(beam, meas, n_elements)) if pairs is None else pairs
    fit_mass = meas.frf is not None
    nuis = model_params(beam, meas, named, positions, fit_mass)
    null = Problem(beam, meas, noise, fixed, nuis, positions, n_elements, pairs, fit_mass)
    u_n = _u_of(nuis, final, beam)
    blocks0 = null.blocks(null.predict(null.beam_at(u_n)[0]))
    weight = np.concatenate([np.full(v.size, 1 / math.sqrt(c_hat.get(k, 1.0))) for k, v in blocks0.items()])
    r0 = np.concatenate(list(blocks0.values()))
    jac = np.empty((r0.size, u_n.size))
    for i, p in enumerate(nuis):
        lo, hi = p.bounds()   # one-sided at a bound (a position fitted at the tip)
        up, dn = u_n.copy(), u_n.copy()
        up[i], dn[i] = min(u_n[i] + 1e-6, hi), max(u_n[i] - 1e-6, lo)
        jac[:, i] = (null.residual(up) - null.residual(dn)) / (up[i] - dn[i])
    q, sv, _ = np.linalg.svd(jac * weight[:, None], full_matrices=False)
    q = q[:, sv > 1e-9 * sv[0]] if sv.size and sv[0] > 0 else q[:, :0]
    out = {}
    for effect in effects:
        p = effect_params(effect, beam, meas, False)[0]
        xs = list(beam.measured_x_m) if has_position(effect) else [None]
        k_new = 1 + (xs[0] is not None)    # a position, continuous or among the measured points, counts as one
        thr = BIC_SIGNIFICANT + k_new * math.log(final.n_obs)
        lam_lim = _noncentrality(thr, k_new)
        by_x = {}
        for x in xs:
            pos = positions if x is None else {**positions, effect: x}
            prob = Problem(beam, meas, noise, fixed, nuis + [p], pos, n_elements, pairs, fit_mass)

            def lam(u_e):
                d = (prob.residual(np.append(u_n, u_e)) - r0) * weight
                return float(d @ d - np.sum((q.T @ d) ** 2))

            by_x[x] = _crossing(lam, p, lam_lim, weak_at_upper=SIZES[fx.effect_of(effect)][2])
        quantity, _, named_below = SIZES[fx.effect_of(effect)]
        per_unit = _size_factors(effect, final.beam, meas, xs, n_elements)
        lims = {x: (None if v is None else v * per_unit[x]) for x, v in by_x.items()}
        found = [v for v in lims.values() if v is not None]
        best = (min(found) if not named_below else max(found)) if found else None
        out[effect] = DetectionLimit(effect, quantity, named_below, best, lims if xs[0] is not None else {}, thr,
                                     lam_lim)
    return out


def _u_of(params: list, fit: Fit, beam: Beam) -> np.ndarray:
    """Optimisation vector of ``params`` at the values of ``fit``."""
    u = []
    for p in params:
        v = (fit.parameters["EI_Nm2"] / beam.EI_Nm2 if p.key == "EI_scale" else
             fit.parameters["mass_per_length_kg_m"] / beam.mass_per_length_kg_m if p.key == "mass_scale" else
             fit.parameters[p.key])
        u.append(math.log(v) if p.log else v)
    return np.asarray(u, dtype=float)


def _size_factors(effect: str, nb: Beam, meas: Measurement, xs: list, n_elements: int) -> dict:
    """Position (or None) -> dimensionless size per unit of the effect's parameter on the calibrated beam ``nb``
    (:data:`SIZES`); a dashpot's is the largest first-order added damping ratio over the measured modes."""
    L, EI, m = nb.length_m, nb.EI_Nm2, nb.mass_per_length_kg_m
    if fx.effect_of(effect) == "local_damping":
        per_c = dashpot_damping_per_c(nb, xs, meas.n_modes, n_elements)
        return {x: float(np.max(row)) for x, row in zip(xs, per_c)}
    effect = fx.effect_of(effect)
    factor = {"shear_deformation": L**2 / EI, "rotary_inertia": 12 / (m * nb.thickness_m**2),
              "root_flexibility": L / EI, "clamp_flexibility": L / EI, "bearing_flexibility": L / EI,
              "suspension": L**3 / EI, "added_mass": 1 / (m * L)}[effect]
    return dict.fromkeys(xs, factor)


def _noncentrality(thr: float, k: int, power: float = DETECTION_POWER) -> float:
    """``lambda`` with ``P(chi^2_k(lambda) >= thr) = power`` (noncentral chi^2 with ``k`` degrees of freedom)."""
    from scipy.optimize import brentq
    from scipy.stats import ncx2

    return float(brentq(lambda lam: ncx2.sf(thr, k, lam) - power, 1e-9, 10 * thr + 100))


def _crossing(lam, p: Param, thr: float, weak_at_upper: bool, n_scan: int = 13, n_bisect: int = 14):
    """Weakest parameter value (physical units) in ``p``'s bounds where ``lam`` reaches ``thr``; None if none."""
    a, b = p.bounds()
    grid = np.linspace(b, a, n_scan) if weak_at_upper else np.linspace(a, b, n_scan)
    prev = None
    for u in grid:
        if lam(u) >= thr:
            if prev is None:
                return p.to_phys(u)
            lo, hi = prev, u        # lam(lo) < thr <= lam(hi)
            for _ in range(n_bisect):
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if lam(mid) >= thr else (mid, hi)
            return p.to_phys(hi)
        prev = u
    return None
