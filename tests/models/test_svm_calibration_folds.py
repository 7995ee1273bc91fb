"""The calibration error of benchmarks/svm_calibration_folds.py (Guo et al. 2017, eq. 3)."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

SCRIPT = runpy.run_path(str(Path(__file__).parents[2] / "benchmarks"
                            / "svm_calibration_folds.py"))
ece = SCRIPT["expected_calibration_error"]


def test_ece_of_four_windows_by_hand():
    proba = np.array([[0.9, 0.1], [0.6, 0.4], [0.45, 0.55], [0.05, 0.95]])
    correct = np.array([True, False, True, True])
    # bins (0.8, 0.9]: 1 window, accuracy 1, confidence 0.9; (0.5, 0.6]: 2 windows,
    # accuracy 0.5, confidence 0.575; (0.9, 1]: 1 window, accuracy 1, confidence 0.95
    expected = 0.25 * 0.1 + 0.5 * 0.075 + 0.25 * 0.05
    assert ece(proba, correct) == pytest.approx(expected)


def test_ece_is_zero_when_confidence_equals_accuracy_and_bins_are_right_closed():
    # confidence 0.5 with half right, confidence 1.0 always right: calibrated
    proba = np.array([[0.5, 0.5]] * 4 + [[1.0, 0.0]] * 2)
    correct = np.array([True, False, True, False, True, True])
    assert ece(proba, correct) == pytest.approx(0.0)


def test_ece_of_a_confident_model_that_is_always_wrong():
    proba = np.tile([0.2, 0.8], (5, 1))
    assert ece(proba, np.zeros(5, bool)) == pytest.approx(0.8)
    assert ece(proba, np.zeros(5, bool), n_bins=3) == pytest.approx(0.8)


def test_a_confidence_of_one_is_in_the_last_bin():
    # half of the fully confident windows wrong: the gap is 0.5, not a window left out
    proba = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert ece(proba, np.array([False, True])) == pytest.approx(0.5)
