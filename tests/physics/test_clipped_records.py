"""Records clipped at an impact: identified from the samples after the clipped runs when they lie in the record's
leading part (every method, the FFT peak too), refused naming the run when they do not."""

import json
import warnings

import numpy as np
import pytest
from impact_records import crb_frequency_std_hz, impact_record, poles

from physics.errors import ShapeError
from physics.identification import identify_records
from physics.identification.fft_peak import fft_peaks, identify_fft_peaks
from physics.identification.record_checks import check_records
from physics.io.timedata import TimeRecords

#: An 8-bit scope capture of a tap: 4 s at 1250 Hz, one 25-Hz mode (1 % damped), the range -128..127 levels, the
#: decay's first peak at 250 levels (clipped over its first 0.45 s), 0.4 level of noise.
FS, N, FN, ZETA, NOISE, PEAK = 1250.0, 5000, 25.0, 0.01, 0.4, 250.0


def _capture(hits_s=(0.4,), gains=None, seed=0):
    """Integer levels in -128..127: the tap's decay (first peak ``PEAK`` levels for gain 1), noise, clipping."""
    y, clean, _ = impact_record(FS, N, [FN], [ZETA], [[1.0]], list(hits_s), 0.0, seed, hit_gains=gains)
    scale = PEAK / np.abs(clean[0, :int(FS * (hits_s[0] + 0.1))]).max()
    noisy = scale * y[0] + NOISE * np.random.default_rng(seed).standard_normal(N)
    return np.clip(np.round(noisy), -128, 127), scale


def _records(y):
    return TimeRecords(1 / FS, y[None], ("1:+Y",), ("acceleration",), {"source": "scope.csv"})


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_decay_clipped_at_its_hit_is_identified_after_the_clipping_within_its_bound(seed):
    """The clipped runs lie after the hit; the crop starts after the last sample at the range's limits and a guard
    as long as the longest run; ``era`` on the samples after it reads 25 Hz within 4 Cramer-Rao bounds of the
    cropped decay (noise: 0.4 level drawn and the rounding's 1/12 level^2)."""
    y, scale = _capture(seed=seed)
    hit = int(np.ceil(0.4 * FS))
    at_limit = np.flatnonzero((y == 127) | (y == -128))
    assert at_limit.size > 3 and hit <= at_limit[0] and at_limit[-1] < hit + 0.5 * FS   # the decay's first 0.5 s
    checked = check_records(y[None], FS)
    crop = checked.crop
    assert crop is not None and crop.n_samples == N and crop.last_at_limit == at_limit[-1]
    longest = max(b - a + 1 for _, a, b in crop.runs)
    assert longest > 5 * 2 and all(k == 0 and hit <= a <= b <= at_limit[-1] for k, a, b in crop.runs)
    assert crop.first_sample == at_limit[-1] + 1 + longest
    assert checked.signals.shape == (1, N - crop.first_sample)
    assert check_records(y[None], FS, chunk_values=777).crop == crop       # read in chunks: the same crop
    np.testing.assert_array_equal(checked.signals, y[None, crop.first_sample:])
    assert checked.mean[0] == pytest.approx(y[crop.first_sample:].mean(), abs=1e-12)
    assert crop.text.startswith("channel 0 clipped at samples ") and \
        f"; identified from sample {crop.first_sample} on" in crop.text

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify_records(_records(y))
    assert [str(w.message) for w in caught if "clipped" in str(w.message)] == [f"scope.csv: {crop.text}"]
    assert res.crop == crop and res.estimate.method == "era"
    lam = poles([FN], [ZETA])
    t0 = crop.first_sample / FS - hit / FS
    amp = scale / (1j * lam.imag) * np.exp(lam * t0)               # the decay at the crop's first sample
    crb = crb_frequency_std_hz(FS, N - crop.first_sample, [FN], [ZETA], amp, np.sqrt(NOISE ** 2 + 1 / 12))[0]
    f = res.estimate.natural_frequencies_hz
    assert np.min(np.abs(f - FN)) < 4 * crb, (f, crb)


