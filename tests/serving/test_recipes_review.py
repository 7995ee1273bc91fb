"""Review tests of the recipes: the documented wheel-only recipe (docs/streaming.md,
"wheel-only") and the feature transformer each feature set names."""

from __future__ import annotations

from features.transformers import SerialFeatureUnion, WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from terrain.run import WHEEL_CHANNELS
from terrain.serving.recipes import RECIPES, ModelRecipe, recipe_features


def test_the_wheel_recipe_is_the_documented_one():
    # docs/streaming.md: 4 s windows every 2 s at 10 Hz, physics features alone (the
    # window statistics drown them), extremely randomised trees, run-balanced weights
    r = RECIPES["wheels"]
    assert (r.signals, r.window_s, r.rate_hz, r.train_hop_s) == ("wheels", 4.0, 10.0, 2.0)
    assert (r.features, r.classifier, r.run_balanced) == ("physics", "extra_trees", True)


def test_each_feature_set_names_its_transformer():
    def features(name):
        recipe = ModelRecipe("wheels", 4.0, 10.0, 2.0, name, "extra_trees")
        return recipe_features(recipe, WHEEL_CHANNELS, track_m=0.6)

    stats, physics, both = (features(n) for n in ("stats", "physics", "stats+physics"))
    assert type(stats) is WindowFeatures and stats.rate_hz == 10.0
    assert type(physics) is WheelPhysicsFeatures and physics.track_m == 0.6
    assert isinstance(both, SerialFeatureUnion)
    assert [type(t) for _, t in both.transformer_list] == [WindowFeatures,
                                                           WheelPhysicsFeatures]
    assert both.transformer_list[1][1].track_m == 0.6
