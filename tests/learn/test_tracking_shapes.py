"""Two close modes told apart by shape (learn/monitor/tracking.py): with shapes at 2 or more sensors a close pair's
tracking band reaches past half the log gap, and a pole there is the mode its MAC matches; by frequency alone (or on
one channel) the band stops at 45 % of the gap and the assignment is the frequency's."""

import math

import numpy as np
import pytest

from learn.monitor import IdentifiedModes, reference_modes, track_modes
from learn.monitor.beyond_band import beyond_bands
from learn.monitor.tracking import (APART_MAC, CORE, MAC_MIN, MODE_MOVED, NEIGHBOUR_SHARE, admissible, narrow_bands_hz,
                                   reach_bands_hz)
from physics.modal import mac

F0 = np.array([100.0, 102.0])                   # 2 % apart: 45 % of the gap is 0.89 %
PHI = np.array([[1.0, 0.0], [0.6, 0.2], [0.0, 1.0], [0.2, -0.5]])    # MAC below 0.001: told apart
DOFS = ("1:x", "2:x", "1:y", "2:y")


def _test(freqs_hz, shapes, dofs=DOFS) -> IdentifiedModes:
    f = np.asarray(freqs_hz, float)
    return IdentifiedModes("modal", "file", f, np.full(f.size, 0.01), shapes, dofs if shapes is not None else ())


def _baseline(shapes: str):
    """20 baseline tests of both modes, 0.25 % scatter in frequency (seeded), with shapes at 4 sensors (``"4"``,
    1 % noise), at one sensor (``"1"``) or none."""
    rng = np.random.default_rng(5)
    out = []
    for _ in range(20):
        f = F0 * np.exp(0.0025 * rng.standard_normal(2))
        phi = PHI + 0.01 * rng.standard_normal(PHI.shape)
        out.append(_test(f, phi, DOFS) if shapes == "4" else _test(f, phi[:1], DOFS[:1]) if shapes == "1" else
                   _test(f, None))
    return out


@pytest.fixture(scope="module")
def refs():
    return {k: reference_modes(_baseline(k)) for k in ("4", "1", "none")}


def test_a_close_pair_told_apart_by_shape_widens_its_bands(refs):
    """By frequency the bands stop at 45 % of the 2 % gap; told apart by shape (MAC of the reference shapes below
    0.001, ``APART_MAC`` 0.4) each band is its scatter's or the core window, ``CORE`` (+-2.47 %), past the neighbour."""
    by_shape, none = refs["4"], refs["none"]
    gap = math.log(by_shape.frequencies_hz[1] / by_shape.frequencies_hz[0])
    assert mac(by_shape.shapes, by_shape.shapes)[0, 1] < APART_MAC
    np.testing.assert_allclose(none.tolerance, NEIGHBOUR_SHARE * gap)
    assert none.frequency_tolerance is None
    np.testing.assert_allclose(by_shape.frequency_tolerance, none.tolerance)
    np.testing.assert_allclose(by_shape.tolerance, np.maximum(CORE, 10 * by_shape.log_std), rtol=0.1)
    assert np.all(by_shape.tolerance > gap)
    np.testing.assert_allclose(narrow_bands_hz(by_shape, by_frequency=True), narrow_bands_hz(none), rtol=1e-12)


def test_crossed_and_scattered_close_modes_are_assigned_by_shape_not_by_frequency(refs):
    """Mode 1 read at 101.2 Hz (+1.2 %, beyond half the gap) and mode 2 at 100.8 Hz (-1.2 %): their frequencies
    crossed. By frequency alone 100.8 Hz is mode 1 and 101.2 Hz mode 2, both wrong; by shape each is its own. A lone
    pole of mode 2's shape at 99.8 Hz (-2.2 %, below mode 1) is mode 1 by frequency, mode 2 by shape."""
    crossed = ([101.2, 100.8], PHI)
    lone = ([99.8], PHI[:, 1:])
    F_freq = track_modes([_test(f, None) for f, _ in (crossed, lone)], refs["none"])[0]
    np.testing.assert_allclose(F_freq, [[100.8, 101.2], [99.8, np.nan]])
    F_shape = track_modes([_test(f, s) for f, s in (crossed, lone)], refs["4"])[0]
    np.testing.assert_allclose(F_shape, [[101.2, 100.8], [np.nan, 99.8]])


def test_a_pole_beyond_the_frequency_band_like_the_neighbour_or_neither_is_not_taken(refs):
    """Beyond the band by frequency alone a pole is the mode's only when its MAC reaches ``MAC_MIN`` with the mode
    and not with the neighbour its band passes: a pole of mode 1's shape 0.7 % below mode 2 (in its band by
    frequency) is mode 1 (+1.3 %); one of a shape between the two (MAC 0.5 with each) is neither."""
    ref = refs["4"]
    mixed = (PHI[:, 0] / np.linalg.norm(PHI[:, 0]) + PHI[:, 1] / np.linalg.norm(PHI[:, 1]))[:, None]
    macs = mac(mixed, ref.shapes)[0]
    assert np.all(macs < MAC_MIN) and np.all(macs > 0.45)
    F = track_modes([_test([101.3], PHI[:, :1]), _test([101.1], mixed)], ref)[0]
    np.testing.assert_allclose(F, [[101.3, np.nan], [np.nan, np.nan]])


