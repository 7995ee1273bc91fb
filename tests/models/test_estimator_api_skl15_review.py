"""scikit-learn API conformance of every window classifier, on tiny 3-D windows.

scikit-learn's ``check_estimator`` feeds 2-D tabular data; the classifiers here take windows
``(n_windows, n_channels, n_samples)`` (the CNNs, which also read 2-D as one channel, are
checked by it in ``test_cnn.py``, the SVM on features in ``test_sklearn_contract.py``). The
checks below are scikit-learn's API rules restated on windows: ``clone``, ``get_params`` /
``set_params``, fit leaving its inputs alone, the fitted attributes, ``NotFittedError``
before fit, probabilities in the order of ``classes_``, pickling, labels and a refit.
"""

from __future__ import annotations

import inspect
import io
import pickle

import joblib
import numpy as np
import pytest
import sklearn.utils.estimator_checks as sk_checks
from sklearn.base import clone
from sklearn.ensemble import ExtraTreesClassifier
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import check_is_fitted

from features.ekf_signals import EKF_CHANNELS
from features.transformers import WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.forest import ForestPipeline
from terrain.models.minirocket import MiniRocketFeatures, make_minirocket
from terrain.models.svm import SVMConfig, svm_window_pipeline
from terrain.models.weighting import run_balanced
from terrain.models.window_ekf import WindowEKFClassifier
from terrain.slip.learned import SlipRegressor

pytestmark = pytest.mark.filterwarnings("ignore::FutureWarning")

RATE_HZ = 50.0
#: wheel speeds and yaw rate first (the EKF wrapper reads them), then three more channels
CHANNELS = ("vel_l", "vel_r", "wz", "ax", "ay", "az")
#: tiny, fast networks: the interface is tested here, not learning
CNN = dict(max_epochs=2, width=4, batch_size=16, device="cpu", n_threads=1)


def _windows(classes=("ICE", "MUD", "SNOW"), runs: int = 3, per_run: int = 5,
             n_samples: int = 64, seed: int = 0):
    """Windows whose level and spread depend on the class; one run id per (class, run)."""
    rng = np.random.default_rng(seed)
    X, y, groups = [], [], []
    for k, c in enumerate(classes):
        for r in range(runs):
            for _ in range(per_run):
                w = rng.normal(0.3 * k, 0.1 * (1 + k), (len(CHANNELS), n_samples))
                w[:2] += 0.5      # driving forward
                X.append(w)
                y.append(c)
                groups.append(f"{c}/{r:02d}")
    return np.asarray(X), np.asarray(y), np.asarray(groups)


def _svm():
    return svm_window_pipeline(CHANNELS, RATE_HZ, SVMConfig(probability=True))


FACTORIES = {
    "svm": _svm,
    "cnn": lambda: RawCNNClassifier(**CNN),
    "cnn-spectrogram": lambda: SpectrogramCNNClassifier(rate_hz=RATE_HZ, segment_s=0.2,
                                                        hop_s=0.1, **CNN),
    "minirocket": lambda: make_minirocket(n_kernels=84, max_dilations_per_kernel=4),
    "ensemble": lambda: SoftVotingEnsemble([("svm", _svm()),
                                            ("cnn", RawCNNClassifier(**CNN))], inner_splits=3),
    "run-balanced": lambda: run_balanced(_svm()),
    "window-ekf": lambda: WindowEKFClassifier(
        svm_window_pipeline(CHANNELS + tuple(EKF_CHANNELS), RATE_HZ,
                            SVMConfig(probability=True)), CHANNELS, RATE_HZ),
    "extra-trees": lambda: ForestPipeline([("features", WindowFeatures(CHANNELS, RATE_HZ)),
                                           ("trees", ExtraTreesClassifier(20, random_state=0))]),
}
KINDS = list(FACTORIES)


def _fit(estimator, X, y, groups):
    if "groups" in inspect.signature(estimator.fit).parameters:
        return estimator.fit(X, y, groups=groups)
    return estimator.fit(X, y)


@pytest.fixture(scope="module")
def data():
    return _windows()


