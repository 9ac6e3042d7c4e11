"""Free responses in closed form (damped sinusoids after hits, white noise) and the Cramer-Rao bound of their
frequencies, for the free-decay identification tests."""

import numpy as np


def poles(fn_hz, zeta):
    """``-zeta w + i w sqrt(1 - zeta^2)`` (rad/s) of natural frequencies (Hz) and damping ratios."""
    w = 2 * np.pi * np.asarray(fn_hz, float)
    z = np.asarray(zeta, float)
    return -z * w + 1j * w * np.sqrt(1 - z ** 2)


def impact_record(fs_hz, n_samples, fn_hz, zeta, shapes, hits_s, noise, seed, hit_gains=None):
    """Impulse responses ``sum_j Re(shape_j g exp(lambda_j (t - t_h)) / (i w_j))`` after each hit time ``t_h``
    (gain ``g`` per hit), plus white noise of ``noise`` times the noise-free record's standard deviation.

    Returns ``(y, clean, noise_std)``, ``y`` shape (n_channels, n_samples)."""
    rng = np.random.default_rng(seed)
    lam = poles(fn_hz, zeta)
    shapes = np.atleast_2d(np.asarray(shapes, float))
    t = np.arange(n_samples) / fs_hz
    clean = np.zeros((shapes.shape[0], n_samples))
    gains = np.ones(len(hits_s)) if hit_gains is None else np.asarray(hit_gains, float)
    for th, g in zip(hits_s, gains):
        k0 = int(np.ceil(th * fs_hz))
        tt = t[k0:] - th
        clean[:, k0:] += g * np.real(shapes @ (np.exp(np.outer(lam, tt)) / (1j * lam.imag)[:, None]))
    sd = noise * clean.std()
    return clean + sd * rng.standard_normal(clean.shape), clean, sd


def crb_frequency_std_hz(fs_hz, n_samples, fn_hz, zeta, amplitudes, noise_std):
    """Cramer-Rao bound (one sigma) of the natural frequencies of damped sinusoids in white noise.

    One channel, ``y_k = sum_j A_j exp(-sigma_j t_k) cos(w_j t_k + p_j) + e_k`` at ``t_k = k / fs``, parameters
    ``(A_j, p_j, sigma_j, w_j)`` of each mode; the Fisher information ``J^T J / noise_std^2`` from the analytic
    Jacobian, its inverse mapped to ``f_n = sqrt(sigma^2 + w^2) / 2 pi`` to first order."""
    lam = poles(fn_hz, zeta)
    sig, w = -lam.real, lam.imag
    A, p = np.abs(amplitudes), np.angle(amplitudes)
    t = np.arange(n_samples) / fs_hz
    e = np.exp(-np.outer(t, sig))
    c, s = np.cos(np.outer(t, w) + p), np.sin(np.outer(t, w) + p)
    J = np.concatenate([e * c, -A * e * s, -t[:, None] * A * e * c, -t[:, None] * A * e * s], axis=1)
    cov = noise_std ** 2 * np.linalg.inv(J.T @ J)
    m = w.size
    wn = np.hypot(sig, w)
    g = np.zeros((m, 4 * m))
    g[np.arange(m), 2 * m + np.arange(m)] = sig / wn
    g[np.arange(m), 3 * m + np.arange(m)] = w / wn
    return np.sqrt(np.einsum("ij,jk,ik->i", g, cov, g)) / (2 * np.pi)


def fft_peak_hz(y, fs_hz, near_hz, pad=16):
    """Zero-padded FFT peak of a one-channel record nearest each of ``near_hz`` (parabolic interpolation of the
    log magnitude over the three lines about the largest within 3 % of it)."""
    n = pad * y.size
    spec = np.abs(np.fft.rfft(y - y.mean(), n))
    f = np.fft.rfftfreq(n, 1 / fs_hz)
    out = []
    for f0 in near_hz:
        idx = np.flatnonzero(np.abs(f - f0) <= 0.03 * f0)
        k = idx[np.argmax(spec[idx])]
        a, b, c = np.log(spec[k - 1:k + 2])
        out.append(f[k] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0]))
    return np.array(out)
