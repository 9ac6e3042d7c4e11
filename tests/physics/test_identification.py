"""Tests of modal identification against closed forms and exact simulated FRFs."""

import json
from importlib import resources

import numpy as np
import pytest

from physics.errors import ConvergenceError, ShapeError
from physics.frf import receptance
from physics.identification import (circle_fit, circle_fit_sdof, identify_lscf, lscf, lsfd,
                                    modal_phase_collinearity, peak_picking, select_poles,
                                    shapes_from_residues, synthesise_frf)
from physics.modal import complex_modes, mac


def beam5(damping="nonprop"):
    """IIRS-reduced beam-5 model (thesis) with a non-proportional damping matrix."""
    text = resources.files("experiments").joinpath("data/thesis/beams.json").read_text()
    red = json.loads(text)["beams"]["5"]["iirs_reduced"]
    M, K = np.array(red["M"]), np.array(red["K"])
    C = 2.0 * M + 4e-6 * K
    C[3, 3] += 0.4  # tip dashpot and a root dashpot make the damping non-proportional
    C[0, 0] += 0.2
    return M, C, K


def align(shapes, ref):
    """Flip each identified shape by the sign (+-1) that best matches the reference."""
    sgn = np.sign(np.real(np.sum(np.conj(ref) * shapes, axis=0)))
    return shapes * sgn


def sdof_receptance(f_hz, fn, zeta, A=1.0):
    w, wn = 2 * np.pi * f_hz, 2 * np.pi * fn
    return A / (wn**2 - w**2 + 2j * zeta * wn * w)


def test_mpc_closed_forms():
    real_times_phase = np.array([[1.0], [-2.0], [0.5]]) * np.exp(0.7j)
    assert modal_phase_collinearity(real_times_phase)[0] == pytest.approx(1.0, abs=1e-14)
    # [1, i]: psi^T psi = 0, so MPC = 0
    assert modal_phase_collinearity(np.array([[1.0], [1j]]))[0] == pytest.approx(0.0, abs=1e-14)
    # [1, e^{i pi/4}]: |1 + i|^2 / 2^2 = 1/2
    assert modal_phase_collinearity(np.array([[1.0], [np.exp(0.25j * np.pi)]]))[0] == pytest.approx(0.5)


def test_synthesis_matches_direct_inversion_and_shapes_from_residues():
    M, C, K = beam5()
    cm = complex_modes(M, C, K)
    f = np.linspace(5, 800, 300)
    psi = cm.eigenvectors
    R = psi[:, None, :] * psi[[3, 1]][None, :, :]  # references: DOFs 3 and 1
    H = synthesise_frf(f, cm.eigenvalues, R)
    Hd = receptance(M, C, K, 2 * np.pi * f, reference=[3, 1])
    np.testing.assert_allclose(H, Hd, rtol=1e-9, atol=1e-12 * np.abs(Hd).max())
    np.testing.assert_allclose(align(shapes_from_residues(R, drive=(1, 1)), psi), psi, rtol=1e-12)


def test_circle_fit_is_exact_for_sdof_mobility():
    fn, zeta = 37.3, 0.015
    f = fn * np.linspace(0.97, 1.03, 15)
    A = 2.5 * np.exp(0.3j)
    Y = 2j * np.pi * f * sdof_receptance(f, fn, zeta, A) + (0.01 - 0.02j)  # offset from other modes
    out = circle_fit_sdof(f, Y, fn * 1.004, 0.02)
    assert out.fn_hz == pytest.approx(fn, rel=1e-9)
    assert out.zeta == pytest.approx(zeta, rel=1e-9)  # eq. 3.13 holds exactly for every pair
    assert out.zeta_std < 1e-10
    assert out.modal_constant == pytest.approx(A, rel=1e-8)
    # the mobility circle of A/(wn^2 - w^2 + 2 i zeta wn w) has diameter |A|/(2 zeta wn)
    assert out.radius == pytest.approx(abs(A) / (4 * zeta * 2 * np.pi * fn), rel=1e-9)
    assert out.centre == pytest.approx((0.01 - 0.02j) + out.radius * np.exp(1j * np.angle(A)), rel=1e-8)


