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
``measured``
    The measured receptances themselves on the same grid: measured FRFs come
    on their own frequency lines and are interpolated onto the grid in
    log-frequency (:func:`map_frf_to_grid`).

Every route sees the same pairs; :func:`load_pairs` is the only function that
reads a dataset. State changes that are not damage (temperature, re-clamping)
are applied to the current state of dataset pairs by
:func:`apply_state_changes` (the generator of the day does not simulate them).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from physics.errors import BeamDamageError, FileFormatError
from physics.fem import beam_model
from physics.modal import undamped_modes

ROUTES = ("modal", "updated", "measured")

#: Fixed FRF representation: log-spaced lines (rad/s) covering the four modes of the thesis beams.
GRID_RAD_S = np.geomspace(60.0, 4800.0, 96)

#: Measured translations of the 4-element thesis grid.
DOFS = ("2:y", "3:y", "4:y", "5:y")


@dataclass(frozen=True)
class BeamSpec:
    """What a model is trained for; a model refuses data of another beam, DOF set or mass model."""

    name: str
    length_m: float
    dofs: tuple
    mass_model: str

    def to_dict(self) -> dict:
        return {"name": self.name, "length_m": self.length_m, "dofs": list(self.dofs), "mass_model": self.mass_model}

    @classmethod
    def from_dict(cls, d: dict) -> "BeamSpec":
        return cls(str(d["name"]), float(d["length_m"]), tuple(d["dofs"]), str(d["mass_model"]))

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
    omega_rad_s : ndarray, shape (F,)
        Lines of the FRFs (rad/s).
    frf_measured, frf_updated : ndarray, complex, shape (n, 2, 4, F) or None
        Measured receptances and those of the updated models, drive at DOF 1.
    table : DataFrame
        Per-pair labels and specimen parameters (empty columns for measured data).
    groups : ndarray of str, shape (n,)
        Specimen key (dataset checksum + specimen/sample id): splits never cut a group.
    beam : BeamSpec
    source : list of dict
        Datasets read: path, manifest checksum, samples, config.
    frequency_ratio : ndarray, shape (n, m) or None
        Natural-frequency ratios a non-damage state change applied to the current
        state (:func:`apply_state_changes`); the FRF routes warp the current FRF by them.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    omega_rad_s: np.ndarray
    frf_measured: np.ndarray | None
    frf_updated: np.ndarray | None
    table: pd.DataFrame
    groups: np.ndarray
    beam: BeamSpec
    source: list
    frequency_ratio: np.ndarray | None = None

    def __len__(self):
        return self.eigenvalues.shape[0]

    def take(self, idx) -> "Pairs":
        idx = np.asarray(idx)
        f = (lambda a: None if a is None else a[idx])
        return replace(self, eigenvalues=self.eigenvalues[idx], eigenvectors=self.eigenvectors[idx],
                       frf_measured=f(self.frf_measured), frf_updated=f(self.frf_updated),
                       table=self.table.iloc[idx].reset_index(drop=True), groups=self.groups[idx],
                       frequency_ratio=f(self.frequency_ratio))


def manifest_checksum(manifest: dict) -> str:
    """sha256 of a dataset manifest's recorded checksums (identifies the data a model was trained on)."""
    return hashlib.sha256(json.dumps(manifest.get("checksums", {}), sort_keys=True).encode()).hexdigest()


def beam_of_manifest(manifest: dict) -> BeamSpec:
    from physics.properties import beam_preset

    cfg = manifest["config"]
    return BeamSpec(cfg["preset"], float(beam_preset(cfg["preset"]).length), DOFS, cfg["updating"]["mass_model"])


