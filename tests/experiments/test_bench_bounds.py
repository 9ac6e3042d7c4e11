"""The benches' Cramér-Rao bounds against the scatter of a least-squares fit of the same model on noisy draws."""

import numpy as np
from scipy.optimize import least_squares

from experiments.benches.bounds import crb_decay_rel, crb_frf_rel
from experiments.second_sim.response import Noise, measure


def _accelerance(w, fn_hz, zeta, R, U, L):
    wn = 2 * np.pi * fn_hz
    lam = wn * (-zeta + 1j * np.sqrt(1 - zeta ** 2))
    return -w ** 2 * (R / (1j * w - lam) + np.conj(R) / (1j * w - np.conj(lam)) + U) + L


def test_the_frf_bound_is_the_scatter_of_a_maximum_likelihood_fit():
    """One mode (10 Hz, 1 %) on 0.1-Hz lines with the simulator's noise (3 % of |H| plus 0.1 % of the peak): the
    frequency of a weighted least-squares fit of the modal sum (the maximum-likelihood estimate) scatters over 300
    draws by the bound within the scatter's own sampling error (about 4 %, 12 % allowed)."""
    f = np.arange(8.0, 12.0, 0.1)
    w = 2 * np.pi * f
    truth = (10.0, 0.01, 2e-3 + 5e-3j, 1e-4 + 0j, 0.05 + 0j)
    acc = _accelerance(w, *truth)
    noise = Noise(0.03, 1e-3)
    sd = np.sqrt((noise.level * np.abs(acc)) ** 2 + (noise.floor * np.abs(acc).max()) ** 2)
    bound = crb_frf_rel(f, acc, [truth[0]], [truth[1]], noise)[0]
    rng = np.random.default_rng(0)
    x0 = np.array([10.0, 0.01, 2e-3, 5e-3, 1e-4, 0.0, 0.05, 0.0])

    def residual(p, y):
        r = (_accelerance(w, p[0], p[1], p[2] + 1j * p[3], p[4] + 1j * p[5], p[6] + 1j * p[7]) - y) / sd
        return np.concatenate([r.real, r.imag])

    fits = [least_squares(residual, x0, args=(measure(acc[None], noise, rng)[0],), x_scale="jac").x[0]
            for _ in range(300)]
    np.testing.assert_allclose(np.std(fits) / truth[0], bound, rtol=0.12)


def test_the_decay_bound_of_one_channel_is_the_damped_sinusoid_bound():
    """One channel, one mode: the bound falls as the noise's sd, and over four equal channels by half (their
    information added), against the closed form of an undamped sinusoid's angular frequency in white noise,
    ``sqrt(24 / N) sd / (a T)`` (``N`` samples over ``T``, amplitude ``a``, phase unknown)."""
    fs, n = 1000.0, 1000
    fn, zeta = np.array([50.0]), np.array([1e-6])
    one = crb_decay_rel(fs, n, 0.0, fn, zeta, np.array([[1.0]]), 0.01)[0]
    four = crb_decay_rel(fs, n, 0.0, fn, zeta, np.ones((4, 1)), 0.01)[0]
    T = n / fs
    closed = np.sqrt(24 / n) * 0.01 / T / (2 * np.pi * fn[0])
    np.testing.assert_allclose(one, closed, rtol=0.02)
    np.testing.assert_allclose(four, one / 2, rtol=1e-9)
