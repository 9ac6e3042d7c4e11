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


def modal_record(frequencies_hz, damping_ratios, shapes, seconds=330.0, fs_hz=40.0, amplitudes=None, noise=0.02,
                 seed=1):
    """Responses ``shapes @ q`` of modes under independent white modal forces (exact ZOH modal filters), plus
    white sensor noise of ``noise`` times each channel's RMS.

    ``shapes`` is (n_channels, n_modes), real; ``amplitudes`` scales each modal force (default 1)."""
    rng = np.random.default_rng(seed)
    fn, zeta = np.asarray(frequencies_hz, float), np.asarray(damping_ratios, float)
    amp = np.ones(fn.size) if amplitudes is None else np.asarray(amplitudes, float)
    wn = 2 * np.pi * fn
    n = int(seconds * fs_hz)
    q = np.empty((fn.size, n))
    for r in range(fn.size):
        num, den, _ = signal.cont2discrete(([1.0], [1, 2 * zeta[r] * wn[r], wn[r] ** 2]), 1 / fs_hz, "zoh")
        q[r] = amp[r] * wn[r] ** 2 * signal.lfilter(num.ravel(), den, rng.standard_normal(n))
    y = np.asarray(shapes, float) @ q
    return y + noise * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


#: Modes of a tall building's ambient test (Hz): two close bending pairs, torsion, higher modes.
BUILDING_HZ = (1.23, 1.29, 1.45, 3.87, 4.25, 5.39)


def building_shapes(n_sensors=20, seed=0):
    """Real unit-norm shapes (n_sensors, 6) of :data:`BUILDING_HZ`: sines along the height mixed by a fixed draw
    (every sensor sees every mode)."""
    rng = np.random.default_rng(seed)
    h = np.arange(1, n_sensors + 1) / n_sensors
    order = np.array([1, 1, 1, 2, 2, 3])
    phi = np.sin((order - 0.5)[None, :] * np.pi * h[:, None]) * (1 + 0.5 * rng.standard_normal((n_sensors, 6)))
    return phi / np.linalg.norm(phi, axis=0)
