"""Beam properties: the thesis's specimens, closed-form frequencies, equivalent EI.

* Presets ``beam5``, ``beam6``, ``beam8`` from Table 4.1 and the geometry of
  Chapter Four: mass per length = mass / 1.219 m (whole beam), cantilever
  length 0.6095 m, 4 elements, masters = translations of nodes 2..5.
* Closed-form cantilever natural frequencies (eq. 4.5), ``beta l`` constants
  and the mode curvature used by the first-order damage sensitivity.
* Equivalent ``EI`` from a static load-deflection test (eqs. 4.2-4.4).
* Flexural rigidity of a layered section (eq. 4.1) and its general,
  unsymmetric form used for slits; solid rectangular and circular sections
  (:func:`solid_section`: ``EI``, area, the shear coefficient of the shape).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import BeamDamageError, ShapeError
from physics.supports import ENDS, THESIS_SUPPORT, support

__all__ = ["BeamPreset", "CANTILEVER_BETA_L", "CURVATURE_FORMS", "PRESETS", "SECTION_KINDS", "SOLID_SECTIONS",
           "SolidSection", "StaticTest", "THESIS_BETA_L", "beam_preset", "cantilever_beta_l",
           "cantilever_curvature_squared", "cantilever_frequencies_hz", "clamped_pinned_beta_l", "curvature_squared",
           "equivalent_ei", "free_free_beta_l", "layered_ei", "section_ei", "solid_section", "uniform_beta_l"]


#: ``beta_l`` of a clamped-free beam as printed in the thesis (Chapter Four).
THESIS_BETA_L = (1.8751, 4.6941, 7.8547, 10.9955)


@dataclass(frozen=True)
class BeamPreset:
    """A specimen of the thesis (Table 4.1 and the Chapter Four geometry).

    Field names match :class:`physics.beam.Beam`.

    Attributes
    ----------
    name : str
    mass_kg : float
        Mass of the whole beam (kg).
    EI_Nm2 : float
        Equivalent flexural rigidity (N m^2).
    total_length_m : float
        Length of the whole beam (m), used for the mass per length.
    length_m : float
        Cantilever (free) length (m).
    width_m, thickness_m : float
        Section (m).
    n_elements : int
        Elements of the thesis's FE model.
    """

    name: str
    mass_kg: float
    EI_Nm2: float
    total_length_m: float = 1.219
    length_m: float = 0.6095
    width_m: float = 0.051
    thickness_m: float = 0.007264
    n_elements: int = 4

    @property
    def mass_per_length_kg_m(self) -> float:
        """Mass per unit length (kg/m): beam mass over the whole length."""
        return self.mass_kg / self.total_length_m

    @property
    def masters(self) -> tuple[str, ...]:
        """The measured DOFs: translations of nodes 2..n_elements+1."""
        return tuple(f"{n}:y" for n in range(2, self.n_elements + 2))


PRESETS = {
    "beam5": BeamPreset("beam5", 0.15792, 22.674),
    "beam6": BeamPreset("beam6", 0.15723, 22.671),
    "beam8": BeamPreset("beam8", 0.15505, 22.059),
}


def beam_preset(name: str) -> BeamPreset:
    """Look up a preset by name (``beam5``, ``beam6``, ``beam8``)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise BeamDamageError(f"unknown beam preset {name!r}; expected one of {sorted(PRESETS)}",
                              parameter="name") from None


def cantilever_beta_l(n_modes: int = 4) -> np.ndarray:
    """Roots of ``cos(bl) cosh(bl) = -1`` (clamped-free), to machine precision.

    Newton's method from ``(k + 1/2) pi`` (each root lies within 0.31 of it; no
    SciPy import, which costs every dataset worker about half a second).
    """
    x = (np.arange(n_modes) + 0.5) * np.pi
    for _ in range(100):
        step = (np.cos(x) * np.cosh(x) + 1.0) / (np.cos(x) * np.sinh(x) - np.sin(x) * np.cosh(x))
        x = x - step
        if np.all(np.abs(step) <= 4 * np.finfo(float).eps * x):
            break
    return x


