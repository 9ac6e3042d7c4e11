"""The supports of a beam (its ``bc``): one :class:`Support` record each in :data:`SUPPORTS`.

A support names the end conditions at ``x = 0`` and ``x = L`` (:data:`ENDS`: the DOF directions each holds and
its symbol in a figure), how many rigid-body modes the beam keeps, and its own springs: where they act (the
rotations of the clamps or pins, the translations of free ends), the beam-file effect that calibrates them
(:mod:`physics.effects`), their stiffness on the nominal beam and what a support change between two tests does
to them (:func:`changed_springs`). :func:`support` looks a name up and refuses an unknown one in one line;
:func:`markdown_table` is the table of ``docs/beam-file.md``. :func:`add_springs` is the one way springs to
ground enter a stiffness matrix (the effects of a beam file, ``generate``'s truth mesh, the sensitivities and the
support-change explanation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.errors import ConfigError

__all__ = ["ENDS", "MECHANISMS", "SUPPORTS", "THESIS_SUPPORT", "End", "Support", "add_springs", "changed_springs",
           "markdown_table", "support", "suspension_unit_stiffness"]


@dataclass(frozen=True)
class End:
    """One end condition.

    Attributes
    ----------
    name : str            ``clamped``, ``pinned`` or ``free``
    held : tuple of str   DOF directions the support holds at zero (``"y"`` translation, ``"rz"`` rotation)
    spring : str          direction of the support's own spring at such an end (a clamp's or pin's rotation, a
                          free end's suspension)
    symbol : str or None  how a figure draws it: ``"wall"`` (a clamp), ``"triangle"`` (a pin), None (free)
    """

    name: str
    held: tuple
    spring: str
    symbol: str | None


#: The end conditions a support combines.
ENDS = {e.name: e for e in (End("clamped", ("y", "rz"), "rz", "wall"), End("pinned", ("y",), "rz", "triangle"),
                            End("free", (), "y", None))}


@dataclass(frozen=True)
class Support:
    """One support (boundary condition) of a beam.

    Attributes
    ----------
    name : str
        The beam file's ``bc``.
    ends : tuple of str
        End conditions (:data:`ENDS`) at ``x = 0`` and ``x = L``.
    rigid_body_modes : int
        Modes of zero frequency on the ideal supports (bounce and pitch of a free beam); left out of the modes a
        test uses, so mode 1 is the first bending mode.
    spring_end : str
        The end condition (:data:`ENDS`) whose springs are the support's own: the clamps' rotational springs, the
        pins' bearing springs or the free ends' suspension.
    effect : str
        The effect of :data:`physics.effects.EFFECTS` that calibrates those springs from measured modes.
    nominal : str
        Those springs on the nominal beam: ``"rigid"`` (a clamp: the rotation held; ``generate`` may draw a
        clamp spring), ``"none"`` (ideal pins) or ``"suspension"`` (:func:`suspension_unit_stiffness`).
    change : str
        How a support change between two tests acts on them: ``"scale"`` (by a factor ``k / k_0``) or ``"add"``
        (springs ``k L / EI`` added where the nominal beam has none).
    change_meaning : str
        What the parameter of a support change is (:func:`changed_springs`).
    help : str
        One line for help texts and the docs.
    """

    name: str
    ends: tuple
    rigid_body_modes: int
    spring_end: str
    effect: str
    nominal: str
    change: str
    change_meaning: str
    help: str

    @property
    def symmetric(self) -> bool:
        """The beam is its own mirror image about midspan: a damage at ``x`` and at ``L - x`` change every natural
        frequency alike."""
        return self.ends[0] == self.ends[1]

    @property
    def clamped(self) -> bool:
        """An end is clamped (its rotational spring is the clamp spring ``generate`` draws and re-clamps)."""
        return "clamped" in self.ends

    def end_dofs(self, n_nodes: int, end: str, direction: str) -> tuple[str, ...]:
        """Names of the DOFs ``direction`` (``"y"``, ``"rz"``) at the ends (node 1, node ``n_nodes``) of condition
        ``end``."""
        return tuple(f"{n}:{direction}" for n, e in zip((1, n_nodes), self.ends) if e == end)

    def constrained_dofs(self, n_nodes: int, released=()) -> tuple[str, ...]:
        """Names of the DOFs the supports hold at zero on a beam of ``n_nodes`` nodes, without those of
        ``released`` (DOFs held by springs instead)."""
        held = tuple(f"{n}:{d}" for n, e in zip((1, n_nodes), self.ends) for d in ENDS[e].held)
        return tuple(d for d in held if d not in released)

    def spring_dofs(self, n_nodes: int) -> tuple[str, ...]:
        """Names of the DOFs the support's own springs act on (:attr:`spring_end`)."""
        return self.end_dofs(n_nodes, self.spring_end, ENDS[self.spring_end].spring)

    def nominal_unit_stiffness(self, length_m: float, suspension_unit: float | None = None) -> float:
        """The nominal stiffness of each of the support's springs for unit ``EI`` (1/m^3 translational, 1/m
        rotational): 0 without springs (rigid clamps, ideal pins), else the suspension ``suspension_unit`` (None:
        :func:`suspension_unit_stiffness`)."""
        if self.nominal != "suspension":
            return 0.0
        return suspension_unit_stiffness(length_m) if suspension_unit is None else float(suspension_unit)

    def draw(self, ax, length_m: float, y: float) -> None:
        """Draw the end conditions on a matplotlib axis under a beam drawn at height ``-0.06 y`` from ``x = 0`` to
        ``length_m``: a clamp as a wall, a pin as a triangle, a free end as nothing."""
        for x, end in zip((0.0, length_m), self.ends):
            symbol = ENDS[end].symbol
            if symbol == "wall":
                ax.plot([x, x], [-0.14 * y, 0.02 * y], color="k", lw=5)
            elif symbol == "triangle":
                ax.plot([x], [-0.1 * y], marker="^", ms=10, color="k")


