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