#: ``beta_l`` of a clamped-free beam to machine precision (first four modes).
CANTILEVER_BETA_L = tuple(float(x) for x in cantilever_beta_l(4))


def free_free_beta_l(n_modes: int = 4) -> np.ndarray:
    """Roots of ``cos(bl) cosh(bl) = 1`` above 0 (free-free and clamped-clamped bending modes), by Newton's method
    from ``(k + 3/2) pi``."""
    x = (np.arange(n_modes) + 1.5) * np.pi
    for _ in range(100):
        step = (np.cos(x) * np.cosh(x) - 1.0) / (np.cos(x) * np.sinh(x) - np.sin(x) * np.cosh(x))
        x = x - step
        if np.all(np.abs(step) <= 4 * np.finfo(float).eps * x):
            break
    return x


def uniform_beta_l(bc: str, n_modes: int = 4) -> np.ndarray:
    """``beta l`` of the first ``n_modes`` bending modes of a uniform Euler-Bernoulli beam on the ideal supports
    ``bc`` (:data:`physics.supports.SUPPORTS`; ``f_n = (beta l_n)^2 / (2 pi L^2) sqrt(EI / m)``, eq. 4.5 for the
    cantilever; a free beam's rigid bounce and pitch left out)."""
    roots = {("clamped", "free"): cantilever_beta_l, ("free", "free"): free_free_beta_l,
             ("clamped", "clamped"): free_free_beta_l, ("clamped", "pinned"): clamped_pinned_beta_l,
             ("pinned", "pinned"): lambda n: np.pi * np.arange(1.0, n + 1)}
    return roots[tuple(sorted(support(bc).ends))](n_modes)


def clamped_pinned_beta_l(n_modes: int = 4) -> np.ndarray:
    """Roots of ``tan(bl) = tanh(bl)`` above 0 (clamped-pinned bending modes), by Newton's method from
    ``(k + 5/4) pi`` on ``sin(bl) cosh(bl) - cos(bl) sinh(bl) = 0``."""
    x = (np.arange(n_modes) + 1.25) * np.pi
    for _ in range(100):
        step = (np.sin(x) * np.cosh(x) - np.cos(x) * np.sinh(x)) / (2.0 * np.sin(x) * np.sinh(x))
        x = x - step
        if np.all(np.abs(step) <= 4 * np.finfo(float).eps * x):
            break
    return x


def _beta_l_cantilever(mode: int) -> float:
    return CANTILEVER_BETA_L[mode] if mode < len(CANTILEVER_BETA_L) else float(cantilever_beta_l(mode + 1)[mode])


#: The closed forms of :func:`curvature_squared` by the support's ends ``(x = 0, x = L)``: ``beta_l_r`` of mode ``r``
#: (from 0) and ``sigma``'s family (``"+"``: ``(C + c) / (S + s)``, ``"-"``: ``(C - c) / (S - s)``), or
#: ``"sine"`` for a beam pinned at both ends. A support whose ends are the mirror image of a pair here is read
#: from the other end; any other pair has no closed form here and is refused.
CURVATURE_FORMS = {
    ("clamped", "free"): (_beta_l_cantilever, "+"),
    ("free", "free"): (lambda r: float(free_free_beta_l(r + 1)[r]), "-"),
    ("clamped", "clamped"): (lambda r: float(free_free_beta_l(r + 1)[r]), "-"),
    ("clamped", "pinned"): (lambda r: float(clamped_pinned_beta_l(r + 1)[r]), "-"),
    ("pinned", "pinned"): (lambda r: (r + 1) * np.pi, "sine"),
}