def load_pairs(roots, frfs=("frf_measured", "frf_updated")) -> Pairs:
    """Read one or more dataset directories into :class:`Pairs` (the only place that reads datasets).

    Parameters
    ----------
    roots : path or sequence of paths
        Directories written by ``beam-damage generate``; all must be of the same beam.
    frfs : sequence of {"frf_measured", "frf_updated"}
        FRF arrays to read (the FRF routes need them; they are large).

    Raises
    ------
    FileFormatError
        A directory is not a complete dataset, or datasets of different beams are mixed.
    """
    from datagen.store import Dataset

    roots = [roots] if isinstance(roots, (str, Path)) else list(roots)
    if not roots:
        raise FileFormatError("no dataset directory given")
    parts, source, beam, omega = [], [], None, None
    for root in roots:
        try:
            ds = Dataset(root)
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{root}: not a dataset directory written by 'beam-damage generate' ({exc})") from None
        if not ds.shards:
            raise FileFormatError(f"{root}: dataset has no complete shard")
        b = beam_of_manifest(ds.manifest)
        if beam is not None and b != beam:
            raise FileFormatError(f"{root}: dataset of another beam ({'; '.join(beam.differences(b))})")
        beam = b
        table = ds.samples
        w = ds.omega_rad_s
        if omega is not None and (w.shape != omega.shape or not np.allclose(w, omega)):
            raise FileFormatError(f"{root}: FRF lines differ from the first dataset's")
        omega = w
        cs = manifest_checksum(ds.manifest)
        key = table["specimen_id"] if "specimen_id" in table else table["sample_id"]
        table = table.assign(frequency_noise=ds.manifest["config"]["measurement"]["frequency_noise"],
                             frf_noise=ds.manifest["config"]["measurement"]["frf_noise"], dataset=str(root))
        parts.append(dict(
            eigenvalues=ds.array("eigenvalues_measured"), eigenvectors=ds.array("eigenvectors_measured"),
            frf_measured=ds.array("frf_measured") if "frf_measured" in frfs else None,
            frf_updated=ds.array("frf_updated") if "frf_updated" in frfs else None,
            table=table, groups=np.array([f"{cs[:12]}:{k}" for k in key.to_numpy()])))
        source.append({"path": str(root), "manifest_checksum": cs, "samples": int(len(table)),
                       "config": ds.manifest["config"]})
    cat = (lambda k: None if parts[0][k] is None else np.concatenate([p[k] for p in parts]))
    return Pairs(cat("eigenvalues"), cat("eigenvectors"), omega, cat("frf_measured"), cat("frf_updated"),
                 pd.concat([p["table"] for p in parts], ignore_index=True), cat("groups"), beam, source)


# --------------------------------------------------------------------------- labels
def labels(table: pd.DataFrame, length_m: float) -> dict:
    """Training targets of each pair from the sample table.

    With several slits the location and element are those of the slit of
    largest stiffness loss, the size is the summed stiffness loss.

    Returns
    -------
    dict of ndarray, shape (n,)
        ``damaged`` (bool: ``damaged`` column or ``n_slits > 0``), ``x_over_L``
        (NaN if intact), ``stiffness_loss_Nm3`` (0 if intact), ``element`` (1..4,
        0 if intact), ``max_drop`` (largest relative drop of the noise-free
        natural frequencies), ``n_slits``.
    """
    n = len(table)
    n_slits = table["n_slits"].to_numpy() if "n_slits" in table else np.zeros(n, int)
    damaged = table["damaged"].to_numpy(bool) if "damaged" in table else n_slits > 0
    k = 1
    loss_cols = []
    while f"slit{k}_stiffness_loss_Nm3" in table:
        loss_cols.append(k)
        k += 1
    if loss_cols:
        loss = np.stack([np.nan_to_num(table[f"slit{j}_stiffness_loss_Nm3"].to_numpy(float)) for j in loss_cols], 1)
        xs = np.stack([table[f"slit{j}_x_m"].to_numpy(float) for j in loss_cols], 1)
        big = np.argmax(loss, axis=1)
        x = xs[np.arange(n), big] / length_m
        size = loss.sum(axis=1)
    else:
        x, size = np.full(n, np.nan), np.zeros(n)
    x = np.where(damaged, np.clip(x, 0.0, 1.0), np.nan)
    element = np.where(damaged, np.clip(np.floor(np.nan_to_num(x) * 4).astype(int) + 1, 1, 4), 0)
    drops = [-table[f"df{r}_rel"].to_numpy(float) for r in range(1, 5) if f"df{r}_rel" in table]
    max_drop = np.max(np.stack(drops, 1), axis=1) if drops else np.full(n, np.nan)
    return {"damaged": damaged, "x_over_L": x, "stiffness_loss_Nm3": np.where(damaged, size, 0.0),
            "element": element, "max_drop": max_drop, "n_slits": n_slits}


