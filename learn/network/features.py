"""Input features of the damage classifier, computed the same way from a dataset and from measured data.

A *pair* is the baseline (undamaged) and the current state of one specimen.
Three input routes turn a pair into a fixed-length real vector:

``modal``
    Modal features (:func:`modal_features`): relative natural-frequency shifts,
    the baseline frequencies, and the changes of the real, unit-norm mode
    shapes and of their curvatures (second differences with the clamp,
    thesis nodes 1..5) between the states.
``updated``
    Log-magnitude receptances of the Lancaster/Pilkey updated models of both
    states (the thesis's route: FRFs -> modal identification -> updated model
    -> FRFs), on the fixed log-frequency grid :data:`GRID_RAD_S`.
``frequency``
    The relative natural-frequency shifts alone (:func:`frequency_features`): one sensor, or natural
    frequencies without shapes.
``measured``
    The measured receptances themselves on the same grid: measured FRFs come
    on their own frequency lines and are interpolated onto the grid in
    log-frequency (:func:`map_frf_to_grid`).

Every route sees the same pairs; :func:`load_pairs` is the only function that
reads a dataset (format ``beam-damage-dataset/2``). What changes between two
test days without damage (temperature, re-clamping) and the per-sample noise
come from the generator (``beam-damage generate --config training``).
"""

from __future__ import annotations

import hashlib
import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from physics.errors import BeamDamageError, FileFormatError
from datagen.dataset import Dataset
from datagen.store import DATASET_FORMAT, read_manifest
from datagen.synth import log_magnitude_map
from learn.explanations.shapes import real_shapes, sign_aligned
from physics.layout import Layout
from physics.supports import THESIS_SUPPORT, Support, support

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["BeamSpec", "DOFS", "as_spec", "GRID_RAD_S", "Pairs", "ROUTES", "beam_of_manifest", "curvature_points",
           "curvatures", "feature_modes", "feature_names", "features", "frequency_features", "frf_features",
           "grid_weights", "labels", "layout_curvatures", "load_pairs", "manifest_checksum", "map_frf_to_grid",
           "modal_features", "split_by_specimen", "with_missing_modes"]

ROUTES = ("modal", "updated", "measured", "frequency")

#: Fixed FRF representation: log-spaced lines (rad/s) covering the four modes of the thesis beams.
GRID_RAD_S = np.geomspace(60.0, 4800.0, 96)

#: Measured translations of the 4-element thesis grid.
DOFS = ("2:y", "3:y", "4:y", "5:y")


