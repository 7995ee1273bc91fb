"""Review fixslip of the slip features and targets: terrain probabilities given as text are
refused naming the terrain and the row (``"1"`` was read as probability 1.0)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.slip_features import (SLIP_CHANNELS, slip_features, window_feature_vector)
from features.windows import WindowSet
from terrain.errors import ConfigError, DataFormatError, NonNumericError
from terrain.vehicles import HUSKY
from test_features_ftr31_review import _window


def _windows(n=3):
    rng = np.random.default_rng(2)
    X = np.stack([_window(rng) for _ in range(n)])
    ids = np.full(n, "r", dtype=object)
    return WindowSet(X, SLIP_CHANNELS, ids, ids, ids, np.arange(float(n)),
                     np.arange(float(n)) + 2, 50.0)


@pytest.mark.parametrize("column, row", [
    ([0.5, "1", 0.0], 1),                   # text among numbers (an object column)
    (["1", "0", "1"], 0),                   # a column of text that spells numbers
    (pd.array(["1", "0", "1"], dtype="string"), 0),
    ([0.5, 0.5, b"1"], 2),                  # bytes
    (np.array([0.5, 0.5, 1 + 0j], dtype=object), 2),    # a complex number
    ([0.5, 0.5, 1 + 0j], 0),                # a complex column: its first row
    ([0.5, True, 0.5], 1)])                 # a boolean among numbers
def test_slip_features_refuse_a_probability_that_is_not_a_number_naming_terrain_and_row(
        column, row):
    probs = pd.DataFrame({"ASPHALT": [0.5, 0.5, 0.5], "ICE": column})
    with pytest.raises(NonNumericError,
                       match=rf"slip_features: probability of ICE holds a value that is not a "
                             rf"number .*row {row}") as info:
        slip_features(_windows(), HUSKY, probs)
    assert info.value.column == "probability of ICE" and info.value.row == row
    assert isinstance(info.value, DataFormatError)     # (as text that failed to convert)


def test_a_mask_is_still_refused_as_booleans_and_numbers_give_the_same_features():
    ws = _windows()
    with pytest.raises(ConfigError, match="probability of ICE must hold numbers, got booleans"):
        slip_features(ws, HUSKY, pd.DataFrame({"ASPHALT": [0.5] * 3,
                                               "ICE": [True, False, True]}))
    floats = pd.DataFrame({"ASPHALT": [0.5, 1.0, 0.0], "ICE": [0.5, 0.0, 1.0]})
    mixed = pd.DataFrame({"ASPHALT": np.array([0.5, 1, 0], dtype=object),
                          "ICE": pd.array([0.5, 0.0, 1.0], dtype="Float64")})
    a = slip_features(ws, HUSKY, floats)
    pd.testing.assert_frame_equal(slip_features(ws, HUSKY, mixed), a, check_exact=True)


@pytest.mark.parametrize("value", ["1", b"1", 1 + 0j])
def test_window_feature_vector_refuses_a_probability_that_is_not_a_number(value):
    ws = _windows(1)
    with pytest.raises(NonNumericError, match="window_feature_vector: probability of ICE"):
        window_feature_vector(ws.X[0], ws.channels, 50.0, HUSKY,
                              {"ASPHALT": 0.0, "ICE": value})
    # a number of NumPy's is one
    window_feature_vector(ws.X[0], ws.channels, 50.0, HUSKY,
                          {"ASPHALT": np.float32(0.0), "ICE": np.float64(1.0)})
