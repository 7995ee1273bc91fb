"""Streaming model recipes: the wheel-only model's compiled forest path, the ensemble
recipes' checks and an ensemble3 stream model deciding on a replayed run, the defaults."""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
import pytest

from features.windows import WindowConfig, add_derived_channels, make_windows, window_frame
from pipelines.stream_eval import add_arguments, resolve_options
from terrain.errors import ConfigError
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.forest import ForestPipeline
from terrain.models.registry import ENSEMBLE3_MEMBERS
from terrain.models.window_ekf import WindowEKFClassifier
from terrain.io.align import align_streams
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig,
                             StreamService, decisions_frame, replay_run)
from terrain.serving.recipes import (DEFAULT_RECIPES, RECIPES, ModelRecipe, fit_stream_model,
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


def _head(run, seconds):
    """The first ``seconds`` of every stream of ``run``."""
    return replace(run, streams={s: f[f[TIME] < f[TIME].iloc[0] + seconds]
                                 for s, f in run.streams.items()})


@pytest.mark.parametrize("kind", ["all-ensemble", "all-ensemble3"])
def test_ensemble_recipes_take_raw_windows_only(kind):
    recipe = RECIPES[kind]
    assert recipe.classifier == kind.removeprefix("all-")
    assert (recipe.window_s, recipe.rate_hz, recipe.train_hop_s) == (
        RECIPES["all"].window_s, RECIPES["all"].rate_hz, RECIPES["all"].train_hop_s)
    for features in ("physics", "stats+physics"):
        with pytest.raises(ConfigError):
            ModelRecipe("all", 2.0, 100.0, 2.0, features, recipe.classifier)
    with pytest.raises(ConfigError):
        recipe_classifier(recipe)
    with pytest.raises(ConfigError):
        ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "boosting")


@pytest.mark.slow
def test_ensemble3_recipe_streams_decisions_with_the_service_columns(train_runs,
                                                                     borealtc_runs):
    # the all-ensemble3 recipe on a 20 Hz clock, the first 30 s of 10 runs (fast)
    recipe = replace(RECIPES["all-ensemble3"], rate_hz=20.0)
    model = fit_stream_model(recipe, [_head(r, 30.0) for r in train_runs], seed=0)
    assert isinstance(model.pipeline, SoftVotingEnsemble)
    assert tuple(name for name, _ in model.pipeline.estimators) == ENSEMBLE3_MEMBERS
    assert model.window.window_s == recipe.window_s and model.window.rate_hz == 20.0
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.has_imu and r.run_id not in seen
               and r.duration_s > 20)
    run = _head(run, 12.0)
    service = StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(hop_s=0.5))
    frame = decisions_frame(replay_run(service, run), model.classes)
    assert list(frame.columns) == (
        ["t_s", "terrain", "confidence"] + [f"proba_{c}" for c in model.classes]
        + ["target_slip_traction", "target_slip_braking", "target_slip_steady",
           "window_age_s", "flags"])
    assert len(frame) >= 15                        # ~10 s of decisions every 0.5 s
    np.testing.assert_allclose(frame.filter(like="proba_").sum(axis=1), 1.0)
    assert set(frame["terrain"]) <= set(model.classes)
    assert np.isfinite(frame["target_slip_traction"]).all()


def test_defaults_follow_the_default_recipes():
    assert set(DEFAULT_RECIPES) == {"all", "wheels"}
    assert all(RECIPES[k].signals == s for s, k in DEFAULT_RECIPES.items())
    parser = argparse.ArgumentParser()
    add_arguments(parser)

    def resolved(argv):
        args = parser.parse_args(argv)
        resolve_options(args)
        return args

    assert resolved([]).kinds == list(DEFAULT_RECIPES.values())
    assert (resolved([]).seeds, resolved([]).folds) == ([0, 1, 2], 5)
    # held-out streams run on a continuous clock across switches unless a dropout is asked
    assert resolved([]).switch_gap_s == 0.0
    assert resolved(["--switch-gap-s", "0.1"]).switch_gap_s == 0.1
    # the all-signal default is the SVM: the ensembles' decisions cost over 1 ms at p99;
    # fitted on windows cut every 0.5 s, more accurate on the held-out streams
    assert RECIPES[DEFAULT_RECIPES["all"]].classifier == "svm"
    assert RECIPES[DEFAULT_RECIPES["all"]].train_hop_s == 0.5


