"""Cramér-Rao bounds of the natural frequencies of simulated records, relative to each frequency: free decays
recorded channel by channel (:func:`crb_decay_rel`) and one accelerance on frequency lines (:func:`crb_frf_rel`), the
references of ``bench_unseen``'s scatter columns."""

from __future__ import annotations

import numpy as np

from experiments.second_sim.response import Noise

__all__ = ["crb_decay_rel", "crb_frf_rel"]


def crb_decay_rel(fs, n, t0, fn, zeta, amp, sd) -> np.ndarray:
    """Relative Cramér-Rao bound of each mode from the channels' decays (one channel's bound each, combined as
    independent information): the damped-sinusoid model's Fisher information (amplitude, phase, decay, frequency
    per mode) on the samples after ``t0``."""
    k = np.arange(int(np.ceil(t0 * fs)), n) / fs - t0
    w = 2 * np.pi * fn * np.sqrt(1 - zeta ** 2)
    s = zeta * 2 * np.pi * fn
    info = np.zeros(fn.size)
    for a in amp:                                       # one small Fisher matrix per channel
        J = []
        for j in range(fn.size):
            e = np.exp(-s[j] * k)
            c, si = e * np.cos(w[j] * k), e * np.sin(w[j] * k)
            J += [a[j] * si, a[j] * c, -a[j] * k * si, a[j] * k * c]     # amplitude, phase, decay, frequency
        J = np.array(J).T
        with np.errstate(all="ignore"):
            cov = np.linalg.pinv(J.T @ J / sd ** 2)
        info += 1.0 / np.maximum(np.diag(cov)[3::4], 1e-300)
    return np.sqrt(1.0 / info) / w


def crb_frf_rel(freq_hz, acc, fn_hz, zeta, noise: Noise) -> np.ndarray:
    """Relative Cramér-Rao bound of each mode's natural frequency from one accelerance ``acc`` (n_lines,) on
    ``freq_hz``: the Fisher information of complex Gaussian noise of variance ``(level |acc|)^2 + (floor
    max |acc|)^2`` per line (:func:`~experiments.second_sim.response.measure`'s model) about the modal sum
    ``-w^2 sum_j [R_j / (i w - lambda_j) + c.c.] - w^2 U + L`` (per mode ``f_n``, ``zeta`` and the complex residue;
    the complex residuals ``U`` and ``L``), the residues and residuals those that fit ``acc`` best."""
    w = 2 * np.pi * np.asarray(freq_hz, float)[:, None]
    wn = 2 * np.pi * np.asarray(fn_hz, float)
    zeta = np.asarray(zeta, float)
    root = np.sqrt(1 - zeta ** 2)
    lam = wn * (-zeta + 1j * root)
    g, gc = -w ** 2 / (1j * w - lam), -w ** 2 / (1j * w - lam.conj())
    one = np.ones_like(w)
    linear = np.concatenate([g + gc, 1j * (g - gc), -w ** 2 * one, -1j * w ** 2 * one, one, 1j * one], axis=1)
    coef = np.linalg.lstsq(np.concatenate([linear.real, linear.imag]), np.concatenate([acc.real, acc.imag]),
                           rcond=None)[0]
    m = wn.size
    R = coef[:m] + 1j * coef[m:2 * m]
    dg, dgc = g * R / (1j * w - lam), gc * R.conj() / (1j * w - lam.conj())     # d/d lambda of each term
    dl_dwn, dl_dz = -zeta + 1j * root, wn * (-1 - 1j * zeta / root)
    J = np.concatenate([2 * np.pi * (dg * dl_dwn + dgc * dl_dwn.conj()), dg * dl_dz + dgc * dl_dz.conj(), linear],
                       axis=1)
    var = (noise.level * np.abs(acc)) ** 2 + (noise.floor * np.abs(acc).max()) ** 2
    info = 2 * np.real(J.conj().T @ (J / var[:, None]))
    return np.sqrt(np.diag(np.linalg.inv(info))[:m]) / np.asarray(fn_hz, float)
