"""Review (mdl7) of the window classifiers: the nested search of a calibrated SVM, the
scikit-learn attributes of the window-EKF wrapper, the single-run time blocks, the soft
vote's weights, the inner-fold run count, the confusion frame and missing labels or runs."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.calibration import CalibratedClassifierCV
from sklearn.dummy import DummyClassifier

from features.ekf_signals import EKF_CHANNELS
from terrain.models.svm import SVMConfig, make_search
from terrain.models.window_ekf import WindowEKFClassifier


def _runs(n_runs=12, per_run=6, seed=0):
    """Features, labels and runs: every run one class (three classes)."""
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(n_runs), per_run)
    y = np.array(["a", "b", "c"] * (n_runs // 3))[groups]
    X = rng.normal(size=(len(y), 4)) + (y == "a")[:, None] * 1.5 - (y == "c")[:, None] * 1.5
    return X, y, groups


@pytest.mark.slow
def test_the_search_of_a_calibrated_svm_tunes_the_svc_inside_the_calibration():
    # the grid named svc__C / svc__gamma, parameters of the SVC: with probability=True the
    # step is a CalibratedClassifierCV and the search raised scikit-learn's bare
    # "Invalid parameter 'C' for estimator CalibratedClassifierCV" at its first fit
    X, y, groups = _runs()
    config = SVMConfig(probability=True, search_C=(1.0, 10.0), search_gamma=("scale", 0.1))
    search = make_search(config, random_state=2).fit(X, y, groups=groups)
    svc = search.best_estimator_.named_steps["svc"]
    assert isinstance(svc, CalibratedClassifierCV)
    best = search.best_params_
    assert set(best) == {"svc__estimator__C", "svc__estimator__gamma"}
    assert (svc.estimator.C, svc.estimator.gamma) == (best["svc__estimator__C"],
                                                      best["svc__estimator__gamma"])
    assert len(search.cv_results_["params"]) == 4
    np.testing.assert_allclose(search.predict_proba(X).sum(axis=1), 1.0)


def test_fit_pipeline_searches_for_a_calibrated_svm_config(vulpi_runs):
    # fit_pipeline serves a calibrated SVM whatever config.svm.probability says and reads
    # the search's svc__C / svc__gamma: its search tunes the plain SVC
    from terrain.models.experiment import ExperimentConfig, fit_pipeline

    svm = SVMConfig(probability=True, inner_splits=2, search_C=(1.0, 10.0),
                    search_gamma=("scale",))
    config = ExperimentConfig(dataset="vulpi", seeds=(0,), search=True, svm=svm)
    model, ws, info = fit_pipeline(config, runs=vulpi_runs)
    assert info["best_C"] in (1.0, 10.0) and info["best_gamma"] == "scale"
    svc = model.named_steps["svc"]
    assert isinstance(svc, CalibratedClassifierCV) and svc.estimator.C == info["best_C"]
    np.testing.assert_allclose(model.predict_proba(ws.X[:5]).sum(axis=1), 1.0)


def test_the_window_ekf_wrapper_records_its_input_width_as_scikit_learn_asks():
    # scikit-learn's fitted-estimator convention (n_features_in_, as RunBalancedClassifier
    # and SoftVotingEnsemble keep): the wrapper kept none, so tools reading the input width
    # of a fitted model (check_n_features_in, serving checks) found nothing
    rng = np.random.default_rng(0)
    X = rng.normal(0.5, 0.1, size=(6, 4, 40))           # 4 channels, 2 s at 20 Hz
    y = np.array(list("ababab"))
    model = WindowEKFClassifier(DummyClassifier(), ("vel_l", "vel_r", "wz", "ax"), 20.0)
    assert model.fit(X, y).n_features_in_ == 4          # the windows' channels, not augmented
    # what the wrapped model saw: the channels and the EKF's
    assert model.estimator_.n_features_in_ == 4 + len(EKF_CHANNELS)


def test_only_a_class_of_a_single_run_is_cut_into_time_blocks():
    # a class of two or three runs is split by run like any other: cutting it into blocks
    # would put windows of both runs into one block (named after the first run), a test
    # block then sharing a run with a training block
    from terrain.models.cv import split_single_run_classes

    runs = np.array(["d/0"] * 8 + ["g/1"] * 4 + ["g/2"] * 4 + ["s/1", "s/2", "s/3"] * 2,
                    dtype=object)
    labels = np.array([r.split("/")[0] for r in runs], dtype=object)
    t0 = np.arange(runs.size, dtype=float)
    groups, split = split_single_run_classes(labels, runs.copy(), t0, n_blocks=2)
    assert split == ["d"]
    assert groups[:8].tolist() == ["d/0@block0"] * 4 + ["d/0@block1"] * 4
    assert groups[8:].tolist() == runs[8:].tolist()


def test_tied_weight_vectors_go_to_the_first_of_the_grid():
    # two identical members score every weight vector the same (to rounding): the choice is
    # the first vector of simplex_grid's order, (0, 1), not whichever comes last
    from terrain.models.ensemble import SoftVotingEnsemble, simplex_grid

    X, y, groups = _runs()
    members = [("a", DummyClassifier(strategy="prior")), ("b", DummyClassifier(strategy="prior"))]
    model = SoftVotingEnsemble(members, weight_step=0.25, inner_splits=3).fit(X, y, groups)
    scores = list(model.weight_scores_.values())
    assert max(scores) - min(scores) < 1e-12 and len(scores) == 5
    np.testing.assert_array_equal(model.weights_, simplex_grid(2, 0.25)[0])
    np.testing.assert_array_equal(model.weights_, [0.0, 1.0])


def test_the_vote_weighs_each_members_probabilities_by_its_weight():
    # fixed weights (3, 1) -> (0.75, 0.25): the vote is 0.75 p_prior + 0.25 p_uniform, per
    # window, and each row sums to 1
    from terrain.models.ensemble import SoftVotingEnsemble

    X, y, _ = _runs()
    y = y.copy()
    y[:30] = "a"                                        # priors a 0.58, b 0.21, c 0.21
    prior = DummyClassifier(strategy="prior").fit(X, y).predict_proba(X[:3])
    members = [("prior", DummyClassifier(strategy="prior")),
               ("uniform", DummyClassifier(strategy="uniform"))]
    model = SoftVotingEnsemble(members, weights=(3.0, 1.0)).fit(X, y)
    np.testing.assert_allclose(model.weights_, [0.75, 0.25])
    expected = 0.75 * prior + 0.25 / 3.0
    np.testing.assert_allclose(model.predict_proba(X[:3]), expected, rtol=1e-12)
    np.testing.assert_allclose(model.predict_proba(X[:3]).sum(axis=1), 1.0, rtol=1e-12)


def test_as_many_runs_as_inner_folds_is_enough():
    # StratifiedGroupKFold(k) needs k runs: k runs pass (one run per fold), k - 1 do not
    from terrain.errors import ConfigError
    from terrain.models.cv import require_runs

    runs = np.array(["r/1", "r/1", "r/2", "r/3"])
    require_runs(runs, 3, "the search", "SVMConfig.inner_splits")
    X, y, groups = _runs(n_runs=3, per_run=6)
    search = make_search(SVMConfig(inner_splits=3, search_C=(1.0,), search_gamma=("scale",)))
    assert search.fit(X, y, groups=groups).best_params_ == {"svc__C": 1.0,
                                                            "svc__gamma": "scale"}
    with pytest.raises(ConfigError, match="it got 2 runs"):
        require_runs(runs[:3], 3, "the search", "SVMConfig.inner_splits")


def test_the_confusion_frame_follows_the_task_classes_absent_ones_included():
    # rows and columns are the task's classes in the order given, a class absent from a
    # fold (here c) a row and a column of zeros: the frames of folds and seeds add up
    from terrain.models.metrics import confusion

    cm = confusion(["b", "b", "a"], ["b", "a", "a"], ["b", "a", "c"])
    assert cm.index.tolist() == ["b", "a", "c"] and cm.columns.tolist() == ["b", "a", "c"]
    np.testing.assert_array_equal(cm.to_numpy(), [[1, 1, 0], [0, 1, 0], [0, 0, 0]])


@pytest.mark.parametrize("argument", ["labels", "groups"])
def test_a_nan_label_or_run_in_an_object_array_is_refused(argument):
    # labels and runs read from a table are object arrays: a missing value there is a float
    # NaN (pandas) and equals nothing, so its window got no share
    from terrain.errors import NonFiniteInputError
    from terrain.models.weighting import run_shares

    values = {"labels": np.array(["a", "a", "b", "b"], dtype=object),
              "groups": np.array(["r1", "r1", "r2", "r3"], dtype=object)}
    values[argument][1] = float("nan")
    with pytest.raises(NonFiniteInputError, match=f"{argument} holds 1 missing.*index 1"):
        run_shares(values["labels"], values["groups"])
