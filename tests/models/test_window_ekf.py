"""A classifier fed each window's own EKF channels (``--window-ekf``)."""

from __future__ import annotations

from dataclasses import replace

import joblib
import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.dummy import DummyClassifier

from features.ekf_signals import EKF_CHANNELS, window_ekf_channels
from features.windows import WindowConfig, make_windows
from pipelines.validation.harness import simulate_husky
from terrain.errors import ConfigError
from terrain.estimation.skid_steer import SkidSteerSettings
from terrain.models.experiment import ExperimentConfig
from terrain.models.registry import ModelConfig, make_model
from terrain.models.svm import SVMPipeline
from terrain.models.window_ekf import WindowEKFClassifier


@pytest.fixture(scope="module")
def windows():
    """Two simulated ground states differing in their ICR expansion (1.2 against 3)."""
    runs = [replace(simulate_husky("ASPHALT", seed=s, duration_s=40.0,
                                   icr_expansion=chi).run,
                    run_id=f"sim/{name}/{s}", terrain=name)
            for name, chi in (("FIRM", 1.2), ("SOFT", 3.0)) for s in (1, 2, 3)]
    return make_windows(runs, "all", WindowConfig(window_s=2.0, hop_s=1.0, rate_hz=50.0))


class _Recorder(ClassifierMixin, BaseEstimator):
    """Records what ``fit`` received."""

    def fit(self, X, y, groups=None):
        self.shape_, self.groups_ = X.shape, groups
        self.classes_ = np.unique(y)
        return self

    def predict_proba(self, X):
        return np.full((len(X), len(self.classes_)), 1.0 / len(self.classes_))


@pytest.mark.slow
def test_make_model_wraps_the_model_built_for_the_augmented_channels(windows):
    model = make_model(ModelConfig(kind="svm", window_ekf=True), windows.channels,
                       windows.rate_hz, "borealtc", random_state=4)
    assert isinstance(model, WindowEKFClassifier) and isinstance(model.estimator, SVMPipeline)
    assert model.channels == tuple(windows.channels) and model.wheel_rate_hz == 6.5
    assert model.estimator.steps[0][1].channels == tuple(windows.channels) + EKF_CHANNELS
    assert model.augmented_channels == tuple(windows.channels) + EKF_CHANNELS
    assert clone(model).get_params()["estimator__svc__estimator__random_state"] == 4


@pytest.mark.slow
def test_the_wrapped_classifier_sees_the_window_and_its_ekf_channels(windows):
    model = WindowEKFClassifier(_Recorder(), windows.channels, windows.rate_hz, 6.5)
    groups = np.asarray(windows.run_ids)
    model.fit(windows.X, windows.labels, groups=groups)
    n, c, s = windows.X.shape
    assert model.estimator_.shape_ == (n, c + len(EKF_CHANNELS), s)
    np.testing.assert_array_equal(model.estimator_.groups_, groups)   # runs passed on
    augmented = model.augment(windows.X[:5])
    np.testing.assert_array_equal(augmented[:, :c], windows.X[:5])
    np.testing.assert_array_equal(
        augmented[:, c:], window_ekf_channels(windows.X[:5], windows.channels,
                                              windows.rate_hz, wheel_rate_hz=6.5))
    # an estimator whose fit takes no groups is fitted without them
    plain = WindowEKFClassifier(DummyClassifier(), windows.channels, windows.rate_hz)
    assert plain.fit(windows.X, windows.labels, groups=groups).predict(windows.X[:2]).shape == (2,)


def test_the_filter_runs_with_the_vehicle_track_width_it_is_given(windows):
    # track_m is the skid-steer kinematics of the vehicle whose windows these are: a
    # narrower track than the Husky's changes the filter's channels, and is the one used
    X = windows.X[:3]
    narrow = WindowEKFClassifier(DummyClassifier(), windows.channels, windows.rate_hz, 6.5,
                                 track_m=0.3).augment(X)[:, X.shape[1]:]
    husky = WindowEKFClassifier(DummyClassifier(), windows.channels, windows.rate_hz,
                                6.5).augment(X)[:, X.shape[1]:]
    np.testing.assert_array_equal(narrow, window_ekf_channels(
        X, windows.channels, windows.rate_hz, wheel_rate_hz=6.5,
        settings=SkidSteerSettings(track_m=0.3)))
    assert not np.allclose(narrow, husky)


def test_window_ekf_svm_separates_planted_ground_states_and_is_stateless(windows, tmp_path):
    held_out = np.isin(windows.run_ids, ["sim/FIRM/3", "sim/SOFT/3"])
    model = make_model(ModelConfig(kind="svm", window_ekf=True), windows.channels,
                       windows.rate_hz, "borealtc").fit(windows.X[~held_out],
                                                        windows.labels[~held_out])
    proba = model.predict_proba(windows.X[held_out])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    labels = windows.labels[held_out]
    correct = model.classes_[proba.argmax(axis=1)] == labels
    # the turning windows carry the ICR expansion (the straight ones carry none of it)
    turning = np.abs(windows.X[held_out][:, windows.channels.index("wz")]).mean(axis=1) > 0.1
    assert turning.sum() >= 20 and correct[turning].mean() >= 0.95 and correct.mean() > 0.8
    np.testing.assert_array_equal(model.predict(windows.X[held_out]),
                                  model.classes_[proba.argmax(axis=1)])
    # a decision depends on its window only: alone or in a batch, the same probabilities
    np.testing.assert_allclose(model.predict_proba(windows.X[held_out][3:4]), proba[3:4],
                               rtol=1e-12)
    path = tmp_path / "model.joblib"
    joblib.dump(model, path)
    np.testing.assert_array_equal(joblib.load(path).predict_proba(windows.X[held_out]), proba)


def test_experiment_config_checks_the_filter_inputs():
    assert ExperimentConfig(window_ekf=True).model_config().window_ekf
    for kwargs in ({"signals": ("wheels",)}, {"signals": ("all+ekf",)},
                   {"search": True}):
        with pytest.raises(ConfigError, match="window-ekf"):
            ExperimentConfig(window_ekf=True, **kwargs)


def test_run_cv_cross_validates_the_window_ekf_svm_on_raw_windows(vulpi_runs, monkeypatch):
    # the SVM's features are computed once for the plain SVM only: with --window-ekf the
    # folds must get the raw windows and the EKF-augmented model, or the plain SVM runs
    import terrain.models.experiment as experiment

    class Captured(Exception):
        pass

    def capture(factory, X, *args, **kwargs):
        raise Captured(factory, X)

    monkeypatch.setattr(experiment, "cross_validate", capture)
    config = ExperimentConfig(dataset="vulpi", seeds=(0,), window_ekf=True)
    with pytest.raises(Captured) as caught:
        experiment.run_cv(config, runs=vulpi_runs)
    factory, X = caught.value.args
    assert isinstance(factory(0), WindowEKFClassifier)
    assert X.ndim == 3 and X.shape[2] == 100               # 2 s windows at 50 Hz, not features
