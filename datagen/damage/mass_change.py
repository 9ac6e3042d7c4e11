"""A point mass added to or lost from the beam: damage kind ``"mass_change"`` (:class:`MassChange`).

A mass change ``k`` has a position ``x_k`` (m, ``0 <= x <= L``) and a signed mass
``m_k`` (kg): positive for a mass added (a sensor, debris, water), negative for
a mass lost (corrosion, a part broken off). The current state's mass matrix gains
the consistent point mass ``m_k N(x_k)^T N(x_k)`` with the Hermite translation
row ``N`` of the truth element holding ``x_k`` (the same row as
:func:`physics.effects.point_mass_matrix`; no rotary inertia). Stiffness and
damping matrices are unchanged.

To first order, a mass-normalised mode ``phi_r`` changes by
``d(omega_r^2) = -omega_r^2 m_k phi_r(x_k)^2``: a mass added lowers the
natural frequencies, a mass lost raises them, most where the mode moves most.

Size
----
The size is the signed mass ratio ``m_k / (m L)``, the change over the
specimen's beam mass (mass per length ``m`` times length ``L``).

Mass lost
---------
Taking a point mass ``m_k < 0`` off the consistent mass matrix leaves it
positive definite only while ``|m_k| < 1 / (N M^-1 N^T)``, smallest at the tip:
``0.0722 m l_e`` for an element of length ``l_e`` (the same on any mesh). A
mass lost is therefore bounded by half of that, :data:`MAX_LOST_ELEMENT_FRACTION`
of one truth element's mass (``mass_ratio >= -0.0018`` on the default 20
elements); larger losses are losses of section, not point masses.
"""

from __future__ import annotations

import numpy as np

from datagen.checks import value_range
from physics.errors import ConfigError

__all__ = ["MAX_LOST_ELEMENT_FRACTION", "MassChange", "point_mass_corrections"]

#: Largest point mass lost, as a fraction of one truth element's mass (half of what keeps M positive definite).
MAX_LOST_ELEMENT_FRACTION = 0.036


def point_mass_corrections(x_m, mass_kg, length_m, n_elements):
    """Element mass corrections ``m N^T N`` of point masses (batched; NaN positions change nothing).

    Parameters
    ----------
    x_m, mass_kg : ndarray, shape (B, S)
        Positions (m) and signed masses (kg); NaN for absent masses.
    length_m : float
    n_elements : int    equal elements of the truth mesh

    Returns
    -------
    ndarray, shape (B, n_elements, 4, 4)   (kg, kg m, kg m^2), element DOFs ``[w1, theta1, w2, theta2]``
    """
    le = length_m / n_elements
    ok = np.isfinite(x_m) & np.isfinite(mass_kg)
    x = np.clip(np.where(ok, x_m, 0.0), 0.0, length_m)
    m = np.where(ok, mass_kg, 0.0)
    e = np.clip(np.floor(x / le).astype(int), 0, n_elements - 1)                # (B, S)
    s = x / le - e
    N = np.stack([1 - 3 * s**2 + 2 * s**3, le * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, le * (-s**2 + s**3)],
                 axis=-1)                                                         # (B, S, 4)
    onehot = (e[..., None] == np.arange(n_elements)).astype(float)                # (B, S, E)
    return np.einsum("bs,bse,bsi,bsj->beij", m, onehot, N, N)


class MassChange:
    """Damage kind ``"mass_change"``: signed point masses (see the module docstring).

    Config keys besides the generic ones: ``n_masses`` (range of the count per damaged
    sample) and ``mass_ratio`` (range of the signed mass over the specimen's beam mass,
    uniform). Parameter per damage: ``mass_kg``. Size: the signed mass ratio ``m_k / (m L)``.
    """

    kind = "mass_change"
    defaults = {
        "n_masses": [1, 1],
        "mass_ratio": [-0.0015, 0.015],  # signed mass / beam mass: lost (< 0) or added (> 0)
    }
    units = {"mass_kg": "kg (signed: > 0 added, < 0 lost)"}
    sample_units: dict = {}
    size_meaning = "signed mass ratio m / (m_per_length L): > 0 mass added, < 0 mass lost"
    perturbs = "mass"

    def validate(self, d: dict, cfg: dict) -> None:
        d["n_masses"] = value_range("damage.n_masses", d["n_masses"], lo=0, hi=8, integer=True)
        d["mass_ratio"] = value_range("damage.mass_ratio", d["mass_ratio"], lo=-1.0, hi=1.0)
        lost = MAX_LOST_ELEMENT_FRACTION / cfg["mesh"]["truth_elements"]
        if d["mass_ratio"][0] < -lost:
            n_el = cfg["mesh"]["truth_elements"]
            raise ConfigError(f"config key 'damage.mass_ratio' must be >= {-lost:.3g}: a point mass lost may be at "
                              f"most {MAX_LOST_ELEMENT_FRACTION:.1%} of one of the {n_el} truth elements' mass (the "
                              f"mass matrix stays positive definite), got {d['mass_ratio']!r}")

    def check_beam(self, d: dict, preset, section: dict) -> None:
        """Any beam holds a point mass."""

    def draw(self, rng: np.random.Generator, n: int, cfg: dict, setup) -> dict:
        """Counts, positions and signed masses of ``n`` samples (mass from the specimen's nominal beam mass)."""
        d = cfg["damage"]
        lo, hi = d["n_masses"]
        smax = max(hi, 1)
        k = rng.integers(lo, hi + 1, size=n)
        u = rng.random((n, smax, 2))
        k = np.where(rng.random(n) < d["intact_fraction"], 0, k)
        present = np.arange(smax)[None, :] < k[:, None]
        (a, b), (ra, rb) = d["position_fraction"], d["mass_ratio"]
        beam_mass_kg = setup.preset.mass_per_length_kg_m * setup.length_m
        return {"n_damages": k, "x_m": np.where(present, (a + (b - a) * u[..., 0]) * setup.length_m, np.nan),
                "mass_kg": np.where(present, (ra + (rb - ra) * u[..., 1]) * beam_mass_kg, np.nan)}

    def corrections(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements, shear_phi=0.0):
        return point_mass_corrections(x_m, params["mass_kg"], length_m, n_elements), None, None

    def size(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return params["mass_kg"] / (np.asarray(mass_per_length_kg_m, float)[:, None] * length_m)

    def columns(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return {}, {"mass_kg": params["mass_kg"]}

    def describe(self, x_m: float, size: float, preset, section: dict | None = None) -> str:
        """``"a mass added at x = 0.300 m of 1.2 % of the beam's mass"`` (or lost, for a negative size)."""
        return f"a mass {'added' if size >= 0 else 'lost'} at x = {x_m:.3f} m of {abs(size):.2%} of the beam's mass"