def test_peak_picking_half_power_on_fine_sdof():
    fn, zeta = 50.0, 0.01
    f = np.arange(40.0, 60.0, 0.005)
    h = sdof_receptance(f, fn, zeta)[None, None, :]
    est = peak_picking(f, h, n_modes=1, drive=(0, 0))
    # the receptance peak lies at fn sqrt(1 - 2 zeta^2), not at fn
    assert est.natural_frequencies_hz[0] == pytest.approx(fn * np.sqrt(1 - 2 * zeta**2), rel=1e-6)
    # half-power bandwidth of a receptance peak: 2 zeta fn to O(zeta^2)
    assert est.damping_ratios[0] == pytest.approx(zeta, rel=2e-3)
    # unit modal A of m = 1: psi^2 = 1/(2 i w_d)
    wd = 2 * np.pi * fn * np.sqrt(1 - zeta**2)
    assert est.shapes[0, 0] ** 2 == pytest.approx(1 / (2j * wd), rel=0.02)


def test_all_methods_on_beam5_noise_free():
    M, C, K = beam5()
    cm = complex_modes(M, C, K)
    f = np.arange(0.5, 800.0, 0.5)
    H = receptance(M, C, K, 2 * np.pi * f, reference=[3])
    res = identify_lscf(f, H, n_modes=4, drive=(3, 0))
    lscf_est, fit = res.estimate, res.fit
    np.testing.assert_allclose(lscf_est.natural_frequencies_hz, cm.natural_frequencies_hz, rtol=1e-7)
    np.testing.assert_allclose(lscf_est.damping_ratios, cm.damping_ratios, rtol=1e-5)
    np.testing.assert_allclose(align(lscf_est.shapes, cm.eigenvectors), cm.eigenvectors,
                               rtol=0, atol=1e-5 * np.abs(cm.eigenvectors).max())
    np.testing.assert_allclose(fit.synthesised, H, rtol=0, atol=1e-6 * np.abs(H).max())
    circ = circle_fit(f, H, n_modes=4, drive=(3, 0))
    np.testing.assert_allclose(circ.natural_frequencies_hz, cm.natural_frequencies_hz, rtol=2e-4)
    np.testing.assert_allclose(circ.damping_ratios, cm.damping_ratios, rtol=0.03)
    assert np.all(np.diag(mac(circ.shapes, cm.eigenvectors)) > 0.999)
    # MPC of the exact complex modes, computed independently
    psi = cm.eigenvectors
    mpc = np.abs(np.einsum("ij,ij->j", psi, psi)) ** 2 / np.einsum("ij,ij->j", psi, psi.conj()).real ** 2
    np.testing.assert_allclose(lscf_est.mpc, mpc, atol=1e-6)


def test_lscf_with_noise_recovers_poles_within_spread():
    M, C, K = beam5()
    cm = complex_modes(M, C, K)
    f = np.arange(0.5, 800.0, 0.5)
    H = receptance(M, C, K, 2 * np.pi * f)  # full 4x4 FRF matrix: poly-reference
    rng = np.random.default_rng(1)
    Hn = H + 0.01 * np.abs(H) * (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)) / np.sqrt(2)
    res = identify_lscf(f, Hn, n_modes=4, drive=(0, 0))
    est, fit = res.estimate, res.fit
    np.testing.assert_allclose(est.natural_frequencies_hz, cm.natural_frequencies_hz, rtol=1e-4)
    np.testing.assert_allclose(est.damping_ratios, cm.damping_ratios, rtol=0.03)
    assert np.all(np.diag(mac(est.shapes, cm.eigenvectors)) > 0.999)
    assert np.all(np.isfinite(est.frequency_std_hz)) and np.all(est.frequency_std_hz > 0)
    assert np.all(fit.residue_std > 0)


