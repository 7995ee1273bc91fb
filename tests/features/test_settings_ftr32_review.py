"""Settings given as None or as one text (review ftr32).

``band_weights(..., bands_hz=None)``, ``WindowFeatures(channels=None)`` / ``stats=None`` and
``statistics(x, None)`` failed with Python's bare TypeError (``len()``, iteration) naming no
setting; ``terrain_columns("p__ICE")`` read the text letter by letter and found none.
"""

import numpy as np
import pandas as pd
import pytest

from features.calculators import band_weights, statistics
from features.slip_features import terrain_columns
from features.transformers import WindowFeatures
from terrain.errors import ConfigError

X = np.random.default_rng(0).normal(size=(2, 1, 100))


@pytest.mark.parametrize("bands", [None, 5.0, "0-5"])
def test_band_weights_refuses_bands_that_are_not_a_sequence_of_pairs(bands):
    with pytest.raises(ConfigError, match="bands_hz"):
        band_weights(100, 50.0, bands)


@pytest.mark.parametrize("field", ["channels", "stats"])
def test_window_features_refuses_none_for_a_sequence_of_names(field):
    with pytest.raises(ConfigError, match=f"WindowFeatures.{field}"):
        WindowFeatures(**{"channels": ("wz",), field: None}).fit(X)


def test_no_bands_is_still_a_valid_empty_selection():
    assert band_weights(100, 50.0, ()).shape == (51, 0)
    names = WindowFeatures(channels=("wz",), stats=("std",), bands_hz=()).fit(X)
    assert list(names.get_feature_names_out()) == ["wz__std"]


@pytest.mark.parametrize("names", [None, 3])
def test_statistics_refuses_names_that_are_not_a_sequence(names):
    with pytest.raises(ConfigError, match="names"):
        statistics(X, names)


@pytest.mark.parametrize("columns", ["p__ICE", None, ["p__ICE", 3]])
def test_terrain_columns_refuses_text_and_non_names(columns):
    # "p__ICE" was read letter by letter and answered [] (no terrain column)
    with pytest.raises(ConfigError, match="terrain_columns"):
        terrain_columns(columns)
    columns = pd.Index(["a__mean", "p__ICE", "phys_std"])
    assert terrain_columns(columns) == ["p__ICE", "phys_std"]
