"""The variable-projection fit of damped sinusoids against independent computations: scipy's least squares on the
full model, an explicitly built Kaufman Jacobian, and the power sums summed term by term."""

import numpy as np
import pytest
from scipy.optimize import least_squares

from physics.identification.damped_sinusoids import _projected, fit_damped_sinusoids, power_sums

FS = 2000.0
#: Three modes, two of them 1.5 Hz apart (close against 1/T = 1.8 Hz of the shorter decay).
FN, ZETA = np.array([101.0, 102.5, 340.0]), np.array([0.004, 0.006, 0.002])


def _decays(seed, lengths=(1100, 700), noise=0.01):
    rng = np.random.default_rng(seed)
    wn = 2 * np.pi * FN
    lam = -ZETA * wn + 1j * wn * np.sqrt(1 - ZETA ** 2)
    out = []
    for n in lengths:
        t = np.arange(n) / FS
        amp = rng.normal(size=FN.size) + 1j * rng.normal(size=FN.size)
        y = np.real(np.exp(np.outer(t, lam)) @ amp) + 0.05 + noise * rng.normal(size=n)
        out.append(y[None, :])
    return out, lam


def _model(x, decays, m):
    """Residuals of the full model: poles, then per decay ``a, b`` (m each) and an offset."""
    sigma, omega = x[:m], x[m:2 * m]
    res, k = [], 2 * m
    for y in decays:
        t = np.arange(y.shape[1]) / FS
        e = np.exp(-np.outer(t, sigma))
        a, b, c = x[k:k + m], x[k + m:k + 2 * m], x[k + 2 * m]
        k += 2 * m + 1
        res.append(y[0] - (e * np.cos(np.outer(t, omega))) @ a - (e * np.sin(np.outer(t, omega))) @ b - c)
    return np.concatenate(res)


def _full_jacobian(x, decays, m):
    """Derivative of the full model's values by its parameters (ordered as :func:`_model`'s)."""
    sigma, omega = x[:m], x[m:2 * m]
    n_tot, k0 = sum(y.shape[1] for y in decays), 2 * m
    J, row = np.zeros((n_tot, x.size)), 0
    for y in decays:
        t = np.arange(y.shape[1]) / FS
        e = np.exp(-np.outer(t, sigma))
        cos, sin = e * np.cos(np.outer(t, omega)), e * np.sin(np.outer(t, omega))
        a, b = x[k0:k0 + m], x[k0 + m:k0 + 2 * m]
        rows = slice(row, row + t.size)
        J[rows, :m] = -t[:, None] * (cos * a + sin * b)
        J[rows, m:2 * m] = t[:, None] * (cos * b - sin * a)
        J[rows, k0:k0 + 2 * m + 1] = np.column_stack([cos, sin, np.ones_like(t)])
        row, k0 = row + t.size, k0 + 2 * m + 1
    return J


