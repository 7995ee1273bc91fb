"""Review (mdl7) of the window classifiers: the nested search of a calibrated SVM and the
scikit-learn attributes of the window-EKF wrapper."""

from __future__ import annotations

import numpy as np
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
