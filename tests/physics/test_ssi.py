"""SSI-cov output-only identification against a closed-form 3-DOF chain under white noise."""

import numpy as np
import pytest
from oma_records import chain_record

from physics.errors import BeamDamageError
from physics.identification.ssi import _svd, identify_ssi, output_correlations
from physics.identification.subspace import MAX_QR_CONDITION, state_matrices, subspace_diagram
from physics.modal import mac


def test_correlations_accumulated_in_chunks_equal_the_direct_sums():
    rng = np.random.default_rng(0)
    y = rng.standard_normal((2, 5000))
    y[1] = np.roll(y[0], 3) + 0.1 * y[1]
    R = output_correlations(y, 100.0, 6, chunk_samples=700).correlations
    ym = y - y.mean(axis=1, keepdims=True)
    direct = np.array([ym[:, k:] @ ym[:, :ym.shape[1] - k].T / (ym.shape[1] - k) for k in range(6)])
    np.testing.assert_allclose(R, direct, atol=1e-12)
    assert R[3, 1, 0] == pytest.approx(1.0, abs=0.05)      # channel 1 is channel 0 three samples later


def test_ssi_cov_finds_the_chain_modes_with_their_damping_and_shapes():
    y, fs, fn, zeta, phi = chain_record()
    res = identify_ssi(y, fs, band_hz=(1, 60), max_order=30)
    e = res.estimate
    assert e.natural_frequencies_hz.size == 3
    np.testing.assert_allclose(e.natural_frequencies_hz, fn, rtol=2e-3)
    np.testing.assert_allclose(e.damping_ratios, zeta, rtol=0.15)
    assert np.all(np.diag(mac(phi, e.shapes)) > 0.999)
    np.testing.assert_allclose(np.linalg.norm(e.shapes, axis=0), 1.0)
    assert not e.scaled and e.method == "ssi"
    assert res.bands is None                                # a stationary record: SSI-cov's own poles
    # the segment spread is a standard error: the truth lies within 4 sigma, and sigma is small but not zero
    assert np.all(np.abs(e.natural_frequencies_hz - fn) < 4 * e.frequency_std_hz)
    assert np.all((e.frequency_std_hz > 0) & (e.frequency_std_hz < 2e-3 * fn))
    assert np.all((e.damping_std > 0) & (e.damping_std < 0.2 * zeta))


def test_decimation_to_the_band_keeps_the_modes():
    y, fs, fn, zeta, _ = chain_record(seconds=300, fs_hz=1000.0, seed=2)
    res = identify_ssi(y, fs, band_hz=(1, 40), max_order=30)
    assert res.correlations.decimation == 10
    np.testing.assert_allclose(res.estimate.natural_frequencies_hz, fn, rtol=3e-3)


@pytest.mark.parametrize("case, message", [
    ("nan", "NaN"), ("clip", "clipped"), ("nyquist", "Nyquist"), ("short", "ten periods"), ("constant", "constant")])
def test_bad_records_are_refused_with_what_cannot_be_identified(case, message):
    y, fs, *_ = chain_record(seconds=120, seed=3)
    band = (1, 60)
    if case == "nan":
        y[1, 500] = np.nan
    elif case == "clip":
        y[2] = np.clip(y[2], -np.inf, 0.5 * y[2].max())
    elif case == "nyquist":
        band = (1, 150)
    elif case == "short":
        y = y[:, :150]          # 0.75 s, five periods of the 7 Hz mode
        band = (5, 60)
    elif case == "constant":
        y[0] = 1.0
    with pytest.raises(BeamDamageError, match=message):
        identify_ssi(y, fs, band_hz=band, max_order=12, block_rows=8 if case == "short" else None)