def test_the_fit_is_scipy_least_squares_on_the_full_model_and_its_covariance_the_schur_complement():
    decays, lam = _decays(seed=3)
    start = lam * (1 + 2e-3 * np.array([1, -1, 1]))
    fit = fit_damped_sinusoids(decays, FS, start)
    m = lam.size
    amps = fit.amplitudes[:, 0, :]                                        # a - i b, (n_decays, m)
    offsets = [np.mean(y[0] - r[0]) for y, r in zip(decays, fit.residuals)]
    x0 = np.concatenate([-start.real, start.imag]
                        + [np.concatenate([a.real * 0, a.imag * 0, [o]]) for a, o in zip(amps, offsets)])
    for j, a in enumerate(amps):                                          # amplitudes near the optimum's
        k = 2 * m + j * (2 * m + 1)
        x0[k:k + m], x0[k + m:k + 2 * m] = 0.9 * a.real, -0.9 * a.imag
    ls = least_squares(_model, x0, args=(decays, m), method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    sigma, omega = ls.x[:m], ls.x[m:2 * m]
    fn_ls = np.hypot(sigma, omega) / (2 * np.pi)
    np.testing.assert_allclose(fit.natural_frequencies_hz, fn_ls, rtol=1e-10)
    np.testing.assert_allclose(fit.damping_ratios, sigma / np.hypot(sigma, omega), rtol=1e-7)
    # the poles' block of s^2 (J^T J)^-1 of the full model, its Jacobian written out at scipy's optimum
    s2 = np.sum(ls.fun ** 2) / (ls.fun.size - ls.x.size)
    cov = s2 * np.linalg.inv(_full_jacobian(ls.x, decays, m).T @ _full_jacobian(ls.x, decays, m))[:2 * m, :2 * m]
    np.testing.assert_allclose(fit.covariance, cov, rtol=1e-7, atol=1e-9 * np.abs(cov).max())
    np.testing.assert_allclose(fit.noise_std, np.sqrt(np.mean(ls.fun ** 2)), rtol=1e-9)


def test_the_normal_equations_are_those_of_the_explicit_kaufman_jacobian():
    decays, lam = _decays(seed=5, lengths=(900, 400))
    sigma, omega = -lam.real * 1.3, lam.imag * (1 + 1e-3)                  # away from the optimum
    weights = np.array([2.5])
    res, coef, normal = _projected(decays, FS, sigma, omega, weights)
    m, blocks, rs = lam.size, [], []
    for y, C in zip(decays, coef):
        t = np.arange(y.shape[1]) / FS
        e = np.exp(-np.outer(t, sigma))
        cos, sin = e * np.cos(np.outer(t, omega)), e * np.sin(np.outer(t, omega))
        Phi = np.column_stack([cos, sin, np.ones_like(t)])
        Q, _ = np.linalg.qr(Phi)
        Yw = weights[0] * y[0]
        r = Yw - Q @ (Q.T @ Yw)
        coefs = np.linalg.lstsq(Phi, Yw, rcond=None)[0]
        a, b = coefs[:m], coefs[m:2 * m]
        D = np.column_stack([-t[:, None] * (cos * a + sin * b), t[:, None] * (cos * b - sin * a)])
        blocks.append(D - Q @ (Q.T @ D))
        rs.append(r)
        np.testing.assert_allclose(C[:, 0], coefs, rtol=1e-8)
    J, r = np.concatenate(blocks), np.concatenate(rs)
    np.testing.assert_allclose(np.concatenate([x[:, 0] for x in res]), r, atol=1e-10 * np.abs(r).max())
    scale = np.sqrt(np.diag(J.T @ J))
    np.testing.assert_allclose(normal.jtj / np.outer(scale, scale), (J.T @ J) / np.outer(scale, scale), atol=1e-10)
    np.testing.assert_allclose(normal.jtr, J.T @ r, atol=1e-9 * np.abs(J.T @ r).max())


@pytest.mark.parametrize("n", [1, 2, 7, 3000])
def test_the_power_sums_are_the_sums_term_by_term_in_and_out_of_the_series_radius(n):
    k = np.arange(n, dtype=np.longdouble)
    mags = np.minimum(np.array([0.0, 1e-6, 0.3, 0.99, 1.01, 2.0, 40.0, 400.0]) / n, 2 * np.pi)   # pairs to Nyquist
    s = np.concatenate([mags * np.exp(1j * a) for a in np.linspace(np.pi / 2, np.pi, 5)] + [[0.3 + 0.2j, 1e-3]])
    shift = np.maximum(s.real * (n - 1), 0.0)
    got = power_sums(s, n, shift)
    for j, sj in enumerate(s):
        re, im = np.longdouble(sj.real), np.longdouble(sj.imag)
        terms = np.exp(re * k - np.longdouble(shift[j])) * (np.cos(im * k) + 1j * np.sin(im * k))
        moduli = np.exp(re * k - np.longdouble(shift[j]))
        for p in range(3):
            want = np.sum(k ** p * terms)
            tol = np.finfo(float).eps * (20 + 2 * n * abs(sj))                   # the phase of exp(n s) to eps |n s|
            assert abs(complex(want) - got[p, j]) <= tol * float(np.sum(np.maximum(k, 1) ** p * moduli)), (sj, p)


def test_a_pole_growing_beyond_the_floating_point_range_is_refused():
    decays, lam = _decays(seed=1)
    with pytest.raises(np.linalg.LinAlgError):
        _projected(decays, FS, np.array([-0.9 * FS, 1.0, 1.0]), lam.imag, np.ones(1))