def curvature_squared(x_m, length_m: float, mode: int, bc: str = THESIS_SUPPORT):
    """Normalised squared curvature ``phi_r''(x)^2 / int_0^L phi_r''^2 dx`` of bending mode ``r`` of a uniform beam
    (1/m).

    With ``b = beta_l_r / L``, ``u = b x`` and ``C, S, c, s = cosh, sinh, cos, sin`` of ``beta_l_r``
    (:data:`CURVATURE_FORMS`):

    =============== =============================================== ======================== =====================
    ends            ``phi''(x) / b^2``                              ``sigma``                ``beta_l_r``
    =============== =============================================== ======================== =====================
    clamped-free    ``cosh u + cos u - sigma (sinh u + sin u)``     ``(C + c) / (S + s)``    ``cos cosh = -1``
    free-free       ``cosh u - cos u - sigma (sinh u - sin u)``     ``(C - c) / (S - s)``    ``cos cosh = 1``
    clamped-clamped ``cosh u + cos u - sigma (sinh u + sin u)``     ``(C - c) / (S - s)``    ``cos cosh = 1``
    clamped-pinned  ``cosh u + cos u - sigma (sinh u + sin u)``     ``(C - c) / (S - s)``    ``tan = tanh``
    pinned-pinned   ``-sin(r pi x / L)``                                                     ``r pi``
    =============== =============================================== ======================== =====================

    A support whose ends are a pair's mirror image (pinned-clamped, free-clamped) is read from ``L - x``. For every
    one of these supports ``int phi''^2 = b^4 int phi^2`` (integration by parts twice: the end terms vanish at
    clamped, pinned and free ends), which is ``b^4 L`` (``b^4 L / 2`` pinned-pinned). ``cosh u - sigma sinh u`` is
    evaluated as ``((1 - sigma) e^u + (1 + sigma) e^-u) / 2`` with ``1 - sigma`` in closed form, exact at high
    modes where the two terms cancel. By first-order perturbation, a loss ``dEI`` over a short length ``w`` at
    ``x`` shifts mode ``r`` by ``df_r/f_r = -(1/2) (dEI/EI) w`` times this value.

    Parameters
    ----------
    x_m : float or ndarray      positions from the end ``x = 0`` (m), ``0 <= x <= L``
    length_m : float            beam length (m)
    mode : int                  bending-mode index from 0 (rigid-body modes of a free-free beam not counted)
    bc : str                    a support of :data:`physics.supports.SUPPORTS`

    Returns
    -------
    ndarray, shape like ``x_m``   (1/m)

    Raises
    ------
    BeamDamageError
        A negative mode, or a support whose ends have no closed form in :data:`CURVATURE_FORMS`.
    """
    mode = int(mode)
    if mode < 0:
        raise BeamDamageError(f"mode must be >= 0 (0 = first bending mode), got {mode}")
    sup = support(bc)
    x = np.asarray(x_m, dtype=float)
    ends = tuple(sup.ends)
    if ends not in CURVATURE_FORMS and ends[::-1] in CURVATURE_FORMS:
        ends, x = ends[::-1], length_m - x
    if ends not in CURVATURE_FORMS:
        raise BeamDamageError(f"support {sup.name!r}: no closed-form curvature for ends {ends[0]}-{ends[1]}; "
                              f"expected ends among {', '.join('-'.join(e) for e in CURVATURE_FORMS)} "
                              "(or their mirror images)", parameter="bc")
    beta_l, family = CURVATURE_FORMS[ends]
    bl = beta_l(mode)
    if family == "sine":
        return 2.0 * np.sin(bl * x / length_m) ** 2 / length_m
    C, S, c, s = np.cosh(bl), np.sinh(bl), np.cos(bl), np.sin(bl)
    if family == "-":
        sigma, one_minus = (C - c) / (S - s), (c - s - np.exp(-bl)) / (S - s)
    else:
        sigma, one_minus = (C + c) / (S + s), (s - c - np.exp(-bl)) / (S + s)
    u = bl * x / length_m
    hyper = 0.5 * (one_minus * np.exp(u) + (1.0 + sigma) * np.exp(-u))
    free_start = not ENDS[ends[0]].held       # phi''(0) = 0 at a free end
    trig = -np.cos(u) + sigma * np.sin(u) if free_start else np.cos(u) - sigma * np.sin(u)
    return (hyper + trig) ** 2 / length_m


def cantilever_curvature_squared(x_m, length_m: float, mode: int):
    """:func:`curvature_squared` of a uniform cantilever (1/m), ``x_m`` from the clamp."""
    return curvature_squared(x_m, length_m, mode, THESIS_SUPPORT)


