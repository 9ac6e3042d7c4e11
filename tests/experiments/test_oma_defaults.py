"""``beam-damage identify REC --json`` with the defaults on the independent simulator's ambient records: every mode
with a clear spectral peak, a warning naming a clear peak left without a mode, one EFDD peak per mode."""

import json
import re

import numpy as np
import pytest

from experiments.cli import main
from experiments.second_sim.ambient import ambient_record, write_npz
from experiments.second_sim.fem import Beam
from experiments.second_sim.pairs import EI_NM2, LENGTH_M, MASS_PER_LENGTH_KG_M
from physics.modal import mac

F1_HZ = 21.706                                   # mode 1 of the simulator's 16-element cantilever
DAMPING = (0.01, 0.008, 0.006, 0.005, 0.005)


def _identify(capsys, tmp_path, rec, *more):
    path = tmp_path / "rec.npz"
    write_npz(path, rec)
    code = main(["identify", str(path), "--json", *more])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    return json.loads(cap.out)


def _record(n_channels, fs_over_f1, seconds, seed, n_modes=4, **kw):
    beam = Beam(LENGTH_M, EI_NM2, MASS_PER_LENGTH_KG_M, n_elements=16)
    x = LENGTH_M * np.arange(1, n_channels + 1) / n_channels
    return ambient_record(beam, x, seconds, round(fs_over_f1 * F1_HZ), DAMPING, None, False, 0.02, n_modes,
                          seed=seed, **kw)


@pytest.mark.parametrize("n_channels, fs_over_f1, seconds, n_modes", [(4, 100, 120, 4), (8, 200, 60, 5)])
def test_the_lowest_mode_far_below_nyquist_is_found_with_the_defaults(capsys, tmp_path, n_channels, fs_over_f1,
                                                                     seconds, n_modes):
    """Mode 1 at 1/100 and 1/200 of the sampling rate: block rows sized to it, or a decimated sub-band pass."""
    rec = _record(n_channels, fs_over_f1, seconds, seed=3, n_modes=n_modes)
    res = _identify(capsys, tmp_path, rec)
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    zeta = np.array([m["damping_ratio"] for m in res["modes"]])
    shapes = np.array([[complex(z) for z in m["shape"]] for m in res["modes"]]).T
    assert f.size == n_modes, f
    np.testing.assert_allclose(f, rec.frequencies_hz, rtol=5e-3)          # mode 1 over 60 s: 1 sigma is 0.35 %
    np.testing.assert_allclose(zeta, rec.damping_ratios, rtol=0.4)
    assert np.all(np.diag(mac(rec.shapes, shapes)) > 0.99)
    assert not any("clear spectral peak" in w for w in res["warnings"]), res["warnings"]
    assert all(m["weakly_stable"] is False for m in res["modes"])


def test_a_clear_peak_without_a_mode_is_named_in_a_warning(capsys, tmp_path):
    """A harmonic in the forces (1.9 f1) makes a clear peak that no mode explains: the warning names it."""
    rec = _record(4, 100, 60, seed=4, harmonics=((1.9 * F1_HZ, 20.0),))
    res = _identify(capsys, tmp_path, rec)
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    np.testing.assert_allclose(f, rec.frequencies_hz, rtol=5e-3)
    warned = [w for w in res["warnings"] if "clear spectral peak" in w]
    assert len(warned) == 1, res["warnings"]
    named = [float(x) for x in re.findall(r"([0-9.]+) Hz \(", warned[0])]
    assert len(named) == 1 and named[0] == pytest.approx(1.9 * F1_HZ, rel=0.01), warned
    assert main(["identify", str(tmp_path / "rec.npz")]) == 0                  # the text output prints it too
    cap = capsys.readouterr()
    assert f"warning: {warned[0]}" in cap.err and "warning:" not in cap.out     # on stderr, one line each


def test_efdd_reports_one_peak_per_mode_on_one_channel(capsys, tmp_path):
    """On one channel every line's singular vector is the same: each bell ends at the valleys beside its peak."""
    rec = _record(1, 100, 120, seed=5)
    res = _identify(capsys, tmp_path, rec, "--method", "efdd")
    f = np.array([m["frequency_hz"] for m in res["modes"]])
    assert f.size == 4 and np.unique(np.round(f, 2)).size == 4, f
    np.testing.assert_allclose(f, rec.frequencies_hz, rtol=5e-3)
    assert all(m["weakly_stable"] is None for m in res["modes"])
