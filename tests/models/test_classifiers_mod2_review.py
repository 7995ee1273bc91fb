"""Review tests (mod2) of the window classifiers: the seeds that draw the CNNs' validation
runs and noise copies, the device choice, and the soft-voting ensemble's contract."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.linear_model import LogisticRegression
from test_cnn import FAST, RATE_HZ, _planted  # same folder (pytest's default prepend import)

from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.cv import class_keeping_split
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.metrics import majority_vote, run_majority_accuracy

ONE_EPOCH = {**FAST, "max_epochs": 1}


@pytest.mark.slow
def test_the_seed_draws_the_early_stopping_validation_runs():
    # random_state is documented as the seed of the validation split too: two seeds hold
    # out the runs of two different class-keeping splits, each that seed's own (seed 0:
    # runs 3 and 6, seed 1: runs 0 and 7)
    X, y, groups = _planted(n_runs=8, per_run=2)
    held = []
    for seed in (0, 1):
        model = RawCNNClassifier(**{**ONE_EPOCH, "width": 2}, early_stopping=True,
                                 validation_splits=4, random_state=seed)
        model.fit(X[..., :32], y, groups=groups)
        _, val = class_keeping_split(y, groups, 4, seed, "early stopping",
                                     "validation_splits", "early_stopping=False")
        assert model.validation_groups_.tolist() == sorted(set(groups[val]))
        held.append(model.validation_groups_.tolist())
    assert held[0] != held[1]


def test_the_seed_draws_the_noise_copy():
    Z = np.random.default_rng(1).normal(size=(6, 2, 5, 3)).astype(np.float32)
    y = np.arange(6) % 2

    def copy(seed):
        model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, augment_noise_std=0.3,
                                         random_state=seed)
        model.mask_ = None
        return model._augmented(Z, y)[0][6:]

    np.testing.assert_array_equal(copy(3), copy(3))
    assert np.abs(copy(3) - copy(4)).min() > 0        # no bin shares its noise draw


@pytest.mark.parametrize("cuda, expected", [(True, "cuda"), (False, "cpu")])
def test_auto_device_is_cuda_exactly_when_torch_has_it(monkeypatch, cuda, expected):
    import torch
    monkeypatch.setattr(torch.cuda, "is_available", lambda: cuda)
    assert RawCNNClassifier(device="auto")._device() == expected
    assert RawCNNClassifier(device="cpu")._device() == "cpu"     # an explicit choice stays


class _MeanLogReg(LogisticRegression):
    """Logistic regression on the window means of ``(n_windows, n_channels, n_samples)``."""

    def fit(self, X, y, groups=None):
        return super().fit(X.mean(axis=2), y)

    def predict_proba(self, X):
        return super().predict_proba(X.mean(axis=2))


class _SureOfTheOther(ClassifierMixin, BaseEstimator):
    """Gives probability 1 to the class that is not the window's (read from its mean)."""

    def fit(self, X, y, groups=None):
        self.classes_ = np.unique(y)
        return self

    def predict_proba(self, X):
        b = (X.mean(axis=(1, 2)) < 0.5).astype(float)     # class "B" windows have mean 1
        return np.column_stack([1 - b, b])


def _two_terrains(first: str = "B"):
    """Runs of 6 windows, class ``first`` first: B windows have mean 1, A windows mean 0."""
    rng = np.random.default_rng(0)
    labels = [first, "A" if first == "B" else "B"] * 4
    X = np.concatenate([rng.normal(lab == "B", 0.3, (6, 2, 8)) for lab in labels])
    return X, np.repeat(labels, 6), np.repeat([f"run{r}" for r in range(8)], 6)


def test_ensemble_classes_are_sorted_whatever_the_label_order_and_columns_follow_them():
    X, y, groups = _two_terrains(first="B")
    assert y[0] == "B"
    ens = SoftVotingEnsemble([("a", _MeanLogReg()), ("b", _MeanLogReg(C=0.01))],
                             weights=(1, 3)).fit(X, y)
    assert ens.classes_.tolist() == ["A", "B"]                 # as np.unique, as the members
    proba = ens.predict_proba(X)
    members = [est.predict_proba(X) for est in ens.estimators_]
    np.testing.assert_allclose(proba, 0.25 * members[0] + 0.75 * members[1], rtol=1e-12)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=1e-12)
    assert (ens.predict(X) == y).mean() > 0.9
    assert clone(ens).get_params()["weights"] == (1, 3)


