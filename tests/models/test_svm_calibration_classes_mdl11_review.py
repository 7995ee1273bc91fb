"""Review tests (mdl11): the Platt-calibrated SVM pipeline over a class with a single training
window, or classes all smaller than its calibration folds, is a ConfigError naming the class,
not scikit-learn's bare ValueError from inside the calibration's cross_val_predict."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.preprocessing import StandardScaler

from terrain.errors import ConfigError
from terrain.models.svm import SVMConfig, SVMPipeline, make_svm

RNG = np.random.default_rng(0)


def _calibrated() -> SVMPipeline:
    return SVMPipeline(make_svm(SVMConfig(probability=True)).steps)


def test_a_class_with_one_training_window_is_named():
    # before: "ValueError: Only 2 class/es in training fold, but 3 in overall dataset. This
    # is not supported for decision_function with imbalanced folds."
    y = np.array(["A"] * 20 + ["B"] * 20 + ["C"])
    with pytest.raises(ConfigError, match=r"\['C'\].*1 training window"):
        _calibrated().fit(RNG.normal(size=(len(y), 3)), y)


def test_classes_all_smaller_than_the_calibration_folds_are_refused():
    # before: "ValueError: n_splits=5 cannot be greater than the number of members in each
    # class"
    y = np.array(["A"] * 4 + ["B"] * 4)
    with pytest.raises(ConfigError, match="5 calibration folds"):
        _calibrated().fit(RNG.normal(size=(len(y), 3)), y)


def test_two_windows_of_a_class_are_enough_and_the_plain_svc_is_unchecked():
    y = np.array(["A"] * 20 + ["B"] * 20 + ["C"] * 2)
    X = RNG.normal(size=(len(y), 3))
    proba = _calibrated().fit(X, y).predict_proba(X[:2])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    y1 = np.array(["A"] * 20 + ["B"] * 20 + ["C"])     # no calibration: one window is fitted
    plain = SVMPipeline([("scale", StandardScaler())] + make_svm(SVMConfig()).steps[1:])
    assert set(plain.fit(X[:41], y1).predict(X[:41])) <= {"A", "B", "C"}