def test_window_ekf_recipe_streams_decisions_from_raw_signals(train_runs, borealtc_runs):
    # the service windows raw signals; the model computes each window's EKF channels itself
    # the recipe's SVM member alone on a 20 Hz clock and non-overlapping windows (fast)
    recipe = replace(RECIPES["all-ensemble-dense-window-ekf"], classifier="svm", rate_hz=20.0,
                     train_hop_s=2.0)
    assert RECIPES["all-ensemble-dense-window-ekf"].window_ekf
    model = fit_stream_model(recipe, [_head(r, 30.0) for r in train_runs], seed=0)
    assert isinstance(model.pipeline, WindowEKFClassifier)
    assert not any(c.startswith("ekf_") for c in model.channels)
    seen = {r.run_id for r in train_runs}
    run = _head(next(r for r in borealtc_runs if r.has_imu and r.run_id not in seen
                     and r.duration_s > 20), 12.0)
    service = StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(hop_s=0.5))
    frame = decisions_frame(replay_run(service, run), model.classes)
    assert len(frame) >= 15
    np.testing.assert_allclose(frame.filter(like="proba_").sum(axis=1), 1.0)
    for bad in ({"classifier": "extra_trees", "features": "physics"}, {"signals": "wheels"}):
        with pytest.raises(ConfigError, match="window_ekf"):
            ModelRecipe(**{**dict(signals="all", window_s=2.0, rate_hz=100.0,
                                  train_hop_s=0.5, features="stats", classifier="svm",
                                  window_ekf=True), **bad})


def test_augmented_recipe_is_the_dense_ensemble_with_noisy_spectra():
    recipe = RECIPES["all-ensemble-dense-augmented"]
    assert replace(recipe, spectrogram_noise_std=0.0) == RECIPES["all-ensemble-dense"]
    assert recipe.spectrogram_noise_std == 0.3
    with pytest.raises(ConfigError, match="ensemble recipe only"):
        ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "svm", spectrogram_noise_std=0.3)


def test_bagged_recipe_is_the_no_speed_dense_ensemble_with_three_networks():
    recipe = RECIPES["all-ensemble-dense-no-speed-bagged"]
    assert replace(recipe, cnn_seeds=1) == RECIPES["all-ensemble-dense-no-speed"]
    assert recipe.cnn_seeds == 3
    with pytest.raises(ConfigError, match="ensemble recipe only"):
        ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "svm", cnn_seeds=3)


def test_bagged_one_second_recipe_is_the_one_second_ensemble_with_three_networks():
    recipe = RECIPES["all-ensemble-dense-no-speed-1s-bagged"]
    assert replace(recipe, cnn_seeds=1) == RECIPES["all-ensemble-dense-no-speed-1s"]
    assert replace(recipe, window_s=2.0) == RECIPES["all-ensemble-dense-no-speed-bagged"]


def test_quarter_second_hop_recipe_overlaps_its_training_windows_as_the_two_second_one():
    recipe = RECIPES["all-ensemble-dense-no-speed-1s-hop025"]
    one_second = RECIPES["all-ensemble-dense-no-speed-1s"]
    two_second = RECIPES["all-ensemble-dense-no-speed"]
    assert replace(recipe, train_hop_s=one_second.train_hop_s) == one_second
    overlap = 1.0 - recipe.train_hop_s / recipe.window_s
    assert overlap == pytest.approx(1.0 - two_second.train_hop_s / two_second.window_s)
    assert overlap == pytest.approx(0.75)


