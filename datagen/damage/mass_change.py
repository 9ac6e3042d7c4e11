"""Mass added to or lost from the beam: damage kind ``"mass_change"`` (:class:`MassChange`).

A mass change ``k`` has a centre ``x_k`` (m, ``0 <= x <= L``), a signed mass ``m_k``
(kg: positive for a mass added, a sensor, debris, water; negative for a mass lost,
corrosion, material cut off a part, a part broken off) and a length ``w_k`` (m) over
which it is spread, ``[x_k - w_k/2, x_k + w_k/2]`` clipped to the beam. The current
state's mass matrix gains the consistent mass of a uniform line mass
``m_k / w_k`` over that length (each element it overlaps: ``(m_k / w_k) int N^T N ds``
over the overlap with the Hermite translation row ``N``, exact by 4-point Gauss
quadrature); a length of 0 is the point mass ``m_k N(x_k)^T N(x_k)`` (the row of
:func:`physics.effects.point_mass_matrix`). Stiffness and damping matrices are unchanged.

To first order, a mass-normalised mode ``phi_r`` changes by
``d(omega_r^2) = -omega_r^2 m_k phi_r(x_k)^2`` (for a short length): a mass added lowers
the natural frequencies, a mass lost raises them, most where the mode moves most.

Mass lost: what the beam carries there
--------------------------------------
A mass lost is taken first from the heaviest of the beam file's added masses within its
length (up to :data:`MAX_LOST_FRACTION` of that mass, a point mass taken off at that
mass's own position: material removed from a bolted mass), the rest from the beam's own
mass along its length, at most :data:`MAX_LOST_FRACTION` of the mass per length there: the
length grows beyond the drawn one to what carries the loss, up to the upper bound of
``width_fraction``. The mass matrix then stays positive definite (the line mass left is
positive everywhere). A lost mass no place of the beam carries within that bound is
refused in one line when the dataset is configured; where the drawn place carries less
(a window clipped at an end of the beam, no added mass there), the loss is what it
carries, and the stored size is the mass applied.

Size
----
The size is the signed mass ratio ``m_k / (m L)``, the change over the specimen's beam
mass (mass per length ``m`` times length ``L``). It is learned through ``asinh(size /
0.01)`` (:attr:`MassChange.size_transform`): signed, linear below 1 % of the beam's mass
and logarithmic above.
"""

from __future__ import annotations

import numpy as np

from datagen.checks import value_range
from datagen.damage.draws import draw_counts
from physics.errors import ConfigError

__all__ = ["MAX_LOST_FRACTION", "MassChange", "line_mass_corrections", "point_mass_corrections"]

#: Largest share of what the beam carries at a place (its own mass per length, an added mass) a loss may take.
MAX_LOST_FRACTION = 0.9

#: Gauss-Legendre points and weights on [0, 1] (4 points: exact for the degree-6 products of Hermite cubics).
_GAUSS_X, _GAUSS_W = (0.5 * (np.polynomial.legendre.leggauss(4)[0] + 1), 0.5 * np.polynomial.legendre.leggauss(4)[1])


def _hermite(s, le):
    """Hermite translation row ``[N1, N2, N3, N4]`` at local ``s = xi`` in [0, 1] (last axis 4)."""
    return np.stack([1 - 3 * s**2 + 2 * s**3, le * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, le * (-s**2 + s**3)],
                    axis=-1)


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
    N = _hermite(x / le - e, le)                                                  # (B, S, 4)
    onehot = (e[..., None] == np.arange(n_elements)).astype(float)                # (B, S, E)
    return np.einsum("bs,bse,bsi,bsj->beij", m, onehot, N, N)


def line_mass_corrections(x_m, width_m, mass_kg, length_m, n_elements):
    """Element mass corrections of uniform line masses ``mass_kg`` over ``[x - w/2, x + w/2]`` (clipped to the beam;
    batched; NaN entries change nothing; a width of 0 is the point mass of :func:`point_mass_corrections`).

    Parameters
    ----------
    x_m, width_m, mass_kg : ndarray, shape (B, S)   centres (m), lengths (m), signed masses (kg)

    Returns
    -------
    ndarray, shape (B, n_elements, 4, 4)
    """
    x_m, width_m, mass_kg = np.broadcast_arrays(*(np.asarray(a, float) for a in (x_m, width_m, mass_kg)))
    ok = np.isfinite(x_m) & np.isfinite(mass_kg) & np.isfinite(width_m)
    point = ok & (width_m <= 0)
    out = point_mass_corrections(np.where(point, x_m, np.nan), np.where(point, mass_kg, np.nan), length_m,
                                 n_elements)
    line = ok & ~point
    if not line.any():
        return out
    le = length_m / n_elements
    x, w = np.where(line, x_m, 0.0), np.where(line, width_m, 1.0)
    a, b = np.clip(x - w / 2, 0.0, length_m), np.clip(x + w / 2, 0.0, length_m)
    mu = np.where(line, mass_kg, 0.0) / np.maximum(b - a, 1e-300)                # (B, S) kg/m over the clipped length
    start = np.arange(n_elements) * le                                            # (E,)
    s1 = np.clip(a[..., None] - start, 0.0, le)                                   # (B, S, E)
    s2 = np.clip(b[..., None] - start, 0.0, le)
    s = (s1[..., None] + (s2 - s1)[..., None] * _GAUSS_X) / le                    # (B, S, E, G)
    wt = (s2 - s1)[..., None] * _GAUSS_W                                          # (B, S, E, G)
    N = _hermite(s, le)                                                           # (B, S, E, G, 4)
    return out + np.einsum("bs,bseg,bsegi,bsegj->beij", mu, wt, N, N)


