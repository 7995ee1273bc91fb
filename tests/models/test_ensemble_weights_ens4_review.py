"""Review tests (ens4) of the soft-voting ensemble's weights, weight grid and class columns."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin

from terrain.errors import ConfigError
from terrain.models.ensemble import (SoftVotingEnsemble, aligned_proba, normalised_weights,
                                     simplex_grid)


def test_fixed_weights_are_scaled_to_sum_one():
    np.testing.assert_allclose(normalised_weights([1, 3], 2), [0.25, 0.75])
    np.testing.assert_allclose(normalised_weights((0.0, 2.0, 2.0), 3), [0.0, 0.5, 0.5])


@pytest.mark.parametrize("weights, n", [([1.0], 2), ([1.0, 1.0, 1.0], 2), ([-0.5, 2.0], 2),
                                        ([0.0, 0.0], 2), ([np.nan, 1.0], 2),
                                        ([np.inf, 1.0], 2)])
def test_weights_that_would_drop_or_flip_a_member_are_refused(weights, n):
    # one weight too few was zipped away with its member; a negative weight subtracts a
    # member's probabilities
    with pytest.raises(ConfigError, match="weight"):
        normalised_weights(weights, n)


def test_the_grid_holds_every_point_of_the_simplex_at_the_step():
    np.testing.assert_array_equal(simplex_grid(2, 1.0), [[0.0, 1.0], [1.0, 0.0]])
    grid = simplex_grid(3, 0.5)
    assert len(grid) == 6                                   # C(2 + 3 - 1, 3 - 1)
    np.testing.assert_allclose(grid.sum(axis=1), 1.0)
    assert {tuple(r) for r in grid} >= {(0.5, 0.5, 0.0), (0.0, 0.0, 1.0)}
    assert len(simplex_grid(4, 0.25)) == 35                 # C(4 + 4 - 1, 4 - 1)


@pytest.mark.parametrize("step", [0.0, -0.5, 1.5, 0.3, np.nan, "0.5", None, True])
def test_a_step_the_grid_cannot_take_is_refused(step):
    # True passed as the number 1 (isinstance(True, Real)) and searched the vertices only
    with pytest.raises(ConfigError, match="weight_step"):
        simplex_grid(2, step)


class _Fixed(ClassifierMixin, BaseEstimator):
    """Gives the same probabilities to every window, over the classes it is given."""

    def __init__(self, classes=("A", "B"), proba=(0.5, 0.5)):
        self.classes = classes
        self.proba = proba

    def fit(self, X, y):
        self.classes_ = np.asarray(self.classes)
        return self

    def predict_proba(self, X):
        return np.tile(np.asarray(self.proba, dtype=float), (len(X), 1))


def test_a_member_that_saw_fewer_classes_gets_its_own_columns():
    member = _Fixed(classes=("B", "C"), proba=(0.2, 0.8)).fit(None, None)
    out = aligned_proba(member, np.zeros((2, 1)), np.array(["A", "B", "C"]))
    np.testing.assert_allclose(out, [[0.0, 0.2, 0.8]] * 2)
    ens = SoftVotingEnsemble([("abc", _Fixed(("A", "B", "C"), (0.6, 0.3, 0.1))),
                              ("bc", _Fixed(("B", "C"), (0.2, 0.8)))], weights=(1, 1))
    ens.fit(np.zeros((3, 1)), np.array(["A", "B", "C"]))
    np.testing.assert_allclose(ens.predict_proba(np.zeros((1, 1))), [[0.3, 0.25, 0.45]])


@pytest.mark.parametrize("fit_kw", [{}, {"groups": np.arange(12) % 4}])
@pytest.mark.parametrize("weights", [None, ()])
def test_an_ensemble_without_members_is_refused_at_fit(fit_kw, weights):
    # no members was float division by zero (equal weights), or with runs a "fitted"
    # ensemble whose weights_ were None and whose predict_proba was a bare TypeError
    X, y = np.zeros((12, 2)), np.repeat(["A", "B"], 6)
    with pytest.raises(ConfigError, match="at least one member"):
        SoftVotingEnsemble([], weights=weights).fit(X, y, **fit_kw)


def test_fixed_or_equal_weights_hold_no_run_out():
    # validation_groups_ is documented empty when the weights are not chosen: fixed weights
    # with runs given, or no runs (equal weights)
    X, y = np.zeros((8, 1)), np.array(["A", "B"] * 4)
    groups = np.array(["r0", "r1", "r2", "r3"] * 2)
    members = [("a", _Fixed()), ("b", _Fixed())]
    fixed = SoftVotingEnsemble(members, weights=(1, 3)).fit(X, y, groups=groups)
    assert fixed.validation_groups_.size == 0 and fixed.weight_scores_ == {}
    np.testing.assert_allclose(fixed.weights_, [0.25, 0.75])
    equal = SoftVotingEnsemble(members).fit(X, y)
    assert equal.validation_groups_.size == 0 and equal.weight_scores_ == {}
    np.testing.assert_allclose(equal.weights_, [0.5, 0.5])
