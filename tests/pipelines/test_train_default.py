"""`terrain train`'s per-dataset default is the best model of the documented comparison."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from pipelines.train import DEFAULT_MODELS
from terrain.models.registry import ENSEMBLE3_MEMBERS, MODELS

TABLE = Path(__file__).parents[2] / "docs" / "model_comparison.csv"
#: Merged equal-weight votes in the table and the model kind that is the same classifier.
KIND_OF = {"vote(svm+cnn-spectrogram)": "ensemble",
           "vote(" + "+".join(ENSEMBLE3_MEMBERS) + ")": "ensemble3"}


@pytest.mark.parametrize("dataset", ["borealtc", "vulpi", "combined"])
def test_default_is_the_most_accurate_single_window_model_of_the_table(dataset):
    table = pd.read_csv(TABLE)
    rows = table[(table["dataset"] == dataset) & (table["protocol"] == "grouped")
                 & (table["signals"] == "all") & (table["window_s"] == 2.0)
                 & (table["history"] == 1) & (table["n_seeds"] >= 3)]
    assert len(rows) >= 4, f"{dataset}: the comparison table lacks 3-seed rows"
    best = rows.sort_values("accuracy_mean").iloc[-1]["model"]
    assert KIND_OF.get(best, best) == DEFAULT_MODELS[dataset]
    assert DEFAULT_MODELS[dataset] in MODELS
