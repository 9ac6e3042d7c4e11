"""A mode lighter than a short record resolves is estimated at zero damping within +-1/(2 pi f T), of either sign
from one model order to the next: SSI-cov in a band known to hold a mode keeps such a pole of either sign, so
that its column over the orders is not broken where the estimate comes out slightly negative (a closed-form
0.57-s decay of a 160-Hz mode damped 0.02 %, an eighth of the record's resolution, and white noise)."""

import numpy as np
import pytest

from physics.identification.poles import damping_resolution, select_poles, stability_status, unresolved
from physics.identification.ssi import identify_ssi, output_correlations, ssi_poles

FS_HZ, DURATION_S, FN_HZ, ZETA = 5000.0, 0.57, 160.0, 2e-4
BAND_HZ = (FN_HZ / 1.15, FN_HZ * 1.15)


def _record(seed=0):
    """Two channels (shape 1, -0.6), the decay from phase 0.3 rad, noise 5 % of its amplitude."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(DURATION_S * FS_HZ)) / FS_HZ
    w = 2 * np.pi * FN_HZ
    q = np.exp(-ZETA * w * t) * np.sin(w * np.sqrt(1 - ZETA**2) * t + 0.3)
    return np.vstack([q, -0.6 * q]) + 0.05 * rng.standard_normal((2, t.size))


def test_two_dampings_within_the_resolution_are_one_whatever_their_sign():
    r = float(damping_resolution(10.0, 10.0))                           # 1.59e-3
    assert unresolved(-1e-4, 2e-4, r) and not unresolved(-1e-4, 2e-3, r) and not unresolved(0.0, 0.0, 0.0)
    order, fn, mpf = np.array([1, 2]), np.array([10.0, 10.0]), np.ones((2, 1))
    zeta = np.array([-1e-5, 2e-5])                  # 3e-5 apart: within 5 % of the resolution (8e-5), either sign
    assert stability_status(order, fn, zeta, mpf, duration_s=10.0).tolist() == [0, 4]


def test_poles_below_zero_within_the_resolution_are_kept_only_for_a_record_of_known_duration():
    cor = output_correlations(_record(), FS_HZ, 60, band_hz=BAND_HZ)
    T = cor.n_samples / cor.sampling_frequency_hz
    r = float(damping_resolution(FN_HZ, T))
    assert ZETA < r / 8
    orders = np.arange(2, 41, 2)
    args = (cor.correlations, cor.sampling_frequency_hz, 30, orders, BAND_HZ)
    old, new = ssi_poles(*args), ssi_poles(*args, duration_s=T)
    near = np.abs(new.natural_frequencies_hz / FN_HZ - 1) <= 0.01
    assert (old.damping_ratios > 0).all()
    below = near & (new.damping_ratios < 0)
    assert np.unique(new.order[below]).size >= 3                      # the estimate about zero, either sign
    assert (new.damping_ratios > -r).all()
    kept = np.unique(new.order[near & (new.status == 4)]).size
    assert kept > np.unique(old.order[(np.abs(old.natural_frequencies_hz / FN_HZ - 1) <= 0.01)
                                      & (old.status == 4)]).size
    sel = select_poles(new)
    k = int(np.argmin(np.abs(sel.natural_frequencies_hz - FN_HZ)))
    assert sel.natural_frequencies_hz[k] == pytest.approx(FN_HZ, rel=3e-4)
    assert 0.0 <= sel.damping_ratios[k] < r                             # unresolved: within it, never below 0


@pytest.mark.parametrize("seed", [0, 18])
def test_identify_ssi_in_the_modes_band_reads_it_where_positive_poles_alone_were_too_few(seed):
    e = identify_ssi(_record(seed), FS_HZ, BAND_HZ, mode_in_band=True).estimate
    k = int(np.argmin(np.abs(e.natural_frequencies_hz - FN_HZ)))
    assert e.natural_frequencies_hz[k] == pytest.approx(FN_HZ, abs=0.05)
    assert 0.0 <= e.damping_ratios[k] < damping_resolution(FN_HZ, DURATION_S)