def cantilever_frequencies_hz(EI_Nm2, mass_per_length_kg_m, length_m, beta_l=THESIS_BETA_L):
    """Closed-form natural frequencies of a uniform cantilever (eq. 4.5).

    ``f_n = (beta l_n)^2 / (2 pi l^2) sqrt(EI / m)``

    Parameters
    ----------
    EI_Nm2 : float
        Flexural rigidity (N m^2).
    mass_per_length_kg_m : float
        Mass per unit length (kg/m).
    length_m : float
        Cantilever length (m).
    beta_l : sequence of float
        Mode constants; the thesis's 5-digit values by default, or
        :func:`cantilever_beta_l` for exact ones.

    Returns
    -------
    ndarray, shape (len(beta_l),)   (Hz)
    """
    bl = np.asarray(beta_l, dtype=float)
    return bl**2 / (2 * np.pi * length_m**2) * np.sqrt(EI_Nm2 / mass_per_length_kg_m)


@dataclass(frozen=True)
class StaticTest:
    """Result of :func:`equivalent_ei`.

    Attributes
    ----------
    EI_Nm2 : float
        Equivalent flexural rigidity (N m^2), eq. 4.3 (old name ``EI``).
    slope_N_m : float
        Least-squares slope of load over deflection (N/m) (old name ``slope``).
    intercept_N : float
        Least-squares intercept (N) (old name ``intercept``).
    r_squared : float
        Coefficient of determination, eq. 4.4.
    """

    EI_Nm2: float
    slope_N_m: float
    intercept_N: float
    r_squared: float


def equivalent_ei(loads_n, deflections_m, x_m: float, a_m: float) -> StaticTest:
    """Equivalent ``EI`` of a cantilever from a load-deflection test (eqs. 4.2-4.4).

    A line ``P = m delta + b`` is fitted by least squares; then
    ``EI = m x^2 (3a - x) / 6`` (eq. 4.3), where the load acts at ``a`` and the
    deflection is measured at ``x`` from the clamp, and
    ``R^2 = 1 - sum (Y - Y_hat)^2 / (sum Y^2 - (sum Y)^2 / n)`` (eq. 4.4).

    Parameters
    ----------
    loads_n : array_like, shape (n,)
        Applied loads (N).
    deflections_m : array_like, shape (n,)
        Measured deflections (m).
    x_m, a_m : float
        Measurement and load positions from the clamp (m), ``0 < x <= a``.
    """
    P = np.asarray(loads_n, dtype=float)
    d = np.asarray(deflections_m, dtype=float)
    if P.shape != d.shape or P.ndim != 1 or P.size < 2 or not (np.all(np.isfinite(P)) and np.all(np.isfinite(d))):
        raise ShapeError("loads_n and deflections_m must be finite 1-D arrays of equal length >= 2")
    if not 0 < x_m <= a_m:
        raise BeamDamageError(f"need 0 < x_m <= a_m, got x_m={x_m}, a_m={a_m}", parameter="x_m")
    slope, intercept = np.polyfit(d, P, 1)
    fit = slope * d + intercept
    r2 = 1.0 - np.sum((P - fit) ** 2) / (np.sum(P**2) - np.sum(P) ** 2 / P.size)
    return StaticTest(slope * x_m**2 * (3 * a_m - x_m) / 6.0, float(slope), float(intercept), float(r2))


def layered_ei(width_m, interfaces_m, moduli_pa):
    """Flexural rigidity of a section symmetric about its neutral axis (eq. 4.1).

    ``EI = (2b/3) sum_k E_k (d_{k+1}^3 - d_k^3)``

    Parameters
    ----------
    width_m : float
        Section width ``b`` (m).
    interfaces_m : array_like, shape (n_layers + 1,)
        Distances ``d_k`` from the neutral axis to the layer interfaces (m),
        ascending from 0 (the mid-plane) to half the thickness.
    moduli_pa : array_like, shape (n_layers,)
        Young's modulus of each layer ``E_k`` (Pa), from the mid-plane out.

    Returns
    -------
    float   (N m^2)
    """
    d = np.asarray(interfaces_m, dtype=float)
    E = np.asarray(moduli_pa, dtype=float)
    if d.ndim != 1 or E.shape != (d.size - 1,) or np.any(np.diff(d) < 0):
        raise ShapeError("interfaces_m must ascend and have one more entry than moduli_pa", parameter="interfaces_m")
    return 2 * width_m / 3 * np.sum(E * (d[1:] ** 3 - d[:-1] ** 3))


