"""Impact tests cut one block per hit (`physics.time_records`): hits anywhere in the record, responses that outlast
their spacing, a force channel with an offset. Responses: the exact FRF of one mode times the force's spectrum,
over a record zero-padded 8-fold (no wrap-around)."""

import warnings

import numpy as np
import pytest

from physics.errors import FileFormatError
from physics.identification.measured import identify_frf
from physics.io.timedata import TimeRecords
from physics.time_records import estimate_as_recorded, estimate_from_records, hit_onsets

FS_HZ, FN_HZ, ZETA = 1024.0, 15.0, 0.01


def _record(hit_times_s, length_s, seed=0, offset_n=0.0, noise=1e-3):
    """Force (N) and displacement (m) of hits at ``hit_times_s`` on one mode (15 Hz, 1 %: its response falls to
    39 % in 1 s), half-sine pulses of 4 ms."""
    rng = np.random.default_rng(seed)
    n = int(length_s * FS_HZ)
    t = np.arange(8 * n) / FS_HZ
    force = np.zeros(8 * n)
    for t0 in hit_times_s:
        force += np.where((t >= t0) & (t < t0 + 0.004), rng.uniform(80, 120) * np.sin(np.pi * (t - t0) / 0.004), 0)
    w = 2j * np.pi * np.fft.rfftfreq(8 * n, 1 / FS_HZ)
    wn = 2 * np.pi * FN_HZ
    x = np.fft.irfft(wn**2 * np.fft.rfft(force) / (w**2 + 2 * ZETA * wn * w + wn**2), 8 * n)[:n]
    x = x + noise * np.abs(x).max() * rng.standard_normal(n)
    f = force[:n] + offset_n + 1e-4 * 100 * rng.standard_normal(n)
    return TimeRecords(1 / FS_HZ, np.vstack([f, x]), ("1:+Z", "2:+Z"), ("force", "displacement"),
                       {"source": "simulated hits"})


def _mode(est):
    """The identified mode near 15 Hz with the exponential window's decay removed: (frequency Hz, damping ratio)."""
    ident = identify_frf(est.frf, band_hz=(5.0, 60.0))
    lam = ident.estimate.eigenvalues[np.argmin(np.abs(ident.estimate.natural_frequencies_hz - FN_HZ))]
    lam = lam + est.added_decay_rate_1_s
    return abs(lam) / (2 * np.pi), -lam.real / abs(lam)


def test_hit_onsets_find_each_hit_not_its_bounce_and_nothing_in_a_random_force():
    rec = _record([0.2 + k + 0.03 * (k % 3) for k in range(8)], 8.0)
    onsets = hit_onsets(rec.signals[0])
    np.testing.assert_allclose(onsets / FS_HZ, [0.2 + k + 0.03 * (k % 3) for k in range(8)], atol=2 / FS_HZ)
    bounced = rec.signals[0].copy()
    bounced[int(3.5 * FS_HZ): int(3.5 * FS_HZ) + 4] += 40.0       # 0.3 s after the fourth hit
    assert hit_onsets(bounced).size == 8
    assert hit_onsets(rec.signals[0] - 30.0).size == 8              # an offset of the force: its median removed
    rng = np.random.default_rng(1)
    assert hit_onsets(rng.normal(size=8192)) is None
    assert hit_onsets(np.sin(2 * np.pi * 5 * np.arange(8192) / FS_HZ)) is None
    assert hit_onsets(np.zeros(8192)) is None


@pytest.mark.parametrize("times, length_s, n_blocks", [
    ([0.2 + k for k in range(8)], 8.0, 7),                           # a 0.2-s pre-trigger, hits 1 s apart
    (list(np.cumsum([0.3, 0.9, 1.4, 0.6, 1.2, 0.5, 1.1, 0.8])), 7.8, 8),   # irregular spacing, 0.5-1.4 s
])
def test_blocks_cut_at_each_hit_read_a_mode_that_outlasts_the_spacing(times, length_s, n_blocks):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")             # the first case's last hit: too close to the end for a block
        est = estimate_from_records(_record(times, length_s), excitation="impact")
    assert est.n_averages == n_blocks and "one per hit" in est.description
    f_hz, zeta = _mode(est)
    # 8 equal blocks of these records (each beginning with the previous hit's response, or holding two hits or
    # none) give LSCF no pole stable over enough model orders
    assert f_hz == pytest.approx(FN_HZ, abs=0.002) and zeta == pytest.approx(ZETA, rel=0.02)


def test_a_hit_too_close_to_the_records_end_is_left_out_and_said():
    rec = _record([0.1 + k for k in range(6)], 5.6)                  # the last hit 0.5 s before the end
    with pytest.warns(UserWarning, match="0 of 5 impact blocks left out .* 1 hit too close to the record's end"):
        est = estimate_from_records(rec, excitation="impact")
    assert est.n_averages == 5


def test_a_force_with_an_offset_is_an_impact_test_and_a_random_one_is_refused_as_hits():
    est = estimate_as_recorded(_record([0.2 + k for k in range(6)], 6.5, offset_n=-30.0))
    assert est.excitation == "impact" and est.n_averages == 6
    assert _mode(est)[0] == pytest.approx(FN_HZ, abs=0.01)
    rng = np.random.default_rng(2)
    shaker = TimeRecords(1 / FS_HZ, rng.normal(size=(2, 4096)), ("1:+Z", "2:+Z"), ("force", "displacement"),
                         {"source": "shaker.npz"})
    with pytest.raises(FileFormatError, match=r"shaker.npz: force channel 1:\+Z is no train of hits: \d+% of its"):
        estimate_from_records(shaker, excitation="impact")


def test_a_clipped_hit_is_left_out_and_said_when_every_other_block_holds_one_hit():
    rec = _record([0.2 + k for k in range(6)], 6.5)
    x = rec.signals.copy()
    seg = slice(int(2.18 * FS_HZ), int(3.18 * FS_HZ))         # the third hit's block, clipped at half its peak
    top = 0.5 * np.abs(x[1, seg]).max()
    x[1, seg] = np.clip(x[1, seg], -top, top)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est = estimate_from_records(TimeRecords(rec.time_step_s, x, rec.dofs, rec.quantities, rec.metadata),
                                    excitation="impact")
    said = [str(w.message) for w in caught]
    assert est.n_averages == 5 and any("1 of 6 impact blocks left out" in w and "2:+Z in block 2" in w for w in said)


@pytest.mark.parametrize("channel, bad", [(0, np.inf), (1, np.nan)])
def test_a_sample_not_finite_is_refused_naming_its_channel_and_sample(channel, bad):
    rec = _record([0.2, 1.2], 2.0)
    x = rec.signals.copy()
    x[channel, 300] = bad
    with pytest.raises(FileFormatError, match=rf"simulated hits: channel {channel + 1}:\+Z holds NaN or inf samples "
                                              r"\(sample 300\); expected finite values"):
        estimate_from_records(TimeRecords(rec.time_step_s, x, rec.dofs, rec.quantities, rec.metadata),
                              excitation="impact")
