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

from terrain.errors import NonFiniteInputError
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.weighting import run_shares, within_class_run_weights

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


@pytest.mark.parametrize("labels, groups, name", [
    (np.array([1.0, np.nan, np.nan, 2.0]), np.array(["a", "b", "b", "c"]), "labels"),
    (np.array(["x", "x", "x"]), np.array([1.0, np.nan, np.nan]), "groups"),
    (np.array(["x", "x", "x"]), np.array(["a", None, None], dtype=object), "groups"),
    (np.array(["x", None], dtype=object), np.array(["a", "a"]), "labels")])
def test_a_missing_label_or_run_is_refused_not_weighted_from_unset_memory(labels, groups, name):
    # a NaN label or run equals nothing (labels == nan is all False), so its windows'
    # shares were never written: np.empty's leftovers came back as weights (labels
    # [1, nan, nan, 2] gave [1, 3, 6, 1]), and a None run was a bare TypeError from sorting
    with pytest.raises(NonFiniteInputError, match=rf"{name}.*index 1"):
        run_shares(labels, groups)
    with pytest.raises(NonFiniteInputError, match=name):
        within_class_run_weights(labels, groups)


def test_one_run_per_class_or_no_window_gives_unit_weights():
    np.testing.assert_array_equal(within_class_run_weights(["A", "A", "B"], [0, 0, 1]),
                                  [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(run_shares(["A", "A", "B"], [0, 0, 1]), [0.5, 0.5, 1.0])
    assert within_class_run_weights([], []).shape == (0,)
    # runs numbered alike in two classes are two runs: class A's run 0 and class B's run 0
    np.testing.assert_allclose(within_class_run_weights(["A", "A", "A", "B"], [0, 0, 1, 0]),
                               [0.75, 0.75, 1.5, 1.0])


def test_run_balanced_wrapper_takes_an_array_like_that_is_not_an_ndarray():
    # np.shape(X) in fit called the array-like's __array_function__, which scikit-learn's
    # _NotAnArray refuses (TypeError), although the wrapped LogisticRegression takes it
    from sklearn.utils.estimator_checks import _NotAnArray

    from terrain.models.weighting import RunBalancedClassifier
    rng = np.random.default_rng(0)
    X, y, groups = rng.normal(size=(20, 3)), np.repeat(["A", "B"], 10), np.arange(20) % 4
    wrapped = RunBalancedClassifier(LogisticRegression()).fit(_NotAnArray(X), y, groups)
    direct = RunBalancedClassifier(LogisticRegression()).fit(X, y, groups)
    assert wrapped.n_features_in_ == 3
    np.testing.assert_allclose(wrapped.predict_proba(X), direct.predict_proba(X))
