"""Run-balanced training weights of the wheel-only streaming recipe: every class weighs the
same, every run inside a class the same, and the fitted forest really uses them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import ConfigError, ShapeError
from terrain.serving.evaluation import grouped_oof_proba
from terrain.serving.recipes import (RECIPES, ModelRecipe, fit_stream_model, recipe_classifier,
                                     run_balanced_weights)


def test_every_class_and_every_run_inside_it_weighs_the_same():
    labels = np.array(["ICE"] * 70 + ["ICE"] * 10 + ["SNOW"] * 5 + ["SNOW"] * 15)
    groups = np.array(["ice/1"] * 70 + ["ice/2"] * 10 + ["snow/1"] * 5 + ["snow/2"] * 15)
    w = run_balanced_weights(labels, groups)
    assert np.all(w > 0) and np.isclose(w.mean(), 1.0)
    per_run = {g: w[groups == g].sum() for g in np.unique(groups)}
    assert np.allclose(list(per_run.values()), per_run["ice/1"])      # 4 runs, equal shares
    assert np.isclose(w[labels == "ICE"].sum(), w[labels == "SNOW"].sum())
    # inside a run every window weighs the same: the long run's windows weigh less
    assert w[0] < w[75] and np.ptp(w[:70]) == 0
    with pytest.raises(ShapeError):
        run_balanced_weights(labels, groups[:-1])


def test_the_wheel_recipe_fits_with_run_balanced_weights(train_runs):
    assert RECIPES["wheels"].run_balanced
    assert recipe_classifier(RECIPES["wheels"]).class_weight is None   # weights replace it
    with pytest.raises(ConfigError):
        ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "svm", run_balanced=True)
    recipe = replace(RECIPES["wheels"], n_trees=20)
    balanced = fit_stream_model(recipe, train_runs, seed=0).pipeline
    plain = fit_stream_model(replace(recipe, run_balanced=False), train_runs, seed=0).pipeline
    forest_b, forest_p = balanced.steps[-1][1], plain.steps[-1][1]
    assert forest_p.class_weight == "balanced" and forest_b.class_weight is None
    # the weights change the fitted trees (same seed, same windows)
    assert any(a.tree_.node_count != b.tree_.node_count or
               not np.array_equal(a.tree_.threshold, b.tree_.threshold)
               for a, b in zip(forest_b.estimators_, forest_p.estimators_))


def test_grouped_out_of_fold_fit_passes_the_weights():
    seen = []

    class Spy:
        classes_ = np.array(["A", "B"])

        def fit(self, X, y, sample_weight=None):
            seen.append(sample_weight)
            return self

        def predict_proba(self, X):
            return np.full((len(X), 2), 0.5)

    rng = np.random.default_rng(0)
    labels = np.repeat(["A", "B"], 50)
    groups = np.repeat([f"r{i}" for i in range(10)], 10)
    F = rng.standard_normal((100, 3))
    grouped_oof_proba(lambda s: Spy(), F, labels, groups, 0, 5, run_balanced=True)
    assert len(seen) == 5 and all(w is not None and np.isclose(w.mean(), 1.0) for w in seen)
    seen.clear()
    grouped_oof_proba(lambda s: Spy(), F, labels, groups, 0, 5)
    assert seen == [None] * 5