#: Every support a beam file's ``bc`` accepts.
SUPPORTS: dict[str, Support] = {s.name: s for s in (
    Support("clamped-free", ("clamped", "free"), 0, "clamped", "root_flexibility", "rigid", "scale",
            "ln(k / k0) of the clamp's rotational spring",
            "a cantilever: clamped at x = 0, free at x = L"),
    Support("free-free", ("free", "free"), 2, "free", "suspension", "suspension", "scale",
            "ln(k / k0) of the suspension springs at both ends",
            "free at both ends, on a soft suspension (its bounce and pitch modes left out)"),
    Support("pinned-pinned", ("pinned", "pinned"), 0, "pinned", "bearing_flexibility", "none", "add",
            "log10(k L / EI) of the bearing rotational springs added at both pins",
            "simply supported: pinned at both ends"),
    Support("clamped-clamped", ("clamped", "clamped"), 0, "clamped", "clamp_flexibility", "rigid", "scale",
            "ln(k / k0) of both clamps' rotational springs",
            "clamped at both ends"),
)}

#: The thesis's support (its cantilever), the ``bc`` of a beam file that names none and of the thesis's test.
THESIS_SUPPORT = "clamped-free"

#: End pairs that leave the beam a mechanism (it moves without bending), refused with their own reason.
MECHANISMS = ("pinned-free", "free-pinned", "free-guided", "guided-free")


def support(name: str, source: str | None = None) -> Support:
    """The :class:`Support` named ``name``.

    Raises
    ------
    ConfigError
        One line naming ``source`` (if given), the key ``bc`` and the accepted names.
    """
    if isinstance(name, str) and name in SUPPORTS:
        return SUPPORTS[name]
    where = f"{source}: " if source else ""
    why = ("leaves the beam a mechanism (it moves without bending)" if name in MECHANISMS else "unknown")
    raise ConfigError(f"{where}'bc' = {name!r} {why}; expected one of {list(SUPPORTS)}")


def suspension_unit_stiffness(length_m: float, bounce_fraction: float = 0.05) -> float:
    """Default suspension of a free-free beam for unit EI (1/m^3), one spring at each end: the bounce mode at
    ``bounce_fraction`` of the first bending frequency (``omega_1 = 22.373 sqrt(EI / (m L^4))``; the bounce
    frequency ``sqrt(2 k / (m L))``, so the mass per length drops out)."""
    return 0.5 * length_m * (bounce_fraction * 22.3733 / length_m**2) ** 2


def add_springs(K, dofs, springs, stiffness):
    """``K`` plus springs to ground of ``stiffness`` on the DOFs named ``springs``.

    Parameters
    ----------
    K : ndarray, shape (..., n, n)
    dofs : sequence of str            the names of ``K``'s DOFs
    springs : sequence of str         the DOFs that get a spring
    stiffness : float or ndarray, shape (...)   (N/m, N m/rad), broadcast over the batch axes

    Returns
    -------
    ndarray, shape (..., n, n)   a new array
    """
    K = np.array(K, dtype=float)
    names = list(dofs)
    k = np.asarray(stiffness, float)
    for d in springs:
        i = names.index(d)
        K[..., i, i] += k
    return K


def changed_springs(sup: Support, nominal_Nm: float, EI_Nm2: float, length_m: float, parameter) -> np.ndarray:
    """Stiffness added to each of the support's springs by a support change (G,) (:attr:`Support.change`).

    ``"scale"``: the springs ``nominal_Nm`` become ``nominal_Nm exp(parameter)`` (``parameter = ln(k / k_0)``);
    ``"add"``: springs ``10**parameter EI / L`` are added where the nominal beam has none.
    """
    g = np.asarray(parameter, float)
    if sup.change == "scale":
        return nominal_Nm * (np.exp(g) - 1.0)
    return 10.0 ** g * EI_Nm2 / length_m


def markdown_table() -> str:
    """The supports as the Markdown table of ``docs/beam-file.md``."""
    rows = ["| `bc` | what it is | held at x = 0 / x = L | rigid-body modes | its springs | support effect "
            "| on the nominal beam | a support change |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    nominal = {"rigid": "rigid clamps (`generate` draws a clamp spring)", "none": "ideal pins, no spring",
               "suspension": "the default suspension: bounce mode at 5 % of the first bending frequency"}
    for s in SUPPORTS.values():
        held = " / ".join(", ".join(ENDS[e].held) or "-" for e in s.ends)
        where = f"{ENDS[s.spring_end].spring} of the {s.spring_end} ends"
        rows.append(f"| {s.name} | {s.help} | {held} | {s.rigid_body_modes} | {where} | `{s.effect}` "
                    f"| {nominal[s.nominal]} | {s.change_meaning} |")
    return "\n".join(rows)
