"""The soft-voting ensemble at its boundaries: one or two classes, one member, the simplex
grid's end points (review mdl23)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.dummy import DummyClassifier
from sklearn.linear_model import LogisticRegression

from terrain.models.ensemble import SoftVotingEnsemble, simplex_grid


def _data(labels):
    rng = np.random.default_rng(0)
    y = np.array(labels * 24)[:24]
    X = rng.normal(size=(24, 3)) + (y == y[0])[:, None]
    groups = np.repeat(np.arange(8), 3)
    return X, y, groups


def _members():
    return [("prior", DummyClassifier(strategy="prior")),
            ("uniform", DummyClassifier(strategy="uniform"))]


def test_weights_to_choose_with_one_class_are_equal():
    # every weight vector gives the one class probability 1: nothing to choose (log_loss
    # refused it with a bare "labels array needs to contain at least two labels")
    X, y, groups = _data(["a"])
    ens = SoftVotingEnsemble(_members(), inner_splits=2).fit(X, y, groups=groups)
    assert ens.weights_.tolist() == [0.5, 0.5]
    assert ens.weight_scores_ == {} and ens.validation_groups_.size == 0
    assert ens.predict(X).tolist() == ["a"] * 24
    np.testing.assert_allclose(ens.predict_proba(X), 1.0)


def test_one_class_with_or_without_groups_fits_alike():
    X, y, groups = _data(["a"])
    with_groups = SoftVotingEnsemble(_members(), inner_splits=2).fit(X, y, groups=groups)
    without = SoftVotingEnsemble(_members(), inner_splits=2).fit(X, y)
    assert with_groups.weights_.tolist() == without.weights_.tolist()


def test_weights_are_chosen_with_two_classes():
    X, y, groups = _data(["a", "b"])
    ens = SoftVotingEnsemble([("logreg", LogisticRegression()),
                              ("uniform", DummyClassifier(strategy="uniform"))],
                             weight_step=0.5, inner_splits=2).fit(X, y, groups=groups)
    assert list(ens.weight_scores_) == [(0.0, 1.0), (0.5, 0.5), (1.0, 0.0)]
    best = min(ens.weight_scores_, key=ens.weight_scores_.get)
    assert tuple(ens.weights_.tolist()) == best


@pytest.mark.parametrize("n_members", [1, 2, 3, 4])
@pytest.mark.parametrize("step", [1.0, 0.5, 0.25, 0.2, 0.1])
def test_simplex_grid_holds_every_vertex_and_the_centre_where_it_is_on_the_grid(
        n_members, step):
    grid = simplex_grid(n_members, step)
    n = round(1 / step)
    # every composition of n into n_members parts: C(n + m - 1, m - 1)
    from math import comb
    assert len(grid) == comb(n + n_members - 1, n_members - 1)
    assert len({tuple(r) for r in grid.tolist()}) == len(grid)
    for vertex in np.eye(n_members):
        assert any(np.array_equal(row, vertex) for row in grid)
    np.testing.assert_allclose(grid.sum(axis=1), 1.0)
    assert (grid >= 0).all() and (grid <= 1).all()
    if n % n_members == 0:
        assert any(np.allclose(row, 1 / n_members) for row in grid)


@pytest.mark.parametrize("step", [1.0, np.nextafter(1.0, 0.0)])
def test_a_step_of_one_gives_the_vertices_only(step):
    assert simplex_grid(3, step).tolist() == np.eye(3)[::-1].tolist()


def test_one_member_with_groups_gets_all_the_weight():
    X, y, groups = _data(["a", "b"])
    ens = SoftVotingEnsemble([("logreg", LogisticRegression())], inner_splits=2)
    assert ens.fit(X, y, groups=groups).weights_.tolist() == [1.0]
