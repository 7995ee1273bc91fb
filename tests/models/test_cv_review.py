"""Review tests of the cross-validation protocols (seeds, votes, metrics, splits)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.model_selection import StratifiedKFold

from terrain.models.cv import (PAPER_RANDOM_STATE, cross_validate, iter_splits,
                               split_single_run_classes)
from terrain.models.experiment import MAX_SEED, ExperimentConfig
from terrain.models.metrics import confusion


def _partitions(n_per_class=10):
    """Two classes, one window per 5 s partition, partitions of distinct runs."""
    labels = np.array(["a"] * n_per_class + ["b"] * n_per_class)
    groups = np.array([f"r{i}#0" for i in range(2 * n_per_class)], dtype=object)
    return labels, groups


def test_the_paper_split_takes_every_seed_the_config_accepts():
    # ExperimentConfig accepts seeds up to MAX_SEED; 21 + MAX_SEED used to reach NumPy's
    # bare "Seed must be between 0 and 2**32 - 1" ValueError inside StratifiedKFold
    assert ExperimentConfig(protocol="paper", seeds=(MAX_SEED,)).seeds == (MAX_SEED,)
    labels, groups = _partitions()
    folds = list(iter_splits("paper", labels, groups, MAX_SEED, 5))
    assert len(folds) == 5
    tested = np.sort(np.concatenate([test for _, test in folds]))
    assert np.array_equal(tested, np.arange(len(labels)))
    # seed 0 is still the published split (random_state 21)
    ref = StratifiedKFold(5, shuffle=True, random_state=PAPER_RANDOM_STATE)
    for (_, test), (_, ref_test) in zip(iter_splits("paper", labels, groups, 0, 5),
                                        ref.split(groups, labels)):
        assert np.array_equal(test, ref_test)


def test_confusion_columns_are_the_predicted_classes_in_the_given_order():
    # asymmetric: a->b once, b->c once; a reversed or shuffled column index mislabels them
    cm = confusion(["a", "a", "b", "c", "c"], ["b", "a", "c", "c", "c"], ["a", "b", "c"])
    assert list(cm.index) == ["a", "b", "c"] and list(cm.columns) == ["a", "b", "c"]
    assert cm.loc["a", "b"] == 1 and cm.loc["b", "a"] == 0
    assert cm.loc["b", "c"] == 1 and cm.loc["c", "b"] == 0
    assert cm.loc["c", "c"] == 2 and cm.to_numpy().sum() == 5


class _SeededGuess(BaseEstimator, ClassifierMixin):
    """Predicts class ``seed % n_classes`` of its training classes, whatever the input."""

    def __init__(self, seed=0):
        self.seed = seed

    def fit(self, X, y):
        self.classes_ = np.unique(y)
        return self

    def predict(self, X):
        return np.full(len(X), self.classes_[self.seed % len(self.classes_)])


def _six_runs():
    labels = np.repeat(["a", "b"], 30)
    groups = np.repeat([f"r{i}" for i in range(6)], 10).astype(object)
    t0 = np.tile(np.arange(10.0), 6)
    return np.zeros((60, 1)), labels, groups, t0


def test_each_seed_builds_its_own_model_and_the_confusion_counts_its_predictions():
    X, y, groups, t0 = _six_runs()
    report = cross_validate(_SeededGuess, X, y, groups, groups, t0, t0 + 1.0,
                            seeds=(4, 7, 8), n_splits=3)
    pred = report.predictions
    # seeds 4 and 8 guess class 0 ("a") everywhere, seed 7 class 1 ("b"): the model seed is
    # honoured
    assert set(pred.loc[pred.seed == 4, "predicted"]) == {"a"}
    assert set(pred.loc[pred.seed == 7, "predicted"]) == {"b"}
    assert report.pooled.set_index("seed")["accuracy"].to_dict() == {4: 0.5, 7: 0.5, 8: 0.5}
    # the confusion (rows true, columns predicted) counts the out-of-fold predictions of
    # every seed: 60 windows predicted "a" and 30 predicted "b" per true class
    cross = pd.crosstab(pred["true"], pred["predicted"])
    assert report.confusion.equals(cross.rename_axis(index="true", columns="predicted"))
    assert report.confusion.loc["b", "a"] == 60 and report.confusion.loc["a", "b"] == 30


def test_single_run_blocks_are_contiguous_in_time_whatever_the_window_order():
    rng = np.random.default_rng(0)
    order = rng.permutation(20)
    t0 = np.arange(20.0)[order]                   # windows listed out of time order
    labels = np.array(["solo"] * 20)
    groups, split = split_single_run_classes(labels, np.full(20, "r0", dtype=object), t0, 4)
    assert split == ["solo"]
    for k in range(4):
        times = np.sort(t0[groups == f"r0@block{k}"])
        assert np.array_equal(times, np.arange(5.0 * k, 5.0 * k + 5))


class _Captured(Exception):
    """Stops run_cv once its estimator factory is captured."""


@pytest.mark.parametrize("search", [True, False])
def test_run_cv_builds_every_cv_seeds_model_and_inner_search_with_that_seed(
        vulpi_runs, monkeypatch, search):
    from terrain.models import experiment

    captured = {}

    def capture(factory, *args, **kwargs):
        captured["factory"] = factory
        raise _Captured

    monkeypatch.setattr(experiment, "cross_validate", capture)
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(5, 9), search=search)
    with pytest.raises(_Captured):
        experiment.run_cv(config, runs=vulpi_runs)
    model = captured["factory"](9)
    if search:          # the inner grouped folds of seed 9 shuffle with seed 9
        assert model.cv.random_state == 9
        model = model.estimator
    assert model.named_steps["svc"].random_state == 9


def test_class_keeping_split_never_holds_out_every_run_of_a_class():
    from sklearn.model_selection import StratifiedGroupKFold

    from terrain.models.cv import class_keeping_split

    # class "solo" has one run: a split holding that run out trains without the class
    labels = np.array(["a"] * 30 + ["b"] * 30 + ["solo"] * 10)
    groups = np.repeat([f"r{i}" for i in range(7)], 10).astype(object)
    first_held_solo = 0
    for seed in range(6):
        fit, held = class_keeping_split(labels, groups, 3, seed, "early stopping",
                                        "validation_splits", "early_stopping=False")
        assert set(labels[fit]) == {"a", "b", "solo"} and held.size
        assert not set(groups[fit]) & set(groups[held])
        first_fit, _ = next(StratifiedGroupKFold(3, shuffle=True, random_state=seed).split(
            labels, labels, groups))
        first_held_solo += "solo" not in set(labels[first_fit])
    assert first_held_solo       # the check above was exercised on at least one seed


def test_paper_folds_count_partitions_not_windows_per_class():
    from terrain.errors import ConfigError

    # 3 partitions per class of 10 windows each: 30 windows, but only 3 partitions, per class
    labels = np.repeat(["a", "b"], 30)
    groups = np.repeat([f"r{i}#0" for i in range(6)], 10).astype(object)
    with pytest.raises(ConfigError, match="no class has as many 5 s partitions"):
        list(iter_splits("paper", labels, groups, 0, 5))
    assert len(list(iter_splits("paper", labels, groups, 0, 3))) == 3


def test_a_run_cut_into_two_blocks_loses_the_windows_straddling_their_boundary():
    # single_run_blocks=2 (the smallest accepted) gives a run of exactly two units: the
    # windows of the first block that reach past the second block's start share samples
    # with its windows and must go, as for more blocks. Windows 2 s long every 0.5 s over
    # 0-20 s: the second block starts at 10 s, so [8.5, 10.5], [9, 11], [9.5, 11.5] straddle
    from terrain.models.cv import purge_block_overlaps

    t0 = np.arange(0.0, 20.0, 0.5)
    labels = np.full(t0.size, "DIRT_ROAD", dtype=object)
    runs = np.full(t0.size, "v/DIRT_ROAD/1", dtype=object)
    groups, _ = split_single_run_classes(labels, runs.copy(), t0, n_blocks=2)
    assert len(set(groups)) == 2 and t0[groups == groups[-1]].min() == 10.0
    keep = purge_block_overlaps(groups, runs, t0, t0 + 2.0)
    assert t0[~keep].tolist() == [8.5, 9.0, 9.5]
