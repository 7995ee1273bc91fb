"""Review of :class:`terrain.serving.recipes.ModelRecipe`: a setting the recipe's classifier
does not use is refused, never ignored without a word."""

from __future__ import annotations

from dataclasses import replace

import pytest

from terrain.errors import ConfigError
from terrain.serving.recipes import RECIPES, ModelRecipe


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