def test_a_failed_selection_names_the_steadiest_poles_and_what_to_try():
    """Poles whose frequency and shape hold over orders (status 3) but whose damping does not: the error names
    them, most orders first, with the orders counted over the whole diagram."""
    from physics.identification.poles import StabilisationDiagram
    from physics.identification.poles import steadiest_text

    order = np.array([1, 2, 3, 4, 5, 6, 4, 5, 6])
    fn = np.array([100.0, 100.2, 99.9, 100.1, 100.0, 100.3, 250.0, 250.5, 260.0])
    status = np.array([0, 3, 3, 3, 3, 3, 0, 3, 1])
    d = StabilisationDiagram(order, 2j * np.pi * fn, fn, np.full(fn.size, 0.01), np.ones((fn.size, 2), complex),
                             status, (50.0, 400.0))
    text = steadiest_text(d)
    assert text.startswith("; the steadiest poles (frequency and shape): 100.1 Hz (5 of 6 orders), 250.5 Hz (1 of 6")
    assert "--method fdd" in text
    assert steadiest_text(StabilisationDiagram(order, 2j * np.pi * fn, fn, np.full(fn.size, 0.01),
                                               np.ones((fn.size, 2), complex), np.zeros(fn.size, int),
                                               (50.0, 400.0))) == ""


def _diagram_with_a_short_cluster():
    """Orders 1-20: a pole at 100 Hz stable in every order, one at 30 Hz stable only in orders 15-19 (5 of 20, below
    the selection's third of the orders)."""
    from physics.identification.poles import StabilisationDiagram

    order = np.concatenate([np.arange(1, 21), np.arange(15, 20)])
    fn = np.concatenate([np.full(20, 100.0), np.full(5, 30.0)]) * (1 + 1e-4 * np.sin(np.arange(25)))
    zeta = np.full(25, 0.01)
    status = np.where(order > 1, 4, 0)
    status[20] = 0                                   # the 30 Hz pole of order 15 is new
    return StabilisationDiagram(order, 2j * np.pi * fn, fn, zeta, np.ones((25, 2), complex) / np.sqrt(2), status,
                                (10.0, 200.0))


def test_a_short_cluster_at_a_clear_peak_is_kept_weakly_stable_and_dropped_without_one():
    from physics.identification.poles import select_poles

    d = _diagram_with_a_short_cluster()
    sel = select_poles(d)
    np.testing.assert_allclose(sel.natural_frequencies_hz, [100.0], rtol=1e-3)
    assert not sel.weakly_stable.any()
    sel = select_poles(d, peaks_hz=[30.2])
    np.testing.assert_allclose(sel.natural_frequencies_hz, [30.0, 100.0], rtol=1e-3)
    assert sel.weakly_stable.tolist() == [True, False] and sel.count[0] < sel.count[1]
    assert select_poles(d, peaks_hz=[33.0]).natural_frequencies_hz.size == 1     # 10 % away: no peak at it
    assert select_poles(d, peaks_hz=[30.2], n_modes=1).weakly_stable.tolist() == [False]   # the steadiest first


def _direct_poles(U, s, n_out, order, fs, band_hz):
    """One order's poles the direct way: its own least squares and eigen-decomposition (no shared factorisation)."""
    O = U[:, :order] * np.sqrt(s[:order])
    mu = np.linalg.eigvals(np.linalg.lstsq(O[:-n_out], O[n_out:], rcond=None)[0])
    lam = np.log(mu.astype(complex)) * fs
    fn = np.abs(lam) / (2 * np.pi)
    zeta = -lam.real / np.abs(lam)
    return np.sort_complex(lam[(lam.imag > 0) & (zeta > 0) & (zeta < 0.2) & (fn >= band_hz[0]) & (fn <= band_hz[1])])