@dataclass(frozen=True)
class BeamSpec:
    """What a model is trained for; a model refuses data of another beam, DOF set, test or mass model.

    ``test`` is the test of the beam file (:class:`physics.layout.Layout`: supports, sensors, band, modes,
    zones), None for the thesis's (4 sensors at the quarter points, modes 1-4, :data:`GRID_RAD_S`, 4 elements).
    """

    name: str
    length_m: float
    dofs: tuple
    mass_model: str
    test: Layout | None = None

    @property
    def n_modes(self) -> int:
        return 4 if self.test is None else self.test.n_modes

    @property
    def support(self) -> Support:
        """The record of the test's supports (:mod:`physics.supports`): the thesis's clamp without a test."""
        return support(THESIS_SUPPORT if self.test is None else self.test.bc, "the model's test")

    @property
    def grid_rad_s(self) -> np.ndarray:
        """The FRF features' log-spaced lines: :data:`GRID_RAD_S`, or 96 over the test's band."""
        if self.test is None:
            return GRID_RAD_S
        lo, hi = self.test.band_hz
        return np.geomspace(2 * np.pi * max(lo, hi / 200), 2 * np.pi * hi, GRID_RAD_S.size)

    @property
    def zone_edges_m(self) -> np.ndarray:
        """Edges of the location zones (m): the thesis's 4 elements, or the test's zones."""
        if self.test is None:
            return np.linspace(0.0, self.length_m, 5)
        return np.asarray(self.test.zones_x_m)

    @property
    def sensors_x_m(self) -> np.ndarray:
        """Sensor positions (m), ascending (the order of the measured DOFs)."""
        if self.test is None:
            return self.length_m * np.arange(1, 5) / 4
        return np.sort(np.asarray(self.test.sensors_x_m))

    @property
    def drive_row(self) -> int:
        """Row of the reference DOF among :attr:`dofs` (the thesis's: the first)."""
        if self.test is None:
            return 0
        return int(np.argmin(np.abs(self.sensors_x_m - self.test.drive_x_m)))

    @property
    def modes(self) -> tuple:
        """Bending modes used (1-based)."""
        return (1, 2, 3, 4) if self.test is None else tuple(self.test.modes)

    def zone_of_x_over_L(self, x_over_L) -> np.ndarray:
        """1-based zone of each ``x / L`` (0 where NaN)."""
        x = np.asarray(x_over_L, float)
        if self.test is None:  # the thesis's elements
            return np.where(np.isnan(x), 0, np.clip(np.floor(np.nan_to_num(x) * 4).astype(int) + 1, 1, 4))
        edges = self.zone_edges_m / self.length_m
        z = np.clip(np.searchsorted(edges, np.nan_to_num(x), side="right"), 1, edges.size - 1)
        return np.where(np.isnan(x), 0, z)

    def to_dict(self) -> dict:
        out = {"name": self.name, "length_m": self.length_m, "dofs": list(self.dofs), "mass_model": self.mass_model}
        if self.test is not None:
            out["test"] = self.test.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "BeamSpec":
        test = Layout.from_dict(d["test"]) if d.get("test") else None
        return cls(str(d["name"]), float(d["length_m"]), tuple(d["dofs"]), str(d["mass_model"]), test)

    def differences(self, other: "BeamSpec") -> list[str]:
        """Plain-language list of what differs (empty when compatible)."""
        out = []
        if self.name != other.name:
            out.append(f"beam {other.name!r} instead of {self.name!r}")
        if abs(self.length_m - other.length_m) > 1e-6 * self.length_m:
            out.append(f"length {other.length_m:g} m instead of {self.length_m:g} m")
        if tuple(self.dofs) != tuple(other.dofs):
            out.append(f"DOF set {list(other.dofs)} instead of {list(self.dofs)}")
        if self.mass_model != other.mass_model:
            out.append(f"mass model {other.mass_model!r} instead of {self.mass_model!r}")
        a, b = self.test, other.test
        if a is not None and b is not None:
            if a.bc != b.bc:
                out.append(f"supports {b.bc} instead of {a.bc}")
            if a.modes != b.modes:
                out.append(f"modes {list(b.modes)} instead of {list(a.modes)}")
        elif (a is None) != (b is None):
            out.append("the thesis's test instead of the beam file's" if b is None else
                       f"a {b.bc} test with {b.n_sensors} sensor(s) and modes {list(b.modes)} instead of the thesis's")
        return out


@dataclass
class Pairs:
    """Baseline/current pairs of ``n`` specimens.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (n, 2, m)
        Measured eigenvalues (rad/s, Im > 0), state 0 = baseline, 1 = current.
    eigenvectors : ndarray, complex, shape (n, 2, 4, m)
        Measured complex shapes at :data:`DOFS`, any scaling.
    log_frf : dict of ndarray, float32, shape (n, 2, 4, G)
        ``log10 |H|`` on :data:`GRID_RAD_S` per FRF kind read ("measured": the noisy
        receptances, "updated": those of the updated models), drive at DOF 1.
    table : DataFrame
        Per-pair labels and specimen parameters (empty columns for measured data).
    groups : ndarray of str, shape (n,)
        Specimen key (dataset checksum + sample id): splits never cut a group.
    beam : BeamSpec
    source : list of dict
        Datasets read: path, manifest checksum, samples, config, truth beam.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    log_frf: dict
    table: pd.DataFrame
    groups: np.ndarray
    beam: BeamSpec
    source: list

    def __len__(self):
        return self.eigenvalues.shape[0]

    def take(self, idx) -> "Pairs":
        idx = np.asarray(idx)
        return replace(self, eigenvalues=self.eigenvalues[idx], eigenvectors=self.eigenvectors[idx],
                       log_frf={k: v[idx] for k, v in self.log_frf.items()},
                       table=self.table.iloc[idx].reset_index(drop=True), groups=self.groups[idx])


def as_spec(beam) -> BeamSpec:
    """A :class:`BeamSpec` from itself or from a length (m): the thesis's test (4 element zones)."""
    return beam if isinstance(beam, BeamSpec) else BeamSpec("", float(beam), (), "")


def manifest_checksum(manifest: dict) -> str:
    """sha256 of a dataset manifest's recorded checksums (identifies the data a model was trained on)."""
    return hashlib.sha256(json.dumps(manifest.get("checksums", {}), sort_keys=True).encode()).hexdigest()


