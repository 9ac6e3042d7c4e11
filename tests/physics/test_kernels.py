import numpy as np

from physics.kernels import box_muller


def test_box_muller_tables_match_the_exact_transform():
    # z = sqrt(-ln(1 - u1)) exp(2 pi i u2), including the exact branch near u1 = 0 and 1
    rng = np.random.default_rng(4)
    u = np.concatenate([rng.random((2000, 2)), [[1e-7, 0.3], [1 - 1e-7, 0.7], [0.0, 0.0]]])
    z = np.array([complex(*box_muller(p)) for p in u])
    exact = np.sqrt(-np.log1p(-u[:, 0])) * np.exp(2j * np.pi * u[:, 1])
    np.testing.assert_allclose(z, exact, rtol=0, atol=1e-5)
    big = np.array([complex(*box_muller(p)) for p in rng.random((20000, 2))])
    assert abs(np.mean(np.abs(big) ** 2) - 1.0) < 0.03  # unit variance
