"""Metamorphic checks of the terrain metrics and of cross_validate (mdl21): the metrics agree
with scikit-learn's and do not depend on the order of the classes; the run vote does not
depend on the runs' names nor on the order of the windows; cross_validate tests every window
once per seed, keeps every split unit on one side, and its folds and predictions do not
change when the windows are shuffled or the runs renamed."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from sklearn.metrics import accuracy_score, balanced_accuracy_score, f1_score
from sklearn.neighbors import KNeighborsClassifier

from terrain.errors import ConfigError
from terrain.models.cv import cross_validate
from terrain.models.metrics import run_majority_accuracy, window_metrics

CLASSES = ["a", "b", "c", "d"]
label = st.sampled_from(CLASSES)


@pytest.mark.slow
@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(label, label), min_size=1, max_size=30), st.permutations(CLASSES),
       st.integers(0, 4))
def test_window_metrics_agree_with_sklearn_for_any_class_order(pairs, order, n_listed):
    y_true, y_pred = [p[0] for p in pairs], [p[1] for p in pairs]
    m = window_metrics(y_true, y_pred, order[:n_listed])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # a predicted class the truth lacks
        assert np.isclose(m["accuracy"], accuracy_score(y_true, y_pred))
        assert np.isclose(m["balanced_accuracy"], balanced_accuracy_score(y_true, y_pred))
        assert np.isclose(m["macro_f1"], f1_score(y_true, y_pred, average="macro",
                                                  zero_division=0))
    other = window_metrics(y_true, y_pred, CLASSES)
    assert m.keys() == other.keys()
    assert all(np.isclose(m[k], other[k]) for k in m)


@pytest.mark.slow
@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 4), label), min_size=1, max_size=30),
       st.lists(label, min_size=5, max_size=5), st.randoms())
def test_run_vote_ignores_run_names_and_window_order(rows, run_truth, rnd):
    runs = np.array([f"run{r}" for r, _ in rows])
    y_true = np.array([run_truth[r] for r, _ in rows])   # one terrain per run
    y_pred = np.array([p for _, p in rows])
    score = run_majority_accuracy(y_true, y_pred, runs)
    perm = np.array(rnd.sample(range(len(rows)), len(rows)))
    assert run_majority_accuracy(y_true[perm], y_pred[perm], runs[perm]) == score
    renamed = np.array([f"{9 - int(r[-1])}-x" for r in runs])      # order reversed too
    assert run_majority_accuracy(y_true, y_pred, renamed) == score
    # by hand: each run's most frequent prediction, a tie to the alphabetically first
    hits = []
    for r in np.unique(runs):
        votes = y_pred[runs == r]
        values, counts = np.unique(votes, return_counts=True)
        hits.append(sorted(values[counts == counts.max()])[0] == y_true[runs == r][0])
    assert np.isclose(score, np.mean(hits))


@st.composite
def labelled_runs(draw):
    rows = []
    for r in range(draw(st.integers(2, 7))):
        terrain = draw(st.sampled_from(["a", "b", "c"]))
        rows += [(f"run{r}", terrain, float(k)) for k in range(draw(st.integers(1, 6)))]
    return rows


def _cv(X, y, groups, t0, protocol, seed):
    return cross_validate(lambda s: KNeighborsClassifier(1), X, y, groups, groups, t0, t0 + 1,
                          protocol, (seed,), 2)


@pytest.mark.slow
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(labelled_runs(), st.sampled_from(["grouped", "loro"]), st.integers(0, 5), st.randoms())
def test_cross_validate_is_invariant_to_window_order_and_run_names(rows, protocol, seed, rnd):
    runs = np.array([r[0] for r in rows])
    y = np.array([r[1] for r in rows])
    t0 = np.array([r[2] for r in rows])
    run_index = np.array([int(r[3:]) for r in runs])
    # distinct points without equidistant neighbours: a 1-NN tie goes by training order
    X = np.c_[np.searchsorted(["a", "b", "c"], y) + 0.1 * t0 + 0.01 * np.sqrt(2) * run_index,
              t0 * np.pi / 10]
    try:
        report = _cv(X, y, runs, t0, protocol, seed)
    except ConfigError:
        return      # too few runs or windows for the folds
    pred = report.predictions
    assert len(pred) == len(rows)                                  # each window tested once
    assert (pred.groupby("group")["fold"].nunique() == 1).all()    # a unit on one side
    pooled = report.pooled.iloc[0]
    assert np.isclose(pooled["accuracy"], accuracy_score(pred["true"], pred["predicted"]))
    assert np.isclose(pooled["macro_f1"], f1_score(pred["true"], pred["predicted"],
                                                   average="macro"))
    key = ["run", "t_start_s"]
    base = pred.sort_values(key)[["fold", "predicted"]].to_numpy()
    perm = np.array(rnd.sample(range(len(rows)), len(rows)))
    shuffled = _cv(X[perm], y[perm], runs[perm], t0[perm], protocol, seed).predictions
    got = shuffled.sort_values(key)[["fold", "predicted"]].to_numpy()
    assert (got[:, 0] == base[:, 0]).all(), "folds"
    assert (got == base).all(), (got.tolist(), base.tolist(), rows, protocol, seed)
    renamed = _cv(X, y, np.char.add("field-", runs), t0, protocol, seed).predictions
    renamed = renamed.assign(run=renamed["run"].str.removeprefix("field-"))
    assert (renamed.sort_values(key)[["fold", "predicted"]].to_numpy() == base).all()