def section_ei(width_m, z_bottom_m, z_top_m, moduli_pa):
    """Flexural rigidity of a general (unsymmetric) layered section.

    The neutral axis sits at the modulus-weighted centroid
    ``z_na = sum E_k A_k z_k / sum E_k A_k``; then
    ``EI = (b/3) sum_k E_k ((z_top_k - z_na)^3 - (z_bot_k - z_na)^3)``. For a
    symmetric stack this equals :func:`layered_ei`. Broadcasts over leading
    axes (e.g. a batch of slit depths that thin the top layer).

    Parameters
    ----------
    width_m : float or ndarray
        Section width (m).
    z_bottom_m, z_top_m : ndarray, shape (..., n_layers)
        Layer bounds (m) measured from the bottom face.
    moduli_pa : ndarray, shape (..., n_layers)
        Young's moduli (Pa).

    Returns
    -------
    ndarray, shape (...)   (N m^2)
    """
    zb = np.asarray(z_bottom_m, dtype=float)
    zt = np.asarray(z_top_m, dtype=float)
    E = np.asarray(moduli_pa, dtype=float)
    ea = E * (zt - zb)
    z_na = np.sum(ea * 0.5 * (zt + zb), axis=-1, keepdims=True) / np.sum(ea, axis=-1, keepdims=True)
    return np.asarray(width_m) / 3.0 * np.sum(E * ((zt - z_na) ** 3 - (zb - z_na) ** 3), axis=-1)


#: Section kinds of a beam file (``section``): a sandwich of two faces on a core (its EI by eq. 4.1), a solid
#: rectangle or circle of one material, or a section given only by its ``EI`` and mass per length (I, box, any).
SECTION_KINDS = ("sandwich", "rectangular", "circular", "given")

#: Solid section kinds.
SOLID_SECTIONS = ("rectangular", "circular")


@dataclass(frozen=True)
class SolidSection:
    """A solid section of one isotropic material.

    Attributes
    ----------
    kind : {"rectangular", "circular"}
    area_m2 : float
    second_moment_m4 : float
    shear_coefficient : float
        Timoshenko's ``k`` of the shape (Cowper 1966: ``10 (1 + nu) / (12 + 11 nu)`` for a rectangle,
        ``6 (1 + nu) / (7 + 6 nu)`` for a circle).
    modulus_pa, shear_modulus_pa : float
        ``E`` and ``G = E / (2 (1 + nu))``.
    """

    kind: str
    area_m2: float
    second_moment_m4: float
    shear_coefficient: float
    modulus_pa: float
    shear_modulus_pa: float

    @property
    def EI_Nm2(self) -> float:
        return self.modulus_pa * self.second_moment_m4

    @property
    def kGA_N(self) -> float:
        """Shear rigidity ``k G A`` (N) of the section."""
        return self.shear_coefficient * self.shear_modulus_pa * self.area_m2


def solid_section(kind: str, width_m: float, thickness_m: float, modulus_pa: float,
                  poisson_ratio: float = 0.3) -> SolidSection:
    """The :class:`SolidSection` of a ``width_m`` x ``thickness_m`` rectangle or a circle of diameter
    ``thickness_m`` (``width_m`` ignored)."""
    nu = float(poisson_ratio)
    if kind == "rectangular":
        area, second, k = width_m * thickness_m, width_m * thickness_m**3 / 12, 10 * (1 + nu) / (12 + 11 * nu)
    elif kind == "circular":
        area, second, k = np.pi * thickness_m**2 / 4, np.pi * thickness_m**4 / 64, 6 * (1 + nu) / (7 + 6 * nu)
    else:
        raise BeamDamageError(f"solid section {kind!r} unknown; expected one of {list(SOLID_SECTIONS)}")
    return SolidSection(kind, float(area), float(second), float(k), float(modulus_pa), modulus_pa / (2 * (1 + nu)))
