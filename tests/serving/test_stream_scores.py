"""Score tables of the held-out streams: written as CSV and read back for pooling, also
from the tables logged before the JSON columns (numpy reprs), with typed errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.serving.evaluation import (StreamScore, encode_stream_scores, pool_scores,
                                        read_stream_scores, seed_accuracies)


def _rows():
    scores = [StreamScore(0.9, (np.float64(1.5), np.float64(np.inf)), 100, 0.95, 80,
                          {"ICE": {"ICE": 90, "SNOW": 10}}),
              StreamScore(0.8, (np.float64(0.5),), 300, 0.85, 200,
                          {"ICE": {"ICE": 40}, "SNOW": {"SNOW": 200, "none": 60}})]
    return pd.DataFrame([{"seed": i, "fold": 0, "smoothing": "f", **s.as_row()}
                         for i, s in enumerate(scores)])


def test_score_table_round_trips_through_csv(tmp_path):
    rows = _rows()
    path = tmp_path / "scores.csv"
    encode_stream_scores(rows).to_csv(path, index=False)
    back = read_stream_scores(path)
    assert back["delays_s"].tolist() == [[1.5, np.inf], [0.5]]
    assert back["confusion"].tolist() == rows["confusion"].tolist()
    assert pool_scores(back) == pool_scores(rows)
    assert pool_scores(back)["accuracy"] == pytest.approx((0.9 * 100 + 0.8 * 300) / 400)
    assert seed_accuracies(back) == {0: 0.9, 1: 0.8}


def test_tables_logged_with_numpy_reprs_are_read(tmp_path):
    path = tmp_path / "old.csv"
    pd.DataFrame({"accuracy": [0.9], "n_decisions": [10], "accuracy_settled": [0.9],
                  "n_settled": [10],
                  "delays_s": ["[np.float64(1.4), np.float64(2e-1), np.float64(inf)]"],
                  "confusion": ["{'ICE': {'ICE': 9, 'SNOW': 1}}"]}).to_csv(path, index=False)
    back = read_stream_scores(path)
    assert back["delays_s"][0] == [1.4, 0.2, np.inf]
    assert pool_scores(back)["recall"] == {"ICE": 0.9}


@pytest.mark.parametrize("column,bad", [("delays_s", "1.5"), ("confusion", "[1, 2]"),
                                        ("confusion", "{oops")])
def test_a_broken_cell_names_file_column_and_line(tmp_path, column, bad):
    frame = encode_stream_scores(_rows())
    frame.loc[1, column] = bad
    path = tmp_path / "broken.csv"
    frame.to_csv(path, index=False)
    with pytest.raises(DataFormatError, match=rf"{column}.*line 3") as err:
        read_stream_scores(path)
    assert err.value.path == str(path) and err.value.column == column
