"""WindowFeatures review (featcalc): a refused fit leaves no half-fitted state behind."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from features.transformers import WindowFeatures
from terrain.errors import ConfigError

CHANNELS = ("ax", "wz")


def _windows(n=4, samples=100, seed=0):
    return np.random.default_rng(seed).standard_normal((n, len(CHANNELS), samples))


@pytest.mark.parametrize("bad", [
    {"bands_hz": ((30.0, 40.0), (1.0, 2.0))},            # above Nyquist: band_weights refuses
    {"bands_hz": ((1.0, 2.0), (1.0000001, 2.0))},        # two bands of one name
])
def test_a_refused_refit_keeps_the_previous_fit_whole(bad):
    """A refit that raises must not mix the new settings into the old fit: the refused
    bands (30, 40) Hz at 50 Hz left 6 names (the new ones) over 22 columns (the old band
    weights), so transform's columns no longer matched get_feature_names_out."""
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0, stats=("mean",)).fit(X)
    names, F = fx.get_feature_names_out(), fx.transform(X)
    fx.set_params(**bad)
    with pytest.raises(ConfigError):
        fx.fit(X)
    np.testing.assert_array_equal(fx.get_feature_names_out(), names)
    np.testing.assert_array_equal(fx.transform(X), F)


def test_a_refused_first_fit_leaves_the_transformer_unfitted():
    """A first fit refused by band_weights had already set the names: transform then failed
    with AttributeError ('band_weights_') instead of NotFittedError."""
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0, bands_hz=((30.0, 40.0),))
    with pytest.raises(ConfigError, match="Nyquist"):
        fx.fit(X)
    with pytest.raises(NotFittedError):
        fx.transform(X)
