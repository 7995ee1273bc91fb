"""The NumPy prediction path of the served SVM equals scikit-learn's on real windows."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.calibration import CalibratedClassifierCV
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from features.windows import WindowConfig, make_windows
from terrain.models.registry import ModelConfig, make_model
from terrain.models.svm import SVMConfig, SVMPipeline, make_svm


@pytest.fixture(scope="module", params=["borealtc", "vulpi"])
def fitted(request, borealtc_runs, vulpi_runs):
    runs = borealtc_runs if request.param == "borealtc" else vulpi_runs
    ws = make_windows(runs, "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    y = ws.labels.astype(str)
    train = np.arange(len(y)) % 3 != 0
    model = make_model(ModelConfig(kind="svm"), ws.channels, ws.rate_hz, request.param, 0)
    model.fit(ws.X[train], y[train])
    return model, ws.X[~train]


@pytest.mark.slow
def test_fast_proba_equals_sklearn_pipeline(fitted):
    model, X_test = fitted
    assert isinstance(model, SVMPipeline) and model._compiled() is not None
    reference = Pipeline(model.steps)              # scikit-learn's own path, same fitted steps
    fast = model.predict_proba(X_test)
    np.testing.assert_allclose(fast, reference.predict_proba(X_test), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(model.predict(X_test), reference.predict(X_test))
    np.testing.assert_allclose(fast.sum(axis=1), 1.0)
    single = np.concatenate([model.predict_proba(X_test[i:i + 1]) for i in range(20)])
    np.testing.assert_allclose(single, fast[:20], rtol=0, atol=1e-12)


def test_refit_renews_the_arrays_and_a_replaced_step_falls_back(fitted):
    model, X_test = fitted
    twin = clone(model)
    assert "_fast_arrays" not in twin.__dict__ and twin._compiled() is None
    rng = np.random.default_rng(0)
    labels = np.array(sorted(model.classes_))
    y = labels[rng.integers(0, len(labels), len(X_test))]
    twin.fit(X_test, y)
    np.testing.assert_allclose(twin.predict_proba(X_test),
                               Pipeline(twin.steps).predict_proba(X_test), rtol=0, atol=1e-12)
    assert twin._compiled() is not model._compiled()
    # a final step swapped in after fitting is not the one the arrays came from
    twin.steps[-1] = ("svc", model.steps[-1][1])
    assert twin._compiled() is None
    np.testing.assert_array_equal(twin.predict_proba(X_test),
                                  Pipeline(twin.steps).predict_proba(X_test))


def test_binary_and_uncalibrated_fall_back_to_sklearn():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((60, 4))
    y = np.where(X[:, 0] > 0, "a", "b")
    binary = SVMPipeline(make_svm(SVMConfig(probability=True)).steps).fit(X, y)
    assert binary._compiled() is None
    np.testing.assert_allclose(binary.predict_proba(X),
                               Pipeline(binary.steps).predict_proba(X))
    plain = SVMPipeline(make_svm(SVMConfig(probability=False)).steps).fit(X, y)
    assert plain._compiled() is None
    np.testing.assert_array_equal(plain.predict(X), Pipeline(plain.steps).predict(X))


def _four_class_svm():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 5))
    y = np.array(list("abcd"))[(X[:, 0] > 0).astype(int) + 2 * (X[:, 1] > 0)]
    model = SVMPipeline(make_svm(SVMConfig(probability=True)).steps).fit(X, y)
    assert model._compiled() is not None
    return model, X


def test_fast_path_refuses_nan_features_as_sklearn_does():
    # the NumPy path gave a NaN row (and predict the first class, 'a') where scikit-learn's
    # SVC raises 'Input X contains NaN'
    model, X = _four_class_svm()
    Xn = X[:2].copy()
    Xn[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        Pipeline(model.steps).predict_proba(Xn)
    for method in (model.predict_proba, model.predict):
        with pytest.raises(ValueError, match="NaN"):
            method(Xn)


def test_fast_path_on_float32_features_equals_sklearn():
    # the NumPy path squared float32 features in float32 (3.4e-9 off scikit-learn, whose
    # SVC casts to float64 first)
    model, X = _four_class_svm()
    X32 = X[:20].astype(np.float32)
    np.testing.assert_allclose(model.predict_proba(X32), Pipeline(model.steps).predict_proba(X32),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("calibration, shape", [
    ({"method": "sigmoid", "ensemble": True}, "ovr"),     # five calibrated copies, averaged
    ({"method": "isotonic", "ensemble": False}, "ovr"),   # no sigmoid a, b to read
    ({"method": "sigmoid", "ensemble": False}, "ovo"),    # pair values calibrated as classes
])
def test_calibrations_the_numpy_path_does_not_reproduce_fall_back_to_sklearn(calibration,
                                                                             shape):
    # the fast path reads one sigmoid per class over scikit-learn's one-vs-rest vote
    # transform of a single calibrated SVC: anything else must take scikit-learn's path
    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 5))
    y = np.array(list("abcd"))[(X[:, 0] > 0).astype(int) + 2 * (X[:, 1] > 0)]
    svc = SVC(C=30.0, class_weight="balanced", decision_function_shape=shape, random_state=0)
    model = SVMPipeline([("scale", StandardScaler()),
                         ("svc", CalibratedClassifierCV(svc, **calibration))]).fit(X, y)
    assert model._compiled() is None
    np.testing.assert_allclose(model.predict_proba(X), Pipeline(model.steps).predict_proba(X),
                               rtol=0, atol=1e-12)


def test_make_svm_balances_the_classes_and_uses_the_configured_kernel_width():
    # 150 windows of class a, 30 of b, 20 of c: each class weighs n / (3 n_class)
    rng = np.random.default_rng(0)
    y = np.repeat(["a", "b", "c"], [150, 30, 20])
    X = rng.normal(size=(len(y), 3)) + np.searchsorted(["a", "b", "c"], y)[:, None]
    svc = make_svm(SVMConfig(C=3.0, gamma=0.05)).fit(X, y).named_steps["svc"]
    np.testing.assert_allclose(svc.class_weight_, [200 / 450, 200 / 90, 200 / 60])
    assert svc.C == 3.0 and svc._gamma == 0.05
    calibrated = make_svm(SVMConfig(gamma=0.05, probability=True)).named_steps["svc"]
    assert calibrated.estimator.gamma == 0.05
