"""Review tests (mdl20): decision history, metrics against scikit-learn, run shares."""

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st
from sklearn.metrics import (accuracy_score, balanced_accuracy_score, confusion_matrix,
                             f1_score)

from terrain.errors import ConfigError, NonFiniteInputError, ShapeError
from terrain.models.compare import history_predictions, soft_vote
from terrain.models.cv import class_keeping_split
from terrain.models.metrics import (confusion, majority_vote, run_majority_accuracy,
                                    window_metrics)


def _frame(proba, groups, classes=("a", "b", "c")):
    proba = np.asarray(proba, dtype=float)
    frame = pd.DataFrame({"group": groups,
                          "t_start_s": np.arange(len(groups), dtype=float)})
    for j, c in enumerate(classes):
        frame[f"proba_{c}"] = proba[:, j]
    return frame


@pytest.mark.parametrize("k", [0, -1, True, 2.5])
def test_history_refuses_a_length_that_is_not_a_positive_integer(k):
    frame = _frame([[0.2, 0.7, 0.1], [0.6, 0.3, 0.1]], ["r1", "r1"])
    with pytest.raises(ConfigError, match="k"):
        history_predictions(frame, ("a", "b", "c"), k)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_history_refuses_probabilities_that_are_not_finite(bad):
    frame = _frame([[0.2, 0.7, 0.1], [bad, bad, bad]], ["r1", "r2"])
    with pytest.raises(NonFiniteInputError, match="proba_"):
        history_predictions(frame, ("a", "b", "c"), 1)


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(st.data())
def test_history_is_the_argmax_of_the_causal_mean_of_the_last_k_windows(data):
    n = data.draw(st.integers(1, 25))
    k = data.draw(st.integers(1, 8))
    proba = data.draw(st.lists(st.lists(st.integers(0, 4), min_size=3, max_size=3),
                               min_size=n, max_size=n))
    groups = data.draw(st.lists(st.sampled_from(["r1", "r2", "r3"]), min_size=n, max_size=n))
    frame = _frame(np.asarray(proba, float) / 4, groups)
    # shuffled rows: the decision follows each row, not its position
    perm = data.draw(st.permutations(range(n)))
    frame = frame.iloc[list(perm)]
    got = history_predictions(frame, ("a", "b", "c"), k)
    p = frame[["proba_a", "proba_b", "proba_c"]].to_numpy()
    for i in range(n):
        g, t = frame["group"].iloc[i], frame["t_start_s"].iloc[i]
        earlier = (frame["group"].to_numpy() == g) & (frame["t_start_s"].to_numpy() <= t)
        rows = np.flatnonzero(earlier)
        rows = rows[np.argsort(frame["t_start_s"].to_numpy()[rows])][-k:]
        total = p[rows].sum(axis=0)      # integer quarters: exact sums, exact ties
        assert got[i] == "abc"[int(np.argmax(total))]


labels = st.sampled_from(["a", "b", "c", "d"])


@pytest.mark.slow
@settings(max_examples=80, deadline=None)
@given(st.data())
def test_window_metrics_match_scikit_learn(data):
    n = data.draw(st.integers(1, 30))
    y_true = data.draw(st.lists(labels, min_size=n, max_size=n))
    y_pred = data.draw(st.lists(labels, min_size=n, max_size=n))
    classes = sorted(set(y_true) | set(y_pred))
    m = window_metrics(y_true, y_pred, classes)
    assert m["accuracy"] == pytest.approx(accuracy_score(y_true, y_pred))
    with warnings.catch_warnings():   # a predicted class the truth lacks: a warning
        warnings.simplefilter("ignore")
        bal = balanced_accuracy_score(y_true, y_pred)
        f1 = f1_score(y_true, y_pred, average="macro", zero_division=0)
    assert m["balanced_accuracy"] == pytest.approx(bal)
    assert m["macro_f1"] == pytest.approx(f1)
    cm = confusion(y_true, y_pred, classes)
    np.testing.assert_array_equal(cm.to_numpy(),
                                  confusion_matrix(y_true, y_pred, labels=classes))
    assert cm.to_numpy().sum() == n