# --------------------------------------------------------------------------- modal route
def real_shapes(eigenvectors):
    """Real, unit-norm mode shapes from complex ones (batched).

    Each column is rotated so that its largest entry is real and positive, its
    real part kept and scaled to unit Euclidean norm.

    Parameters
    ----------
    eigenvectors : ndarray, complex, shape (..., n_dofs, m)

    Returns
    -------
    ndarray, shape (..., n_dofs, m)
    """
    psi = np.asarray(eigenvectors, complex)
    big = np.take_along_axis(psi, np.argmax(np.abs(psi), axis=-2)[..., None, :], axis=-2)
    u = (psi * np.exp(-1j * np.angle(big))).real
    return u / np.linalg.norm(u, axis=-2, keepdims=True)


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


def modal_features(eigenvalues, eigenvectors, n_modes: int = 4):
    """Modal features of pairs (batched).

    Parameters
    ----------
    eigenvalues : ndarray, complex, shape (n, 2, m)
    eigenvectors : ndarray, complex, shape (n, 2, 4, m)

    Returns
    -------
    ndarray, shape (n, 10 n_modes)
        Per mode: relative frequency shift (percent) and log baseline frequency
        (Hz); then the shape changes (4 DOFs x modes) and curvature changes
        (clamp and nodes 2..4 x modes), times 10.
    """
    lam = np.asarray(eigenvalues, complex)[..., :n_modes]
    f = np.abs(lam) / (2 * np.pi)
    shift = 100 * (f[:, 1] / f[:, 0] - 1)
    u = real_shapes(np.asarray(eigenvectors, complex)[..., :n_modes])
    # the current shape's sign follows the baseline's (MAC-sign)
    sign = np.sign(np.sum(u[:, 1] * u[:, 0], axis=-2, keepdims=True))
    u1 = u[:, 1] * np.where(sign == 0, 1.0, sign)
    du = u1 - u[:, 0]
    dk = curvatures(u1) - curvatures(u[:, 0])
    n = lam.shape[0]
    return np.concatenate([shift, np.log(f[:, 0]), 10 * du.reshape(n, -1), 10 * dk.reshape(n, -1)], axis=1)


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