@pytest.fixture(scope="module")
def fitted(data):
    X, y, groups = data
    return {kind: _fit(make(), X, y, groups) for kind, make in FACTORIES.items()}


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_clone_of_a_fitted_model_is_unfitted_with_equal_parameters(kind, fitted, data):
    model = fitted[kind]
    copy = clone(model)
    assert type(copy) is type(model)
    assert repr(copy.get_params(deep=False)) == repr(model.get_params(deep=False))
    with pytest.raises(NotFittedError):
        check_is_fitted(copy)
    with pytest.raises(NotFittedError):
        copy.predict_proba(data[0][:2])


@pytest.mark.parametrize("kind", KINDS)
def test_set_params_of_get_params_changes_nothing(kind):
    model = FACTORIES[kind]()
    before = repr(model.get_params(deep=True))
    model.set_params(**model.get_params(deep=False))
    assert repr(model.get_params(deep=True)) == before
    assert repr(clone(model).get_params(deep=True)) == before


@pytest.mark.parametrize("kind", KINDS)
def test_predict_before_fit_is_not_fitted_error(kind, data):
    model = FACTORIES[kind]()
    for method in (model.predict, model.predict_proba):
        with pytest.raises(NotFittedError):
            method(data[0][:2])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("kind", KINDS)
def test_fit_and_predict_leave_their_inputs_unchanged(kind, dtype, data):
    X, y, groups = data
    X = X.astype(dtype)
    kept = X.copy(), y.copy(), groups.copy()
    model = _fit(FACTORIES[kind](), X, y, groups)
    model.predict_proba(X)
    model.predict(X[:1])
    for now, before in zip((X, y, groups), kept):
        np.testing.assert_array_equal(now, before)


@pytest.mark.parametrize("kind", KINDS)
def test_fitted_attributes_and_probabilities_follow_classes(kind, fitted, data):
    X, y, _ = data
    model = fitted[kind]
    assert list(model.classes_) == ["ICE", "MUD", "SNOW"]     # sorted text labels
    assert model.n_features_in_ == len(CHANNELS)              # channels of the windows
    proba = model.predict_proba(X)
    assert proba.shape == (len(X), 3)
    assert np.all(proba >= 0)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    np.testing.assert_array_equal(model.predict(X), model.classes_[proba.argmax(axis=1)])


@pytest.mark.parametrize("kind", KINDS)
def test_pickle_and_joblib_round_trips_predict_the_same(kind, fitted, data):
    X = data[0]
    model = fitted[kind]
    proba = model.predict_proba(X)
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(model)).predict_proba(X), proba)
    buffer = io.BytesIO()
    joblib.dump(model, buffer)
    buffer.seek(0)
    np.testing.assert_array_equal(joblib.load(buffer).predict_proba(X), proba)


@pytest.mark.parametrize("kind", KINDS)
def test_a_refit_forgets_the_first_fit(kind, fitted, data):
    # a model fitted on three classes, then on two others' windows, is the model fitted on
    # those alone: no class, weight, scaling or member of the first fit survives
    X, y, groups = data
    keep = y != "MUD"
    refit = pickle.loads(pickle.dumps(fitted[kind]))
    _fit(refit, X[keep], y[keep], groups[keep])
    fresh = _fit(FACTORIES[kind](), X[keep], y[keep], groups[keep])
    assert list(refit.classes_) == ["ICE", "SNOW"]
    np.testing.assert_array_equal(refit.predict_proba(X), fresh.predict_proba(X))


@pytest.mark.parametrize("kind", KINDS)
def test_labels_renamed_in_their_sort_order_give_the_same_model(kind, data):
    # text or integer labels, any names: only their order sets the columns
    X, y, groups = data
    rename = {"ICE": 0, "MUD": 1, "SNOW": 2}
    a = _fit(FACTORIES[kind](), X, y, groups)
    b = _fit(FACTORIES[kind](), X, np.array([rename[v] for v in y]), groups)
    assert list(b.classes_) == [0, 1, 2]
    np.testing.assert_array_equal(a.predict_proba(X), b.predict_proba(X))


@pytest.mark.parametrize("kind", ["extra-trees"])
def test_shuffled_training_order_gives_the_same_model(kind, data):
    # the models whose fit does not depend on the window order (the SVM's calibration folds,
    # the networks' minibatches and MiniRocket's bias sample do, by design)
    X, y, groups = data
    order = np.random.default_rng(1).permutation(len(X))
    a = _fit(FACTORIES[kind](), X, y, groups)
    b = _fit(FACTORIES[kind](), X[order], y[order], groups[order])
    np.testing.assert_array_equal(a.predict_proba(X), b.predict_proba(X))