def test_the_fft_peak_reads_the_same_crop():
    """The plain estimator's record is the identification's: the zero-padded FFT peak of the clipped capture is
    that of the samples after its clipping (to the bit), its clear peaks too."""
    y, _ = _capture()
    first = check_records(y[None], FS).crop.first_sample
    whole, cut = fft_peaks(y[None], FS, [FN], 2.0), fft_peaks(y[None, first:], FS, [FN], 2.0)
    assert whole.frequency_hz[0] == cut.frequency_hz[0] and abs(whole.frequency_hz[0] - FN) < 0.05
    est, _ = identify_fft_peaks(y[None], FS, (10.0, 100.0))
    np.testing.assert_array_equal(est.natural_frequencies_hz,
                                  identify_fft_peaks(y[None, first:], FS, (10.0, 100.0))[0].natural_frequencies_hz)


@pytest.mark.parametrize("hits, gains, band, why", [
    ((0.4, 2.6), [0.5, 1.0], None, "a record needs at least half of its 5000 samples there"),
    ((1.2,), None, (3.5, 100.0), "shorter than ten periods of the band's lower limit (3.5 Hz): that needs 2.86 s"),
])
def test_a_record_clipped_late_or_leaving_too_little_is_refused_naming_the_run(hits, gains, band, why):
    """A second, harder hit clipped at 2.6 s of 4; a hit at 1.2 s clipped for 0.45 s, leaving 2.3 s, fewer than
    ten periods of the band's 3.5 Hz: refused in one line naming the longest clipped run and what the record would
    need."""
    y, _ = _capture(hits, gains)
    top = np.flatnonzero((y == 127) | (y == -128))
    runs = np.split(top, np.flatnonzero(np.diff(top) > 1) + 1)
    longest = max((r for r in runs if r.size >= 3), key=len)
    with pytest.raises(ShapeError, match=rf"record: channel 0 is clipped: samples {longest[0]}-{longest[-1]} "
                                         rf"\({longest.size} in a row\) are held at its (highest|lowest) value") as e:
        check_records(y[None], FS, band)
    assert why in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ShapeError, match="is clipped"):
        identify_records(_records(y), band_hz=band)


