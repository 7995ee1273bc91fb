"""Review of the SVM's nested search (:func:`terrain.models.svm.make_search`): inner folds
grouped by run and shuffled by the seed, candidates scored by macro F1 on those folds."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.metrics import f1_score

from terrain.models.svm import SVMConfig, make_search, make_svm


def _runs(n_runs=12, per_run=6, seed=0):
    """Features, labels and runs: every run one class (three classes, one rare)."""
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(n_runs), per_run)
    run_class = np.array(["a", "b", "a", "b", "a", "c"] * (n_runs // 6))
    y = run_class[groups]
    X = rng.normal(size=(len(y), 4)) + (y == "a")[:, None] * 0.8
    return X, y, groups


def _test_runs(search, X, y, groups):
    return [frozenset(np.unique(groups[test]).tolist())
            for _, test in search.cv.split(X, y, groups)]


def test_inner_folds_are_grouped_by_run_and_shuffled_by_the_seed():
    X, y, groups = _runs()
    for seed in (0, 1, 2):
        search = make_search(SVMConfig(inner_splits=3), seed)
        assert search.cv.get_n_splits() == 3
        for train, test in search.cv.split(X, y, groups):
            assert not set(groups[train]) & set(groups[test])     # no run on both sides
        # the same seed gives the same folds (reproducible search) ...
        again = make_search(SVMConfig(), seed)
        assert _test_runs(search, X, y, groups) == _test_runs(again, X, y, groups)
    # ... and another seed other folds (the CV seeds vary the inner split too)
    folds = set()
    for seed in range(4):
        runs = _test_runs(make_search(SVMConfig(), seed), X, y, groups)
        folds.add(tuple(sorted(tuple(sorted(f)) for f in runs)))
    assert len(folds) > 1


def test_every_candidate_of_the_grid_is_scored_by_macro_f1_of_the_inner_folds():
    # a rare class makes accuracy and macro F1 differ: each candidate's score is the mean
    # macro F1 of that candidate refitted on each inner training split
    X, y, groups = _runs()
    config = SVMConfig(search_C=(1.0, 10.0), search_gamma=("scale", 0.1))
    search = make_search(config, random_state=5).fit(X, y, groups=groups)
    params = search.cv_results_["params"]
    assert sorted((p["svc__C"], str(p["svc__gamma"])) for p in params) == [
        (1.0, "0.1"), (1.0, "scale"), (10.0, "0.1"), (10.0, "scale")]
    for k, p in enumerate(params):
        candidate = replace(config, C=p["svc__C"], gamma=p["svc__gamma"])
        expected = []
        for train, test in search.cv.split(X, y, groups):
            model = clone(make_svm(candidate, 5)).fit(X[train], y[train])
            expected.append(f1_score(y[test], model.predict(X[test]), average="macro"))
        assert search.cv_results_["mean_test_score"][k] == pytest.approx(np.mean(expected),
                                                                         abs=1e-12)
    best = params[int(np.argmax(search.cv_results_["mean_test_score"]))]
    assert search.best_params_ == best
    # refitted on every training window with the chosen settings
    svc = search.best_estimator_.named_steps["svc"]
    assert (svc.C, svc.gamma) == (best["svc__C"], best["svc__gamma"])


@pytest.mark.parametrize("probability", [False, True])
def test_the_svm_weighs_each_class_inversely_to_its_windows(probability):
    # class_weight="balanced": n / (n_classes n_c), so a rare terrain is not out-voted by
    # the common ones (README: class weights fitted on the training windows only)
    X, y, _ = _runs()                                   # a 36, b 24, c 12 windows
    pipe = make_svm(SVMConfig(probability=probability)).fit(X, y)
    svc = pipe.named_steps["svc"]
    svc = svc.calibrated_classifiers_[0].estimator if probability else svc
    np.testing.assert_allclose(svc.class_weight_, [72 / (3 * 36), 72 / (3 * 24), 72 / (3 * 12)])
