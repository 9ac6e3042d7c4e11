"""What every damage kind's ``draw`` and ``validate`` share: the damage counts of a batch, and the bound on a
damage's extra stiffness-proportional damping."""

from __future__ import annotations

import numpy as np

from physics.errors import ConfigError

__all__ = ["MAX_LOSS_FACTOR", "check_loss_factor", "draw_counts"]

#: Largest loss factor ``beta * omega`` of a damage's stiffness-proportional damping over the measurement band.
MAX_LOSS_FACTOR = 1.0


def draw_counts(rng: np.random.Generator, n: int, d: dict, count_key: str, n_uniform: int):
    """Damage counts of ``n`` samples and their uniform draws, in one order for every kind.

    Returns ``k`` (n,): each sample's count from ``d[count_key]`` (0 for the share ``d["intact_fraction"]``),
    ``u`` (n, S, n_uniform): uniforms in [0, 1) per damage slot (``S``: the largest count, at least 1), and
    ``present`` (n, S): the slots a sample's count fills.
    """
    lo, hi = d[count_key]
    smax = max(hi, 1)
    k = rng.integers(lo, hi + 1, size=n)
    u = rng.random((n, smax, n_uniform))
    k = np.where(rng.random(n) < d["intact_fraction"], 0, k)
    return k, u, np.arange(smax)[None, :] < k[:, None]


def check_loss_factor(key: str, beta_s, cfg: dict) -> None:
    """Refuse a damping range ``beta_s`` (s) of config key ``damage.<key>`` whose loss factor ``beta * omega``
    passes :data:`MAX_LOSS_FACTOR` below the top of the measurement band."""
    top_rad_s = cfg["measurement"]["band_rad_s"][1]
    if beta_s[1] * top_rad_s > MAX_LOSS_FACTOR:
        raise ConfigError(f"config key 'damage.{key}' must keep the loss factor beta*omega <= {MAX_LOSS_FACTOR:g} up "
                          f"to the top of measurement.band_rad_s ({top_rad_s:g} rad/s): beta <= "
                          f"{MAX_LOSS_FACTOR / top_rad_s:.3g} s, got {beta_s!r}")
