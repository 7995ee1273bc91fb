"""Settings of the spectral bands and of WindowFeatures given as None (review ftr32).

``band_weights(..., bands_hz=None)`` and ``WindowFeatures(channels=None)`` / ``stats=None``
failed with Python's bare TypeError (``len()``, iteration) naming no setting.
"""

import numpy as np
import pytest

from features.calculators import band_weights
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