def _assert_streamed_decisions_are_batch_predictions(model, train_runs, borealtc_runs,
                                                     n_rows, atol):
    """Both streams of an unseen run on the model's 20 Hz clock, pushed interleaved,
    unsmoothed, one decision per window length: every decision is the batch prediction of
    the window of the same span."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.has_imu and r.run_id not in seen
               and r.duration_s > 20)
    frame = add_derived_channels(align_streams(run, ("imu", "wheels"), 20.0)).iloc[:n_rows]
    service = StreamService(model, CataloguePeakTargets(model.classes), StreamConfig(
        hop_s=model.window.window_s, smoothing=SmoothingConfig(dwell_s=None)))
    decisions = []
    for row in frame.itertuples(index=False):
        for stream, chans in (("imu", IMU_CHANNELS), ("wheels", WHEEL_CHANNELS)):
            decisions += service.push(stream, row.t_s, {c: getattr(row, c) for c in chans})
    X = window_frame(frame, model.channels, model.window)[0]
    n = min(len(decisions), len(X))
    assert n >= len(X) - 1 >= 8
    order = [list(model.pipeline.classes_).index(c) for c in model.classes]
    np.testing.assert_allclose(np.array([d.proba for d in decisions[:n]]),
                               model.pipeline.predict_proba(X[:n])[:, order], atol=atol)


def test_no_speed_recipe_needs_the_wheel_speeds_but_does_not_classify_them(train_runs,
                                                                           borealtc_runs):
    # the SVM of all-dense-no-speed on a 20 Hz clock and non-overlapping windows (fast)
    assert RECIPES["all-ensemble-dense-no-speed"].signals == "all-no-speed"
    recipe = replace(RECIPES["all-dense-no-speed"], rate_hz=20.0, train_hop_s=2.0)
    model = fit_stream_model(recipe, [_head(r, 30.0) for r in train_runs], seed=0)
    assert not {"vel_l", "vel_r", "vel_mean"} & set(model.channels)
    # the turning channels are derived from the speeds, so the service still asks for them
    assert {"vel_l", "vel_r", "cur_l", "cur_r"} <= set(model.raw_channels)
    _assert_streamed_decisions_are_batch_predictions(model, train_runs, borealtc_runs, 400,
                                                     1e-6)


@pytest.mark.slow
def test_one_second_recipe_is_the_no_speed_dense_ensemble_on_shorter_windows(train_runs,
                                                                             borealtc_runs):
    recipe = RECIPES["all-ensemble-dense-no-speed-1s"]
    assert replace(recipe, window_s=2.0) == RECIPES["all-ensemble-dense-no-speed"]
    # the ensemble (spectrogram CNN of 0.5 s segments included) on 1 s windows of a 20 Hz
    # clock
    small = replace(recipe, rate_hz=20.0, train_hop_s=1.0)
    model = fit_stream_model(small, [_head(r, 30.0) for r in train_runs], seed=0)
    assert isinstance(model.pipeline, SoftVotingEnsemble)
    assert model.window.window_s == 1.0
    _assert_streamed_decisions_are_batch_predictions(model, train_runs, borealtc_runs, 200,
                                                     1e-5)


def test_run_balanced_one_second_recipe_hands_the_runs_to_its_ensemble(train_runs,
                                                                       monkeypatch):
    """The recipe differs from the 1 s recipe in its weights only; its ensemble is built
    with ``ModelConfig(run_balanced=True)`` and fitted with the run of every window."""
    import terrain.serving.recipes as recipes
    recipe = RECIPES["all-ensemble-dense-no-speed-1s-run-balanced"]
    assert replace(recipe, run_balanced=False) == RECIPES["all-ensemble-dense-no-speed-1s"]
    seen = {}

    class Recorder:
        def fit(self, X, y, groups=None):
            seen.update(n=len(y), groups=groups)
            self.classes_ = np.unique(y)
            return self

    def fake_make_model(config, *args, **kwargs):
        seen["config"] = config
        return Recorder()

    monkeypatch.setattr(recipes, "make_model", fake_make_model)
    fit_stream_model(recipe, train_runs[:4], seed=0)
    assert seen["config"].run_balanced and seen["config"].kind == "ensemble"
    assert seen["groups"] is not None and len(seen["groups"]) == seen["n"]
    assert set(seen["groups"]) == {r.run_id for r in train_runs[:4]}
    fit_stream_model(RECIPES["all-ensemble-dense-no-speed-1s"], train_runs[:4], seed=0)
    assert seen["groups"] is None and not seen["config"].run_balanced
    with pytest.raises(ConfigError, match="run_balanced"):
        ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "svm", run_balanced=True)
