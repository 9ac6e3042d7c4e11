"""The test a beam file describes: supports, sensors, reference DOF, band, the modes it holds, location zones.

:func:`layout_of` turns a :class:`physics.beam.Beam` into a :class:`Layout`, the one record that
``generate``, ``train``, ``classify`` and the classical methods size themselves by. The beam-file keys:

``bc``
    clamped-free, free-free, pinned-pinned or clamped-clamped (:data:`physics.supports.SUPPORTS`).
    A free-free beam has two rigid-body modes (bounce and pitch, on whatever soft suspension holds it):
    they are recognised and left out (:attr:`physics.supports.Support.rigid_body_modes`), so mode 1 is the
    first bending mode.
``measured_x_m``
    The sensor positions (m from ``x = 0``), any number >= 1; the reference DOF's FRFs are measured there.
``drive_x_m``
    Where the force acts (the reference DOF; default: the first sensor).
``band_hz``
    ``[lo, hi]``, the band measured (Hz). The modes used are the bending modes of the nominal beam inside it
    that the sensors and the reference DOF see. Default: 9.549-763.9 Hz (60-4800 rad/s, the thesis's band)
    when it holds 4 or more bending modes of the beam, else from half the first to 1.25 times the
    ``max(4, min(sensors, 10))``-th bending frequency.
``zones_x_m``
    Interior edges (m) of the location zones a verdict names. Default: the spans between neighbouring
    sensors (and from each end to its nearest sensor) when that gives 3 or more zones, else 4 equal spans.
    On the thesis's beam (sensors at the quarter points) the zones are its 4 elements.

Refused in one line (:class:`physics.errors.ConfigError`): coinciding sensors, a band that holds no bending
mode, a sensor at a node of every mode used (it measures nothing), a reference DOF at a node of every mode.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from physics.effects import interpolation_matrix
from physics.errors import ConfigError
from physics.beam import Beam
from physics.supports import THESIS_SUPPORT, Support, support

__all__ = ["DEFAULT_BAND_HZ", "MIN_VISIBLE", "Layout", "layout_of", "nominal_modes",
           "relative_amplitude", "uniform_shapes"]

#: The thesis's band: 60-4800 rad/s.
DEFAULT_BAND_HZ = (60.0 / (2 * np.pi), 4800.0 / (2 * np.pi))

#: A mode is seen at a point when its amplitude there is at least this fraction of its largest amplitude.
MIN_VISIBLE = 0.02

#: Elements of the mesh the nominal modes are computed on.
NOMINAL_ELEMENTS = 120


@dataclass(frozen=True)
class Layout:
    """The test of one beam.

    Attributes
    ----------
    bc : str                           support
    length_m : float
    sensors_x_m : tuple of float       sensor positions (m), in the beam file's order
    drive_x_m : float                  reference DOF (force) position (m)
    band_hz : tuple (lo, hi)           band measured (Hz)
    zones_x_m : tuple of float         zone edges (m), ``0 ... length_m``, strictly increasing
    modes : tuple of int               bending-mode numbers used (1 = first bending mode), ascending
    frequencies_hz : tuple of float    their nominal natural frequencies (Hz)
    unseen : tuple of int              bending modes in the band that no sensor or the reference DOF sees
    thesis : bool                      the thesis's test: a clamped-free beam measured at the quarter points and
                                       driven at the first, without ``band_hz`` or ``zones_x_m``: its band
                                       (60-4800 rad/s), modes 1-4 and 4 element zones, whatever the band holds
    """

    bc: str
    length_m: float
    sensors_x_m: tuple
    drive_x_m: float
    band_hz: tuple
    zones_x_m: tuple
    modes: tuple
    frequencies_hz: tuple
    unseen: tuple = ()
    thesis: bool = False

    @property
    def support(self) -> Support:
        """The record of the test's supports (:mod:`physics.supports`)."""
        return support(self.bc)

    @cached_property
    def sensor_shapes(self) -> np.ndarray:
        """Shapes (S, m) of the test's modes at its sensors in ascending ``x`` for a uniform beam on its supports
        (:func:`uniform_shapes`): what an identified shape is paired against."""
        return uniform_shapes(self, sorted(self.sensors_x_m))

    @property
    def n_sensors(self) -> int:
        return len(self.sensors_x_m)

    @property
    def n_modes(self) -> int:
        return len(self.modes)

    @property
    def n_zones(self) -> int:
        return len(self.zones_x_m) - 1

    @property
    def drive_sensor(self) -> int | None:
        """Index of the sensor at the reference DOF (a driving-point FRF), or None."""
        d = np.abs(np.asarray(self.sensors_x_m) - self.drive_x_m)
        k = int(np.argmin(d))
        return k if d[k] <= 1e-9 * self.length_m else None

    def zone_of(self, x_m) -> np.ndarray:
        """1-based zone holding each ``x_m`` (0 where NaN), shape of ``x_m``."""
        x = np.asarray(x_m, float)
        z = np.clip(np.searchsorted(np.asarray(self.zones_x_m), np.nan_to_num(x), side="right"), 1, self.n_zones)
        return np.where(np.isnan(x), 0, z)

    def to_dict(self) -> dict:
        return {"bc": self.bc, "length_m": self.length_m, "sensors_x_m": list(self.sensors_x_m),
                "drive_x_m": self.drive_x_m, "band_hz": list(self.band_hz), "zones_x_m": list(self.zones_x_m),
                "modes": list(self.modes), "frequencies_hz": list(self.frequencies_hz), "unseen": list(self.unseen),
                "thesis": bool(self.thesis)}

    @classmethod
    def from_dict(cls, d: dict) -> "Layout":
        return cls(support(d["bc"], "layout").name, float(d["length_m"]), tuple(map(float, d["sensors_x_m"])),
                   float(d["drive_x_m"]),
                   tuple(map(float, d["band_hz"])), tuple(map(float, d["zones_x_m"])), tuple(map(int, d["modes"])),
                   tuple(map(float, d["frequencies_hz"])), tuple(map(int, d.get("unseen", ()))),
                   bool(d.get("thesis", False)))


