"""The random draws of a batch: specimens, damage, the day-to-day changes and all measurement noise.

All randomness of a batch is drawn up front by :func:`draw_batch` in a fixed order, so the batched path
:func:`datagen.pipeline.simulate_batch` and the per-sample path :func:`datagen.naive.simulate_naive` consume the
same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from datagen.config import REPEATABILITY
from datagen.setup import Setup
from datagen.specimen import draw_specimens
from physics.errors import ConfigError

__all__ = ["BatchInputs", "draw_batch"]

@dataclass(frozen=True)
class BatchInputs:
    """All random draws of a batch of ``B`` samples (see :func:`draw_batch`).

    Specimen: ``EI_Nm2``, ``mass_per_length_kg_m``, ``damping_scale`` (-),
    ``root_spring_Nm_rad`` (``inf`` for a rigid clamp) each (B,). Damage: ``n_damages`` (B,), centres
    ``x_m`` (B, S) NaN-padded and ``damage``, the parameters of the damage model (name -> (B, S),
    its ``draw`` returns). Between the test days (B,):
    ``temperature_stiffness_change`` (relative EI change of the current state)
    and ``root_spring_change`` (relative change of the root spring). Modal
    measurement noise (standard normal, per state): ``n_freq``, ``n_zeta``
    (B, 2, 4), ``n_shape`` (B, 2, 4, 4, 2). FRF noise: ``noise_level`` (relative
    to |H|), ``noise_floor`` (relative to each FRF's peak) and the uint64
    ``noise_seed`` of the counter-based stream the FRF noise is drawn from (B,), and the factor
    ``modal_noise_scale`` on the modal noise's standard deviations (B,); the specimen's
    ``shear_flexibility`` ``EI / (kGA L^2)`` (B,). Repeatability of the tests (B,) each
    (``measurement.*_scatter``): ``frequency_scatter``, ``damping_scatter`` and ``shape_scatter``, stds of
    independent per-mode changes of each test added in quadrature to the modal noise, and ``gain_scatter``, the
    std of each sensor channel's relative gain error per test, with its standard normal draws ``n_gain``
    (B, 2, S) (zeros when ``gain_scatter`` is 0). ``support_changed`` (B,) bool: an intact specimen whose
    supports change between the days beyond re-clamping (``specimen.support_change_fraction``); its
    ``root_spring_change`` is then ``factor - 1`` with the factor drawn from ``specimen.support_change_factor``
    (softer or stiffer alike). Supports without a spring (pinned ends without bearing springs) change none.
    With ``measurement.modal_noise = "output-only"``: ``sensor_noise`` (relative to the response RMS) and
    ``record_length_s`` (s) of each sample's tests (B,), drawn after everything else (None otherwise).
    """

    EI_Nm2: np.ndarray
    mass_per_length_kg_m: np.ndarray
    damping_scale: np.ndarray
    root_spring_Nm_rad: np.ndarray
    n_damages: np.ndarray
    x_m: np.ndarray
    damage: dict
    temperature_stiffness_change: np.ndarray
    root_spring_change: np.ndarray
    n_freq: np.ndarray
    n_zeta: np.ndarray
    n_shape: np.ndarray
    noise_level: np.ndarray
    noise_floor: np.ndarray
    noise_seed: np.ndarray
    modal_noise_scale: np.ndarray
    shear_flexibility: np.ndarray
    frequency_scatter: np.ndarray
    damping_scatter: np.ndarray
    shape_scatter: np.ndarray
    gain_scatter: np.ndarray
    n_gain: np.ndarray
    support_changed: np.ndarray
    sensor_noise: np.ndarray | None = None
    record_length_s: np.ndarray | None = None

    def __len__(self):
        return self.EI_Nm2.shape[0]

    def take(self, i) -> "BatchInputs":
        """Sub-batch by index (slice or array)."""
        def part(k):
            v = getattr(self, k)
            return {p: a[i] for p, a in v.items()} if k == "damage" else None if v is None else v[i]
        return BatchInputs(**{k: part(k) for k in self.__dataclass_fields__})


def _uniform(u, lo_hi, log=False):
    """Uniform (log-uniform when ``log`` and ``lo > 0``) draws in a range ``[lo, hi]``, or a fixed number."""
    lo, hi = (lo_hi, lo_hi) if np.isscalar(lo_hi) else lo_hi
    if lo == hi:
        return np.full(u.shape, float(lo))
    if log and lo > 0:
        return np.exp(np.log(lo) + (np.log(hi) - np.log(lo)) * u)
    return lo + (hi - lo) * u


def draw_batch(rng: np.random.Generator, n: int, setup: Setup) -> BatchInputs:
    """Draw specimens, damage, day-to-day changes and all measurement noise of ``n`` samples, in a fixed order."""
    cfg = setup.cfg
    sp = draw_specimens(rng, n, cfg, setup.preset, setup.root_spring_relative, setup.shear_band)
    dmg = setup.damage.draw(rng, n, cfg, setup)
    S, m = setup.n_meas, setup.n_modes
    nf = rng.standard_normal((n, 2, m))
    nz = rng.standard_normal((n, 2, m))
    ns = rng.standard_normal((n, 2, S, m, 2))
    u = rng.random((n, 4))
    seeds = rng.integers(0, np.iinfo(np.uint64).max, size=n, dtype=np.uint64, endpoint=True)
    u_scale = rng.random(n)
    spc, meas = cfg["specimen"], cfg["measurement"]
    scatter = {k: _uniform(np.zeros(n) if meas[k][0] == meas[k][1] else rng.random(n), meas[k], log=True)
               for k in REPEATABILITY}                                     # one value: not drawn
    n_gain = rng.standard_normal((n, 2, S)) if meas["gain_scatter"][1] > 0 else np.zeros((n, 2, S))
    change = _uniform(u[:, 1], spc["root_spring_change"])
    support = np.zeros(n, bool)
    if spc["support_change_fraction"] > 0 and (setup.spring or setup.day_spring_dofs.size):   # a spring to change
        v = rng.random((n, 3))
        support = (dmg["n_damages"] == 0) & (v[:, 0] < spc["support_change_fraction"])
        factor = _uniform(v[:, 1], spc["support_change_factor"], log=True) ** np.where(v[:, 2] < 0.5, -1, 1)
        change = np.where(support, factor - 1, change)
    if not np.all(np.isfinite(sp["root_spring_Nm_rad"])) and setup.spring:
        raise ConfigError("config key 'specimen.root_spring_relative' gave an infinite spring")
    oma = {}
    if meas["modal_noise"] == "output-only":       # drawn last: the other draws stay those of the other modes
        u_oma = rng.random((n, 2))
        oma = {"sensor_noise": _uniform(u_oma[:, 0], meas["sensor_noise"], log=True),
               "record_length_s": _uniform(u_oma[:, 1], meas["record_length_s"], log=True)}
    return BatchInputs(sp["EI_Nm2"], sp["mass_per_length_kg_m"], sp["damping_scale"], sp["root_spring_Nm_rad"],
                       dmg.pop("n_damages"), dmg.pop("x_m"), dmg,
                       _uniform(u[:, 0], spc["temperature_stiffness_change"]),
                       change, nf, nz, ns,
                       _uniform(u[:, 2], meas["frf_noise"], log=True),
                       _uniform(u[:, 3], meas["frf_noise_floor"], log=True), seeds,
                       _uniform(u_scale, meas["modal_noise_scale"], log=True), sp["shear_flexibility"],
                       *(scatter[k] for k in REPEATABILITY), n_gain, support, **oma)
