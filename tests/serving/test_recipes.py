"""Streaming model recipes: the wheel-only model's compiled forest path, the ensemble
recipe's checks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from features.windows import WindowConfig, make_windows
from terrain.errors import ConfigError
from terrain.models.forest import ForestPipeline
from terrain.serving.evaluation import (RECIPES, ModelRecipe, fit_stream_model,
                                        recipe_classifier)


def test_wheel_recipe_serves_the_compiled_forest_with_sklearn_probabilities(train_runs,
                                                                           borealtc_runs):
    recipe = replace(RECIPES["wheels"], n_trees=40)
    model = fit_stream_model(recipe, train_runs, seed=0)
    assert isinstance(model.pipeline, ForestPipeline) and model.pipeline._compiled() is not None
    unseen = [r for r in borealtc_runs if r not in train_runs and "wheels" in r.streams][:3]
    X = make_windows(unseen, model.channels, WindowConfig(window_s=recipe.window_s, hop_s=1.0,
                                                          rate_hz=recipe.rate_hz)).X
    ref = super(ForestPipeline, model.pipeline).predict_proba(X)    # scikit-learn's path
    out = model.pipeline.predict_proba(X)
    assert np.allclose(out, ref, rtol=0, atol=1e-12)
    for i in (0, len(X) // 2, len(X) - 1):                            # single windows
        assert np.array_equal(model.pipeline.predict_proba(X[i:i + 1]), ref[i:i + 1])
    assert tuple(model.pipeline.classes_) == model.classes


def test_ensemble_recipe_takes_raw_windows_only():
    assert RECIPES["all-ensemble"].classifier == "ensemble"
    assert RECIPES["all-ensemble"].window_s == RECIPES["all"].window_s
    with pytest.raises(ConfigError):
        ModelRecipe("all", 2.0, 100.0, 2.0, "physics", "ensemble")
    with pytest.raises(ConfigError):
        recipe_classifier(RECIPES["all-ensemble"])
    with pytest.raises(ConfigError):
        ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "boosting")
