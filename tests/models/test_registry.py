"""The model registry: every kind by name, the three-member ensemble's fixed composition."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.registry import (ENSEMBLE3_MEMBERS, ENSEMBLES, MAX_CNN_SEEDS,
                                     MAX_TORCH_THREADS, MODELS, ModelConfig, band_limits_hz,
                                     ensemble_member_kinds, make_model)
from terrain.models.svm import SVMPipeline

CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")


def test_ensemble3_is_the_equal_weight_vote_of_svm_raw_cnn_and_spectrogram_cnn():
    # ensemble_members configures the two-member "ensemble" only; ensemble3 is fixed
    config = ModelConfig(kind="ensemble3", ensemble_members=("svm", "minirocket"),
                         max_epochs=7, n_threads=2, early_stopping=True)
    model = make_model(config, CHANNELS, 50.0, "borealtc", random_state=3)
    assert isinstance(model, SoftVotingEnsemble)
    assert [name for name, _ in model.estimators] == list(ENSEMBLE3_MEMBERS)
    assert [type(m) for _, m in model.estimators] == [SVMPipeline, RawCNNClassifier,
                                                      SpectrogramCNNClassifier]
    assert model.weights == (1.0, 1.0, 1.0) and model.random_state == 3
    # members share the budget and seed; the spectrogram member keeps the wheel band limit
    cnn, spec = model.estimators[1][1], model.estimators[2][1]
    assert cnn.max_epochs == spec.max_epochs == 7
    assert cnn.random_state == spec.random_state == 3
    # ... and the thread budget and early stopping (a dropped setting left the default)
    assert cnn.n_threads == spec.n_threads == 2
    assert cnn.early_stopping is spec.early_stopping is True
    assert spec.band_limits_hz[CHANNELS.index("vel_l")] == pytest.approx(3.25)
    two = make_model(ModelConfig(kind="ensemble"), CHANNELS, 50.0, "borealtc")
    assert [name for name, _ in two.estimators] == ["svm", "cnn-spectrogram"]


def test_ensemble_member_kinds_are_the_members_make_model_builds():
    for config in (ModelConfig(kind="ensemble"), ModelConfig(kind="ensemble3"),
                   ModelConfig(kind="ensemble", ensemble_members=("svm", "cnn"))):
        model = make_model(config, CHANNELS, 50.0, "borealtc")
        assert ensemble_member_kinds(config) == tuple(name for name, _ in model.estimators)
    assert ensemble_member_kinds(ModelConfig(kind="ensemble")) == ("svm", "cnn-spectrogram")
    with pytest.raises(ConfigError, match="not an ensemble"):
        ensemble_member_kinds(ModelConfig(kind="svm"))


def test_tuned_weights_reach_ensemble3():
    model = make_model(ModelConfig(kind="ensemble3", tune_weights=True), CHANNELS, 50.0,
                       "vulpi")
    assert model.weights is None


@pytest.mark.parametrize("members", [("svm", "ensemble3"), ("ensemble",), (), ("knn",)])
def test_ensemble_members_must_be_single_models(members):
    with pytest.raises(ConfigError, match="ensemble members"):
        ModelConfig(kind="ensemble", ensemble_members=members)


def test_every_kind_is_built_and_ensembles_are_listed():
    assert set(ENSEMBLES) <= set(MODELS) and "ensemble3" in MODELS
    for kind in MODELS:
        if kind == "minirocket":
            continue  # optional extra (aeon), built in tests/models/test_ensemble_minirocket
        assert hasattr(make_model(ModelConfig(kind=kind), CHANNELS, 50.0, "vulpi"),
                       "predict_proba")
    with pytest.raises(ConfigError, match="unknown model"):
        ModelConfig(kind="ensemble4")


def test_spectrogram_noise_reaches_the_spectrogram_member_only():
    from terrain.models.registry import ModelConfig, make_model
    channels = ("wx", "wy", "wz", "ax", "ay", "az", "vel_l", "vel_r", "cur_l", "cur_r")
    model = make_model(ModelConfig("ensemble", spectrogram_noise_std=0.3), channels, 100.0,
                       "borealtc")
    members = dict(model.estimators)
    assert members["cnn-spectrogram"].augment_noise_std == 0.3
    assert make_model(ModelConfig("cnn-spectrogram"), channels, 100.0,
                      "borealtc").augment_noise_std == 0.0
    with pytest.raises(ConfigError, match="spectrogram_noise_std"):
        ModelConfig("ensemble", spectrogram_noise_std=-1.0)


def test_cnn_seeds_bag_independently_seeded_networks_with_equal_weights():
    import numpy as np

    config = ModelConfig(kind="ensemble", cnn_seeds=3, max_epochs=1, n_threads=1)
    model = make_model(config, CHANNELS[:3], 50.0, "borealtc", random_state=4)
    svm, bag = (m for _, m in model.estimators)
    assert isinstance(svm, SVMPipeline)             # the SVM is not bagged
    assert isinstance(bag, SoftVotingEnsemble) and bag.weights == (1.0, 1.0, 1.0)
    assert [m.random_state for _, m in bag.estimators] == [4, 5, 6]
    assert all(isinstance(m, SpectrogramCNNClassifier) for _, m in bag.estimators)
    # the bag's probabilities are the mean of its networks', which differ by their seed
    rng = np.random.default_rng(0)
    X = rng.normal(size=(24, 3, 100)).astype(np.float32)
    y = np.array(["A", "B", "C"] * 8)
    bag.fit(X, y)
    each = np.stack([m.predict_proba(X) for m in bag.estimators_])
    assert np.allclose(bag.predict_proba(X), each.mean(axis=0))
    assert not np.allclose(each[0], each[1])
    # one network, the default, is the plain classifier
    assert isinstance(make_model(ModelConfig(kind="cnn"), CHANNELS, 50.0, "vulpi"),
                      RawCNNClassifier)


@pytest.mark.parametrize("seeds", [0, -1, 1.5, True, MAX_CNN_SEEDS + 1])
def test_cnn_seeds_must_be_a_positive_integer(seeds):
    with pytest.raises(ConfigError, match="cnn_seeds"):
        ModelConfig(kind="cnn", cnn_seeds=seeds)


def test_cnn_seeds_need_a_model_that_holds_a_cnn():
    from terrain.models.compare import CompareConfig
    from terrain.models.registry import cnn_kinds

    assert cnn_kinds("ensemble3") == ("cnn", "cnn-spectrogram")
    assert cnn_kinds("ensemble", ("svm", "minirocket")) == () == cnn_kinds("svm")
    for config in ({"kind": "svm"}, {"kind": "minirocket"},
                   {"kind": "ensemble", "ensemble_members": ("svm", "minirocket")}):
        for seeds in (2, 3):
            with pytest.raises(ConfigError, match="has none"):
                ModelConfig(cnn_seeds=seeds, **config)
    # a comparison bags the cells whose model holds a CNN and refuses a grid without one
    assert CompareConfig(models=("svm", "cnn"), cnn_seeds=3).cnn_seeds == 3
    with pytest.raises(ConfigError, match="none of the models"):
        CompareConfig(models=("svm", "minirocket"), cnn_seeds=3)
    with pytest.raises(ConfigError, match="cnn_seeds must be"):
        CompareConfig(models=("cnn",), cnn_seeds=0)


@pytest.mark.parametrize("setting, value", [
    ("max_epochs", 0), ("max_epochs", -3), ("max_epochs", 2.5), ("max_epochs", True),
    ("minirocket_kernels", 0), ("minirocket_max_dilations", 0),
    ("spectrogram_noise_std", float("inf")), ("spectrogram_noise_std", float("nan")),
    ("n_threads", 0), ("n_threads", MAX_TORCH_THREADS + 1)])
def test_training_budget_settings_are_checked_before_any_fit(setting, value):
    # max_epochs=0 trained no epoch and served the untrained network's probabilities
    # (n_epochs_ 0, no word); a 0-dilation MiniRocket reached aeon's bare ZeroDivisionError;
    # an infinite noise level passed the ">= 0" check
    with pytest.raises(ConfigError, match=setting):
        ModelConfig(kind="cnn", **{setting: value})


def test_ensemble_members_are_calibrated_where_a_plain_svm_is_asked_for():
    # probability=False asks for the uncalibrated SVC of a lone SVM; an ensemble's SVM
    # member must still give probabilities to be voted with
    plain = make_model(ModelConfig(kind="svm"), CHANNELS, 50.0, "vulpi", probability=False)
    assert not hasattr(plain.named_steps["svc"], "predict_proba")
    for kind in ENSEMBLES:
        model = make_model(ModelConfig(kind=kind), CHANNELS, 50.0, "vulpi", probability=False)
        svm = dict(model.estimators)["svm"]
        assert hasattr(svm.named_steps["svc"], "predict_proba")


def test_band_limits_are_the_native_nyquist_of_every_wheel_channel_derived_ones_included():
    channels = ("wz", "vel_l", "cur_r", "vel_mean", "cur_diff", "yaw_rate_wheels")
    assert band_limits_hz(channels, "borealtc") == (np.inf, 3.25, 3.25, 3.25, 3.25, 3.25)
    assert band_limits_hz(channels, "vulpi")[1:] == (7.5,) * 5
    # the combined dataset takes the lower native rate (BorealTC's): nothing above 3.25 Hz
    assert band_limits_hz(channels, "combined") == band_limits_hz(channels, "borealtc")
    assert band_limits_hz(channels, "unknown") == (np.inf,) * 6


def test_minirocket_gets_the_seed_and_budget_it_is_asked_for():
    config = ModelConfig(kind="minirocket", minirocket_kernels=840, minirocket_max_dilations=8)
    model = make_model(config, CHANNELS, 50.0, "vulpi", random_state=7)
    params = model.get_params()
    assert params["minirocket__random_state"] == 7
    assert params["minirocket__n_kernels"] == 840
    assert params["minirocket__max_dilations_per_kernel"] == 8
