"""Run-balanced training of the window models: every run of a class weighs the same, the
class totals stay as they are, and the SVM and the CNNs really train with the weights."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.linear_model import LogisticRegression

from terrain.errors import ConfigError, ShapeError
from terrain.models.cnn import RawCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.registry import ModelConfig, make_model
from terrain.models.weighting import (RunBalancedClassifier, run_shares,
                                      within_class_run_weights)

RATE_HZ = 100.0
FAST = dict(max_epochs=15, width=8, batch_size=32, n_threads=1, device="cpu")


def test_every_run_of_a_class_weighs_the_same_and_each_class_keeps_its_count():
    labels = np.array(["ICE"] * 70 + ["ICE"] * 10 + ["SNOW"] * 5 + ["SNOW"] * 15 + ["SNOW"])
    groups = np.array(["i1"] * 70 + ["i2"] * 10 + ["s1"] * 5 + ["s2"] * 15 + ["s3"])
    w = within_class_run_weights(labels, groups)
    assert np.all(w > 0)
    for c, n in (("ICE", 80), ("SNOW", 21)):
        assert np.isclose(w[labels == c].sum(), n) and np.isclose(w[labels == c].mean(), 1.0)
        per_run = [w[groups == g].sum() for g in np.unique(groups[labels == c])]
        assert np.allclose(per_run, per_run[0])
    assert np.isclose(w[0], 80 / (2 * 70)) and np.isclose(w[-1], 21 / 3)
    share = run_shares(labels, groups)
    assert np.isclose(share[labels == "ICE"].sum(), 1.0)
    assert np.isclose(share[labels == "SNOW"].sum(), 1.0)
    with pytest.raises(ShapeError):
        within_class_run_weights(labels, groups[:-1])
    with pytest.raises(ShapeError):                      # one label per window, not a table
        within_class_run_weights(labels[:, None], groups[:, None])


def _tabular():
    """Class B's long run r1 sits at x = 0, its short runs at x = 3; class A at x = -3."""
    rng = np.random.default_rng(0)
    X = np.concatenate([rng.normal(-3, 1, 40), rng.normal(0, 1, 200), rng.normal(3, 1, 40)])
    y = np.array(["A"] * 40 + ["B"] * 240)
    groups = np.array(["a0"] * 20 + ["a1"] * 20 + ["r1"] * 200 + ["r2"] * 20 + ["r3"] * 20)
    return X[:, None], y, groups


def test_wrapper_fits_its_estimator_with_the_within_class_run_weights():
    X, y, groups = _tabular()
    wrapped = RunBalancedClassifier(LogisticRegression()).fit(X, y, groups)
    direct = LogisticRegression().fit(X, y, sample_weight=within_class_run_weights(y, groups))
    np.testing.assert_allclose(wrapped.estimator_.coef_, direct.coef_)
    np.testing.assert_allclose(wrapped.predict_proba(X), direct.predict_proba(X))
    assert list(wrapped.classes_) == ["A", "B"]
    # scikit-learn's convention, as its siblings (the ensemble, the CNN) keep it: it was
    # absent after fit while the fitted LogisticRegression inside had n_features_in_ 1
    assert wrapped.n_features_in_ == wrapped.estimator_.n_features_in_ == X.shape[1]
    # the long run no longer sets where class B begins: the boundary moves towards B's
    # short runs
    plain = LogisticRegression().fit(X, y)
    boundary = (lambda m: -m.intercept_[0] / m.coef_[0, 0])
    assert boundary(direct) > boundary(plain) + 0.2
    with pytest.raises(ConfigError, match="groups"):
        RunBalancedClassifier(LogisticRegression()).fit(X, y)


class _Recorder(ClassifierMixin, BaseEstimator):
    """Records what ``fit`` was handed."""

    def fit(self, X, y, groups=None, sample_weight=None):
        self.groups_, self.sample_weight_ = groups, sample_weight
        self.classes_ = np.unique(y)
        return self