def warped_log_magnitude(H, omega_rad_s, ratio, mode_rad_s, grid_rad_s=GRID_RAD_S):
    """``log10 |H'|`` on the grid for a state whose natural frequencies moved by ``ratio`` (batched over pairs).

    A stiffness change that multiplies mode ``r``'s frequency by ``rho_r`` gives,
    for well-separated modes, ``H'(w) ~ H(w / rho(w)) / rho(w)^2`` with ``rho``
    interpolated in log-frequency between the modes (exact for a uniform change).

    Parameters
    ----------
    H : ndarray, complex, shape (n, S, F)
    ratio : ndarray, shape (n, m)
    mode_rad_s : ndarray, shape (n, m)   natural frequencies of the unwarped state

    Returns
    -------
    ndarray, shape (n, S, G)
    """
    g = np.log(np.asarray(grid_rad_s, float))
    n = H.shape[0]
    lr = np.log(ratio)
    lw = np.log(mode_rad_s)
    o = np.argsort(lw, axis=1)
    lw, lr = np.take_along_axis(lw, o, 1), np.take_along_axis(lr, o, 1)
    # per-pair interpolation of log rho at the grid points (flat ends)
    j = np.clip(np.sum(g[None, :, None] >= lw[:, None, :], axis=2) - 1, 0, lw.shape[1] - 1)   # (n, G)
    j1 = np.minimum(j + 1, lw.shape[1] - 1)
    a, b = np.take_along_axis(lw, j, 1), np.take_along_axis(lw, j1, 1)
    t = np.clip(np.where(b > a, (g[None] - a) / np.where(b > a, b - a, 1.0), 0.0), 0.0, 1.0)
    lrho = (1 - t) * np.take_along_axis(lr, j, 1) + t * np.take_along_axis(lr, j1, 1)
    q = g[None] - lrho                                                                           # (n, G)
    lwf = np.log(np.asarray(omega_rad_s, float))
    k = np.clip(np.searchsorted(lwf, q) - 1, 0, lwf.size - 2)
    u = np.clip((q - lwf[k]) / (lwf[k + 1] - lwf[k]), 0.0, 1.0)
    L = np.log10(np.abs(np.asarray(H)) + 1e-30)                                                  # (n, S, F)
    lo = np.take_along_axis(L, np.broadcast_to(k[:, None, :], (n, L.shape[1], k.shape[1])), 2)
    hi = np.take_along_axis(L, np.broadcast_to(k[:, None, :] + 1, (n, L.shape[1], k.shape[1])), 2)
    return (1 - u[:, None]) * lo + u[:, None] * hi - 2 * lrho[:, None] / np.log(10)


def frf_features(H, omega_rad_s, grid_rad_s=GRID_RAD_S, ratio=None, mode_rad_s=None):
    """FRF features of pairs: baseline log-magnitude and the current-minus-baseline change.

    Parameters
    ----------
    H : ndarray, complex, shape (n, 2, S, F)
    ratio, mode_rad_s : ndarray, shape (n, m), optional
        Warp of the current state (:func:`warped_log_magnitude`).

    Returns
    -------
    ndarray, shape (n, 2 S G)
    """
    n = H.shape[0]
    out = np.empty((n, 2 * H.shape[2] * len(grid_rad_s)), np.float32)
    for i in range(0, n, 2048):  # bounded memory
        s = slice(i, i + 2048)
        base = map_frf_to_grid(H[s, 0], omega_rad_s, grid_rad_s)
        if ratio is None:
            cur = map_frf_to_grid(H[s, 1], omega_rad_s, grid_rad_s)
        else:
            cur = warped_log_magnitude(H[s, 1], omega_rad_s, ratio[s], mode_rad_s[s], grid_rad_s)
        m = base.shape[0]
        out[s] = np.concatenate([base.reshape(m, -1) + 5.0, 10 * (cur - base).reshape(m, -1)], axis=1)
    return out


def features(pairs: Pairs, route: str = "modal") -> np.ndarray:
    """Feature matrix (n, d) of ``pairs`` for one input route (:data:`ROUTES`)."""
    if route == "modal":
        X = modal_features(pairs.eigenvalues, pairs.eigenvectors)
    elif route in ("updated", "measured"):
        H = pairs.frf_updated if route == "updated" else pairs.frf_measured
        if H is None:
            raise BeamDamageError(f"input route {route!r} needs FRFs of both states; none were given")
        mode = None if pairs.frequency_ratio is None else np.abs(pairs.eigenvalues[:, 0, :pairs.frequency_ratio.shape[1]])
        X = frf_features(H, pairs.omega_rad_s, ratio=pairs.frequency_ratio, mode_rad_s=mode)
    else:
        raise BeamDamageError(f"input route {route!r} must be one of {', '.join(ROUTES)}")
    return np.where(np.isfinite(X), X, 0.0)


# --------------------------------------------------------------------------- state changes that are not damage
@dataclass(frozen=True)
class StateChanges:
    """Ranges of the changes between two test days (uniform, symmetric about 0).

    temperature : relative global stiffness change (0.003 = +-0.3 %)
    reclamp : relative change of the root rotational spring (0.05 = +-5 %)
    """

    temperature: float = 0.003
    reclamp: float = 0.05