def beam_of_manifest(manifest: dict) -> BeamSpec:
    """The beam a format-2 dataset simulates: ``preset`` (name, length of the truth beam or beam file),
    ``schema.measured_dofs``, ``config.updating.mass_model`` and ``layout`` (the test; None for the thesis's)."""
    lay = manifest.get("layout")
    test = Layout.from_dict(lay) if lay and not lay.get("thesis") else None
    return BeamSpec(manifest["preset"]["name"], float(manifest["preset"]["length_m"]),
                    tuple(manifest["schema"]["measured_dofs"]), manifest["config"]["updating"]["mass_model"], test)


def load_pairs(roots, frfs=("measured", "updated"), chunk: int = 1024, workers: int | None = None) -> Pairs:
    """Read one or more format-2 dataset directories into :class:`Pairs` (the only place that reads datasets).

    FRFs are synthesised by :meth:`datagen.dataset.Dataset.frf` ``chunk`` samples
    at a time, only on the lines :data:`GRID_RAD_S` interpolates from (168 of
    the default 1024; each with exactly its value in the full FRF, noise
    included), and kept only as ``log10 |H|`` on the grid, so memory stays at
    ``chunk`` FRF sets plus 3 kB per pair and kind. Chunks are synthesised on
    ``workers`` threads (default: the CPUs this process may use; the compiled
    kernels release the GIL); the result does not depend on ``workers``.

    Parameters
    ----------
    roots : path or sequence of paths
        Directories written by ``beam-damage generate``; all must be of the same beam.
    frfs : sequence of {"measured", "updated"}
        FRF kinds to read (the FRF routes need them).

    Raises
    ------
    FileFormatError
        A directory is not a complete format-2 dataset, or datasets of different beams are mixed.
    """
    import pandas as pd  # pandas: only where datasets are read

    roots = [roots] if isinstance(roots, (str, Path)) else list(roots)
    if not roots:
        raise FileFormatError("no dataset directory given")
    workers = workers or len(os.sched_getaffinity(0))
    parts, source, beam = [], [], None
    for root in roots:
        read_manifest(root, formats=(DATASET_FORMAT,))   # format 1 is refused in one line
        try:
            ds = Dataset(root)
        except FileFormatError:  # names the damaged file itself
            raise
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{root}: not a dataset directory written by 'beam-damage generate' ({exc})") \
                from None
        if not ds.shards or not ds.manifest.get("complete"):
            raise FileFormatError(f"{root}: dataset is incomplete; re-run its 'beam-damage generate' command")
        ds.verify_or_raise()  # every shard's checksums, before any thread reads
        b = beam_of_manifest(ds.manifest)
        if beam is not None and b != beam:
            raise FileFormatError(f"{root}: dataset of another beam ({'; '.join(beam.differences(b))})")
        beam = b
        table = ds.samples.assign(dataset=str(root))
        cs = manifest_checksum(ds.manifest)
        lines, log_grid = log_magnitude_map(grid_weights(ds.omega_rad_s, b.grid_rad_s)[0])
        log_frf = {}
        if "updated" in frfs and not ds.has_updated_model:
            raise FileFormatError(f"{root}: {ds.updating}")
        for kind in frfs:
            out = np.empty((len(ds), 2, len(b.dofs), b.grid_rad_s.size), np.float32)

            def read(i, kind=kind, out=out):
                H = ds.frf(kind, np.arange(i, min(i + chunk, len(ds))), lines=lines)
                out[i:i + chunk] = log_grid(H)

            with ThreadPoolExecutor(workers) as pool:
                list(pool.map(read, range(0, len(ds), chunk)))
            log_frf[kind] = out
        parts.append(dict(eigenvalues=ds.array("eigenvalues_measured"), eigenvectors=ds.array("eigenvectors_measured"),
                          log_frf=log_frf, table=table,
                          groups=np.array([f"{cs[:12]}:{k}" for k in table["sample_id"].to_numpy()])))
        source.append({"path": str(root), "manifest_checksum": cs, "samples": int(len(table)),
                       "config": ds.manifest["config"], "truth_beam": ds.manifest["preset"]})

    def cat(k):
        return np.concatenate([p[k] for p in parts])

    return Pairs(cat("eigenvalues"), cat("eigenvectors"),
                 {k: np.concatenate([p["log_frf"][k] for p in parts]) for k in frfs},
                 pd.concat([p["table"] for p in parts], ignore_index=True), cat("groups"), beam, source)