def test_wrapper_hands_the_runs_on_to_an_estimator_that_takes_them():
    X, y, groups = _tabular()
    wrapped = RunBalancedClassifier(_Recorder()).fit(X, y, groups)
    assert wrapped.n_features_in_ == X.shape[1]      # an estimator without it: from X
    fitted = wrapped.estimator_
    assert fitted.groups_ is groups
    np.testing.assert_allclose(fitted.sample_weight_, within_class_run_weights(y, groups))


def _planted_with_an_odd_long_run(seed: int = 0):
    """Terrain B adds a 20 Hz vibration on channel 0, except its long run ``odd`` (60
    windows without it, like A's); four short runs per class."""
    rng = np.random.default_rng(seed)
    t = np.arange(200) / RATE_HZ
    X, y, groups = [], [], []
    runs = [("A", f"a{r}", 12, False) for r in range(4)] + \
           [("B", f"b{r}", 12, True) for r in range(4)] + [("B", "odd", 60, False)]
    for label, run, n, vibrates in runs:
        for _ in range(n):
            w = rng.normal(0.0, 1.0, (2, t.size))
            if vibrates:
                w[0] += 1.5 * np.sin(2 * np.pi * 20.0 * t + rng.uniform(0, 2 * np.pi))
            X.append(w)
            y.append(label)
            groups.append(run)
    return np.asarray(X, dtype=np.float32), np.asarray(y), np.asarray(groups)


@pytest.mark.slow
def test_cnn_draws_its_epochs_by_the_window_weights():
    X, y, groups = _planted_with_an_odd_long_run()
    test = np.isin(groups, ["a3", "b3"])
    train = ~test
    weight = np.where(groups[train] == "odd", 0.0, 1.0)      # the odd run is never drawn
    fit = (lambda w, seed=0: RawCNNClassifier(**FAST, random_state=seed).fit(
        X[train], y[train], sample_weight=w))
    model = fit(weight)
    assert (model.predict(X[test]) == y[test]).mean() >= 0.9
    np.testing.assert_array_equal(model.predict_proba(X[test]),
                                  fit(weight).predict_proba(X[test]))      # deterministic
    uniform = fit(np.ones(train.sum()))
    assert np.abs(uniform.predict_proba(X[test]) - model.predict_proba(X[test])).max() > 1e-3
    # weight only on B's odd run: the vibration is never seen as B, unseen B is not found
    blind = fit(np.where(np.isin(groups[train], ["b0", "b1", "b2"]), 0.0, 1.0))
    assert (blind.predict(X[test]) == y[test]).mean() <= 0.7
    one_negative = np.where(np.arange(train.sum()) == 0, -1.0, weight)   # sum still > 0
    for bad in (np.zeros(train.sum()), -weight, one_negative, np.full(train.sum(), np.nan)):
        with pytest.raises(ValueError, match="sample_weight must be finite and >= 0"):
            fit(bad)
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        fit(np.ones(3))


@pytest.mark.slow
def test_fitted_cnn_keeps_neither_its_training_weights_nor_its_draw_generator():
    X, y, groups = _planted_with_an_odd_long_run()
    weighted = RawCNNClassifier(**FAST).fit(X, y, sample_weight=np.linspace(0.5, 2.0, len(y)))
    plain = RawCNNClassifier(**FAST).fit(X, y)
    for model in (weighted, plain):
        params = model.net_.get_params()
        assert params.get("iterator_train__sampler") is None
        assert params.get("iterator_train__generator") is None
        copy = pickle.loads(pickle.dumps(model))
        np.testing.assert_array_equal(copy.predict_proba(X), model.predict_proba(X))
    # the same draws as before the clean-up: a refit gives the same network
    np.testing.assert_array_equal(
        RawCNNClassifier(**FAST).fit(X, y, sample_weight=np.linspace(0.5, 2.0, len(y)))
        .predict_proba(X), weighted.predict_proba(X))