def nominal_modes(beam, n_elements: int = NOMINAL_ELEMENTS):
    """Bending modes of the nominal beam (rigid-body modes of a free-free beam left out).

    Returns
    -------
    frequencies_hz : ndarray, shape (r,)
    shape_at : callable   ``shape_at(x_m)`` -> ndarray (len(x_m), r) of mass-normalised translations
    """
    from scipy.linalg import eigh

    model = beam.fe_model(n_elements)
    w2, v = eigh(model.K, model.M)
    skip = beam.support.rigid_body_modes
    w2, v = w2[skip:], v[:, skip:]
    f = np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)

    def shape_at(x_m):
        return interpolation_matrix(model, np.atleast_1d(np.asarray(x_m, float))) @ v

    return f, shape_at


def relative_amplitude(shape_at, x_m, length_m: float) -> np.ndarray:
    """``|phi(x)|`` over each mode's largest amplitude along the beam, shape (len(x_m), r), of ``shape_at`` of
    :func:`nominal_modes` (the measure :data:`MIN_VISIBLE` is compared with)."""
    peak = np.abs(shape_at(np.linspace(0, length_m, 241))).max(axis=0)
    return np.abs(shape_at(x_m)) / peak


def uniform_shapes(test: Layout, x_m) -> np.ndarray:
    """Shapes (len(x_m), m) of the test's modes at ``x_m`` for a uniform beam on the test's supports (mass
    normalised for unit mass per length; a uniform beam's shapes do not depend on ``EI`` or the mass), rigid-body
    modes left out."""
    shape_at = _uniform_shape_at(test.bc, float(test.length_m))
    return shape_at(np.atleast_1d(np.asarray(x_m, float)))[:, np.asarray(test.modes) - 1]


@lru_cache(maxsize=16)
def _uniform_shape_at(bc: str, length_m: float):

    beam = Beam("uniform", length_m, length_m, 0.01, 0.01, EI_Nm2=1.0, mass_per_length_kg_m=1.0, bc=bc,
                measured_x_m=(length_m,))
    return nominal_modes(beam)[1]


def _default_band(f_hz: np.ndarray, n_sensors: int) -> tuple:
    lo, hi = DEFAULT_BAND_HZ
    if np.count_nonzero((f_hz >= lo) & (f_hz <= hi)) >= 4:
        return DEFAULT_BAND_HZ
    k = max(4, min(n_sensors, 10))
    return (0.5 * f_hz[0], 1.25 * f_hz[min(k, f_hz.size) - 1])