def test_a_member_sure_of_the_wrong_class_scores_the_log_loss_of_the_1e_12_floor():
    # probability 0 on the true class is clipped to 1e-12 (then the row renormalised):
    # a log loss of -ln(1e-12) = 27.63 per window, the floor the weight search is built on
    X, y, groups = _two_terrains(first="A")
    ens = SoftVotingEnsemble([("sure", _SureOfTheOther()), ("logreg", _MeanLogReg())],
                             weight_step=0.5, inner_splits=4).fit(X, y, groups=groups)
    assert ens.weights_.tolist() == [0.0, 1.0]
    assert ens.weight_scores_[(1.0, 0.0)] == pytest.approx(-np.log(1e-12), rel=1e-9)
    assert ens.weight_scores_[(0.5, 0.5)] < 1.0


def test_the_ensemble_seed_draws_the_runs_its_weights_are_chosen_on():
    X, y, groups = _two_terrains(first="A")
    held = []
    for seed in (0, 1):
        ens = SoftVotingEnsemble([("a", _MeanLogReg()), ("b", _MeanLogReg(C=0.01))],
                                 weight_step=0.5, random_state=seed).fit(X, y, groups=groups)
        _, val = class_keeping_split(y, groups, 4, seed, "choosing the ensemble weights",
                                     "inner_splits", "fixed weights")
        assert ens.validation_groups_.tolist() == sorted(set(groups[val]))
        held.append(ens.validation_groups_.tolist())
    assert held[0] != held[1]


class _Float32MeanLogReg(_MeanLogReg):
    """Probabilities rounded to float32, as the CNNs' softmax gives them (rows sum to 1
    within ~1e-7, beyond the 1.5e-8 scikit-learn's log_loss tolerates without a warning)."""

    def predict_proba(self, X):
        return super().predict_proba(X).astype(np.float32).astype(np.float64)


def test_weights_are_chosen_on_float32_member_probabilities_without_a_warning():
    import warnings
    X, y, groups = _two_terrains(first="A")
    X = X + np.random.default_rng(1).normal(0, 0.4, X.shape)     # unsure members
    members = [("a", _Float32MeanLogReg()), ("b", _Float32MeanLogReg(C=0.01))]
    held = np.isin(groups, SoftVotingEnsemble(members).fit(X, y, groups=groups)
                   .validation_groups_)
    p = members[0][1].fit(X[~held], y[~held]).predict_proba(X[held])
    assert np.abs(p.sum(axis=1) - 1).max() > 1.5e-8          # not normalised in float64
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ens = SoftVotingEnsemble(members, weight_step=0.5).fit(X, y, groups=groups)
    assert len(ens.weight_scores_) == 3 and np.isclose(ens.weights_.sum(), 1.0)


def test_a_groups_true_label_is_that_of_its_first_window():
    # documented rule of run_majority_accuracy: g1's truth is A (its first window) although
    # most of its windows say B; the vote B is then wrong
    groups = ["g1", "g1", "g1", "g2", "g2"]
    y_true = ["A", "B", "B", "C", "C"]
    y_pred = ["B", "B", "B", "C", "A"]
    assert majority_vote(y_pred, groups).to_dict() == {"g1": "B", "g2": "A"}
    assert run_majority_accuracy(y_true, y_pred, groups) == 0.0
    assert run_majority_accuracy(y_true, ["A", "A", "B", "C", "C"], groups) == 1.0


def test_forest_pipeline_with_a_two_output_forest_takes_scikit_learns_path():
    # pack_forest refuses a forest with two outputs: the pipeline then predicts as a plain
    # Pipeline (one probability table per output) instead of failing
    from sklearn.ensemble import ExtraTreesClassifier
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    from terrain.models.forest import ForestPipeline

    rng = np.random.default_rng(0)
    F = rng.normal(size=(40, 3))
    Y = np.column_stack([np.where(F[:, 0] > 0, "a", "b"), np.where(F[:, 1] > 0, "c", "d")])
    pipe = ForestPipeline([("scale", StandardScaler()),
                           ("forest", ExtraTreesClassifier(5, random_state=0))]).fit(F, Y)
    assert pipe._compiled() is None
    expected = Pipeline(pipe.steps).predict_proba(F)
    got = pipe.predict_proba(F)
    assert len(got) == len(expected) == 2
    for g, e in zip(got, expected):
        np.testing.assert_array_equal(g, e)
    np.testing.assert_array_equal(pipe.predict(F), Pipeline(pipe.steps).predict(F))
