"""Review tests (ens4) of the soft-voting ensemble's scikit-learn contract and of the
run-balanced weights' refusals."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.linear_model import LogisticRegression
from sklearn.tree import DecisionTreeClassifier
from sklearn.utils import get_tags
from sklearn.utils.estimator_checks import check_classifier_data_not_an_array
from sklearn.utils.estimator_checks import parametrize_with_checks

from terrain.models.ensemble import SoftVotingEnsemble

#: check_supervised_y_no_nan feeds NaN labels on purpose; sklearn's cast warns before raising
pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered in cast:RuntimeWarning")


def _members():
    return [("lr", LogisticRegression()), ("tree", DecisionTreeClassifier(random_state=0))]


@parametrize_with_checks([SoftVotingEnsemble(_members()),
                          SoftVotingEnsemble(_members(), weights=(1.0, 3.0))])
def test_soft_voting_ensemble_follows_sklearn_contract(estimator, check):
    # every check, none expected to fail: the input tags follow the members (both take
    # sparse input here; the sparse tag said no and sparse fits passed)
    check(estimator)


def test_input_tags_are_those_every_member_has():
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.svm import SVC
    both = get_tags(SoftVotingEnsemble(_members())).input_tags
    assert both.sparse and not both.allow_nan
    nan = get_tags(SoftVotingEnsemble([("hgb", HistGradientBoostingClassifier()),
                                       ("hgb2", HistGradientBoostingClassifier())])).input_tags
    assert nan.allow_nan and not nan.sparse
    mixed = get_tags(SoftVotingEnsemble([("hgb", HistGradientBoostingClassifier()),
                                         ("svc", SVC())])).input_tags
    assert not mixed.allow_nan and not mixed.sparse


def test_an_array_like_that_is_not_an_ndarray_is_fitted_as_its_array():
    # np.shape(X) in fit called the array-like's __array_function__, which scikit-learn's
    # _NotAnArray refuses (TypeError "Don't want to call array_function shape!")
    check_classifier_data_not_an_array("SoftVotingEnsemble", SoftVotingEnsemble(_members()))


def test_weights_are_chosen_for_a_list_input_as_for_its_array():
    # X[tr] on a list was Python's "list indices must be integers" TypeError
    rng = np.random.default_rng(0)
    groups = np.repeat(np.arange(8), 5)
    y = np.where(groups % 2 == 0, "A", "B")
    X = rng.normal(size=(40, 3)) + (y == "B")[:, None]
    ens = SoftVotingEnsemble(_members(), weight_step=0.5)
    a = clone(ens).fit(X, y, groups=groups)
    b = clone(ens).fit(X.tolist(), y, groups=groups)
    np.testing.assert_array_equal(a.weights_, b.weights_)
    assert a.weight_scores_ == b.weight_scores_
    np.testing.assert_array_equal(a.predict_proba(X), b.predict_proba(X.tolist()))
    assert b.n_features_in_ == 3
