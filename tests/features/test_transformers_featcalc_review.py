"""WindowFeatures review (featcalc): a refused fit leaves no half-fitted state behind."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from features.transformers import WindowFeatures, linear_bands
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
    before = fx.get_params()
    fx.set_params(**bad)
    with pytest.raises(ConfigError):
        fx.fit(X)
    np.testing.assert_array_equal(fx.get_feature_names_out(), names)
    # the settings now differ from the fitted ones: transform refuses them (ftr10) ...
    with pytest.raises(NotFittedError, match=r"settings \['bands_hz'\] changed since fit"):
        fx.transform(X)
    # ... and the previous fit, whole, transforms under its own settings
    np.testing.assert_array_equal(fx.set_params(**before).transform(X), F)


def test_a_refused_first_fit_leaves_the_transformer_unfitted():
    """A first fit refused by band_weights had already set the names: transform then failed
    with AttributeError ('band_weights_') instead of NotFittedError."""
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0, bands_hz=((30.0, 40.0),))
    with pytest.raises(ConfigError, match="Nyquist"):
        fx.fit(X)
    with pytest.raises(NotFittedError):
        fx.transform(X)


@pytest.mark.parametrize("rate, width", [(21.0, 0.7), (57.0, 0.57)])
def test_linear_bands_drop_the_empty_band_arange_leaves_at_nyquist(rate, width):
    """``np.arange(0, rate / 2, width)`` can end on the Nyquist frequency itself (10.5 Hz
    for 21 Hz and 0.7 Hz bands) or a rounding below it (28.499999999999996 Hz for 57 Hz
    and 0.57 Hz): that empty band would be named (``band_10p5_10p5hz``) and refused at
    fit. The bands tile [0, Nyquist) with the given width (the last may end a rounding
    below Nyquist, where no bin lies)."""
    bands = linear_bands(rate, width)
    n = int(round(rate / 2 / width))
    assert len(bands) == n
    assert all(hi - lo == pytest.approx(width) for lo, hi in bands)
    assert bands[-1][1] == pytest.approx(rate / 2, abs=1e-12)
    X = np.random.default_rng(0).standard_normal((2, 1, 4 * int(rate)))
    fx = WindowFeatures(channels=("ax",), rate_hz=rate, stats=("mean",),
                        band_width_hz=width).fit(X)
    assert fx.transform(X).shape == (2, 1 + n) == (2, len(fx.get_feature_names_out()))


def test_feature_names_out_is_a_copy_the_caller_may_edit():
    """Editing the returned names (e.g. prefixing them for a table) must not rename the
    fitted transformer's columns."""
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0, stats=("mean",)).fit(X)
    names = fx.get_feature_names_out()
    names[0] = "renamed"
    assert fx.get_feature_names_out()[0] == "ax__mean"
