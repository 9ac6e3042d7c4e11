"""No silently wrong sample: the status column, its counts, and configs whose every sample would be degenerate."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from datagen.config import MIN_ROOT_SPRING_RELATIVE, merge, validate
from datagen.generation import generate
from datagen.pipeline import simulate_shard
from datagen.setup import build_setup
from datagen.store import STATUS, sample_status
from physics.errors import ConfigError


def _case(k_eigs=(1.0, 2.0, 3.0, 4.0), poles_finite=True, n_slits=1, drop=1e-3, converged=True):
    """One sample's labels and outputs with an updated K of the given eigenvalues (both states)."""
    q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((4, 4)))
    K = q @ np.diag(k_eigs) @ q.T
    poles = np.full((1, 2, 4), -1 + 10j)
    if not poles_finite:
        poles[0, 1, 2] = np.nan
    out = {"K_updated": np.broadcast_to(K, (1, 2, 4, 4)), "updated_poles": poles,
           "damage_frequency_drop": np.array([drop]), "converged": np.array([[True, converged]])}
    return {"n_damages": np.array([n_slits])}, out


@pytest.mark.parametrize(("kwargs", "want"), [
    ({}, "ok"),
    ({"k_eigs": (-1e-3, 2.0, 3.0, 4.0)}, "not_positive_definite"),
    ({"k_eigs": (0.0, 2.0, 3.0, 4.0)}, "not_positive_definite"),
    ({"poles_finite": False}, "nan_poles"),
    ({"drop": 0.0}, "no_damage_effect"),
    ({"drop": 0.0, "n_slits": 0}, "ok"),
    ({"converged": False, "k_eigs": (-1.0, 2.0, 3.0, 4.0)}, "not_converged"),
])
def test_sample_status_names_the_first_failure(kwargs, want):
    assert list(sample_status(*_case(**kwargs))) == [want]


def test_soft_root_springs_are_flagged_and_counted(tmp_path):
    cfg = merge({"output": {"shard_size": 6}, "measurement": {"lines": 32},
                 "specimen": {"root_spring_relative": [0.001, 0.01]}})
    m = generate(tmp_path / "ds", cfg, n=12, seed=1, progress=False)
    t = pd.read_parquet(tmp_path / "ds" / "samples.parquet")
    K = np.concatenate([np.load(tmp_path / "ds" / "shards" / e["name"] / "K_updated.npy") for e in m["shards"]])
    not_pd = np.any(np.linalg.eigvalsh(0.5 * (K + np.swapaxes(K, -1, -2)))[..., 0] <= 0, axis=1)
    assert 0 < not_pd.sum() < 12  # an independent check of the flag on the stored matrices
    np.testing.assert_array_equal(t["status"] == "not_positive_definite", not_pd & t["converged_base"]
                                  & t["converged_cur"])
    assert not t.loc[not_pd, "converged"].any()
    counts = m["counts"]["status"]
    assert set(counts) == set(STATUS) and sum(counts.values()) == 12
    assert counts["not_positive_definite"] == int((t["status"] == "not_positive_definite").sum())
    assert m["counts"]["converged"] == int(t["converged"].sum())


def test_below_the_refused_root_spring_most_updated_models_are_not_positive_definite():
    """The bound MIN_ROOT_SPRING_RELATIVE (docs/datasets.md, "Status of each sample"): of 20 samples of the default
    config (seed 0) with the root spring ``k_r L / EI`` set to each value, the updated stiffness is not positive
    definite in 20 at 0.001, 11 at 0.003, 4 at 0.01, none at 0.03 (their smallest eigenvalues lie 5e-8 or more of
    the largest away from 0: no rounding flips a count)."""
    base = build_setup(merge({"measurement": {"lines": 32}}))
    counts = []
    for k in (0.001, 0.003, MIN_ROOT_SPRING_RELATIVE, 0.03):
        labels, out = simulate_shard(replace(base, root_spring_relative=(k, k)), np.random.SeedSequence(0), 20)
        counts.append(int(np.sum(sample_status(labels, out) == "not_positive_definite")))
    assert counts == [20, 11, 4, 0]


@pytest.mark.parametrize(("override", "key"), [
    ({"damage": {"depth_m": [0.0, 0.0]}}, "damage.depth_m"),
    ({"damage": {"ei_loss": [0.0, 0.0]}}, "damage.ei_loss"),
    ({"specimen": {"root_spring_relative": [0.001, 0.001]}}, "specimen.root_spring_relative"),
    ({"specimen": {"root_spring_relative": [0.001, 0.005]}}, "specimen.root_spring_relative"),
])
def test_configs_whose_every_sample_is_degenerate_are_refused(override, key):
    with pytest.raises(ConfigError, match=rf"'{key}' = \[.*\]: "):
        validate(merge(override))


@pytest.mark.parametrize("override", [
    {"damage": {"depth_m": [0.0, 0.0], "n_slits": [0, 0]}},
    {"damage": {"depth_m": [0.0, 0.0], "intact_fraction": 1.0}},
    {"damage": {"depth_m": [0.0, 0.0003]}},
    {"specimen": {"root_spring_relative": [0.001, 0.01]}},
    {"specimen": {"root_spring_relative": []}},
])
def test_configs_with_some_meaningful_samples_stay_accepted(override):
    validate(merge(override))
