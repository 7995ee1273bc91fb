"""Metric inputs of other lengths, or none, refused by name (review mdl17)."""

from __future__ import annotations

import pytest

from terrain.errors import ShapeError
from terrain.models.metrics import confusion, run_majority_accuracy, window_metrics


@pytest.mark.parametrize("metric", [window_metrics, confusion])
def test_truth_and_predictions_of_other_lengths_are_a_shape_error(metric):
    # scikit-learn's "Found input variables with inconsistent numbers of samples: [3, 2]",
    # where run_majority_accuracy already named its arguments
    with pytest.raises(ShapeError, match="y_true.*y_pred"):
        metric(["A", "B", "A"], ["A", "B"], ["A", "B"])


@pytest.mark.parametrize("metric", [window_metrics, confusion])
def test_no_window_is_a_shape_error(metric):
    # scikit-learn's bare "Found empty input array (e.g., `y_true` or `y_pred`)"
    with pytest.raises(ShapeError, match="no window"):
        metric([], [], ["A", "B"])


def test_run_majority_accuracy_of_no_window_is_a_shape_error_not_nan():
    with pytest.raises(ShapeError, match="no window"):
        run_majority_accuracy([], [], [])


@pytest.mark.parametrize("missing", [None, float("nan")])
def test_a_window_without_its_run_is_refused_not_left_out_of_the_vote(missing):
    # pandas' groupby drops a NaN/None key: the window's run was left out of the vote and of
    # the count (run accuracy 1.0 although that run was voted A against its truth B)
    from terrain.errors import NonFiniteInputError
    from terrain.models.metrics import majority_vote

    groups = [missing, "g", "g"]
    with pytest.raises(NonFiniteInputError, match="groups.*index 0"):
        majority_vote(["A", "B", "B"], groups)
    with pytest.raises(NonFiniteInputError, match="groups.*index 0"):
        run_majority_accuracy(["B", "B", "B"], ["A", "B", "B"], groups)


def test_a_predicted_label_outside_classes_counts_in_macro_f1():
    """A model trained on a class its held-out truth lacks (Vulpi DIRT_ROAD, one run, never
    held out) predicted it, and a caller listing the truth's classes (benchmarks/
    unseen_runs.py: sorted(true.unique())) left it out of macro-F1 without a word: 0.833
    where scikit-learn's macro average, over the labels of truth and predictions, is 0.556."""
    from sklearn.metrics import f1_score

    y_true, y_pred = ["A", "A", "B", "B"], ["A", "C", "B", "B"]
    m = window_metrics(y_true, y_pred, ["A", "B"])
    assert m["macro_f1"] == pytest.approx(f1_score(y_true, y_pred, average="macro"))
    assert m["macro_f1"] == pytest.approx((2 / 3 + 1 + 0) / 3)
    assert m["accuracy"] == 0.75 and m["recall_A"] == 0.5 and "recall_C" not in m
    # a truth label outside classes is a class of the truth: recalled and balanced
    m = window_metrics(["A", "C"], ["A", "A"], ["A"])
    assert m["recall_C"] == 0.0 and m["balanced_accuracy"] == 0.5