# --------------------------------------------------------------------------- labels
def labels(table: pd.DataFrame, beam) -> dict:
    """Training targets of each pair from a format-2 sample table.

    The size of a damage is the ``damage{k}_size`` its model stores
    (:mod:`datagen.damage`; a slit's hinge flexibility ``w r / ((1 - r) L)``, a mass
    change's signed mass ratio). With several damages the location and element are
    those of the largest ``|size|`` and the size is the sum.

    Returns
    -------
    dict of ndarray, shape (n,)
        ``damaged`` (bool), ``x_over_L`` (NaN if intact), ``size`` (the damage kind's size; 0 if intact),
        ``element`` (its zone, :meth:`BeamSpec.zone_of_x_over_L`, 1.., 0 if intact; the thesis's elements 1..4),
        ``max_drop`` (largest relative drop of the noise-free
        natural frequencies due to the damage alone: ``max_frequency_drop_rel``), ``n_damages``,
        ``support_changed`` (bool: supports changed beyond re-clamping; False where the table lacks the column).
    """
    beam = as_spec(beam)
    length_m = beam.length_m
    n = len(table)
    damaged = table["damaged"].to_numpy(bool)
    k = 0
    while f"damage{k}_size" in table:
        k += 1
    if k > 0:
        sizes = np.stack([np.nan_to_num(table[f"damage{j}_size"].to_numpy(float)) for j in range(k)], 1)
        xs = np.stack([table[f"damage{j}_x_m"].to_numpy(float) for j in range(k)], 1)
        x = xs[np.arange(n), np.argmax(np.abs(sizes), axis=1)] / length_m
        size = sizes.sum(axis=1)
    else:
        x = np.full(n, np.nan)
        size = np.zeros(n)
    x = np.where(damaged, np.clip(x, 0.0, 1.0), np.nan)
    element = np.where(damaged, beam.zone_of_x_over_L(x), 0)
    return {"damaged": damaged, "x_over_L": x, "size": np.where(damaged, size, 0.0),
            "element": element, "max_drop": table["max_frequency_drop_rel"].to_numpy(float),
            "n_damages": table["n_damages"].to_numpy(int),
            "support_changed": (table["support_changed"].to_numpy(bool) if "support_changed" in table
                                else np.zeros(n, bool))}


# --------------------------------------------------------------------------- modal route
def curvatures(shapes):
    """Second differences of shapes at the clamp and nodes 2..4 (unit element length), batched.

    Displacement and slope are zero at the clamp (node 1), so there
    ``w'' ~ 2 w_2 / h^2``; at inner nodes ``(w_{i-1} - 2 w_i + w_{i+1}) / h^2``.

    Parameters
    ----------
    shapes : ndarray, shape (..., 4, m)   translations of nodes 2..5

    Returns
    -------
    ndarray, shape (..., 4, m)
    """
    w = np.concatenate([np.zeros_like(shapes[..., :1, :]), shapes], axis=-2)
    inner = w[..., :-2, :] - 2 * w[..., 1:-1, :] + w[..., 2:, :]
    return np.concatenate([2 * shapes[..., :1, :], inner], axis=-2)


def curvature_points(test: Layout) -> tuple[np.ndarray, tuple[int, int]]:
    """The points of :func:`layout_curvatures`: the sensors (ascending) plus each end whose translation a support
    holds at zero when no sensor sits there; returns their positions (m) and how many ends were added (0/1, 0/1)."""
    x = np.sort(np.asarray(test.sensors_x_m, float))
    L, tol = test.length_m, 1e-9 * test.length_m
    held = test.support.constrained_dofs(2)                              # "1:y" / "2:y": an end's translation held
    ends = (int("1:y" in held and x[0] > tol), int("2:y" in held and x[-1] < L - tol))
    return np.concatenate([[0.0] * ends[0], x, [L] * ends[1]]), ends


