"""Review tests (ens4) of the NumPy path of the calibrated SVM."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils.multiclass import _ovr_decision_function

from terrain.models.svm import _CalibratedRBF, _pair_matrices, calibrated_rbf_proba


@pytest.mark.parametrize("intercept", [[0.0, 0.0, 0.0], [0.0, 0.4, -0.2], [-0.3, 0.0, 0.0]])
def test_a_pair_decided_at_exactly_zero_votes_for_its_first_class_as_sklearn(intercept):
    # SVC.decision_function (ovr) votes with `dec < 0` for the second class of a pair, so a
    # decision value of exactly 0 is a vote for the first; the support vector lies so far
    # away that its kernel is exactly 0 and the decision values are the intercepts
    first, second = _pair_matrices(3)
    sv = np.array([[1e3, 1e3]])
    arrays = _CalibratedRBF(support_vectors=sv, support_sq_norms=(sv * sv).sum(axis=1),
                            pair_coef=np.ones((3, 1)), intercept=np.asarray(intercept),
                            gamma=1.0, first=first, second=second,
                            sigmoid_a=np.full(3, -1.0), sigmoid_b=np.zeros(3),
                            columns=np.arange(3), n_classes=3)
    X = np.zeros((2, 2))
    dec = np.tile(np.asarray(intercept), (2, 1))
    ovr = _ovr_decision_function(dec < 0, -dec, 3)
    expected = 1.0 / (1.0 + np.exp(-ovr))
    expected /= expected.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(calibrated_rbf_proba(X, arrays), expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("value", ["no", "false", 0, 1, None])
def test_probability_is_true_or_false_not_anything_truthy(value):
    # probability="no" was truthy and wrapped the SVC in Platt calibration
    from terrain.errors import ConfigError
    from terrain.models.svm import SVMConfig
    with pytest.raises(ConfigError, match="SVMConfig.probability must be True or False"):
        SVMConfig(probability=value)
    assert SVMConfig(probability=np.bool_(True)).probability
