"""FE sensitivities of the measured modal data to the size of a damage in each element.

What a unit size changes comes from the damage model's ``perturbs``
(:mod:`datagen.damage`). A stiffness damage (size: the hinge flexibility
``theta = EI / (k_theta L)`` its rigidity loss amounts to, e.g. a slit's)
inside element ``e`` of length ``l_e`` of the nominal cantilever changes the
element stiffness, to first order, by ``dK ~ -(EI L theta / l_e) K_e^1``
(``K_e^1`` the element stiffness for ``EI = 1``, eq. 3.9), so for a
mass-normalised undamped mode ``phi_r``

    ``d f_r / f_r = d(omega_r^2) / (2 omega_r^2) = -EI L theta phi_r^T K_e^1 phi_r / (2 l_e omega_r^2)``,

i.e. the curvature squared at the damage. A mass damage (size: the signed
mass ratio ``mu = m_k / (m L)``) spread over element ``e`` adds
``dM = (m L mu / l_e) M_e^1`` (``M_e^1`` the consistent element mass for unit
mass per length, eq. 3.8), so ``d f_r / f_r = -m L mu phi_r^T M_e^1 phi_r / (2 l_e)``,
the displacement squared there. Shape sensitivities are finite differences of the real, unit-norm shapes at the
measured DOFs (:func:`learn.explanations.shapes.real_shapes`). The same numbers serve the
classical methods (Cawley-Adams, DLAC/MDLAC, sensitivity updating) and the
classifier's "detectable here" rule.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from datagen.damage import DEFAULT_KIND, damage_model
from learn.explanations.shapes import real_shapes, sign_aligned
from physics.effects import hermite_row, point_mass_matrix
from physics.fem import beam_model, dof_names, element_mass, element_stiffness
from physics.modal import undamped_modes
from physics.properties import beam_preset
from physics.supports import add_springs

__all__ = ["Sensitivity", "beam_numbers", "beam_sensitivity", "with_masses"]

@dataclass(frozen=True)
class Sensitivity:
    """Sensitivities of the nominal beam on an ``E``-element grid.

    Attributes
    ----------
    x_over_L : ndarray, shape (E,)           element centres / L
    length_m : float
    EI_Nm2 : float
    frequency : ndarray, shape (m, E)        relative frequency change per unit damage size, <= 0
    shape : ndarray, shape (4 m, E)          change of the real unit-norm shapes (DOF-major per mode, as
                                             ``reshape`` of (4, m)) per unit damage size
    frequencies_hz : ndarray, shape (m,)     nominal natural frequencies
    """

    x_over_L: np.ndarray
    length_m: float
    EI_Nm2: float
    frequency: np.ndarray
    shape: np.ndarray
    frequencies_hz: np.ndarray

    @property
    def n_elements(self) -> int:
        return self.x_over_L.size

    def element_of(self, x_over_L):
        """Index of the grid element holding ``x / L`` (batched)."""
        return np.clip((np.asarray(x_over_L, float) * self.n_elements).astype(int), 0, self.n_elements - 1)

    def modes(self, indices) -> "Sensitivity":
        """The sensitivities of the nominal modes ``indices`` (0-based, ascending) alone, e.g. ``[0, 1, 3]`` for
        modes 1, 2 and 4."""
        k = np.asarray(indices, int)
        m = self.frequency.shape[0]
        shape = self.shape.reshape(-1, m, self.n_elements)[:, k].reshape(-1, self.n_elements)
        return replace(self, frequency=self.frequency[k], shape=shape, frequencies_hz=self.frequencies_hz[k])

    def largest_drop(self, x_over_L, size):
        """Largest first-order relative frequency change (either sign: a rise is a change too) of a damage of that
        signed size (batched), >= 0."""
        e = self.element_of(np.nan_to_num(x_over_L))
        return np.max(np.abs(self.frequency[:, e]), axis=0) * np.abs(np.asarray(size, float))

def beam_numbers(preset) -> tuple[float, float, float, tuple]:
    """``(length_m, EI_Nm2, mass_per_length_kg_m, added masses)`` of a preset name or of such a tuple (the added
    masses ``((x_m, mass_kg), ...)`` optional, none for a preset)."""
    if isinstance(preset, str):
        p = beam_preset(preset)
        return p.length_m, p.EI_Nm2, p.mass_per_length_kg_m, ()
    L, EI, m, *rest = preset
    return float(L), float(EI), float(m), tuple(rest[0]) if rest else ()


def with_masses(models, masses, length_m: float, n_elements: int):
    """``models`` (a batch of one beam's FE models) with the point masses ``((x_m, mass_kg), ...)`` added to M."""
    if not masses:
        return models

    node_x = np.linspace(0.0, length_m, n_elements + 1)
    names = [f"{n}:{d}" for n in range(1, n_elements + 2) for d in ("y", "rz")]
    keep = [names.index(d) for d in models.dofs]
    dM = sum(point_mass_matrix(node_x, mk, x) for x, mk in masses)[np.ix_(keep, keep)]
    return replace(models, M=np.asarray(models.M) + dM)

@lru_cache(maxsize=16)
def beam_sensitivity(preset="beam5", root_spring_relative: float | None = 948.7, n_elements: int = 40,
                     n_modes: int = 4, step: float = 0.01, kind: str = DEFAULT_KIND, test=None) -> Sensitivity:
    """Sensitivities of the nominal beam (clamped, or on a root spring ``k_r L / EI``) to damage of ``kind``.

    Parameters
    ----------
    preset : beam preset name, or ``(length_m, EI_Nm2, mass_per_length_kg_m[, added masses])`` of the truth beam
        (e.g. a calibrated beam file: its Euler-Bernoulli equivalent with the same EI and mass, and its added
        masses ``((x_m, mass_kg), ...)``)
    root_spring_relative : float or None
        ``k_r L / EI`` of the nominal root spring (None = rigid clamp); default the
        geometric mean of the generator's default range [300, 3000].
    n_elements : int, multiple of 4 (the measured nodes sit at quarter points)
    step : relative element stiffness loss (mass gain, for a mass damage) of the finite differences
    kind : damage kind (:data:`datagen.damage.DAMAGE_MODELS`): its ``perturbs`` says which matrix a size changes
    test : physics.layout.Layout, optional
        Another test than the thesis's: its supports, sensors (shapes interpolated there) and modes (``n_modes``
        is then theirs; a free-free beam's rigid-body modes left out); the root spring acts on every clamp (as the
        clamp springs ``generate`` draws), the default suspension holds a free-free beam (:mod:`physics.supports`).
    """
    perturbs = damage_model(kind).perturbs
    if test is not None and not test.thesis:
        return _layout_sensitivity(preset, root_spring_relative, n_elements, step, perturbs, test)
    L, EI, m, masses = beam_numbers(preset)
    le = L / n_elements
    kr = None if root_spring_relative is None else root_spring_relative * EI / L
    factors = np.ones((n_elements + 1, n_elements))
    if perturbs == "stiffness":
        factors[1:] -= step * np.eye(n_elements)
        models = beam_model(n_elements, L, EI, m, ei_factors=factors, root_spring=kr)
    else:
        factors[1:] += step * np.eye(n_elements)
        models = beam_model(n_elements, L, EI, m, mass_factors=factors, root_spring=kr)
    models = with_masses(models, masses, L, n_elements)
    w, phi = undamped_modes(models.M, models.K)
    meas = models.index([f"{1 + n_elements // 4 * q}:y" for q in range(1, 5)])
    u = real_shapes(phi[:, meas, :n_modes].astype(complex))
    du = (sign_aligned(u[1:], u[0]) - u[0]) * L / (step * le)   # (E, 4, m) per unit size (step le / L per step)
    nominal = with_masses(beam_model(n_elements, L, EI, m, root_spring=kr), masses, L, n_elements)
    w0, phi0 = undamped_modes(nominal.M, nominal.K)
    dlnf = _energy_sensitivity(phi0[:, :n_modes], nominal.dofs, w0[:n_modes], L, EI, m, n_elements, perturbs)
    return Sensitivity((np.arange(n_elements) + 0.5) / n_elements, L, EI, dlnf,
                       np.transpose(du, (1, 2, 0)).reshape(4 * n_modes, n_elements), w0[:n_modes] / (2 * np.pi))

def _energy_sensitivity(phi0, dofs, w0, L, EI, m, n_elements, perturbs) -> np.ndarray:
    """Exact first-order ``d ln f`` per unit size of each element ``(m, E)`` from the element energies of the nominal
    modes ``phi0`` (on ``dofs`` of the mesh, (n, m)) at ``w0`` (rad/s, (m,)): stiffness or mass as ``perturbs``."""
    le = L / n_elements
    full = np.zeros((2 * (n_elements + 1), phi0.shape[1]))
    full[[dof_names(n_elements + 1).index(d) for d in dofs]] = phi0
    ends = np.stack([full[2 * e:2 * e + 4] for e in range(n_elements)])    # (E, 4, m)
    if perturbs == "stiffness":
        energy = np.einsum("eim,ij,ejm->me", ends, element_stiffness(1.0, le), ends)
        return -EI * L * energy / (2 * le * w0[:, None] ** 2)
    return -m * L * np.einsum("eim,ij,ejm->me", ends, element_mass(1.0, le), ends) / (2 * le)


def _layout_sensitivity(preset, root_spring_relative, n_elements, step, perturbs, test) -> Sensitivity:
    """:func:`beam_sensitivity` of any test (:class:`physics.layout.Layout`): shapes at the sensors."""
    L, EI, m, masses = beam_numbers(preset)
    le = L / n_elements
    sup = test.support
    kr = root_spring_relative * EI / L if sup.clamped and root_spring_relative is not None else None
    factors = np.ones((n_elements + 1, n_elements))
    key = "ei_factors" if perturbs == "stiffness" else "mass_factors"
    factors[1:] += (-step if perturbs == "stiffness" else step) * np.eye(n_elements)
    models = with_masses(beam_model(n_elements, L, EI, m, bc=test.bc, root_spring=kr, **{key: factors}), masses, L,
                          n_elements)
    # the support's nominal springs (a soft suspension: the rigid-body modes stay the two lowest)
    K = add_springs(models.K, models.dofs, sup.spring_dofs(n_elements + 1), sup.nominal_unit_stiffness(L) * EI)
    w, phi = undamped_modes(models.M, K)
    keep = [dof_names(n_elements + 1).index(d) for d in models.dofs]
    node_x = np.linspace(0.0, L, n_elements + 1)
    T = np.array([hermite_row(float(x), node_x)[0][keep] for x in sorted(test.sensors_x_m)])   # (S, n)
    used = sup.rigid_body_modes + np.asarray(test.modes) - 1
    S = T.shape[0]
    u = real_shapes((T @ phi[..., used]).astype(complex))                     # (E + 1, S, m)
    du = (sign_aligned(u[1:], u[0]) - u[0]) * L / (step * le)   # (E, S, m)
    w0 = w[0][used]
    dlnf = _energy_sensitivity(phi[0][:, used], models.dofs, w0, L, EI, m, n_elements, perturbs)
    return Sensitivity((np.arange(n_elements) + 0.5) / n_elements, L, EI, dlnf,
                       np.transpose(du, (1, 2, 0)).reshape(S * used.size, n_elements), w0 / (2 * np.pi))