def test_identify_names_the_crop_in_its_result_and_modal_json(capsys, tmp_path):
    from experiments.cli import main

    y, _ = _capture()
    path = tmp_path / "scope.npz"
    np.savez(path, signals=y[None] / 128, sampling_frequency_hz=np.array(FS), quantity=np.array("acceleration"))
    crop = check_records(y[None], FS).crop
    assert main(["identify", str(path), "--band", "10", "100", "--out", str(tmp_path / "id"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    saved = json.loads((tmp_path / "id" / "modal.json").read_text())
    expected = {"first_sample": crop.first_sample, "clipped_runs": [list(r) for r in crop.runs],
                "last_at_limit": crop.last_at_limit, "n_samples": N, "text": crop.text}
    assert out["record_crop"] == expected and saved["record_crop"] == expected
    assert any(crop.text in w for w in out["warnings"])


def test_monitor_identifies_a_test_clipped_at_its_hit_and_names_the_crop(tmp_path):
    """``monitor``'s identification of one test: the crop's text in its modes (kept through the cache's JSON), no
    record problem; a test clipped late is a record problem naming the run."""
    from learn.monitor.identification import IdentifiedModes, identification_settings, identify_test, record_problem

    early, late = tmp_path / "early.npz", tmp_path / "late.npz"
    y, _ = _capture()
    np.savez(early, signals=y[None] / 128, sampling_frequency_hz=np.array(FS))
    np.savez(late, signals=_capture((0.4, 2.6), [0.5, 1.0])[0][None] / 128, sampling_frequency_hz=np.array(FS))
    modes = identify_test(early, identification_settings((10.0, 100.0)))
    assert modes.record_crop == check_records(y[None], FS).crop.text
    assert np.min(np.abs(modes.frequencies_hz - FN)) < 0.01
    assert modes.line_hz == pytest.approx(FS / (N - check_records(y[None], FS).crop.first_sample))
    assert IdentifiedModes.from_dict(json.loads(json.dumps(modes.to_dict()))).record_crop == modes.record_crop
    assert record_problem(early) is None
    assert "channel 0 is clipped: samples" in record_problem(late) and str(late) in record_problem(late)


def _kept_reference(y, first, step):
    """Each channel's mean over ``y[:, first:]`` (summed in chunks of ``step`` samples, as the check sums a record),
    or the one-line refusal of that part: constant, or clipped by the rule read plainly (the runs of each whole
    channel at its own extremes against the longest run at any other level within 10 % of its range of them)."""
    rest = np.asarray(y[:, first:], float)
    lo, hi = rest.min(axis=1), rest.max(axis=1)
    if np.any(hi <= lo):
        return (f"record (from sample {first} on, after its clipped runs): channel {int(np.argmax(hi <= lo))} is "
                "constant; nothing to identify from it")
    for k, v in enumerate(rest):
        starts = np.r_[0, np.flatnonzero(np.diff(v)) + 1]
        lengths, values = np.diff(np.r_[starts, v.size]), v[starts]
        extreme = (values == lo[k]) | (values == hi[k])
        margin = 0.1 * (hi[k] - lo[k])
        near = lengths[~extreme & ((values <= lo[k] + margin) | (values >= hi[k] - margin))].max(initial=1)
        clipped = np.flatnonzero(extreme & (lengths >= 3) & (lengths > 5 * near))
        if clipped.size:
            i = clipped[0]
            return (f"record: channel {k} is clipped before sample {first} and after it, at samples "
                    f"{first + starts[i]}-{first + starts[i] + lengths[i] - 1} (held at {values[i]:.6g}); identify "
                    "from unclipped records")
    total = np.zeros(rest.shape[0])
    for a in range(0, rest.shape[1], step):
        total += rest[:, a:a + step].sum(axis=1)
    return total / rest.shape[1]


def _held_at_start(seed, n=3000, hold=(400, 20)):
    """Two channels of integer noise (3 levels rms); channel 0 held at 50 over ``hold`` (first sample, length), far
    above the noise: the crop starts a guard of that length after the run."""
    rng = np.random.default_rng(seed)
    y = np.round(3 * rng.standard_normal((2, n)))
    a, r = hold
    y[0, a:a + r] = 50.0
    return y, a + 2 * r


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("case, outcome", [
    ("noise", "kept"), ("held later", "clipped"), ("six held later", "clipped"), ("five held later", "kept"),
    ("dead after", "constant"), ("coarse after", "clipped"), ("slow after", "kept")])
@pytest.mark.parametrize("chunk_values", [2**22, 777])
def test_the_kept_part_of_a_record_clipped_at_its_start_gives_the_plain_reading(seed, case, outcome, chunk_values):
    """The samples after the crop: their mean to the bit, or the refusal word for word, as the plain reading of
    the rule on that part (:func:`_kept_reference`): noise kept; a run held at 30 levels later (the kept part's
    highest, below the record's 50) clipped, one of 6 samples too (longer than 5 runs of 1), one of 5 not; channel 1
    dead after the crop constant; channel 1 clipped at 2 levels clipped; a slow sine quantised to 8 levels (its top
    level held 136 samples, 2.7 times a run at the level below) kept. Levels of 0.01: the sums are rounded, and
    their order shows in the mean."""
    y, first = _held_at_start(seed)
    n = y.shape[1]
    if case.endswith("held later"):
        y[0, 2000:2000 + {"held later": 15, "six held later": 6, "five held later": 5}[case]] = 30.0
    elif case == "dead after":
        y[1, 300:] = 0.0
    elif case == "coarse after":
        y[1, first:] = np.clip(y[1, first:], -2, 2)
    elif case == "slow after":
        y[1, first:] = np.round(8 * np.sin(2 * np.pi * np.arange(n - first) / 1200))
    y = 0.01 * y
    expected = _kept_reference(y, first, max(1, chunk_values // 2))
    if outcome == "kept":
        checked = check_records(y, FS, chunk_values=chunk_values)
        assert checked.crop.first_sample == first and checked.crop.runs == ((0, 400, 419),)
        np.testing.assert_array_equal(checked.signals, y[:, first:])
        assert checked.mean.tobytes() == expected.tobytes()
    else:
        assert isinstance(expected, str) and (("constant" in expected) == (outcome == "constant"))
        with pytest.raises(ShapeError) as e:
            check_records(y, FS, chunk_values=chunk_values)
        assert str(e.value) == expected