def test_registry_wraps_every_single_model_of_a_run_balanced_ensemble():
    channels = ("wx", "wy", "ax")
    model = make_model(ModelConfig(kind="ensemble", run_balanced=True, cnn_seeds=2), channels,
                       RATE_HZ, "borealtc")
    svm, bag = (est for _, est in model.estimators)
    assert isinstance(svm, RunBalancedClassifier) and svm.weight_param == "svc__sample_weight"
    assert isinstance(bag, SoftVotingEnsemble)
    assert all(isinstance(est, RunBalancedClassifier) and est.weight_param == "sample_weight"
               for _, est in bag.estimators)
    plain = make_model(ModelConfig(kind="ensemble"), channels, RATE_HZ, "borealtc")
    assert not any(isinstance(est, RunBalancedClassifier) for _, est in plain.estimators)
    with pytest.raises(ConfigError, match="window_ekf"):
        ModelConfig(kind="svm", run_balanced=True, window_ekf=True)


def test_experiment_config_hands_run_balance_to_the_model_and_refuses_it_with_search():
    from terrain.models.experiment import ExperimentConfig
    config = ExperimentConfig(model="ensemble", run_balanced=True)
    assert config.model_config().run_balanced and config.as_params()["run_balanced"]
    with pytest.raises(ConfigError, match="run-balanced"):
        ExperimentConfig(model="svm", search=True, run_balanced=True)


def test_fit_pipeline_serves_the_run_balanced_svm_it_is_asked_for(vulpi_runs):
    # terrain train --run-balanced: the served SVM is the run-balanced wrapper, fitted with
    # the windows' runs, and takes raw windows like the plain one
    from terrain.models.experiment import ExperimentConfig, fit_pipeline

    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                              run_balanced=True)
    model, ws, info = fit_pipeline(config, runs=vulpi_runs)
    assert isinstance(model, RunBalancedClassifier) and info["model"] == "svm"
    proba = model.predict_proba(ws.X[:3])
    assert proba.shape == (3, 4)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


def test_window_svm_is_a_hard_margin_fit_that_window_weights_do_not_move():
    """Why run balance reaches the ensemble through its CNN only: on the shipped Vulpi
    windows the SVM (C = 30, balanced classes) keeps no support vector at its bound, so
    weights, which scale C per window, leave its solution as it is."""
    from features.transformers import WindowFeatures
    from terrain.models.experiment import ExperimentConfig, load_windows
    from terrain.models.svm import SVMConfig, make_svm
    ws = load_windows(ExperimentConfig(dataset="vulpi"))
    F = WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz).fit(ws.X).transform(ws.X)
    y, groups = ws.labels.astype(str), np.asarray(ws.run_ids)
    plain = make_svm(SVMConfig(), 0).fit(F, y)
    svc = plain[-1]
    bound = svc.C * svc.class_weight_[np.searchsorted(svc.classes_, y[svc.support_])]
    assert (np.abs(svc.dual_coef_).max(axis=0) < 0.999 * bound).all()
    weighted = RunBalancedClassifier(make_svm(SVMConfig(), 0),
                                     weight_param="svc__sample_weight").fit(F, y, groups)
    assert np.ptp(within_class_run_weights(y, groups)) > 1.0       # the weights do differ
    np.testing.assert_allclose(weighted.estimator_.decision_function(F),
                               plain.decision_function(F), atol=1e-9)


def test_run_cv_cross_validates_the_run_balanced_svm_it_is_asked_for(vulpi_runs, monkeypatch):
    import terrain.models.experiment as experiment
    from terrain.models.experiment import ExperimentConfig, run_cv

    class Captured(Exception):
        pass

    def capture(factory, *args, **kwargs):
        raise Captured(factory)

    monkeypatch.setattr(experiment, "cross_validate", capture)
    for balanced in (True, False):
        config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                                  run_balanced=balanced)
        with pytest.raises(Captured) as caught:
            run_cv(config, runs=vulpi_runs)
        model = caught.value.args[0](0)
        assert isinstance(model, RunBalancedClassifier) is balanced
        if balanced:
            assert model.weight_param == "svc__sample_weight"
