"""Review of the model registry (:func:`terrain.models.registry.make_model`): settings at
their documented bounds are taken, and the training runs' vehicle's track width reaches the
window EKF."""

from __future__ import annotations

from dataclasses import replace

import pytest

from features.windows import HUSKY_TRACK_M, derived_track_m
from terrain.errors import ConfigError
from terrain.models.experiment import ExperimentConfig
from terrain.models.registry import MAX_CNN_SEEDS, ModelConfig, make_model
from terrain.models.window_ekf import WindowEKFClassifier

CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")


def test_cnn_seeds_take_their_documented_maximum():
    # "at most MAX_CNN_SEEDS": the bound itself bags that many networks
    config = ModelConfig(kind="cnn", cnn_seeds=MAX_CNN_SEEDS, max_epochs=1)
    bag = make_model(config, CHANNELS, 50.0, "vulpi", random_state=2)
    assert [m.random_state for _, m in bag.estimators] == list(range(2, 2 + MAX_CNN_SEEDS))
    with pytest.raises(ConfigError, match="cnn_seeds"):
        ModelConfig(kind="cnn", cnn_seeds=MAX_CNN_SEEDS + 1)


@pytest.mark.parametrize("kind", ["svm", "ensemble"])
def test_window_ekf_takes_the_configured_track_width_and_native_wheel_rate(kind):
    # another vehicle's track (here 0.9 m, not the Husky's) must reach the skid-steer filter
    model = make_model(ModelConfig(kind=kind, window_ekf=True, track_m=0.9), CHANNELS, 50.0,
                       "vulpi")
    assert isinstance(model, WindowEKFClassifier)
    assert model.track_m == 0.9 and model.wheel_rate_hz == 15.0
    assert make_model(ModelConfig(kind=kind, window_ekf=True), CHANNELS, 50.0,
                      "sim").wheel_rate_hz is None


def test_the_model_takes_the_track_width_of_its_training_runs_vehicle(vulpi_runs):
    # the window EKF of a model trained on another vehicle's runs must use that vehicle's
    # track (tracked: 0.393 m), not the Husky's 0.5708 m
    config = ExperimentConfig(dataset="vulpi", window_ekf=True)
    tracked = [replace(run, vehicle="tracked") for run in vulpi_runs[:3]]
    assert config.model_config(tracked).track_m == derived_track_m("tracked") == 0.393
    assert config.model_config(vulpi_runs[:3]).track_m == HUSKY_TRACK_M
    # runs of several vehicles: the Husky's (each training window used its own run's)
    assert config.model_config(tracked + vulpi_runs[3:4]).track_m == HUSKY_TRACK_M


class _Captured(Exception):
    """Stops run_cv once its estimator factory is captured."""


@pytest.mark.parametrize("kind, window_ekf", [("cnn", False), ("svm", True)])
def test_run_cv_builds_every_cv_seeds_raw_window_model_with_that_seed(
        vulpi_runs, monkeypatch, kind, window_ekf):
    # the models on raw windows (CNNs, ensembles, the window-EKF SVM) are built by the
    # registry per CV seed: seed 9's folds get a model seeded 9, not the first seed's
    from terrain.models import experiment

    captured = {}

    def capture(factory, *args, **kwargs):
        captured["factory"] = factory
        raise _Captured

    monkeypatch.setattr(experiment, "cross_validate", capture)
    config = ExperimentConfig(dataset="vulpi", signals=("all",), seeds=(5, 9), model=kind,
                              window_ekf=window_ekf, max_epochs=1)
    with pytest.raises(_Captured):
        experiment.run_cv(config, runs=vulpi_runs)
    model = captured["factory"](9)
    if window_ekf:
        assert isinstance(model, WindowEKFClassifier)
        assert model.estimator.named_steps["svc"].estimator.random_state == 9
    else:
        assert model.random_state == 9


def test_a_minirocket_member_without_aeon_is_refused_before_any_data(monkeypatch):
    # an ensemble holding MiniRocket needs the optional extra as much as MiniRocket alone
    from terrain.models import registry

    def missing():
        raise ConfigError("minirocket needs aeon")

    monkeypatch.setattr(registry, "require_aeon", missing)
    for kind, members in (("minirocket", ()), ("ensemble", ("svm", "minirocket"))):
        with pytest.raises(ConfigError, match="aeon"):
            registry.check_dependencies(kind, members)
    registry.check_dependencies("ensemble3")            # svm + CNNs: no aeon needed
    registry.check_dependencies("ensemble", ("svm", "cnn"))
