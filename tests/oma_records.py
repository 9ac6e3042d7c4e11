"""Response records of a closed-form 3-DOF chain under white noise, for the output-only tests."""

import numpy as np
from scipy import linalg, signal


def chain_record(seconds=600.0, fs_hz=200.0, noise=0.02, seed=1):
    """Displacements of a fixed-free 3-mass chain under white forces at every mass (exact ZOH modal filters)."""
    rng = np.random.default_rng(seed)
    M = np.eye(3)
    K = 1e4 * np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]])
    w2, phi = linalg.eigh(K, M)
    wn, zeta = np.sqrt(w2), np.array([0.01, 0.015, 0.02])
    n = int(seconds * fs_hz)
    force = rng.standard_normal((3, n))
    y = np.zeros((3, n))
    for r in range(3):
        num, den, _ = signal.cont2discrete(([1.0], [1, 2 * zeta[r] * wn[r], wn[r] ** 2]), 1 / fs_hz, "zoh")
        y += np.outer(phi[:, r], signal.lfilter(num.ravel(), den, phi[:, r] @ force))
    y += noise * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    return y, fs_hz, wn / (2 * np.pi), zeta, phi
