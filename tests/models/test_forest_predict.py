"""Compiled forest adaptor (terrain.tree_predict.forest_proba, ForestPipeline): it must
reproduce scikit-learn's ``predict_proba`` of the fitted forest on real BorealTC windows."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sklearn.ensemble import ExtraTreesClassifier, RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline

from features.wheel_physics import WheelPhysicsFeatures
from features.windows import WindowConfig, make_windows
from terrain.errors import ConfigError, NonFiniteInputError, ShapeError
from terrain.models.forest import ForestPipeline
from terrain.serving.recipes import extra_trees, run_balanced_weights
from terrain.tree_predict import forest_proba, pack_forest


@pytest.fixture(scope="module")
def wheel_windows(borealtc_runs):
    """Wheel-only windows (4 s at 10 Hz) of two runs per terrain for training and one
    other run per terrain for testing."""
    train, test = [], []
    for terrain in sorted({r.terrain for r in borealtc_runs}):
        runs = [r for r in borealtc_runs if r.terrain == terrain and "wheels" in r.streams]
        train += runs[:2]
        test += runs[2:3]
    config = WindowConfig(window_s=4.0, hop_s=2.0, rate_hz=10.0)
    return make_windows(train, "wheels", config), make_windows(test, "wheels", config)


def _features(ws):
    return WheelPhysicsFeatures(channels=ws.channels, rate_hz=10.0).fit(ws.X).transform(ws.X)


@pytest.mark.parametrize("forest", [
    ExtraTreesClassifier(60, min_samples_leaf=3, max_features=0.3, class_weight="balanced",
                         random_state=0),
    RandomForestClassifier(40, class_weight="balanced_subsample", random_state=1),
    ExtraTreesClassifier(30, random_state=2),
])
def test_packed_forest_equals_sklearn_on_real_windows(wheel_windows, forest):
    train, test = wheel_windows
    F, Ft = _features(train), _features(test)
    forest.fit(F, train.labels.astype(str))
    ref = forest.predict_proba(Ft)
    out = forest_proba(pack_forest(forest), Ft)
    assert np.allclose(out, ref, rtol=0, atol=1e-12)
    assert np.array_equal(out, ref)                 # same float64 sums in the same order
    assert np.array_equal(forest_proba(pack_forest(forest), Ft[3:4]), ref[3:4])  # one row
    # not a trivial forest: the windows get different, confident answers
    assert len(np.unique(ref.argmax(axis=1))) >= 3 and ref.max() > 0.8
    with pytest.raises(ShapeError):
        forest_proba(pack_forest(forest), Ft[:, :5])


def test_packed_forest_equals_sklearn_with_the_wheel_recipes_run_balanced_weights(
        wheel_windows):
    # the shipped wheel recipe fits its trees with run-balanced sample weights, not
    # class_weight (docs/streaming.md, Latency): weights change the stored leaf fractions only
    train, test = wheel_windows
    F, Ft = _features(train), _features(test)
    forest = extra_trees(40, 3, class_weight=None)
    weights = run_balanced_weights(train.labels.astype(str), np.asarray(train.run_ids))
    assert len(np.unique(np.round(weights, 12))) > 1     # not uniform: the test weighs
    forest.fit(F, train.labels.astype(str), sample_weight=weights)
    unweighted = extra_trees(40, 3, class_weight=None).fit(F, train.labels.astype(str))
    assert not np.array_equal(forest.predict_proba(Ft), unweighted.predict_proba(Ft))
    assert np.array_equal(forest_proba(pack_forest(forest), Ft), forest.predict_proba(Ft))


def test_inputs_on_and_just_above_a_split_threshold_take_sklearns_side():
    # integer features: a random forest splits half-way (x <= 1.5 goes left); a float64
    # input 1e-9 above a threshold is that threshold once cast to float32, as scikit-learn
    # casts it, so it goes left too
    rng = np.random.default_rng(0)
    F = rng.integers(0, 5, (300, 3)).astype(float)
    y = np.where(F[:, 0] + F[:, 1] + rng.integers(0, 2, 300) > 4, "a", "b")
    forest = RandomForestClassifier(20, random_state=0).fit(F, y)
    axis = np.arange(-0.5, 5.0, 0.5)
    grid = np.stack(np.meshgrid(axis, axis, axis), axis=-1).reshape(-1, 3)
    grid = np.concatenate([grid, grid + 1e-9])
    assert np.array_equal(forest_proba(pack_forest(forest), grid), forest.predict_proba(grid))


def test_missing_values_take_the_learned_side(wheel_windows):
    train, test = wheel_windows
    F, Ft = _features(train), _features(test)
    rng = np.random.default_rng(0)
    F[rng.random(F.shape) < 0.05] = np.nan
    Ft[rng.random(Ft.shape) < 0.1] = np.nan
    forest = ExtraTreesClassifier(40, random_state=0).fit(F, train.labels.astype(str))
    ref = forest.predict_proba(Ft)
    assert np.array_equal(forest_proba(pack_forest(forest), Ft), ref)
    Ft[0, 0] = np.inf
    with pytest.raises(NonFiniteInputError):
        forest_proba(pack_forest(forest), Ft)


def test_pack_forest_rejects_what_it_cannot_reproduce(wheel_windows):
    train, _ = wheel_windows
    F = _features(train)
    with pytest.raises(ConfigError):
        pack_forest(ExtraTreesClassifier(5))                        # not fitted
    y2 = np.column_stack([train.labels.astype(str), train.labels.astype(str)])
    with pytest.raises(ConfigError):
        pack_forest(ExtraTreesClassifier(5, random_state=0).fit(F, y2))   # two outputs


def test_forest_pipeline_uses_the_compiled_path_and_survives_pickling(wheel_windows):
    train, test = wheel_windows
    labels = train.labels.astype(str)
    pipe = ForestPipeline([
        ("features", WheelPhysicsFeatures(channels=train.channels, rate_hz=10.0)),
        ("classifier", ExtraTreesClassifier(50, min_samples_leaf=3, max_features=0.3,
                                            class_weight="balanced", random_state=0))])
    pipe.fit(train.X, labels)
    assert pipe._compiled() is not None
    # scikit-learn's own path over the same fitted steps (super(ForestPipeline, pipe) is
    # CompiledPipeline, whose predict_proba is the compiled path under test)
    ref = Pipeline(pipe.steps).predict_proba(test.X)
    assert np.array_equal(pipe.predict_proba(test.X), ref)
    assert np.array_equal(pipe.predict(test.X), pipe.classes_[ref.argmax(axis=1)])
    loaded = pickle.loads(pickle.dumps(pipe))
    assert np.array_equal(loaded.predict_proba(test.X[:1]), ref[:1])
    # refitting the final step repacks it: no stale trees
    pipe.steps[-1][1].set_params(random_state=5).fit(pipe[:-1].transform(train.X), labels)
    assert np.array_equal(pipe.predict_proba(test.X),
                          Pipeline(pipe.steps).predict_proba(test.X))
    # another final step: scikit-learn's path
    other = ForestPipeline([("features", WheelPhysicsFeatures(channels=train.channels,
                                                              rate_hz=10.0)),
                            ("classifier", LogisticRegression(max_iter=50))])
    assert other._compiled() is None
