"""A tracked pole far from its reference mode, checked by the narrow-band re-identification around the mode
(learn.monitor.pole_confirmation), on simulated drive-point FRFs: a mode split into two poles either side of it
(the one in the band a spurious reading) is read at the mode; a mode that really moved stays moved. The narrow-band
re-identification runs over the mode's search band (+-15 %) and only its poles within the tracking band count."""

from dataclasses import replace

import numpy as np
import pytest

from learn.monitor import IdentificationSettings, IdentifiedModes, identify_test, reference_modes, track_modes
from learn.monitor.pole_confirmation import confirm_far_poles, far_from_reference
from learn.monitor.tracking import CORE, identified_by, narrow_bands_hz, search_bands_hz
from physics.io import MeasuredFRF
from physics.io.npz import write_frf_npz

SETTINGS = IdentificationSettings((2.0, 60.0))


def _frf(path, modes_hz):
    """A drive-point receptance of equal modes at ``modes_hz`` (1 % damping), 1 % noise, 0.025-60 Hz."""
    f = np.arange(1, 2401) * 0.025
    w = 2 * np.pi * f
    H = sum(1.0 / (wn**2 - w**2 + 2j * 0.01 * wn * w) for wn in 2 * np.pi * np.asarray(modes_hz))
    rng = np.random.default_rng(0)
    H = H * (1 + 0.01 * (rng.standard_normal(H.size) + 1j * rng.standard_normal(H.size)))
    write_frf_npz(path, MeasuredFRF(f, H[None, None], ("1:+Y",), ("1:+Y",)))
    return path


@pytest.fixture(scope="module")
def ref():
    """Reference modes at 10 and 25 Hz, 0.1 % scatter over 20 baseline tests: bands +-2.47 % (the floor ``CORE``),
    10 robust standard deviations 0.7 %; search bands +-15 %."""
    rng = np.random.default_rng(1)
    base = [IdentifiedModes("modal", "file", np.array([10.0, 25.0]) * np.exp(0.001 * rng.standard_normal(2)),
                            np.full(2, 0.01), None) for _ in range(20)]
    return reference_modes(base)


def test_a_split_mode_is_read_at_the_mode_by_its_narrow_band(ref, tmp_path):
    path = _frf(tmp_path / "split.npz", [10.0, 25.0])
    broad = identify_test(path, SETTINGS)
    np.testing.assert_allclose(broad.frequencies_hz, [10.0, 25.0], rtol=1e-3)
    # the first pass split the 25-Hz mode: 24.0 Hz beyond its band (24.39-25.62 Hz), 25.5 Hz (+2 %) inside it
    split = replace(broad, frequencies_hz=np.array([10.0, 24.0, 25.5]), damping_ratios=np.full(3, 0.01), shapes=None,
                    dofs=())
    band_lo, band_hi = narrow_bands_hz(ref)[1]
    assert band_lo == pytest.approx(25.0 * np.exp(-CORE), rel=2e-3) and 24.0 < band_lo < 25.5 < band_hi
    lo, hi = search_bands_hz(ref)[1]
    assert lo == pytest.approx(25.0 / 1.15, rel=2e-3)
    F = track_modes([split], ref)[0]
    assert F[0, 1] == 25.5                                          # the spurious pole holds the mode's place
    np.testing.assert_array_equal(far_from_reference(F, ref), [[False, True]])
    pending = []
    [fixed] = confirm_far_poles([split], [path], ref, SETTINGS, tmp_path, pending)
    F, _, _, cols = track_modes([fixed], ref)
    np.testing.assert_allclose(F[0], [10.0, 25.0], rtol=1e-3)
    assert 25.5 in fixed.frequencies_hz and 24.0 in fixed.frequencies_hz      # kept, unassigned
    assert identified_by([fixed], cols)[0] == ["lscf", f"lscf, narrow band {lo:.4g}-{hi:.4g} Hz"]
    assert len(pending) == 1                                        # one narrow-band identification, cached


def test_a_mode_that_moved_stays_moved_and_a_near_pole_is_not_checked(ref, tmp_path):
    path = _frf(tmp_path / "moved.npz", [10.0, 25.5])               # the 25-Hz mode moved +2 %
    moved = identify_test(path, SETTINGS)
    F = track_modes([moved], ref)[0]
    np.testing.assert_allclose(F[0], [10.0, 25.5], rtol=1e-3)
    pending = []
    [same] = confirm_far_poles([moved], [path], ref, SETTINGS, tmp_path, pending)
    assert same is moved and len(pending) == 1                      # checked, confirmed by its narrow band
    assert 10 * ref.log_std[1] == pytest.approx(0.0066, abs=5e-4)
    near = replace(moved, frequencies_hz=np.array([10.0, 25.1]))    # +0.4 %: within 10 standard deviations
    assert not far_from_reference(track_modes([near], ref)[0], ref).any()
    pending = []
    assert confirm_far_poles([near], [path], ref, SETTINGS, tmp_path, pending)[0] is near and pending == []
