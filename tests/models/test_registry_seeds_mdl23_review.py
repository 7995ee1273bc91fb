"""Seeds of a bag of networks at the top of NumPy's seed range (review mdl23)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.models.registry import ModelConfig, make_model

TOP = 2 ** 32 - 1


def _bag(kind: str, seed: int, n: int = 3):
    return make_model(ModelConfig(kind=kind, cnn_seeds=n, max_epochs=1), ("ax", "ay"), 50.0,
                      "borealtc", seed)


@pytest.mark.parametrize("seed, seeds", [(0, [0, 1, 2]), (TOP - 2, [TOP - 2, TOP - 1, TOP]),
                                         (TOP - 1, [TOP - 1, TOP, 0]), (TOP, [TOP, 0, 1])])
def test_the_networks_of_a_bag_are_seeded_in_numpys_range(seed, seeds):
    # a valid seed near 2**32 - 1 seeded the last networks 2**32 and more, which their fit
    # refused (ConfigError "random_state must be an integer in [0, 4294967295]") in the
    # middle of a cross-validation whose seeds were all valid
    bag = _bag("cnn", seed)
    assert [est.random_state for _, est in bag.estimators] == seeds
    assert [name for name, _ in bag.estimators] == [f"cnn-seed{s}" for s in seeds]


def test_a_bag_seeded_at_the_top_of_the_range_fits():
    bag = _bag("cnn", TOP, n=2)
    for _, network in bag.estimators:
        network.set_params(width=2, device="cpu", n_threads=1)
    X = np.random.default_rng(0).normal(size=(8, 2, 20)).astype(np.float32)
    y = np.array(["a", "b"] * 4)
    assert bag.fit(X, y).predict_proba(X[:1]).shape == (1, 2)


def test_the_bags_inside_an_ensemble_are_seeded_in_range_too():
    model = _bag("ensemble3", TOP, n=2)
    for name, member in model.estimators:
        if hasattr(member, "estimators"):
            assert [est.random_state for _, est in member.estimators] == [TOP, 0], name