@pytest.mark.parametrize("metric", [window_metrics, confusion])
def test_metrics_refuse_repeated_classes(metric):
    # a repeated class was scored twice: balanced accuracy 0.67 and macro-F1 0.44 for
    # recalls (1, 0), and the confusion matrix gave one of the rows no count
    with pytest.raises(ConfigError, match="'a'"):
        metric(["a", "b"], ["a", "a"], ["a", "a", "b"])


def test_confusion_refuses_no_class():
    with pytest.raises(ConfigError, match="classes"):
        confusion(["a", "b"], ["a", "a"], [])


@pytest.mark.parametrize("missing", [None, np.nan])
@pytest.mark.parametrize("where", ["y_true", "y_pred"])
def test_metrics_refuse_missing_labels(missing, where):
    # NaN became a class 'nan' (recall_nan), None a bare TypeError from np.unique
    labels = {"y_true": ["a", "b", "a"], "y_pred": ["a", "b", "b"]}
    labels[where] = [labels[where][0], missing, labels[where][2]]
    with pytest.raises(NonFiniteInputError, match=where):
        window_metrics(labels["y_true"], labels["y_pred"], ["a", "b"])
    with pytest.raises(NonFiniteInputError, match=where):
        confusion(labels["y_true"], labels["y_pred"], ["a", "b"])
    with pytest.raises(NonFiniteInputError, match=where):
        # None predictions: the vote left them out, and the accuracy of no run was NaN
        run_majority_accuracy(labels["y_true"], labels["y_pred"], ["r1", "r1", "r2"])


def test_majority_vote_refuses_sequences_of_other_lengths():
    with pytest.raises(ShapeError, match="groups"):
        majority_vote(["a", "b"], ["r1"])


def _member(proba_a, proba_b):
    return pd.DataFrame({"seed": 0, "fold": 0, "run": ["r1", "r2"], "t_start_s": [0.0, 0.0],
                         "proba_a": proba_a, "proba_b": proba_b})


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_soft_vote_refuses_probabilities_that_are_not_finite(bad):
    # a NaN member probability made the vote of its window NaN, decided as the first class
    with pytest.raises(NonFiniteInputError, match="proba_"):
        soft_vote([_member([0.4, 0.3], [0.6, 0.7]), _member([0.5, bad], [0.5, bad])],
                  ["a", "b"])


def test_soft_vote_names_a_class_without_probabilities():
    with pytest.raises(ConfigError, match="proba_c"):      # pandas' bare KeyError before
        soft_vote([_member([0.4, 0.3], [0.6, 0.7])], ["a", "c"])
    with pytest.raises(ConfigError, match="'a'"):
        soft_vote([_member([0.4, 0.3], [0.6, 0.7])], ["a", "a"])


@pytest.mark.parametrize("cut", ["labels", "groups", "2-D groups"])
def test_inner_split_names_runs_of_another_length(cut):
    y = np.repeat(["a", "b", "a", "b"], 3)
    g = np.repeat(["r1", "r2", "r3", "r4"], 3)
    if cut == "labels":
        y = y[:-1]
    elif cut == "groups":
        g = g[:-1]            # (scikit-learn's "inconsistent numbers of samples: [12, 12, 11]")
    else:
        g = g.reshape(-1, 1)  # (a bare TypeError: unhashable type 'list')
    with pytest.raises(ShapeError, match="groups"):
        class_keeping_split(y, g, 2, 0, "early stopping", "validation_splits",
                            "early_stopping=False")


@pytest.mark.parametrize("shape", [(0, 3, 64), (4, 0, 64)])
def test_minirocket_refuses_no_window_or_no_channel(shape):
    pytest.importorskip("aeon")
    from terrain.models.minirocket import MiniRocketFeatures

    # (aeon's bare IndexError "index 0 is out of bounds", or numpy's "a must be greater
    # than 0 unless no samples are taken")
    with pytest.raises(ValueError, match="no window|no channel"):
        MiniRocketFeatures(n_kernels=84).fit(np.zeros(shape))
    fitted = MiniRocketFeatures(n_kernels=84).fit(
        np.random.default_rng(0).normal(size=(6, 3, 64)))
    with pytest.raises(ValueError, match="no window|no channel"):
        fitted.transform(np.zeros(shape))


