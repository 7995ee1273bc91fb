"""Review of :class:`terrain.serving.recipes.ModelRecipe`: a setting the recipe's classifier
does not use is refused, never ignored without a word."""

from __future__ import annotations

from dataclasses import replace

import pytest

from terrain.errors import ConfigError
from terrain.serving.recipes import DEFAULT_RECIPES, RECIPES, ModelRecipe, extra_trees


@pytest.mark.parametrize("name", ["all", "all-dense", "all-ensemble-dense"])
def test_n_trees_of_a_recipe_without_trees_is_refused(name):
    # before: the SVM or ensemble recipe was fitted as if n_trees had not been given
    with pytest.raises(ConfigError, match="n_trees"):
        replace(RECIPES[name], n_trees=50)


@pytest.mark.parametrize("n_trees", [0, -3, True, 2.5, "300"])
def test_n_trees_must_be_a_positive_integer(n_trees):
    # before: 0 or -3 failed inside scikit-learn at fit time, 2.5 and True were taken
    with pytest.raises(ConfigError, match="n_trees"):
        replace(RECIPES["wheels"], n_trees=n_trees)


def test_the_shipped_recipes_and_an_explicit_default_stay_valid():
    assert replace(RECIPES["wheels"], n_trees=20).n_trees == 20
    assert ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "svm", n_trees=300).n_trees == 300


@pytest.mark.parametrize("setting", [dict(cnn_seeds=3), dict(spectrogram_noise_std=0.3)])
def test_an_ensemble_setting_on_a_recipe_without_cnn_is_refused(setting):
    with pytest.raises(ConfigError, match=next(iter(setting))):
        replace(RECIPES["all-dense"], **setting)


def test_the_extra_trees_are_the_documented_ones():
    # docstring of extra_trees: min_samples_leaf=3, max_features=0.3, one process
    params = extra_trees(50, 7).get_params()
    assert (params["n_estimators"], params["min_samples_leaf"], params["max_features"],
            params["n_jobs"], params["random_state"], params["class_weight"]) == \
        (50, 3, 0.3, 1, 7, "balanced")
    assert extra_trees(class_weight=None).get_params()["class_weight"] is None


def test_the_default_recipes_are_the_documented_ones():
    # docs/streaming.md and the DEFAULT_RECIPES comment: all signals all-dense (the SVM on
    # windows cut every 0.5 s), wheel-only wheels
    assert dict(DEFAULT_RECIPES) == {"all": "all-dense", "wheels": "wheels"}
    dense = RECIPES["all-dense"]
    assert (dense.signals, dense.window_s, dense.rate_hz, dense.train_hop_s,
            dense.classifier) == ("all", 2.0, 100.0, 0.5, "svm")