@pytest.mark.parametrize("kind", KINDS)
def test_shuffled_training_order_keeps_classes_and_most_predictions(kind, data):
    X, y, groups = data
    order = np.random.default_rng(2).permutation(len(X))
    a = _fit(FACTORIES[kind](), X, y, groups)
    b = _fit(FACTORIES[kind](), X[order], y[order], groups[order])
    np.testing.assert_array_equal(a.classes_, b.classes_)
    assert a.predict_proba(X).shape == b.predict_proba(X).shape
    if kind not in ("cnn", "cnn-spectrogram"):     # (2 epochs: not trained to agree)
        assert np.mean(a.predict(X) == b.predict(X)) >= 0.9


def test_minirocket_features_before_fit_are_not_fitted_error(data):
    # was AttributeError: 'MiniRocketFeatures' object has no attribute 'rocket_'
    with pytest.raises(NotFittedError):
        MiniRocketFeatures(n_kernels=84).transform(data[0][:2])


#: scikit-learn checks that need no data: parameters, init, repr, clone, tags
API_CHECKS = ("check_no_attributes_set_in_init", "check_get_params_invariance",
              "check_set_params", "check_estimator_repr",
              "check_do_not_raise_errors_in_init_or_set_params", "check_estimator_cloneable",
              "check_mixin_order", "check_valid_tag_types", "check_estimator_tags_renamed",
              "check_parameters_default_constructible")
ALL_ESTIMATORS = {**{k: make for k, make in FACTORIES.items()},
                  "window-features": lambda: WindowFeatures(CHANNELS, RATE_HZ),
                  "wheel-physics": WheelPhysicsFeatures,
                  "minirocket-features": MiniRocketFeatures,
                  "slip-regressor": SlipRegressor}


@pytest.mark.parametrize("check", API_CHECKS)
@pytest.mark.parametrize("kind", list(ALL_ESTIMATORS))
def test_scikit_learn_api_checks_that_need_no_data(kind, check):
    estimator = ALL_ESTIMATORS[kind]()
    getattr(sk_checks, check)(type(estimator).__name__, estimator)


#: why scikit-learn's data checks (``check_estimator``) are not run on these estimators
NOT_TABULAR = {
    "window-features": "takes 3-D windows of named channels; 2-D tabular X is refused",
    "wheel-physics": "takes 3-D windows holding the four wheel channels",
    "minirocket-features": "aeon's MiniRocket needs series of >= 9 samples; the checks' 2-D "
                           "tables read as series of 1-5 samples",
    "run-balanced": "fit needs the run of every window (groups); the checks give none",
    "window-ekf": "takes 3-D windows holding vel_l, vel_r and wz",
    "slip-regressor": "y is (n_windows, 4) slips, chi and lateral velocity, not 1-D",
    "svm / extra-trees / ensemble on windows": "windows go through WindowFeatures first "
                                               "(3-D); the SVM on features and the ensemble "
                                               "of 3-D-tolerant members are checked in "
                                               "test_sklearn_contract.py and "
                                               "test_ensemble_contract_review.py",
}


@pytest.mark.parametrize("kind", list(NOT_TABULAR))
def test_check_estimator_does_not_apply(kind):
    pytest.skip(NOT_TABULAR[kind])


class _MeanWindowClassifier:
    """A 3-D-window classifier that records no ``n_features_in_`` (a plain duck type)."""

    def get_params(self, deep=True):
        return {}

    def set_params(self, **params):
        return self

    def fit(self, X, y, sample_weight=None):
        from sklearn.naive_bayes import GaussianNB

        self.model_ = GaussianNB().fit(X.mean(axis=2), y, sample_weight=sample_weight)
        self.classes_ = self.model_.classes_
        return self

    def predict_proba(self, X):
        return self.model_.predict_proba(X.mean(axis=2))

    def predict(self, X):
        return self.model_.predict(X.mean(axis=2))


def test_run_balanced_records_the_channels_when_its_classifier_does_not(data):
    X, y, groups = data
    model = run_balanced(_MeanWindowClassifier()).fit(X, y, groups=groups)
    assert not hasattr(model.estimator_, "n_features_in_")
    assert model.n_features_in_ == len(CHANNELS)     # X.shape[1], not the samples
