"""Soft-voting ensemble (weights on held-out training runs) and the MiniRocket baseline."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.dummy import DummyClassifier
from sklearn.linear_model import LogisticRegression

from terrain.models.ensemble import SoftVotingEnsemble, simplex_grid


#: groups each RecordingLogReg was fitted on (clone copies parameters, so not a parameter)
FITS: list = []


class RecordingLogReg(ClassifierMixin, BaseEstimator):
    """Logistic regression on the window means that records the groups it was fitted on."""

    def fit(self, X, y, groups=None):
        FITS.append(None if groups is None else set(groups))
        self.model_ = LogisticRegression().fit(X.mean(axis=2), y)
        self.classes_ = self.model_.classes_
        return self

    def predict_proba(self, X):
        return self.model_.predict_proba(X.mean(axis=2))

    def predict(self, X):
        return self.model_.predict(X.mean(axis=2))


class FlatDummy(DummyClassifier):
    """Prior-probability dummy accepting 3-D windows."""

    def fit(self, X, y, sample_weight=None):
        return super().fit(X.reshape(len(X), -1), y)

    def predict_proba(self, X):
        return super().predict_proba(X.reshape(len(X), -1))


def _runs(n_runs=12, per_run=10, seed=0):
    rng = np.random.default_rng(seed)
    X, y, g = [], [], []
    for r in range(n_runs):
        label = "A" if r % 2 == 0 else "B"
        mean = 0.0 if label == "A" else 1.0
        X.append(rng.normal(mean, 1.0, (per_run, 2, 20)))
        y += [label] * per_run
        g += [f"run{r}"] * per_run
    return np.concatenate(X), np.asarray(y), np.asarray(g)


def test_simplex_grid_covers_the_simplex():
    grid = simplex_grid(3, 0.25)
    assert len(grid) == 15                                  # C(4 + 2, 2)
    np.testing.assert_allclose(grid.sum(axis=1), 1.0)
    assert (grid >= 0).all()


def test_weights_favour_the_informative_member_and_use_training_runs_only():
    X, y, groups = _runs()
    FITS.clear()
    ens = SoftVotingEnsemble([("dummy", FlatDummy(strategy="prior")),
                              ("logreg", RecordingLogReg())], inner_splits=4)
    train = ~np.isin(groups, ["run10", "run11"])
    ens.fit(X[train], y[train], groups=groups[train])
    assert ens.weights_[1] >= 0.75                          # the informative member wins
    assert len(ens.weight_scores_) == 5
    inner, full = FITS
    assert inner < full == set(groups[train])              # inner fit: a subset of runs
    assert len(full - inner) >= 2                           # whole runs held out
    assert (ens.predict(X[~train]) == y[~train]).mean() >= 0.8
    np.testing.assert_allclose(ens.predict_proba(X[~train]).sum(axis=1), 1.0)


class ConfidentlyWrong(ClassifierMixin, BaseEstimator):
    """Gives the opposite of the informative window-mean rule a probability of 0.99."""

    def fit(self, X, y, groups=None):
        self.classes_ = np.unique(y)
        return self

    def predict_proba(self, X):
        b = np.where(X.mean(axis=(1, 2)) > 0.5, 0.01, 0.99)
        return np.column_stack([1 - b, b])


def test_weights_minimise_the_held_out_log_loss_not_the_members_confidence():
    from sklearn.metrics import log_loss

    X, y, groups = _runs()
    members = [("wrong", ConfidentlyWrong()), ("logreg", RecordingLogReg())]
    ens = SoftVotingEnsemble(members, inner_splits=4).fit(X, y, groups=groups)
    assert ens.weights_.tolist() == [0.0, 1.0]
    # the score of a weight vector is the log loss, on the held-out runs, of the members
    # fitted on the other runs
    held = np.isin(groups, ens.validation_groups_)
    logreg = RecordingLogReg().fit(X[~held], y[~held])
    expected = log_loss(y[held], np.clip(logreg.predict_proba(X[held]), 1e-12, 1.0),
                        labels=["A", "B"])
    assert ens.weight_scores_[(0.0, 1.0)] == pytest.approx(expected, rel=1e-9)
    assert ens.weight_scores_[(1.0, 0.0)] > 1.0 > ens.weight_scores_[(0.0, 1.0)]


def test_fixed_or_groupless_weights_are_not_searched():
    X, y, groups = _runs(n_runs=4)
    members = [("a", FlatDummy(strategy="prior")), ("b", RecordingLogReg())]
    assert SoftVotingEnsemble(members).fit(X, y).weights_.tolist() == [0.5, 0.5]
    ens = SoftVotingEnsemble(members, weights=(1, 3)).fit(X, y, groups=groups)
    assert ens.weights_.tolist() == [0.25, 0.75] and ens.weight_scores_ == {}


def test_minirocket_separates_planted_terrains_on_unseen_runs():
    pytest.importorskip("aeon")
    from terrain.models.minirocket import make_minirocket

    rng = np.random.default_rng(1)
    t = np.arange(100) / 50.0
    X, y, groups = [], [], []
    for r in range(6):
        label = "A" if r % 2 == 0 else "B"
        for _ in range(10):
            w = rng.normal(0, 1, (2, t.size))
            if label == "B":
                w[0] += 2 * np.sin(2 * np.pi * 8 * t + rng.uniform(0, 6.3))
            X.append(w)
            y.append(label)
            groups.append(r)
    X, y, groups = np.asarray(X, dtype=np.float32), np.asarray(y), np.asarray(groups)
    model = make_minirocket(0, n_kernels=840)
    test = groups >= 4
    model.fit(X[~test], y[~test])
    assert (model.predict(X[test]) == y[test]).mean() >= 0.9
    np.testing.assert_allclose(model.predict_proba(X[test]).sum(axis=1), 1.0)


def test_minirocket_biases_follow_the_seed_and_the_head_is_balanced_with_its_c():
    pytest.importorskip("aeon")
    from terrain.models.minirocket import MiniRocketFeatures, make_minirocket

    X, _, _ = _runs(n_runs=2, per_run=8)
    X = X.astype(np.float32)
    features = [MiniRocketFeatures(n_kernels=84, max_dilations_per_kernel=4,
                                   random_state=seed).fit(X).transform(X)
                for seed in (0, 0, 1)]
    np.testing.assert_array_equal(features[0], features[1])
    assert not np.array_equal(features[0], features[2])
    head = make_minirocket(0, C=0.5).get_params()
    assert head["logreg__C"] == 0.5 and head["logreg__class_weight"] == "balanced"