class MassChange:
    """Damage kind ``"mass_change"``: signed masses over a length (see the module docstring).

    Config keys besides the generic ones: ``n_masses`` (range of the count per damaged sample), ``mass_ratio``
    (range of the signed mass over the specimen's beam mass, uniform) and ``width_fraction`` (range of the length
    over ``L``, uniform; a loss widens it to what carries it). Parameters per damage: ``mass_kg`` (signed total),
    ``width_m`` and ``point_kg`` taken off an added mass at ``point_x_m`` (0 and NaN without).
    Size: the signed mass ratio ``m_k / (m L)``.
    """

    kind = "mass_change"
    defaults = {
        "n_masses": [1, 1],
        "mass_ratio": [-0.05, 0.05],     # signed mass / beam mass: lost (< 0) or added (> 0)
        "width_fraction": [0.0, 0.1],    # length over L the change is spread over (0: a point mass)
    }
    units = {"mass_kg": "kg (signed: > 0 added, < 0 lost)", "width_m": "m",
             "point_kg": "kg (taken off an added mass, <= 0)", "point_x_m": "m"}
    sample_units: dict = {}
    size_meaning = "signed mass ratio m / (m_per_length L): > 0 mass added, < 0 mass lost"
    #: The size head learns ``asinh(size / scale)``: signed, linear below ``scale``, logarithmic above.
    size_transform = "asinh:0.01"
    size_label = "mass ratio"
    label = "a mass change"
    perturbs = "mass"
    sections = None                 # every section
    separates = {"support_change": "mode shapes near the support or a higher mode"}

    def size_range(self, d: dict, beam) -> tuple[float, float]:
        """The ``mass_ratio`` range (signed)."""
        return float(d["mass_ratio"][0]), float(d["mass_ratio"][1])

    def spread_m(self, d: dict, length_m: float) -> float:
        """The middle of the lengths ``width_fraction * L`` (m)."""
        return 0.5 * (d["width_fraction"][0] + d["width_fraction"][1]) * length_m

    def validate(self, d: dict, cfg: dict) -> None:
        d["n_masses"] = value_range("damage.n_masses", d["n_masses"], lo=0, hi=8, integer=True)
        d["mass_ratio"] = value_range("damage.mass_ratio", d["mass_ratio"], lo=-MAX_LOST_FRACTION, hi=1.0)
        d["width_fraction"] = value_range("damage.width_fraction", d["width_fraction"], lo=0.0, hi=1.0)

    def check_beam(self, d: dict, preset, section: dict, added_masses=()) -> None:
        """Refuse a lost mass that no place of the beam carries: more than :data:`MAX_LOST_FRACTION` of its own
        mass over the widest length plus of its heaviest added mass."""
        beam_kg = preset.mass_per_length_kg_m * preset.length_m
        heaviest = max((m for _, m in added_masses), default=0.0)
        carried = MAX_LOST_FRACTION * (d["width_fraction"][1] * beam_kg + heaviest)
        lost = -d["mass_ratio"][0] * beam_kg
        if lost > carried * (1 + 1e-12):
            raise ConfigError(f"config key 'damage.mass_ratio': a loss of {-d['mass_ratio'][0]:.3g} of the beam's mass "
                              f"({lost:.4g} kg) is more than any place of the beam carries ({carried:.4g} kg: "
                              f"{MAX_LOST_FRACTION:.0%} of its own mass over the widest length, damage.width_fraction "
                              f"{d['width_fraction'][1]:g} of L, plus of its heaviest added mass, {heaviest:.4g} kg); "
                              f"widen damage.width_fraction or lose less")

    def draw(self, rng: np.random.Generator, n: int, cfg: dict, setup) -> dict:
        """Counts, positions, lengths and signed masses of ``n`` samples (masses from the nominal beam mass)."""
        d = cfg["damage"]
        k, u, present = draw_counts(rng, n, d, "n_masses", 3)
        (a, b), (ra, rb), (wa, wb) = d["position_fraction"], d["mass_ratio"], d["width_fraction"]
        L = setup.length_m
        m_per_l = setup.preset.mass_per_length_kg_m
        x = (a + (b - a) * u[..., 0]) * L
        mass = (ra + (rb - ra) * u[..., 1]) * m_per_l * L
        w = (wa + (wb - wa) * u[..., 2]) * L
        point_kg, point_x, mass, w = _carried(x, w, mass, m_per_l, L, wb * L, setup.added_masses)
        nan = np.nan
        return {"n_damages": k, "x_m": np.where(present, x, nan), "mass_kg": np.where(present, mass, nan),
                "width_m": np.where(present, w, nan), "point_kg": np.where(present, point_kg, nan),
                "point_x_m": np.where(present, point_x, nan)}

    def corrections(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m, n_elements, shear_phi=0.0):
        line = params["mass_kg"] - np.nan_to_num(params["point_kg"])
        dM = line_mass_corrections(x_m, params["width_m"], line, length_m, n_elements)
        dM += point_mass_corrections(params["point_x_m"], params["point_kg"], length_m, n_elements)
        return dM, None, None

    def size(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return params["mass_kg"] / (np.asarray(mass_per_length_kg_m, float)[:, None] * length_m)

    def damage_at(self, d, beam, x_m, size, extent, mass_per_length_kg_m, length_m):
        """A signed mass ``size * m L`` at ``x_m`` over the length ``width_fraction`` at ``extent`` (0: its lower
        bound, 1: its upper) times ``L``; a loss over the length that carries it (within the beam, as drawn: no
        added mass taken), clipped only where the whole beam does not."""
        (wa, wb) = d["width_fraction"]
        x, mass = np.asarray(x_m, float), np.asarray(size, float) * mass_per_length_kg_m * length_m
        w = (wa + (wb - wa) * np.clip(np.asarray(extent, float), 0.0, 1.0)) * length_m * np.ones_like(x)
        need = np.clip(-mass, 0.0, None) / (MAX_LOST_FRACTION * mass_per_length_kg_m)     # the length a loss needs
        w = np.maximum.reduce([w, need, 2 * (need - x), 2 * (need - (length_m - x))])
        point_kg, point_x, mass, w = _carried(x, w, mass, mass_per_length_kg_m, length_m, 2 * length_m, ())
        return {"mass_kg": mass, "width_m": w, "point_kg": point_kg, "point_x_m": point_x}

    def columns(self, params, x_m, ei_Nm2, mass_per_length_kg_m, length_m):
        return {}, {k: params[k] for k in ("mass_kg", "width_m", "point_kg", "point_x_m")}

    def describe(self, x_m: float, size: float, preset, section: dict | None = None) -> str:
        """``"a mass added at x = 0.300 m of 1.2 % of the beam's mass"`` (or lost, for a negative size; no place for
        ``x_m`` None)."""
        at = "" if x_m is None else f" at x = {x_m:.3f} m"
        return f"a mass {'added' if size >= 0 else 'lost'}{at} of {abs(size):.2%} of the beam's mass"


def _carried(x, w, mass, m_per_l, L, w_max, added_masses):
    """Split losses into what the heaviest added mass within the length gives (point part) and the line part,
    widening the length to carry the line part (up to ``w_max``) and clipping a loss to what its place carries.

    Returns ``point_kg`` (<= 0), ``point_x_m`` (NaN without), the signed mass applied and the length (m).
    """
    point_kg = np.zeros_like(mass)
    point_x = np.full_like(mass, np.nan)
    lost = mass < 0
    if added_masses:
        ax = np.array([p for p, _ in added_masses], float)
        am = np.array([m for _, m in added_masses], float)
        inside = np.abs(ax - x[..., None]) <= np.maximum(w, 0.0)[..., None] / 2 + 1e-12      # (n, S, A)
        heavy = np.where(inside, am, 0.0)
        j = np.argmax(heavy, axis=-1)
        avail = np.take_along_axis(heavy, j[..., None], -1)[..., 0] * MAX_LOST_FRACTION
        take = np.where(lost, np.minimum(-mass, avail), 0.0)
        point_kg = -take
        point_x = np.where(take > 0, ax[j], np.nan)
    rest = np.where(lost, -mass + point_kg, 0.0)                                               # line part lost (>= 0)
    w = np.where(lost, np.minimum(np.maximum(w, rest / (MAX_LOST_FRACTION * m_per_l)), w_max), w)
    span = np.clip(x + w / 2, 0, L) - np.clip(x - w / 2, 0, L)
    rest = np.minimum(rest, MAX_LOST_FRACTION * m_per_l * span)
    return point_kg, point_x, np.where(lost, point_kg - rest, mass), w
