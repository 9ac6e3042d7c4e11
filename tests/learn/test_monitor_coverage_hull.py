"""The baseline's coverage of the environment as its convex hull (:mod:`learn.monitor.coverage`): a combination the
baseline never saw inside the ellipse of its largest held-out distance, the hull against a linear programme, and
the exchangeable rate of tests outside it."""

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from learn.monitor.coverage import HULL_MAX_DIM, coverage, outside_hull


def _triangle(n, seed):
    """``n`` points uniform in the triangle (0, 0), (1, 0), (0, 1) and its three corners."""
    u = np.random.default_rng(seed).uniform(size=(n, 2))
    u = np.where(u.sum(axis=1, keepdims=True) > 1, 1 - u, u)
    return np.r_[u, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]


def test_a_combination_outside_the_baselines_hull_but_inside_its_ellipse_is_extrapolated():
    """A baseline filling the triangle x + y <= 1 (mean (1/3, 1/3), variance 1/18, covariance -1/36): (0.6, 0.6) lies
    within both ranges and at squared Mahalanobis distance 0.533^2 / 2 / (1/36) = 5.12 from the mean, inside the
    ellipse of the largest held-out distance (8.7, at a corner), but beyond the baseline's x + y <= 1: extrapolated,
    by the hull; (0.3, 0.3) is inside; (1.2, 0) beyond the range of x."""
    Eb = _triangle(400, 3)
    E = np.r_[Eb, [[0.6, 0.6], [0.3, 0.3], [1.2, 0.0]]]
    nb = len(Eb)
    cov = coverage(("temperature_c", "clamp"), E, np.arange(nb), np.arange(nb, nb + 3))
    assert cov.mahalanobis[nb] == pytest.approx((1.2 - 2 / 3) ** 2 / 2 * 36, rel=0.1)
    assert cov.mahalanobis[nb] < cov.mahalanobis_max                 # the ellipse's proxy misses it
    assert cov.extrapolated[nb:].tolist() == [True, False, True]
    assert cov.outside_hull[nb:].tolist() == [True, False, True]
    assert "convex hull" in cov.reasons[nb] and "combination" in cov.reasons[nb]
    assert cov.reasons[nb + 2].startswith("temperature_c 1.2 beyond the baseline's 0 to 1")
    assert not cov.extrapolated[:nb].any()


def test_the_hull_agrees_with_a_linear_programme():
    """Three coordinates: a test is inside the hull of 60 baseline tests exactly when some convex weights of them
    reproduce it (a feasibility linear programme), for 40 tests about the baseline's edge."""
    rng = np.random.default_rng(7)
    Eb = rng.standard_normal((60, 3)) * [1.0, 5.0, 0.2] + [10.0, -3.0, 0.5]
    E = Eb.mean(axis=0) + 1.2 * (rng.standard_normal((40, 3)) * [1.0, 5.0, 0.2])
    out = outside_hull(Eb, E, max_vertex_share=1.0)
    A = np.r_[Eb.T, np.ones((1, len(Eb)))]
    lp = [linprog(np.zeros(len(Eb)), A_eq=A, b_eq=np.r_[x, 1.0], bounds=(0, None)).status == 2 for x in E]
    assert out.tolist() == lp
    assert 5 < out.sum() < 35                                          # both kinds tested
    assert outside_hull(Eb, E) is None                                 # 60 tests, 3 coordinates: vertices > 5 %
    assert outside_hull(Eb[:, :1], E[:, :1], 1.0) is None              # one coordinate: the range does
    assert outside_hull(np.c_[Eb, Eb[:, :1] * 2], np.c_[E, E[:, :1] * 2], 1.0) is None      # flat: no hull
    assert outside_hull(rng.standard_normal((80, HULL_MAX_DIM + 1)), E[:, :1].repeat(5, 1), 1.0) is None


def test_a_new_exchangeable_test_lies_outside_the_hull_at_the_share_of_its_vertices():
    """Two Gaussian coordinates, 200 baseline tests: a baseline test is outside the hull of the others exactly when
    it is one of its vertices, and a new test of the same law lies outside with probability E[V] / (n + 1)
    (exchangeability), 4.8 % here (the ellipse of the largest held-out distance: at most 1 / (n + 1), 0.5 %)."""
    rng = np.random.default_rng(11)
    n, shares, verts = 200, [], []
    for k in range(60):
        Eb = rng.standard_normal((n, 2)) @ [[1.0, 0.6], [0.0, 0.8]]
        hull = ConvexHull(Eb)
        if k < 2:
            loo = [bool(outside_hull(np.delete(Eb, i, axis=0), Eb[i:i + 1], 1.0)[0]) for i in range(n)]
            assert np.flatnonzero(loo).tolist() == sorted(hull.vertices.tolist())
        verts.append(len(hull.vertices))
        shares.append(outside_hull(Eb, rng.standard_normal((4000, 2)) @ [[1.0, 0.6], [0.0, 0.8]], 1.0).mean())
    assert np.mean(shares) == pytest.approx(np.mean(verts) / (n + 1), rel=0.1)
    assert 0.04 < np.mean(shares) < 0.08
