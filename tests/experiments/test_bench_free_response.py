"""free_response's verdict on the hammer-test family of :mod:`experiments.benches.bench_free_response` (pre-trigger,
several hits, short and long records, light and heavy damping, noise, quantisation, offset and drift, clipping, a
weak first mode, one and four channels) and on its stationary controls: three seeds of each case."""

import numpy as np
import pytest

from experiments.benches.bench_free_response import CASES, record, verdict

#: Cases whose verdict is not the truth, and why.
KNOWN = {
    # no pre-trigger and 2 dB of fall over the record: within the record, a stationary response of lightly damped
    # modes; era finds no decay in it either (SSI-cov identifies it)
    "light damping 0.05 %, hit at 0": False,
}
#: Cases left unpinned: the decay leads its pre-trigger by 11-12 dB, at FREE_LEAD_DB (free in 15 of 20 seeds).
UNPINNED = {"noise 1e-1, light damping"}


@pytest.mark.parametrize("fam", [c for c in CASES if c.name not in UNPINNED], ids=lambda c: c.name)
def test_the_family_is_judged_free_or_stationary_as_it_was_made(fam):
    expected = KNOWN.get(fam.name, fam.truth == "free")
    got = [verdict(record(fam, seed), fam.fs_hz) for seed in range(3)]
    assert got == [expected] * 3


def test_the_family_records_have_the_levels_they_are_made_with():
    """The record's make-up: white noise of the ringing's peak (the record's peak but the pulse's samples), alone
    before the hit."""
    fam = next(c for c in CASES if c.name == "pre-trigger 25 %")
    y = record(fam, 0)[0]
    k = int(0.25 * fam.n)
    clean = record(type(fam)(**{**fam.__dict__, "noise": 0.0}), 0)[0]
    np.testing.assert_allclose(y[:k].std(), fam.noise * np.abs(np.delete(clean, np.s_[k:k + 5])).max(), rtol=0.1)
    assert np.abs(clean[:k + 1]).max() == 0.0 and np.abs(clean[k + 1:k + 5]).max() == np.abs(clean).max()
