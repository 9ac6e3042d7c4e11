"""Shared test helpers: random, lightly and non-proportionally damped systems."""

import numpy as np


def random_system(n, seed, damping=0.02):
    """A stable, underdamped, non-proportionally damped (M, C, K) of ``n`` DOFs.

    ``M`` and ``K`` are random symmetric positive definite matrices; ``C`` is a
    random SPD matrix scaled so the modal damping ratios are about ``damping``
    (light damping) while the modal damping matrix is far from diagonal.
    """
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    M = a @ a.T / n + np.eye(n)
    b = rng.standard_normal((n, n))
    K = 100.0 * (b @ b.T / n + 0.5 * np.eye(n))
    c = rng.standard_normal((n, n))
    C = c @ c.T / n + 0.1 * np.eye(n)
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real
    C *= 2 * damping * np.sqrt(np.max(w2)) / np.max(np.linalg.eigvals(np.linalg.solve(M, C)).real)
    return M, C, K