def _default_zones(length_m: float, sensors_x_m) -> tuple:
    tol = 1e-9 * length_m
    edges = [0.0]
    for x in sorted(sensors_x_m):
        if x - edges[-1] > tol and length_m - x > tol:
            edges.append(float(x))
    edges.append(float(length_m))
    if len(edges) - 1 >= 3:
        return tuple(edges)
    return tuple(float(v) for v in np.linspace(0.0, length_m, 5))


def layout_of(beam, source: str = "beam") -> Layout:
    """The test ``beam`` describes (module docstring), validated.

    Raises
    ------
    ConfigError
        One line naming ``source`` and the key: coinciding sensors, zone edges out of order or outside the
        beam, a band without bending modes, a sensor or the reference DOF at a node of every mode used.
    """
    L = beam.length_m
    xs = np.asarray(beam.measured_x_m, float)
    tol = 1e-6 * L
    order = np.argsort(xs)
    close = np.flatnonzero(np.diff(xs[order]) < tol)
    if close.size:
        a, b = sorted((int(order[close[0]]), int(order[close[0] + 1])))
        raise ConfigError(f"{source}: 'measured_x_m' sensors {a + 1} and {b + 1} coincide at {xs[a]:g} m; "
                          "expected distinct positions")
    drive = float(xs[0]) if beam.drive_x_m is None else float(beam.drive_x_m)
    quarter = xs.size == 4 and bool(np.allclose(xs, L * np.arange(1, 5) / 4, rtol=0, atol=1e-9 * L))
    thesis = (beam.bc == THESIS_SUPPORT and quarter and drive == xs[0]
              and beam.band_hz is None and beam.zones_x_m is None)
    f_all, shape_at = nominal_modes(beam)
    band = DEFAULT_BAND_HZ if thesis else _default_band(f_all, xs.size) if beam.band_hz is None else \
        tuple(map(float, beam.band_hz))
    inside = np.flatnonzero((f_all >= band[0]) & (f_all <= band[1]))
    if thesis:
        inside = np.arange(4)
    if inside.size == 0:
        near = ", ".join(f"{v:.4g}" for v in f_all[:4])
        raise ConfigError(f"{source}: 'band_hz' [{band[0]:g}, {band[1]:g}] holds no bending mode of the beam "
                          f"(its first bending frequencies: {near} Hz); expected a band around them")
    rel = relative_amplitude(shape_at, np.concatenate([xs, [drive]]), L)[:, inside]   # (S + 1, r)
    sensor_sees = rel[:-1] >= MIN_VISIBLE                            # (S, r)
    drive_sees = rel[-1] >= MIN_VISIBLE                              # (r,)
    blind = np.flatnonzero(~sensor_sees.any(axis=1))
    if blind.size:
        k = int(blind[0])
        raise ConfigError(f"{source}: 'measured_x_m' sensor {k + 1} at {xs[k]:g} m lies at a node of every mode in "
                          f"the band (amplitude below {MIN_VISIBLE:.0%} of each mode's largest): it measures nothing; "
                          "expected a position away from the supports and nodes")
    if not drive_sees.any():
        raise ConfigError(f"{source}: 'drive_x_m' = {drive:g} m lies at a node of every mode in the band: the force "
                          "excites nothing; expected a position away from the supports and nodes")
    seen = sensor_sees.any(axis=0) & drive_sees
    if not seen.any():
        raise ConfigError(f"{source}: no mode in 'band_hz' [{band[0]:g}, {band[1]:g}] is seen both at a sensor and "
                          "at the reference DOF; expected sensors and a drive point away from the modes' nodes")
    zones = _default_zones(L, xs) if beam.zones_x_m is None else (0.0, *map(float, beam.zones_x_m), float(L))
    if np.any(np.diff(zones) <= tol):
        raise ConfigError(f"{source}: 'zones_x_m' must be increasing positions strictly inside (0, {L:g}) m, "
                          f"got {list(beam.zones_x_m)}")
    modes = tuple(int(i) + 1 for i in inside[seen])
    if thesis:
        modes = (1, 2, 3, 4)
    return Layout(beam.bc, float(L), tuple(map(float, xs)), drive, band, tuple(map(float, zones)), modes,
                      tuple(float(f_all[m - 1]) for m in modes),
                      tuple(int(i) + 1 for i in inside[~seen]), thesis)