def layout_curvatures(shapes, test: Layout):
    """Second divided differences of shapes at the sensors of any test, times the mean sensor spacing squared.

    The points are the sensors (ascending) plus each end whose translation a support holds at zero (a clamp or a
    pin) when no sensor sits there; every point with a neighbour on both sides gets
    ``2 (w_- / (h_- (h_- + h_+)) - w / (h_- h_+) + w_+ / (h_+ (h_- + h_+)))``.

    Parameters
    ----------
    shapes : ndarray, shape (..., S, m)   translations at the sensors, ascending positions

    Returns
    -------
    ndarray, shape (..., K, m)   K = the points with two neighbours (0 for one sensor on a free-free beam)
    """
    xp, ends = curvature_points(test)
    zero = np.zeros_like(shapes[..., :1, :])
    w = np.concatenate([zero] * ends[0] + [shapes] + [zero] * ends[1], axis=-2)
    if xp.size < 3:
        return shapes[..., :0, :]
    hm, hp = np.diff(xp)[:-1, None], np.diff(xp)[1:, None]
    d2 = 2 * (w[..., :-2, :] / (hm * (hm + hp)) - w[..., 1:-1, :] / (hm * hp) + w[..., 2:, :] / (hp * (hm + hp)))
    return d2 * np.mean(np.diff(xp)) ** 2


def modal_features(eigenvalues, eigenvectors, n_modes: int = 4, test: Layout | None = None):
    """Modal features of pairs (batched).

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (n, 2, m)
    eigenvectors : ndarray, complex, shape (n, 2, 4, m)

    Returns
    -------
    ndarray, shape (n, 9 n_modes)
        NaN in the columns of a mode whose eigen-data are NaN (:func:`with_missing_modes`).
        Per mode: relative frequency shift (percent); then the shape changes
        (4 DOFs x modes) and curvature changes (clamp and nodes 2..4 x modes),
        times 10. Only changes between the two tests: nothing of the baseline
        beam itself (its frequencies or their ratios), so that a beam whose
        stiffness, mass, root or shear flexibility differ from the training
        beam's is not a pair the network has never seen.
    """
    lam = np.asarray(eigenvalues, complex)[..., :n_modes]
    f = np.abs(lam) / (2 * np.pi)
    shift = 100 * (f[:, 1] / f[:, 0] - 1)
    with np.errstate(invalid="ignore"):                              # NaN modes (with_missing_modes) stay NaN
        u = real_shapes(np.asarray(eigenvectors, complex)[..., :n_modes])
    u1 = sign_aligned(u[:, 1], u[:, 0])                              # the current shape's sign follows the baseline's
    du = u1 - u[:, 0]
    curv = curvatures if test is None else (lambda v: layout_curvatures(v, test))
    dk = curv(u1) - curv(u[:, 0])
    n = lam.shape[0]
    return np.concatenate([shift, 10 * du.reshape(n, -1), 10 * dk.reshape(n, -1)], axis=1)


def feature_names(route: str, beam) -> list[str]:
    """Names of the feature columns of ``route`` ("modal" or "frequency") for ``beam``'s test, in column order:
    ``"df{r} (%)"`` the relative shift of mode ``r``; ``"dphi {dof} m{r}"`` the shape change of mode ``r`` at a
    sensor; ``"dkappa x={x} m{r}"`` its curvature change at a point (the clamp, ``x = 0``, on the thesis's test)."""
    beam = as_spec(beam)
    modes = beam.modes
    names = [f"df{r} (%)" for r in modes]
    if route == "frequency":
        return names
    if route != "modal":
        raise BeamDamageError(f"feature names are defined for the modal and frequency routes, not {route!r}")
    names += [f"dphi {d} m{r}" for d in beam.dofs for r in modes]
    if beam.test is None:
        points = beam.length_m * np.arange(4) / 4
    else:
        xp = curvature_points(beam.test)[0]
        points = xp[1:-1] if xp.size >= 3 else xp[:0]
    names += [f"dkappa x={x:.4g} m m{r}" for x in points for r in modes]
    return names


def feature_modes(n_features: int, n_modes: int) -> list[int]:
    """The 0-based mode of each column of the modal or frequency features (blocks of ``n_modes`` columns, one per
    mode: :func:`feature_names`)."""
    return [j % n_modes for j in range(n_features)]


def with_missing_modes(eigenvalues, eigenvectors, modes, n_modes: int):
    """Eigen-data of pairs on all ``n_modes`` of a model, NaN for the modes a pair lacks: the features of
    :func:`modal_features` and :func:`frequency_features` are then NaN exactly in the columns of those modes.

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (n, 2, c)
    eigenvectors : ndarray, complex, shape (n, 2, S, c)
    modes : array of int, shape (c,)   0-based model modes the ``c`` columns are

    Returns
    -------
    (ndarray (n, 2, n_modes), ndarray (n, 2, S, n_modes))
    """
    lam, vec = np.asarray(eigenvalues, complex), np.asarray(eigenvectors, complex)
    full_lam = np.full(lam.shape[:-1] + (n_modes,), np.nan, complex)
    full_vec = np.full(vec.shape[:-1] + (n_modes,), np.nan, complex)
    full_lam[..., modes], full_vec[..., modes] = lam, vec
    return full_lam, full_vec