def root_spring_effect(EI, m_per_length, root_spring, factor, length_m, n_elements: int = 8, n_modes: int = 4):
    """Frequency ratios and real-shape changes at nodes 2..5 when the root spring is multiplied by ``factor``.

    Undamaged Euler-Bernoulli cantilever on a rotational root spring (batched); 8 elements give
    the ratios of modes 1..4 within 0.5 % of their change on a 20-element mesh.

    Returns
    -------
    ratio : ndarray, shape (n, n_modes)        f(k factor) / f(k)
    dshape : ndarray, shape (n, 4, n_modes)    change of the unit-norm real shapes
    """
    kr = np.asarray(root_spring, float)
    fin = np.isfinite(kr)
    kr = np.where(fin, kr, 1e12 * np.asarray(EI, float) / length_m)
    both = beam_model(n_elements, length_m, np.concatenate([EI, EI]), np.concatenate([m_per_length, m_per_length]),
                      root_spring=np.concatenate([kr, kr * np.where(fin, factor, 1.0)]))
    w, phi = undamped_modes(both.M, both.K)
    idx = both.index([f"{1 + n_elements // 4 * q}:y" for q in range(1, 5)])
    u = real_shapes(phi[:, idx, :n_modes].astype(complex))
    n = kr.size
    return w[n:, :n_modes] / w[:n, :n_modes], u[n:] - u[:n]


def apply_state_changes(pairs: Pairs, changes: StateChanges, seed: int = 0, chunk: int = 4096) -> Pairs:
    """Current states of dataset pairs with a random temperature and re-clamping change (batched).

    Temperature scales every eigenvalue by ``sqrt(1 + e_T)`` (global stiffness
    change, damping ratios kept); re-clamping changes the root spring by a
    factor ``1 + e_k`` and moves frequencies and shapes as the undamaged FE
    cantilever of the specimen predicts. The frequency ratios are kept in
    ``frequency_ratio`` so the FRF routes warp the current FRFs consistently.
    Needs the specimen columns of the table.
    """
    if changes.temperature == 0 and changes.reclamp == 0:
        return pairs
    rng = np.random.default_rng(seed)
    n = len(pairs)
    eT = changes.temperature * (2 * rng.random(n) - 1)
    ek = changes.reclamp * (2 * rng.random(n) - 1)
    t = pairs.table
    lam = pairs.eigenvalues.copy()
    psi = pairs.eigenvectors.copy()
    m = min(lam.shape[-1], 4)
    ratios = np.ones((n, m))
    from threadpoolctl import threadpool_limits  # (a scikit-learn dependency)

    for i in range(0, n, chunk):
        s = slice(i, i + chunk)
        with threadpool_limits(1):  # many tiny eigenproblems: threaded BLAS only adds overhead
            ratio, du = root_spring_effect(t["ei_Nm2"].to_numpy(float)[s], t["m_per_length_kg_m"].to_numpy(float)[s],
                                           t["root_spring_Nm_rad"].to_numpy(float)[s], 1 + ek[s],
                                           pairs.beam.length_m, n_modes=m)
        ratios[s] = ratio * np.sqrt(1 + eT[s])[:, None]
        lam[s, 1, :m] *= ratios[s]
        cur = psi[s, 1, :, :m]
        big = np.take_along_axis(cur, np.argmax(np.abs(cur), axis=-2)[:, None, :], axis=-2)
        scale = np.linalg.norm((cur * np.exp(-1j * np.angle(big))).real, axis=-2, keepdims=True)
        psi[s, 1, :, :m] = cur + du * scale * np.exp(1j * np.angle(big))
    table = t.assign(temperature_change=eT, reclamp_change=ek)
    return replace(pairs, eigenvalues=lam, eigenvectors=psi, table=table, frequency_ratio=ratios)


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
