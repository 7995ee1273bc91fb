"""Review srv19 of :func:`terrain.serving.evaluation.pool_scores` on edge tables."""

from __future__ import annotations

import math

import pandas as pd

from terrain.serving.evaluation import pool_scores

COLUMNS = ["accuracy", "n_decisions", "accuracy_settled", "n_settled", "delays_s",
           "confusion"]


def test_pooling_no_rows_gives_no_score_not_a_numpy_error():
    """A selection of rows that holds none (a benchmark arm or smoothing not run) failed
    inside NumPy with "need at least one array to concatenate"; as rows without a decision
    do, it pools to NaN scores and no switch."""
    pooled = pool_scores(pd.DataFrame(columns=COLUMNS))
    assert math.isnan(pooled["accuracy"]) and math.isnan(pooled["accuracy_settled"])
    assert math.isnan(pooled["median_delay_s"]) and pooled["n_switches"] == 0
    assert pooled["recall"] == {} and pooled["confusion"] == {}


def test_pooling_one_row_is_that_row():
    row = {"accuracy": 0.75, "n_decisions": 4, "accuracy_settled": 1.0, "n_settled": 2,
           "delays_s": [1.0, 3.0, float("inf")], "confusion": {"A": {"A": 3, "B": 1}}}
    pooled = pool_scores(pd.DataFrame([row]))
    assert pooled["accuracy"] == 0.75 and pooled["accuracy_settled"] == 1.0
    assert pooled["median_delay_s"] == 3.0 and pooled["n_switches"] == 3
    assert pooled["recall"] == {"A": 0.75}
