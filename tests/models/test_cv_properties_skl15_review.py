"""Run-grouped cross-validation as properties over random run layouts (Hypothesis).

No split unit on both sides of a fold, every window tested once per seed, the fold and pooled
metrics those of scikit-learn on the same predictions, and a seed that reproduces its folds.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from sklearn.naive_bayes import GaussianNB
from sklearn.metrics import (accuracy_score, balanced_accuracy_score, f1_score,
                             recall_score)

from terrain.errors import ConfigError
from terrain.models.cv import class_keeping_split, cross_validate, iter_splits
from terrain.models.metrics import run_majority_accuracy, window_metrics

#: the stratified splitters warn when a class has fewer windows than folds (allowed here)
pytestmark = pytest.mark.filterwarnings("ignore:The least populated class:UserWarning")

FAST = settings(max_examples=60, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@st.composite
def layouts(draw, max_classes: int = 4, max_runs: int = 4, max_windows: int = 6,
            min_classes: int = 1, min_runs: int = 1):
    """Labels and run ids of windows in a random order: 1-4 classes of 1-4 runs each."""
    labels, groups = [], []
    for c in range(draw(st.integers(min_classes, max_classes))):
        for r in range(draw(st.integers(min_runs, max_runs))):
            n = draw(st.integers(1, max_windows))
            labels += [f"T{c}"] * n
            groups += [f"T{c}/{r:02d}"] * n
    order = draw(st.permutations(range(len(labels))))
    return np.asarray(labels)[order], np.asarray(groups, dtype=object)[order]


def _splits(protocol, labels, groups, seed, n_splits):
    try:
        return list(iter_splits(protocol, labels, groups, seed, n_splits))
    except ConfigError:     # too few runs or windows for the folds: refused by name
        return None


@FAST
@given(layouts(), st.sampled_from(["grouped", "loro", "paper"]), st.integers(0, 2 ** 32 - 1),
       st.integers(2, 6))
def test_no_unit_on_both_sides_and_every_window_tested_once(layout, protocol, seed, n_splits):
    labels, groups = layout
    splits = _splits(protocol, labels, groups, seed, n_splits)
    if splits is None:
        return
    n = len(labels)
    tested = np.concatenate([test for _, test in splits])
    assert sorted(tested.tolist()) == list(range(n))         # each window tested once
    for train, test in splits:
        assert len(test) > 0
        assert not set(groups[train]) & set(groups[test])
        assert sorted(np.concatenate([train, test]).tolist()) == list(range(n))
    if protocol == "loro":
        assert [len(set(groups[test])) for _, test in splits] == [1] * len(splits)
    again = _splits(protocol, labels, groups, seed, n_splits)
    for (a_tr, a_te), (b_tr, b_te) in zip(splits, again, strict=True):   # seed reproduces
        np.testing.assert_array_equal(a_tr, b_tr)
        np.testing.assert_array_equal(a_te, b_te)


@FAST
@given(layouts(), st.integers(0, 2 ** 32 - 1), st.integers(2, 5))
def test_class_keeping_split_holds_runs_out_whole_and_trains_every_class(layout, seed, k):
    labels, groups = layout
    try:
        fit, held = class_keeping_split(labels, groups, k, seed, "a test", "splits", "none")
    except ConfigError:
        return
    assert len(held) and not set(groups[fit]) & set(groups[held])
    assert set(labels[fit]) == set(labels)
    assert sorted(np.concatenate([fit, held]).tolist()) == list(range(len(labels)))
    again = class_keeping_split(labels, groups, k, seed, "a test", "splits", "none")
    np.testing.assert_array_equal(again[0], fit)


@st.composite
def predictions(draw):
    classes = [f"T{i}" for i in range(draw(st.integers(2, 4)))]
    n = draw(st.integers(1, 30))
    y_true = draw(st.lists(st.sampled_from(classes), min_size=n, max_size=n))
    y_pred = draw(st.lists(st.sampled_from(classes), min_size=n, max_size=n))
    return classes, np.asarray(y_true), np.asarray(y_pred)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(predictions())
def test_window_metrics_are_scikit_learns(case):
    classes, y_true, y_pred = case
    m = window_metrics(y_true, y_pred, classes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # (a predicted class absent from the truth)
        assert m["accuracy"] == pytest.approx(accuracy_score(y_true, y_pred))
        assert m["balanced_accuracy"] == pytest.approx(balanced_accuracy_score(y_true, y_pred))
        assert m["macro_f1"] == pytest.approx(f1_score(y_true, y_pred, average="macro",
                                                       zero_division=0))
    present = sorted(set(y_true))
    recalls = recall_score(y_true, y_pred, labels=present, average=None, zero_division=0)
    assert {k: v for k, v in m.items() if k.startswith("recall_")} == pytest.approx(
        {f"recall_{c}": r for c, r in zip(present, recalls)})


def _vote_reference(y_true, y_pred, groups) -> float:
    """Per group: the most frequent prediction, ties to the alphabetically first label."""
    right = []
    for g in dict.fromkeys(groups):
        sel = [i for i, h in enumerate(groups) if h == g]
        counts = pd.Series([y_pred[i] for i in sel]).value_counts()
        top = sorted(counts.index[counts == counts.max()])[0]
        right.append(top == y_true[sel[0]])
    return float(np.mean(right))


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(predictions(), st.data())
def test_run_majority_accuracy_equals_a_slow_vote(case, data):
    _, y_true, y_pred = case
    groups = np.asarray(data.draw(st.lists(st.sampled_from("abcde"), min_size=len(y_true),
                                           max_size=len(y_true))))
    # a group's truth is that of its first window (the runs of one class in practice)
    first = {g: y_true[list(groups).index(g)] for g in set(groups)}
    y_true = np.asarray([first[g] for g in groups])
    assert run_majority_accuracy(y_true, y_pred, groups) == pytest.approx(
        _vote_reference(y_true, y_pred, groups))


def _features(labels, groups, seed: int = 0) -> np.ndarray:
    """Two noisy features, class-dependent, with a per-run offset."""
    rng = np.random.default_rng(seed)
    code = {c: i for i, c in enumerate(sorted(set(labels)))}
    run = {g: rng.normal(0, 0.5, 2) for g in sorted(set(groups))}
    return np.asarray([[code[c], -code[c]] + run[g] + rng.normal(0, 0.7, 2)
                       for c, g in zip(labels, groups)])


def _cv(X, labels, groups, seeds, protocol="grouped", n_splits=3):
    n = len(labels)
    return cross_validate(lambda s: GaussianNB(), X, labels, groups,
                          run_ids=groups, t_start_s=np.arange(n, dtype=float),
                          t_end_s=np.arange(n) + 1.0, protocol=protocol, seeds=seeds,
                          n_splits=n_splits)


@pytest.mark.slow
@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(layouts(max_classes=3, max_runs=3, max_windows=5, min_classes=2, min_runs=2),
       st.sampled_from(["grouped", "loro"]))
def test_fold_and_pooled_metrics_are_scikit_learns_on_the_reported_predictions(
        layout, protocol):
    labels, groups = layout
    try:
        report = _cv(_features(labels, groups), labels, groups, seeds=(0, 1),
                     protocol=protocol)
    except (ConfigError, ValueError):   # too few runs / a training fold of one class
        event("refused")
        return
    pred = report.predictions
    for (seed, fold), rows in pred.groupby(["seed", "fold"]):
        row = report.folds[(report.folds.seed == seed) & (report.folds.fold == fold)].iloc[0]
        assert row["accuracy"] == pytest.approx(accuracy_score(rows.true, rows.predicted))
        assert row["n_test"] == len(rows)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert row["balanced_accuracy"] == pytest.approx(
                balanced_accuracy_score(rows.true, rows.predicted))
        assert row["run_majority_accuracy"] == pytest.approx(
            _vote_reference(rows.true.to_numpy(), rows.predicted.to_numpy(),
                            rows.group.to_numpy()))
        proba = rows[[f"proba_{c}" for c in report.classes]].to_numpy()
        np.testing.assert_allclose(proba.sum(axis=1), 1.0)
        np.testing.assert_array_equal(np.asarray(report.classes)[proba.argmax(axis=1)],
                                      rows.predicted)
    for seed, rows in pred.groupby("seed"):
        pooled = report.pooled[report.pooled.seed == seed].iloc[0]
        assert pooled["macro_f1"] == pytest.approx(
            f1_score(rows.true, rows.predicted, average="macro", zero_division=0))
        # every window tested once per seed (t_start_s is the window's index here)
        assert sorted(rows.t_start_s) == list(range(len(labels)))
        # a fold trains on the windows of the runs it does not test, and only on them
        for fold, test in rows.groupby("fold"):
            n_train = report.folds[(report.folds.seed == seed)
                                   & (report.folds.fold == fold)].n_train.iloc[0]
            assert n_train == np.sum(~np.isin(groups, test.group.unique()))


def test_the_same_seeds_reproduce_the_report_whatever_their_order():
    rng = np.random.default_rng(3)
    labels = np.repeat(["A", "B", "C"], 24)
    groups = np.asarray([f"{c}/{i // 4}" for i, c in enumerate(labels)], dtype=object)
    order = rng.permutation(len(labels))
    labels, groups = labels[order], groups[order]
    X = _features(labels, groups)
    a = _cv(X, labels, groups, seeds=(0, 1))
    b = _cv(X, labels, groups, seeds=(1, 0))
    cols = [c for c in a.folds.columns if c != "fit_s"]
    key = ["seed", "fold"]
    pd.testing.assert_frame_equal(a.folds[cols].sort_values(key).reset_index(drop=True),
                                  b.folds[cols].sort_values(key).reset_index(drop=True))
    sort = ["seed", "fold", "t_start_s"]
    pd.testing.assert_frame_equal(a.predictions.sort_values(sort).reset_index(drop=True),
                                  b.predictions.sort_values(sort).reset_index(drop=True))
    # another seed gives other folds (the seed is used)
    tests = {s: sorted(map(tuple, a.predictions[a.predictions.seed == s]
                           .groupby("fold").group.unique().map(sorted))) for s in (0, 1)}
    assert tests[0] != tests[1]


def test_cross_validate_fits_copies_never_the_factorys_estimator():
    # a factory handing out one shared estimator: every fold fits its own clone, and the
    # caller's object stays unfitted (no fold's fit left in it)
    from sklearn.exceptions import NotFittedError
    from sklearn.utils.validation import check_is_fitted

    labels = np.repeat(["A", "B"], 12)
    groups = np.asarray([f"{c}/{i // 3}" for i, c in enumerate(labels)], dtype=object)
    shared = GaussianNB()
    n = len(labels)
    report = cross_validate(lambda s: shared, _features(labels, groups), labels, groups,
                            run_ids=groups, t_start_s=np.arange(n, dtype=float),
                            t_end_s=np.arange(n) + 1.0, seeds=(0,), n_splits=2)
    assert len(report.folds) == 2
    with pytest.raises(NotFittedError):
        check_is_fitted(shared)


def test_terrain_cv_pooled_recall_is_scikit_learns_over_all_seeds_predictions():
    # pipelines/cv.py's per-class recall of the confusion summed over seeds is the recall of
    # every seed's out-of-fold predictions taken together
    from pipelines.cv import pooled_recall

    rng = np.random.default_rng(4)
    labels = np.repeat(["A", "B", "C"], 12)
    groups = np.asarray([f"{c}/{i // 3}" for i, c in enumerate(labels)], dtype=object)
    X = _features(labels, groups) + rng.normal(0, 1.0, (len(labels), 2))
    report = _cv(X, labels, groups, seeds=(0, 1, 2))
    pred = report.predictions
    expected = recall_score(pred.true, pred.predicted, labels=report.classes, average=None)
    assert pooled_recall(report.confusion) == pytest.approx(
        dict(zip(report.classes, expected)))
    summary = report.summary()
    assert summary["accuracy"]["mean"] == pytest.approx(report.folds.accuracy.mean())
    assert summary["accuracy"]["n_folds"] == 9


@FAST
@given(layouts(max_classes=3, max_runs=3, max_windows=8))
def test_within_class_run_weights_give_every_run_of_a_class_the_same_total(layout):
    from terrain.models.weighting import within_class_run_weights

    labels, groups = layout
    w = within_class_run_weights(labels, groups)
    assert np.all(w > 0)
    for c in set(labels):
        in_class = labels == c
        runs = sorted(set(groups[in_class]))
        assert w[in_class].mean() == pytest.approx(1.0)
        for r in runs:
            assert w[in_class & (groups == r)].sum() == pytest.approx(
                in_class.sum() / len(runs))


@FAST
@given(st.lists(st.tuples(st.integers(3, 30), st.booleans()), min_size=1, max_size=4),
       st.integers(1, 4), st.integers(2, 5), st.data())
def test_time_blocks_of_a_single_run_class_share_no_sample_after_the_purge(runs, hop, k, data):
    # windows of 4 time steps every `hop` steps; a class of one run is cut into k blocks,
    # and windows straddling a block boundary are dropped: no kept window of one block
    # overlaps a kept window of another block of its run
    from terrain.models.cv import purge_block_overlaps, split_single_run_classes

    labels, run_ids, start = [], [], []
    for i, (n, single) in enumerate(runs):
        cls = f"S{i}" if single else "multi"
        labels += [cls] * n
        run_ids += [f"run{i}"] * n
        start += [hop * j * 0.1 for j in range(n)]
    order = np.asarray(data.draw(st.permutations(range(len(labels)))))
    labels, run_ids = np.asarray(labels)[order], np.asarray(run_ids, dtype=object)[order]
    start = np.asarray(start)[order]
    end = start + 0.4
    units, split = split_single_run_classes(labels, run_ids, start, k)
    keep = purge_block_overlaps(units, run_ids, start, end)
    for c in split:                     # contiguous, ordered blocks of at most k
        sel = labels == c
        assert len(set(units[sel])) == min(k, sel.sum())
    for i in np.flatnonzero(keep):
        for j in np.flatnonzero(keep):
            if run_ids[i] == run_ids[j] and units[i] != units[j]:
                assert end[i] <= start[j] + 1e-9 or end[j] <= start[i] + 1e-9


@FAST
@given(st.lists(st.tuples(st.integers(3, 20), st.booleans()), min_size=1, max_size=3),
       st.integers(2, 4), st.integers(1, 3), st.integers(2, 4))
def test_a_denser_training_window_never_shares_a_sample_with_another_units_window(
        runs, hop, train_hop, k):
    # evaluation windows (4 steps long, every `hop` steps) define the units; a denser
    # training cut of the same runs (every `train_hop` steps) trains a fold only through
    # its unit: none of its windows overlaps an evaluation window of another unit
    from terrain.models.cv import (purge_block_overlaps, split_single_run_classes,
                                   training_units)

    labels, run_ids, start, t_run, t_start = [], [], [], [], []
    for i, (n, single) in enumerate(runs):
        labels += [f"S{i}" if single else "multi"] * n
        run_ids += [f"run{i}"] * n
        start += [0.1 * hop * j for j in range(n)]
        m = (hop * (n - 1)) // train_hop + 1
        t_run += [f"run{i}"] * m
        t_start += [0.1 * train_hop * j for j in range(m)]
    labels, run_ids = np.asarray(labels), np.asarray(run_ids, dtype=object)
    start, t_start = np.asarray(start), np.asarray(t_start)
    t_run = np.asarray(t_run, dtype=object)
    units, _ = split_single_run_classes(labels, run_ids, start, k)
    keep = purge_block_overlaps(units, run_ids, start, start + 0.4)
    run_ids, start, units = run_ids[keep], start[keep], units[keep]
    dense = training_units(run_ids, start, start + 0.4, units, t_run, t_start, t_start + 0.4)
    for i, u in enumerate(dense):
        if u is None:
            continue
        other = (run_ids == t_run[i]) & (units != u)
        overlap = ((start[other] < t_start[i] + 0.4 - 1e-9)
                   & (start[other] + 0.4 > t_start[i] + 1e-9))
        assert not overlap.any()
        assert u in set(units[run_ids == t_run[i]])
