"""Exact refinement of a damage kind's competing explanation: the nominal beam re-analysed with the kind's own damage.

The explanation's grid (:mod:`learn.explanations.hypotheses`) predicts a kind's frequency changes from first-order
sensitivities of the nominal shapes; a damage that changes the shapes (a mass of tens of percent of the beam's, a deep
slit) lies beyond it. Here the nominal FE beam of the sensitivities (:func:`nominal_beam`: its supports, springs, added
masses, sensors and modes) gets the element corrections of the kind's own damage (``damage_at`` then ``corrections`` of
its row of :data:`datagen.damage.DAMAGE_MODELS`) and is solved exactly (:meth:`ExactKind.changes`). :func:`refine` fits
the place ``x``, the size ``s``, the kind's spread ``e`` (``extent`` in [0, 1] through the lengths its config
draws) and the temperature nuisance ``a`` to a pair's frequency (and shape) changes by bounded Levenberg-Marquardt
steps from the grid's best candidates; :func:`local_grid` lays an exact grid in ``(x, s)`` about a refined fit, as
wide as the Laplace approximation (the Gauss-Newton covariance, widened by the Birge ratio) says, read finer by
interpolating the exact changes. :func:`refined_fits` does both for a chunk of pairs: the best fit gives the
explanation's misfit, the local grids of every distinct fit nearly as good (a symmetric beam's mirror place) its
intervals (:func:`kind_parameters`).

The Birge ratio (:func:`birge_ratio`) ``max(1, chi2_f / max(1, m - 3), chi2_s / D)`` of the frequency block (``m``
modes, three parameters) and the shape block (``D`` entries) tempers the likelihood of a fit whose misfit exceeds
the noise: its intervals widen by the misfit rather than stay as narrow as the noise alone would allow.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import cached_property, lru_cache

import numpy as np

from datagen.damage import DAMAGE_MODELS
from learn.network.intervals import LEVELS
from learn.explanations.likelihood import nuisance_loglik
from learn.explanations.sensitivity import beam_numbers, with_masses
from learn.explanations.shapes import real_shapes, sign_aligned
from physics.effects import hermite_row
from physics.fem import assemble, beam_model, dof_names
from physics.supports import add_springs

__all__ = ["KEEP_CHI2", "SIZE_SCALE_STD", "ExactFit", "ExactKind", "NominalBeam", "birge_ratio", "kind_parameters",
           "local_grid", "nominal_beam", "refine", "refined_fits"]

#: Damaged models solved in one array operation (memory: about 0.2 MB each).
CHUNK_MODELS = 256

#: Relative standard deviation of a size for a given change (10 %): the nominal beam stands for a specimen whose EI,
#: mass and clamp differ from it by several percent; it widens the size intervals.
SIZE_SCALE_STD = 0.1

#: Levenberg-Marquardt iterations, the points per axis of the local exact grid, and how much finer the grid the
#: likelihood is read on (the exact changes linearly interpolated between the exact grid's points).
N_ITER, N_LOCAL, UPSAMPLE = 12, 11, 4

#: Levenberg-Marquardt iterations between two finite-difference Jacobians (Broyden's updates in between).
JACOBIAN_EVERY = 2

#: Elements of the exact model (Hermite cubics: the first six modes' frequencies within 1e-5 of a 40-element mesh's
#: on 20, at an eighth of its cost).
N_ELEMENTS = 20


@dataclass(frozen=True, eq=False)
class NominalBeam:
    """The nominal FE beam of the sensitivities (:func:`learn.explanations.sensitivity.beam_sensitivity`).

    Attributes
    ----------
    M, K : ndarray, shape (n, n)      over the kept DOFs (the support's springs in ``K``)
    keep : ndarray, shape (n,)        the kept DOFs' indices among all node DOFs
    T : ndarray, shape (S, n)         the sensors' translation rows
    used : ndarray, shape (m,)        the modes' indices among the eigenvalues (rigid-body modes skipped)
    length_m, EI_Nm2, mass_per_length_kg_m : float
    n_elements : int
    """

    M: np.ndarray
    K: np.ndarray
    keep: np.ndarray
    T: np.ndarray
    used: np.ndarray
    length_m: float
    EI_Nm2: float
    mass_per_length_kg_m: float
    n_elements: int

    def solve(self, dM=None, dK=None):
        """Angular frequencies (B, m) and real unit-norm shapes at the sensors (B, S, m) of the beam plus the
        kept-DOF blocks of full-mesh corrections ``dM``, ``dK`` (B, 2N, 2N) (None: none; no batch: the nominal).

        As :func:`physics.modal.undamped_modes`, with the inverse Cholesky factor of the mass formed once (the
        nominal's, when the mass does not change) and applied by products: ``L^-1 K L^-T`` is symmetric."""
        k = self.keep[:, None], self.keep
        K = self.K if dK is None else self.K + dK[..., k[0], k[1]]
        Linv = (self.mass_factor_inverse if dM is None
                else np.linalg.inv(np.linalg.cholesky(self.M + dM[..., k[0], k[1]])))
        A = Linv @ K @ np.swapaxes(Linv, -1, -2)
        w2, v = np.linalg.eigh(0.5 * (A + np.swapaxes(A, -1, -2)))
        phi = np.swapaxes(Linv, -1, -2) @ v[..., self.used]
        return np.sqrt(np.clip(w2[..., self.used], 0.0, None)), real_shapes((self.T @ phi).astype(complex))

    @cached_property
    def mass_factor_inverse(self) -> np.ndarray:
        """``L^-1`` of the nominal mass ``M = L L^T`` (n, n)."""
        return np.linalg.inv(np.linalg.cholesky(self.M))

    @cached_property
    def nominal_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`solve` of the nominal beam: its angular frequencies (m,) and shapes at the sensors (S, m)."""
        return self.solve()


@lru_cache(maxsize=16)
def nominal_beam(preset, root_spring_relative=948.7, test=None, n_elements: int = N_ELEMENTS,
                 n_modes: int = 4) -> NominalBeam:
    """The nominal beam :func:`learn.explanations.sensitivity.beam_sensitivity` differentiates (same arguments): the
    thesis's clamped beam on its root spring measured at the quarter points, or a test's supports, sensors and modes."""
    L, EI, m, masses = beam_numbers(preset)
    names = list(dof_names(n_elements + 1))
    node_x = np.linspace(0.0, L, n_elements + 1)
    if test is None or test.thesis:
        kr = None if root_spring_relative is None else root_spring_relative * EI / L
        model = with_masses(beam_model(n_elements, L, EI, m, root_spring=kr), masses, L, n_elements)
        K, sensors, used = np.asarray(model.K), [L * q / 4 for q in range(1, 5)], np.arange(n_modes)
    else:
        sup = test.support
        kr = root_spring_relative * EI / L if sup.clamped and root_spring_relative is not None else None
        model = with_masses(beam_model(n_elements, L, EI, m, bc=test.bc, root_spring=kr), masses, L, n_elements)
        K = add_springs(model.K, model.dofs, sup.spring_dofs(n_elements + 1), sup.nominal_unit_stiffness(L) * EI)
        sensors, used = sorted(test.sensors_x_m), sup.rigid_body_modes + np.asarray(test.modes) - 1
    keep = np.array([names.index(d) for d in model.dofs])
    T = np.array([hermite_row(float(x), node_x)[0][keep] for x in sensors])
    return NominalBeam(np.asarray(model.M), np.asarray(K), keep, T, np.asarray(used), L, EI, m, n_elements)


@dataclass(frozen=True, eq=False)
class ExactKind:
    """A damage kind's exact model on the nominal beam: the kind's name (:data:`datagen.damage.DAMAGE_MODELS`), its
    config section ``d``, the beam as its ``size_range`` takes it, the nominal beam and the modes weighed (indices
    into the nominal beam's ``used``)."""

    name: str
    d: dict
    beam: object
    nominal: NominalBeam
    modes_index: np.ndarray

    def modes(self, indices) -> "ExactKind":
        """The model on the modes ``indices`` (0-based among its modes) alone."""
        return replace(self, modes_index=self.modes_index[np.asarray(indices, int)])

    def changes(self, x_m, size, extent):
        """Relative frequency changes (P, m) and changes of the real unit-norm shapes at the sensors (P, S m,
        sensor-major) of the damage of ``size`` at ``x_m`` with spread ``extent`` (each (P,)), exactly."""
        nb, kind = self.nominal, DAMAGE_MODELS[self.name]
        w0, u0 = (v[..., self.modes_index] for v in nb.nominal_modes)
        x, s, e = np.broadcast_arrays(*(np.asarray(v, float).ravel() for v in (x_m, size, extent)))
        freq, shapes = np.empty((x.size, w0.size)), np.empty((x.size, u0.size))
        for i in range(0, x.size, CHUNK_MODELS):
            c = slice(i, i + CHUNK_MODELS)
            xc = np.clip(x[c], 0.0, nb.length_m)[:, None]
            params = kind.damage_at(self.d, self.beam, xc, s[c, None], e[c, None], nb.mass_per_length_kg_m,
                                    nb.length_m)
            ones = np.ones(xc.shape[0])
            dM, dK, _ = kind.corrections(params, xc, nb.EI_Nm2 * ones, nb.mass_per_length_kg_m * ones, nb.length_m,
                                         nb.n_elements)
            w, u = nb.solve(None if dM is None else assemble(dM), None if dK is None else assemble(dK))
            w, u = w[..., self.modes_index], u[..., self.modes_index]
            freq[c] = w / w0 - 1.0
            shapes[c] = (sign_aligned(u, u0) - u0).reshape(u.shape[0], -1)
        return freq, shapes


@dataclass(frozen=True)
class ExactFit:
    """Refined fits of P candidates (:func:`refine`).

    Attributes
    ----------
    x_m, size, extent, a : ndarray, shape (P,)
    predicted : ndarray, shape (P, m)      ``a`` plus the exact frequency changes there
    shapes : ndarray, shape (P, D)         the exact shape changes there (whitened by the shape std)
    chi2_frequency, chi2_shape : ndarray, shape (P,)
    cov : ndarray, shape (P, 2, 2)         Gauss-Newton covariance of ``(x_m, size)`` (the others marginalised)
    """

    x_m: np.ndarray
    size: np.ndarray
    extent: np.ndarray
    a: np.ndarray
    predicted: np.ndarray
    shapes: np.ndarray
    chi2_frequency: np.ndarray
    chi2_shape: np.ndarray
    cov: np.ndarray


def _residuals(exact, p, y, sigma, model_error, ys, ss):
    """Whitened residuals (P, m + D + 1) at parameters ``p`` (P, 4) = (x, s, e, a): the frequencies', the shapes'
    and the extent's weak prior (``0.1 (e - 1/2)``); and the exact frequency and shape changes there."""
    g, h = exact.changes(p[:, 0], p[:, 1], p[:, 2])
    rf = (p[:, 3:4] + g - y) / np.sqrt(sigma**2 + (model_error * g) ** 2)
    rs = np.zeros((p.shape[0], 0)) if ys is None else h / ss - ys
    return np.concatenate([rf, rs, 0.1 * (p[:, 2:3] - 0.5)], axis=1), g, h


def _jacobian(exact, p, r, g, y, sigma, model_error, ys, ss, lower, upper):
    """Forward differences of the residuals in x, s and e (batched, one call), the a column exact: (P, N, 4)."""
    P = p.shape[0]
    step = np.array([1e-3 * upper[0], 1e-3 * max(upper[1] - lower[1], 1e-9), 0.05])
    trial = np.repeat(p[None], 3, axis=0)                                      # (3, P, 4)
    h = np.where(p[:, :3] + step > upper[:3], -step, step)                     # (P, 3) stay within the bounds
    for j in range(3):
        trial[j, :, j] += h[:, j]
    rt = _residuals(exact, trial.reshape(3 * P, 4), np.tile(y, (3, 1)), sigma, model_error,
                    None if ys is None else np.tile(ys, (3, 1)), ss)[0].reshape(3, P, -1)
    J = np.zeros(r.shape + (4,))
    J[..., :3] = np.moveaxis((rt - r[None]) / h.T[:, :, None], 0, -1)
    J[:, :g.shape[1], 3] = 1.0 / np.sqrt(sigma**2 + (model_error * g) ** 2)
    return J


def refine(exact: ExactKind, x0, size0, y, sigma, half: float, model_error: float, size_bounds, shapes=None,
           shape_sigma=1.0, n_iter: int = N_ITER) -> ExactFit:
    """Fit ``(x, s, e, a)`` of the exact model to each candidate's measured changes by bounded Levenberg-Marquardt
    (a finite-difference Jacobian every :data:`JACOBIAN_EVERY` steps, Broyden's rank-one updates in between).

    Parameters
    ----------
    exact : ExactKind
    x0, size0 : array, shape (P,)        starts (the grid's best place and size)
    y : array, shape (P, m)              measured relative frequency changes
    sigma : array (m,)                   relative std of each change; ``model_error`` of each predicted change
    half : float                         the temperature nuisance's bound ``|a| <= half``
    size_bounds : (lo, hi)               the size's prior range
    shapes : array, shape (P, D), optional   measured shape changes, whitened by ``shape_sigma`` (D,)
    """
    y = np.atleast_2d(np.asarray(y, float))
    P, m = y.shape
    lower = np.array([0.0, size_bounds[0], 0.0, -half])
    upper = np.array([exact.nominal.length_m, size_bounds[1], 1.0, half])
    p = np.clip(np.stack([np.asarray(x0, float), np.asarray(size0, float), np.full(P, 0.5), np.zeros(P)], 1),
                lower, upper)
    ss = np.asarray(shape_sigma, float)
    r, g, h = _residuals(exact, p, y, sigma, model_error, shapes, ss)
    chi2 = np.sum(r**2, axis=1)
    lam = np.full(P, 1e-3)
    for it in range(n_iter):
        if it % JACOBIAN_EVERY == 0:       # in between, Broyden's rank-one updates
            J = _jacobian(exact, p, r, g, y, sigma, model_error, shapes, ss, lower, upper)
        A = np.einsum("pni,pnj->pij", J, J)
        A_damped = A + lam[:, None, None] * (np.eye(4) * np.diagonal(A, axis1=1, axis2=2)[:, None] + 1e-12 * np.eye(4))
        step = -np.linalg.solve(A_damped, np.einsum("pni,pn->pi", J, r)[..., None])[..., 0]
        p_try = np.clip(p + step, lower, upper)
        r_try, g_try, h_try = _residuals(exact, p_try, y, sigma, model_error, shapes, ss)
        chi2_try = np.sum(r_try**2, axis=1)
        d = p_try - p
        J = J + np.einsum("pn,pi->pni", r_try - r - np.einsum("pni,pi->pn", J, d), d) / np.maximum(
            np.sum(d**2, axis=1), 1e-300)[:, None, None]
        better = chi2_try < chi2
        p, r, g, h = (np.where(better[:, None], new, old) for new, old in ((p_try, p), (r_try, r), (g_try, g),
                                                                           (h_try, h)))
        chi2 = np.where(better, chi2_try, chi2)
        lam = np.where(better, lam / 3, lam * 4)
    J = _jacobian(exact, p, r, g, y, sigma, model_error, shapes, ss, lower, upper)
    A = np.einsum("pni,pnj->pij", J, J) + 1e-12 * np.eye(4)
    cov = np.linalg.pinv(A)[:, :2, :2]
    return ExactFit(p[:, 0], p[:, 1], p[:, 2], p[:, 3], p[:, 3:4] + g, h / ss if shapes is not None else h,
                    np.sum(r[:, :m] ** 2, axis=1), np.sum(r[:, m:-1] ** 2, axis=1), cov)


def birge_ratio(chi2_frequency, n_modes: int, chi2_shape=0.0, n_shape: int = 0) -> np.ndarray:
    """``max(1, chi2_f / max(1, m - 3), chi2_s / D)``: by how much fits' misfit (chi-squares, any shape) exceeds
    the noise (each block of data its own; the three parameters ``x``, ``s``, ``a`` counted against the ``m``
    frequencies, ``D`` the shape entries, none: no shape block)."""
    out = np.maximum(1.0, np.asarray(chi2_frequency, float) / max(1, n_modes - 3))
    return np.maximum(out, np.asarray(chi2_shape, float) / n_shape) if n_shape else out


def local_grid(exact: ExactKind, fit: ExactFit, size_bounds, scale, n: int = N_LOCAL):
    """An exact grid in ``(x, s)`` centred on each fit: ``n`` (odd) points per axis over 6 standard deviations of the
    Gauss-Newton covariance widened by ``scale`` (P,), at least a four-hundredth of the beam and a hundredth of the size
    range, at most a quarter of either (a place the changes hardly tell: the grid spans what it can); at the fit's
    spread; then :data:`UPSAMPLE` times finer, the changes linearly interpolated. Points beyond the beam or the size
    range are marked invalid.

    Returns
    -------
    G = (UPSAMPLE (n - 1) + 1)^2 points:
    x_m, size : ndarray, shape (P, G)       the grid's places and sizes
    freq : ndarray, shape (P, G, m)         exact relative frequency changes (without ``a``)
    shapes : ndarray, shape (P, G, D)       exact shape changes
    valid : ndarray of bool, shape (P, G)   within the beam and the size range
    half_width_m : ndarray, shape (P,)        half the grid's spacing in x
    """
    L = exact.nominal.length_m
    lo_s, hi_s = size_bounds
    sd = np.sqrt(np.clip(np.diagonal(fit.cov, axis1=1, axis2=2), 0.0, None) * np.asarray(scale)[:, None])
    ext_x = np.clip(6 * sd[:, 0], L / 400, L / 4)
    ext_s = np.clip(6 * sd[:, 1], 0.01 * (hi_s - lo_s), 0.25 * (hi_s - lo_s))
    t = np.linspace(-1.0, 1.0, n)
    X = (fit.x_m[:, None] + ext_x[:, None] * t)[:, :, None] * np.ones(n)                 # (P, n x, n s)
    S = (fit.size[:, None] + ext_s[:, None] * t)[:, None, :] * np.ones((n, 1))
    P = X.shape[0]
    freq, shapes = exact.changes(X.ravel(), S.ravel(), np.repeat(fit.extent, n * n))
    fine = [_upsampled(a.reshape(P, n, n, -1)) for a in (X[..., None], S[..., None], freq, shapes)]
    X, S = fine[0][..., 0], fine[1][..., 0]
    valid = (X >= 0) & (X <= L) & (S >= lo_s) & (S <= hi_s)
    N = X.shape[1]
    return (X.reshape(P, -1), S.reshape(P, -1), fine[2].reshape(P, N * N, -1), fine[3].reshape(P, N * N, -1),
            valid.reshape(P, -1), ext_x / (N - 1))


def _upsampled(a, factor: int = UPSAMPLE):
    """``a`` (P, n, n, k) on a grid ``factor`` times finer along both middle axes, linearly interpolated."""
    n = a.shape[1]
    t = np.linspace(0.0, n - 1.0, factor * (n - 1) + 1)
    i = np.minimum(t.astype(int), n - 2)
    w = (t - i)[:, None, None]
    a = a[:, i] * (1 - w) + a[:, i + 1] * w                               # along x
    return a[:, :, i] * (1 - w[None, :, 0]) + a[:, :, i + 1] * w[None, :, 0]  # along s


def _interval(values: np.ndarray, weights: np.ndarray, level: float, half_width: float = 0.0) -> list:
    """Equal-tailed interval of a discrete distribution, widened by ``half_width`` on each side (the half-width of
    a grid cell)."""
    order = np.argsort(values, kind="stable")
    values, weights = np.asarray(values)[order], np.asarray(weights)[order]
    c = np.cumsum(weights) / np.sum(weights)
    lo = values[min(np.searchsorted(c, (1 - level) / 2), values.size - 1)]
    hi = values[min(np.searchsorted(c, 1 - (1 - level) / 2), values.size - 1)]
    return [float(lo - half_width), float(hi + half_width)]


def _scaled(sizes: np.ndarray, weights: np.ndarray):
    """The size distribution times a factor ``N(1, SIZE_SCALE_STD)`` (9 points): values and weights, flattened."""
    c = 1 + SIZE_SCALE_STD * np.linspace(-2.5, 2.5, 9)
    w = np.exp(-0.5 * ((c - 1) / SIZE_SCALE_STD) ** 2)
    return (np.ravel(sizes)[:, None] * c[None]).ravel(), (np.ravel(weights)[:, None] * w[None]).ravel()


def kind_parameters(x_m: float, size: float, length_m: float, label: str, x_values, size_values, loglik,
                    half_width_m: float, fits_noise: bool, birge: float = 1.0, log_area=0.0) -> dict:
    """A damage kind's most likely place and size and their 68 % / 95 % intervals from its log-likelihood on a
    grid of places ``x_values`` and sizes ``size_values`` (same shape), tempered by the Birge ratio ``birge``
    (``exp(loglik / birge)``, times ``exp(log_area)``: each point's cell); the places' intervals widened by
    ``half_width_m`` (half a grid cell, within the beam), the sizes' by :data:`SIZE_SCALE_STD`. The intervals are
    None when the kind does not fit (no interval rather than a narrow one)."""
    out = {"x_m": float(x_m), "x_over_L": float(x_m / length_m), "size": float(size), "size_label": label,
           "birge_ratio": float(birge)}
    keys = ("x_m_68", "x_m_95", "size_68", "size_95")
    if not fits_noise:
        return {**out, **dict.fromkeys(keys)}
    z = np.ravel(loglik) / birge + np.ravel(log_area)                    # a point's weight: its cell's area
    post = np.exp(z - z.max())
    x, s = np.ravel(x_values), np.ravel(size_values)
    xs = {f"x_m_{q}": [float(v) for v in np.clip(_interval(x, post, lv, half_width_m), 0.0, length_m)]
          for q, lv in LEVELS.items()}
    return {**out, **xs, **{f"size_{q}": _interval(*_scaled(s, post), lv) for q, lv in LEVELS.items()}}


#: A refined fit joins the posterior when its chi-square, over the Birge ratio, is within this of the best's (its
#: peak at least a thousandth of the best's): the mirror place of a symmetric beam, another place the modes cannot
#: tell apart.
KEEP_CHI2 = 2 * np.log(1000.0)


def refined_fits(kind, y, sigma, half: float, model_error: float, grid_loglik, shapes=None, shape_sigma=1.0,
                 n_starts: int = 3) -> list[dict]:
    """A damage kind's explanation (a :class:`learn.explanations.hypotheses.KindExplanation` holding its ``exact``
    model) refined for each pair of a chunk, with its intervals' posterior.

    The ``n_starts`` best places of its grid log-likelihood ``grid_loglik`` (n, K, E), an eighth of the beam apart
    (each at its best size), are refined (:func:`refine`); the best fit gives the place, size, prediction and Birge
    ratio; every distinct fit within :data:`KEEP_CHI2` of it (over the Birge ratio; a twentieth of the beam apart)
    gets a local exact grid (:func:`local_grid`), and the grids together, each point weighed by its cell's area,
    are the posterior of the place and size.

    Parameters
    ----------
    y : array, shape (n, m)    measured relative frequency changes; ``sigma`` (m,), ``half``, ``model_error`` as
                               :func:`learn.explanations.likelihood.nuisance_loglik` takes them
    shapes : array, shape (n, D), optional   measured shape changes whitened by ``shape_sigma``

    Returns
    -------
    per pair a dict: ``x_m``, ``size``, ``predicted`` (m,), ``birge``, ``x_values``, ``size_values``, ``loglik``,
    ``log_area`` (the posterior's points), ``half_width_m`` and ``gain``, the exact fit's best log-likelihood less
    the grid's (by which the evidence moves).
    """
    n, _, E = grid_loglik.shape
    prof, starts = grid_loglik.max(axis=1), []                           # (n, E): the best size at each place
    for _ in range(n_starts):
        e = np.argmax(prof, axis=1)
        starts.append((e, np.argmax(grid_loglik[np.arange(n), :, e], axis=1)))
        prof = np.where(np.abs(np.arange(E)[None] - e[:, None]) < E / 8, -np.inf, prof)
    e, t = (np.concatenate(v) for v in zip(*starts))                     # start-major: candidate j n + i
    bounds, L = (float(kind.sizes[0]), float(kind.sizes[-1])), kind.exact.nominal.length_m
    fit = refine(kind.exact, np.asarray(kind.sens.x_over_L)[e] * L, kind.sizes[t], np.tile(y, (n_starts, 1)), sigma,
                 half, model_error, bounds, None if shapes is None else np.tile(shapes, (n_starts, 1)), shape_sigma)
    chi2 = (fit.chi2_frequency + fit.chi2_shape).reshape(n_starts, n)
    order = np.argsort(chi2, axis=0, kind="stable")                     # (n_starts, n) best first
    best = order[0] * n + np.arange(n)
    birge = birge_ratio(fit.chi2_frequency[best], y.shape[1], fit.chi2_shape[best],
                        0 if shapes is None else shapes.shape[1])
    keep = []                                                            # (candidate, pair) of the posterior
    for i in range(n):
        kept = []
        for j in order[:, i]:
            c = j * n + i
            if (chi2[j, i] - chi2[order[0, i], i]) / birge[i] <= KEEP_CHI2 and all(
                    abs(fit.x_m[c] - fit.x_m[k]) > L / 20 for k in kept):
                kept.append(c)
        keep += [(c, i) for c in kept]
    cand = np.array([c for c, _ in keep])
    sub = _rows(fit, cand)
    X, S, G, H, valid, half_width = local_grid(kind.exact, sub, bounds, birge[[i for _, i in keep]])
    area = np.log(np.ptp(X, axis=1) * np.ptp(S, axis=1) + 1e-300)       # the grid's extent: its cells' area
    per_pair: dict = {}
    for r, (c, i) in enumerate(keep):
        li = nuisance_loglik(G[r], y[i:i + 1], sigma, half, model_error)[0][0]             # (n n,)
        if shapes is not None:
            p = H[r] / shape_sigma
            li = li + p @ shapes[i] - 0.5 * np.sum(p**2, axis=1)
        per_pair.setdefault(i, []).append((c, np.where(valid[r], li, -np.inf), X[r], S[r], area[r], half_width[r]))
    out = []
    for i in range(n):
        parts = per_pair[i]
        c0 = parts[0][0]
        li = np.concatenate([p[1] for p in parts])
        out.append({"x_m": fit.x_m[c0], "size": fit.size[c0], "predicted": fit.predicted[c0], "birge": birge[i],
                    "x_values": np.concatenate([p[2] for p in parts]),
                    "size_values": np.concatenate([p[3] for p in parts]), "loglik": li,
                    "log_area": np.concatenate([np.full(p[1].size, p[4]) for p in parts]),
                    "half_width_m": parts[0][5], "gain": float(parts[0][1].max() - grid_loglik[i].max())})
    return out


def _rows(fit: ExactFit, index) -> ExactFit:
    """The fits ``index`` of ``fit``."""
    return ExactFit(*(getattr(fit, f.name)[index] for f in fields(ExactFit)))
