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