def _two_class_runs():
    """40 windows of 8 runs (5 each), classes A and B: X, y, runs, window starts."""
    rng = np.random.default_rng(0)
    y = np.repeat(["A", "B"], 20)
    g = np.repeat([f"r{i}" for i in range(8)], 5)
    return rng.normal(size=(40, 3)), y, g, np.tile(np.arange(5.0), 8)


def test_cross_validate_names_a_training_class_no_evaluation_window_holds():
    from sklearn.linear_model import LogisticRegression

    from terrain.models.cv import TrainingWindows, cross_validate

    X, y, g, t0 = _two_class_runs()
    dense_y = y.copy()
    dense_y[::7] = "C"      # a stretch of another terrain only the denser cut reaches
    training = TrainingWindows(X.copy(), dense_y, g.astype(object))
    # (the fold mapping its probabilities raised a bare "'C' is not in list")
    with pytest.raises(ConfigError, match="'C'"):
        cross_validate(lambda s: LogisticRegression(), X, y, g, g, t0, t0 + 1, seeds=(0,),
                       n_splits=2, training=training)


def test_cross_validate_ignores_the_class_of_training_windows_without_a_unit():
    from sklearn.linear_model import LogisticRegression

    from terrain.models.cv import TrainingWindows, cross_validate

    X, y, g, t0 = _two_class_runs()
    units = np.append(g, "r8").astype(object)
    units[-1] = None        # a run without evaluation windows: never trained on
    training = TrainingWindows(np.vstack([X, X[:1]]), np.append(y, "C"), units)
    report = cross_validate(lambda s: LogisticRegression(), X, y, g, g, t0, t0 + 1,
                            seeds=(0,), n_splits=2, training=training)
    assert report.classes == ["A", "B"]


@pytest.mark.parametrize("column, bad", [("t_start_s", np.nan), ("t_start_s", np.inf),
                                         ("group", None), ("group", np.nan)])
def test_history_refuses_windows_without_a_place_in_their_run(column, bad):
    # a NaN start sorted last (taken as the run's latest window), a missing group made
    # every such window a run of its own
    frame = _frame([[0.2, 0.7, 0.1], [0.6, 0.3, 0.1], [0.5, 0.4, 0.1]], ["r1", "r1", "r1"])
    frame[column] = frame[column].astype(object)
    frame.loc[1, column] = bad
    with pytest.raises(NonFiniteInputError, match=column):
        history_predictions(frame, ("a", "b", "c"), 2)


@pytest.mark.parametrize("cut", ["X", "y", "units"])
def test_training_windows_refuse_parts_of_other_lengths(cut):
    from terrain.models.cv import TrainingWindows

    parts = {"X": np.zeros((6, 2, 4)), "y": np.array(list("AABBAB")),
             "units": np.array(list("112233"), dtype=object)}
    parts[cut] = parts[cut][:-1]     # (an IndexError in every fold of cross_validate)
    with pytest.raises(ShapeError, match=cut):
        TrainingWindows(**parts)


@pytest.mark.parametrize("param", ["svc__sample_weight", "weights"])
def test_run_balanced_names_a_weight_parameter_its_classifier_lacks(param):
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from terrain.models.weighting import RunBalancedClassifier

    rng = np.random.default_rng(0)
    y = np.repeat(["A", "B"], 20)
    g = np.repeat([f"r{i}" for i in range(8)], 5)
    X = rng.normal(size=(40, 3))
    for est in (LogisticRegression(), make_pipeline(StandardScaler(), LogisticRegression())):
        # (a bare TypeError "fit() got an unexpected keyword argument", or the Pipeline's
        # ValueError on a parameter without '__')
        with pytest.raises(ConfigError, match=param):
            RunBalancedClassifier(est, weight_param=param).fit(X, y, groups=g)
    pipe = make_pipeline(StandardScaler(), LogisticRegression())
    RunBalancedClassifier(pipe, "logisticregression__sample_weight").fit(X, y, groups=g)