@pytest.mark.parametrize("n_out", [1, 3])
def test_multi_order_diagram_equals_the_direct_ssi_of_each_order(n_out):
    """The diagram's poles of orders 4 and 12 (one QR for all orders) equal each order's own least squares and
    eigenvalues; at order 4 (two modes, noise-free correlations ``C A^k G``) they are the system's poles."""
    fs, fn, zeta = 100.0, np.array([7.0, 19.0]), np.array([0.02, 0.01])
    lam = -zeta * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - zeta ** 2)
    mu = np.exp(np.concatenate([lam, lam.conj()]) / fs)
    rng = np.random.default_rng(4)
    C = rng.standard_normal((n_out, 2)) + 1j * rng.standard_normal((n_out, 2))
    C, G = np.hstack([C, C.conj()]), np.vstack([C.T, C.T.conj()])     # real correlations
    R = np.real(np.einsum("ck,lk,kr->lcr", C, mu[None, :] ** np.arange(24)[:, None], G))
    R += 1e-9 * rng.standard_normal(R.shape)                          # orders above 4 fit this floor
    U, s = _svd(R, 12)
    d = subspace_diagram(U, s, n_out, np.arange(2, 13, 2), fs, (0.5, 45.0), max_damping=0.2)
    for order in (4, 12):
        got = np.sort_complex(d.eigenvalues[d.order == order // 2])
        np.testing.assert_allclose(got, _direct_poles(U, s, n_out, order, fs, (0.5, 45.0)), rtol=1e-9)
    np.testing.assert_allclose(np.sort_complex(d.eigenvalues[d.order == 2]), np.sort_complex(lam), rtol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(d.participation, axis=1), 1.0)
    big = d.participation[np.arange(d.order.size), np.argmax(np.abs(d.participation), axis=1)]
    np.testing.assert_allclose(big.imag, 0.0, atol=1e-12)
    assert np.all(big.real > 0)


def test_orders_the_shared_qr_cannot_take_are_solved_by_their_own_least_squares():
    """Orders past the rows of the shifted matrix (underdetermined) or past MAX_QR_CONDITION equal lstsq."""
    rng = np.random.default_rng(5)
    O = rng.standard_normal((9, 12))
    O[:, 5] = O[:, 4] + 1e-3 / MAX_QR_CONDITION * rng.standard_normal(9)     # orders >= 6 ill-conditioned
    orders = [2, 4, 6, 8, 10]                                                 # 10 > 8 rows of O[:-1]
    for p, A in zip(orders, state_matrices(O, 1, orders)):
        np.testing.assert_allclose(A, np.linalg.lstsq(O[:-1, :p], O[1:, :p], rcond=None)[0], rtol=1e-8, atol=1e-8)


def _decay_crb_hz(t, fn, zeta, amp, sigma):
    """Cramer-Rao bound (Hz) of each damped frequency of ``sum amp e^(-zeta w t) sin(w_d t)`` in white noise of
    standard deviation ``sigma``: Fisher information of the damped frequencies, decay rates and cosine/sine
    amplitudes from the model's exact Jacobian."""
    w = 2 * np.pi * fn
    wd, s = w * np.sqrt(1 - zeta ** 2), zeta * w
    env = np.exp(-s[:, None] * t)
    c, sn = env * np.cos(wd[:, None] * t), env * np.sin(wd[:, None] * t)
    J = np.vstack([amp[:, None] * t * c, -amp[:, None] * t * sn, c, sn]).T
    return np.sqrt(np.diag(np.linalg.inv(J.T @ J / sigma ** 2))[:fn.size]) / (2 * np.pi)


def test_a_free_decay_is_identified_near_the_cramer_rao_bound():
    # SSI-cov's poles of a decay's correlations scatter tens of times the bound (the correlations' error has the
    # modes' spectrum, and a high-order model's extra poles sit beside each mode); refined in their bands they
    # reach it, as era's do
    fs, fn, zeta, amp, sigma = 500.0, np.array([12.0, 47.0]), np.array([0.01, 0.005]), np.array([1.0, 0.5]), 1e-3
    t = np.arange(int(4 * fs)) / fs
    clean = amp @ (np.exp(-zeta[:, None] * 2 * np.pi * fn[:, None] * t)
                   * np.sin(2 * np.pi * fn[:, None] * np.sqrt(1 - zeta[:, None] ** 2) * t))
    rng = np.random.default_rng(7)
    got, one_sigma = [], []
    for _ in range(8):
        res = identify_ssi((clean + sigma * rng.standard_normal(t.size))[None], fs)
        assert res.bands is not None                        # a free response: the band refinement ran
        f = res.estimate.natural_frequencies_hz
        j = np.argmin(np.abs(f[:, None] - fn[None, :]), axis=0)
        got.append(f[j])
        one_sigma.append(res.estimate.frequency_std_hz[j])
    crb = _decay_crb_hz(t, fn, zeta, amp, sigma)
    # natural frequency |lambda| / 2 pi: its scatter is the damped frequency's
    assert np.all(np.abs(np.mean(got, axis=0) - fn) < 4 * crb)
    assert np.all(np.std(got, axis=0, ddof=1) < 2.0 * crb)
    np.testing.assert_allclose(np.mean(one_sigma, axis=0), crb, rtol=0.5)   # the band fit's sigma is the bound's
    unrefined = identify_ssi((clean + sigma * rng.standard_normal(t.size))[None], fs, refine_decays=False)
    assert unrefined.bands is None


def test_a_provisional_mode_is_replaced_by_the_sub_band_mode_only_when_that_one_is_steadier():
    """A mode whose whole-band lags spanned under two periods (provisional) against the sub-band pass's estimate of
    it: the one whose frequency scatters less over its segments is kept (the merge's standard error), and a weakly
    stable provisional mode is replaced whatever the scatter; a provisional mode kept is settled, and a weakly
    stable sub-band pole is taken only at a peak no settled mode explains and it lies nearer than every earlier
    mode (the split pole beside mode 1 is not)."""
    from physics.identification.fdd import ClearPeaks
    from physics.identification.ssi import _merge_sub_band, _PassMode

    peaks = ClearPeaks(np.array([100]), np.array([10.1]), np.array([20.0]), np.array([[90, 110]]), np.array([0.3]),
                       np.array([True]))
    wobble = np.array([1.0, -1.0, 0.5, -0.5, 0.8, -0.8, 0.2, -0.2])

    def mode(f_hz, spread_hz, provisional, weak=False):
        return _PassMode(f_hz, 0.01, weak, 30, np.ones(3, complex) / np.sqrt(3), f_hz + spread_hz * wobble,
                         np.full(8, 0.01), provisional)

    whole = [mode(10.09, 0.02, True), mode(64.4, 0.05, False)]
    noisy_sub = mode(10.01, 0.09, False)
    kept = _merge_sub_band(whole, [noisy_sub], peaks, lag_before_s=0.1)
    assert [m.frequency_hz for m in kept] == [10.09, 64.4]
    steady_sub = mode(10.1, 0.005, False)
    kept = _merge_sub_band(whole, [steady_sub], peaks, lag_before_s=0.1)
    assert sorted(m.frequency_hz for m in kept) == [10.1, 64.4]
    weak = [mode(10.09, 0.02, True, weak=True), whole[1]]
    kept = _merge_sub_band(weak, [noisy_sub], peaks, lag_before_s=0.1)
    assert sorted(m.frequency_hz for m in kept) == [10.01, 64.4]
    split = mode(10.31, 0.02, True, weak=True)          # the sub-band's weakly stable pole beside the kept mode
    kept = _merge_sub_band(whole, [split, noisy_sub], peaks, lag_before_s=0.1)
    assert [m.frequency_hz for m in kept] == [10.09, 64.4] and not kept[0].provisional    # settled: not sought again
    kept = _merge_sub_band(whole, [split, steady_sub], peaks, lag_before_s=0.1)
    assert sorted(m.frequency_hz for m in kept) == [10.1, 64.4]
    lone = mode(10.0, 0.02, True, weak=True)            # no sub-band mode settles the peak: taken nearer it only
    assert [m.frequency_hz for m in _merge_sub_band([whole[1]], [lone], peaks, 0.1)] == [64.4, 10.0]
    far = [mode(10.3, 0.02, True, weak=True), mode(30.0, 0.02, False)]   # the peak lies nearer the earlier mode
    kept = _merge_sub_band([mode(10.12, 0.02, True), whole[1]], far, peaks, 0.1)
    assert [m.frequency_hz for m in kept] == [10.12, 64.4]