def test_a_pole_like_both_modes_stays_within_the_band_by_frequency():
    """Two modes whose shapes' MAC is 0.3 (below ``APART_MAC``: told apart): a pole of the shape half-way between
    them (MAC 0.77 with each) may be a mode's reading within its band by frequency (mode 2 at +0.4 %, mode 1 at
    +0.5 %), never beyond it (mode 1 at +2.4 %, mode 2 at -1.5 %: past 45 % of the gap): like the neighbour too,
    its shape does not tell it."""
    a = math.acos(math.sqrt(0.3))
    phi = np.array([[1.0, math.cos(a)], [0.0, math.sin(a)], [0.0, 0.0]])
    dofs = ("1:x", "1:y", "2:x")
    rng = np.random.default_rng(6)
    ref = reference_modes([_test(F0 * np.exp(0.0025 * rng.standard_normal(2)), phi + 0.005 *
                                 rng.standard_normal(phi.shape), dofs) for _ in range(20)])
    assert ref.frequency_tolerance is not None
    half = np.array([[math.cos(a / 2)], [math.sin(a / 2)], [0.0]])
    np.testing.assert_allclose(mac(half, ref.shapes)[0], math.cos(a / 2) ** 2, atol=0.02)
    ok = admissible(ref, [102.0 * 1.004, 102.0 / 1.015], mac(np.c_[half, half], ref.shapes))
    np.testing.assert_array_equal(ok, [[False, True], [True, False]])


def test_one_channel_gives_the_assignment_by_frequency(refs):
    """Shapes at one sensor tell no modes apart (``shapes_at`` is None there): the reference, its bands and every
    assignment are those by frequency alone, the crossed pair included."""
    one, none = refs["1"], refs["none"]
    assert one.shapes is None and one.frequency_tolerance is None
    np.testing.assert_array_equal(one.tolerance, none.tolerance)
    np.testing.assert_array_equal(one.frequencies_hz, none.frequencies_hz)
    tests = [_test([101.2, 100.8], PHI[:1], DOFS[:1]), _test([99.8], PHI[:1, 1:], DOFS[:1])]
    for got, want in zip(track_modes(tests, one), track_modes([_test(t.frequencies_hz, None) for t in tests], none)):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(track_modes(tests, one)[0], [[100.8, 101.2], [99.8, np.nan]])


def test_a_close_mode_moved_past_its_neighbour_is_read_moved_by_shape(refs):
    """Mode 2 down 4 % (97.92 Hz, 2.1 % below mode 1), its shape intact: beyond its band (+-2.5 %), and by frequency
    alone beyond its reach too (half the 2 % gap, 1 %), so it read as lost. Mode 1, told apart by shape, bounds no
    reach by shape: the reach is the open side's ``REACH_FACTOR``, and the pole is mode 2 moved -4 %, flagged (the
    baseline found mode 2 in every test). A pole of mode 1's shape there is no reading of mode 2; an FFT peak's reach
    (no shape) stays half the gap towards the neighbour (the open sides: the factor)."""
    ref = refs["4"]
    f = ref.frequencies_hz
    half = 0.5 * math.log(f[1] / f[0])
    np.testing.assert_allclose(reach_bands_hz(ref), [[f[0] / 2, f[0] * np.exp(half)], [f[1] * np.exp(-half), 2 * f[1]]],
                               rtol=1e-12)
    np.testing.assert_allclose(reach_bands_hz(ref, by_shape=True), np.outer(f, [0.5, 2.0]), rtol=1e-12)
    moved, other = 102.0 * 0.96, 100.0 * 0.979
    tests = _baseline("4") + [_test([100.0, moved], PHI), _test([other, 100.0], PHI[:, [0, 0]])]
    cols = track_modes(tests, ref)[3]
    np.testing.assert_array_equal(cols[20:], [[0, -1], [1, -1]])          # mode 2 missing from its band in both
    bb = beyond_bands(tests, ref, cols, range(20), 0.01)
    assert bb.moved_hz[20, 1] == pytest.approx(moved) and bb.flagged[20, 1] and bb.status(20) == MODE_MOVED
    assert bb.readings(20, ref)[0]["change_pct"] == pytest.approx(100 * (moved / f[1] - 1))
    assert abs(bb.readings(20, ref)[0]["change_pct"] + 4.0) < 0.3
    assert bb.lost[21, 1] and np.isnan(bb.moved_hz[21]).all()             # mode 1's shape: not mode 2
