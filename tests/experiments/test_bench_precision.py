"""``bench_precision``: its Cramér-Rao bounds against closed forms, its simulated records, and a ``--quick`` run."""

import numpy as np
import pytest

from experiments.benches import bench_precision as bp


def test_crb_of_one_undamped_sinusoid_is_the_classical_bound():
    # one mode, no damping, one channel: var(f) >= 12 / ((2 pi)^2 eta N (N^2 - 1) dt^2), eta = A^2 / (2 sigma^2)
    # (Kay, Fundamentals of Statistical Signal Processing I, eq. 3.41)
    case = bp.Case("decay", 1, 2.0, noise=1e-2)
    old = bp.DECAY_ZETA.copy(), bp.DECAY_AMP.copy()
    try:
        bp.DECAY_ZETA[:] = 1e-12
        bp.DECAY_AMP[:] = [1.0, 0.0, 0.0]
        bp.DECAY_AMP[1:] = 1e-9                               # other modes present but negligible
        crb = bp.crb_decay_hz(case)
    finally:
        bp.DECAY_ZETA[:], bp.DECAY_AMP[:] = old
    n, dt = 2000, 1 / bp.DECAY_FS_HZ
    eta = 1.0 / (2 * 1e-4)
    assert crb[0] == pytest.approx(np.sqrt(12 / ((2 * np.pi) ** 2 * eta * n * (n ** 2 - 1) * dt ** 2)), rel=0.01)


def test_crb_falls_with_channels_and_ambient_bound_with_length():
    one, four = bp.crb_decay_hz(bp.Case("decay", 1, 4.0)), bp.crb_decay_hz(bp.Case("decay", 4, 4.0))
    assert np.all(four < one)
    a1, a20 = bp.crb_ambient_hz(60.0), bp.crb_ambient_hz(1200.0)
    np.testing.assert_allclose(a1 / a20, np.sqrt(20.0))
    np.testing.assert_allclose(a1, np.sqrt(0.01 * bp.AMBIENT_FN_HZ / (2 * np.pi * 60.0)))


def test_simulated_records_hold_the_truth_frequencies():
    y = bp.decay_records(bp.Case("decay", 4, 4.0), 2, seed=1)
    assert y.shape == (2, 4, 4000)
    spec = np.abs(np.fft.rfft(y[0, 3], 64000))               # tip: mode 1 the strongest
    f = np.fft.rfftfreq(64000, 1 / bp.DECAY_FS_HZ)
    assert f[np.argmax(spec)] == pytest.approx(bp.DECAY_FN_HZ[0], abs=0.05)
    amb = bp.ambient_records(1, 60.0, 1, seed=2)
    assert amb.shape == (1, 1, 3840) and np.all(np.isfinite(amb))


def test_quick_run_prints_every_record_method_and_the_baseline(capsys):
    assert bp.main(["--quick", "--real", ""]) == 0
    out = capsys.readouterr().out
    rows = [r for r in out.splitlines() if r.startswith("| ") and not r.startswith(("| method", "| ---"))]
    methods = {r.split("|")[1].strip() for r in rows}
    assert methods == set(bp.record_methods()) and "fftpeak" in methods
    assert len(rows) == len(methods) * (3 + 2)                # decay: 3 modes, ambient: 2
    base = [r for r in rows if r.split("|")[1].strip() == "fftpeak"]
    assert all(r.split("|")[11].strip() in ("1", "-") for r in base)   # its own std ratio


def test_the_oversampled_capture_holds_noise_before_its_tap_and_its_bound_counts_the_samples_after():
    case = bp.DECAY[-1]
    assert case.label == "decay 1e-03, 8-bit, 10 kHz, tap at 0.4 s"
    y = bp.decay_records(case, 1, seed=3)[0, 0]
    tap = int(case.pre_s * case.fs_hz)
    step = np.diff(np.unique(y)).min()
    assert y.size == 40000 and np.all(np.abs(y[:tap]) <= step) and np.abs(y[tap:tap + 200]).max() > 50 * step
    after = bp.Case("decay", 1, case.duration_s - case.pre_s, case.noise, case.bits, case.fs_hz)
    np.testing.assert_allclose(bp.crb_decay_hz(case), bp.crb_decay_hz(after), rtol=1e-9)