def frequency_features(eigenvalues, n_modes: int = 4):
    """The ``frequency`` route: relative natural-frequency shifts (percent) of each mode, shape (n, n_modes); what
    one sensor, or natural frequencies alone, tell (the first columns of :func:`modal_features`)."""
    f = np.abs(np.asarray(eigenvalues, complex)[..., :n_modes])
    return 100 * (f[:, 1] / f[:, 0] - 1)


# --------------------------------------------------------------------------- FRF routes
def grid_weights(omega_rad_s, grid_rad_s=GRID_RAD_S):
    """Linear-interpolation matrix in log-frequency from FRF lines onto the grid.

    Grid points outside the lines take the nearest line's value.

    Returns
    -------
    W : ndarray, shape (G, F)
    covered : ndarray of bool, shape (G,)   grid points inside the measured band
    """
    w = np.log(np.asarray(omega_rad_s, float))
    g = np.log(np.asarray(grid_rad_s, float))
    j = np.clip(np.searchsorted(w, g) - 1, 0, w.size - 2)
    t = np.clip((g - w[j]) / (w[j + 1] - w[j]), 0.0, 1.0)
    W = np.zeros((g.size, w.size))
    W[np.arange(g.size), j] = 1 - t
    W[np.arange(g.size), j + 1] += t
    return W, (g >= w[0] - 1e-12) & (g <= w[-1] + 1e-12)


def map_frf_to_grid(H, omega_rad_s, grid_rad_s=GRID_RAD_S):
    """``log10 |H|`` on the fixed grid (interpolated in log-frequency), batched over leading axes.

    Parameters
    ----------
    H : ndarray, complex, shape (..., F)   receptance (m/N)
    omega_rad_s : ndarray, shape (F,)

    Returns
    -------
    ndarray, shape (..., G)
    """
    W, _ = grid_weights(omega_rad_s, grid_rad_s)
    return np.log10(np.abs(np.asarray(H)) + 1e-30) @ W.T


def frf_features(log_frf):
    """FRF features of pairs: baseline log-magnitude and the current-minus-baseline change.

    Parameters
    ----------
    log_frf : ndarray, shape (n, 2, S, G)   ``log10 |H|`` on the grid (:func:`map_frf_to_grid`)

    Returns
    -------
    ndarray, float32, shape (n, 2 S G)
    """
    L = np.asarray(log_frf, np.float32)
    n = L.shape[0]
    return np.concatenate([L[:, 0].reshape(n, -1) + 5.0, 10 * (L[:, 1] - L[:, 0]).reshape(n, -1)], axis=1)


def features(pairs: Pairs, route: str = "modal") -> np.ndarray:
    """Feature matrix (n, d) of ``pairs`` for one input route (:data:`ROUTES`)."""
    if route == "frequency":
        X = frequency_features(pairs.eigenvalues, pairs.beam.n_modes)
    elif route == "modal":
        X = modal_features(pairs.eigenvalues, pairs.eigenvectors, pairs.beam.n_modes, pairs.beam.test)
    elif route in ("updated", "measured"):
        if route not in pairs.log_frf:
            raise BeamDamageError(f"input route {route!r} needs FRFs of both states; none were read")
        X = frf_features(pairs.log_frf[route])
    else:
        raise BeamDamageError(f"input route {route!r} must be one of {', '.join(ROUTES)}")
    return np.where(np.isfinite(X), X, 0.0)


# --------------------------------------------------------------------------- splits
def split_by_specimen(groups, fractions=(0.7, 0.15, 0.15), seed: int = 0):
    """Train/validation/test indices with every specimen in exactly one part.

    Parameters
    ----------
    groups : array_like, shape (n,)   specimen key of each pair
    fractions : three fractions summing to 1

    Returns
    -------
    tuple of three ndarray of int
    """
    groups = np.asarray(groups)
    uniq, inv = np.unique(groups, return_inverse=True)
    perm = np.random.default_rng(seed).permutation(uniq.size)
    rank = np.empty(uniq.size, int)
    rank[perm] = np.arange(uniq.size)
    cut = np.cumsum(np.asarray(fractions, float)) / np.sum(fractions) * uniq.size
    part = np.searchsorted(cut, rank[inv], side="right")
    return tuple(np.flatnonzero(part == k) for k in range(3))