def test_poly_reference_separates_closely_spaced_overlapping_modes():
    # two modes 0.5 % apart with 1 % damping: half-power bands overlap completely
    lam = np.array([-0.01 * 2 * np.pi * 100 + 2j * np.pi * 100, -0.01 * 2 * np.pi * 100.5 + 2j * np.pi * 100.5])
    fn_true, z_true = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    psi = np.array([[1.0, 0.8], [0.7, -1.0], [0.3, 0.6]], complex) * 0.01
    R = psi[:, None, :] * psi[:2][None, :, :]  # two references at DOFs 0 and 1
    f = np.arange(90.0, 110.0, 0.05)
    H = synthesise_frf(f, lam, R)
    est = identify_lscf(f, H, n_modes=2, drive=(0, 0), max_order=30).estimate
    np.testing.assert_allclose(est.natural_frequencies_hz, fn_true, rtol=1e-7)
    np.testing.assert_allclose(est.damping_ratios, z_true, rtol=1e-5)
    assert np.all(np.diag(mac(est.shapes, psi)) > 0.99999)
    # a single SDOF peak cannot separate them
    assert peak_picking(f, H, drive=(0, 0)).natural_frequencies_hz.size == 1


def test_lsfd_residuals_absorb_out_of_band_modes():
    M, C, K = beam5()
    cm = complex_modes(M, C, K)
    f = np.arange(80.0, 450.0, 0.5)  # modes 2 and 3 only; modes 1 and 4 out of band
    H = receptance(M, C, K, 2 * np.pi * f, reference=[3])
    R_true = cm.eigenvectors[:, None, 1:3] * cm.eigenvectors[3, 1:3]
    with_res = lsfd(f, H, cm.eigenvalues[1:3])
    without = lsfd(f, H, cm.eigenvalues[1:3], lower_residual=False, upper_residual=False)
    err_with = np.abs(with_res.residues - R_true).max() / np.abs(R_true).max()
    err_without = np.abs(without.residues - R_true).max() / np.abs(R_true).max()
    assert err_with < 2e-3
    assert err_without > 5 * err_with
    assert with_res.lower_residual[3, 0] > 0  # a mode below the band acts like a mass line


def test_select_poles_rules_and_errors():
    M, C, K = beam5()
    f = np.arange(0.5, 800.0, 0.5)
    H = receptance(M, C, K, 2 * np.pi * f, reference=[3])
    d = lscf(f, H, max_order=30)
    # exact data: the four poles are stable (code 4) from the order that first holds all of them
    top_order = d.order == d.order.max()
    assert np.sum(d.status[top_order] == 4) >= 4
    top = select_poles(d, n_modes=2)
    assert top.eigenvalues.size == 2 and np.all(top.count >= 5)
    # the two largest clusters are two of the four true modes, sorted by frequency
    exact = complex_modes(M, C, K).natural_frequencies_hz
    assert np.all(np.min(np.abs(top.natural_frequencies_hz[:, None] / exact[None, :] - 1), axis=1) < 1e-6)
    assert np.all(np.diff(top.natural_frequencies_hz) > 0)
    with pytest.raises(ConvergenceError, match="stable"):
        select_poles(d, min_count=10_000)
    with pytest.raises(ShapeError):
        lscf(f[:5], H[..., :5], max_order=30)


def test_peak_picking_warns_when_the_half_power_band_is_below_the_line_spacing():
    import warnings as _w

    from experiments.bench_identification import simulate
    from physics.identification import peak_picking

    frf, exact = simulate(noise=0.0, damping="thesis")  # mode 1: zeta 0.26 %, band 0.1 Hz < 0.5 Hz lines
    with pytest.warns(UserWarning, match="fewer than 2 frequency lines"):
        peak_picking(frf.frequency_hz, frf.frf, 4, drive=(3, 0))
    fine, _ = simulate(noise=0.0, damping="heavy")
    with _w.catch_warnings():
        _w.simplefilter("error")
        peak_picking(fine.frequency_hz, fine.frf, 4, drive=(3, 0))
