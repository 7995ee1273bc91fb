"""Feature transformers review (ftr23): boundaries (band counts, band edges, Nyquist)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.transformers import MAX_BANDS, linear_bands
from terrain.errors import ConfigError


@settings(max_examples=200, deadline=None)
@given(st.integers(10, 4000))
def test_a_width_that_cuts_exactly_max_bands_is_allowed(decihertz):
    """:data:`MAX_BANDS` is the most bands :func:`linear_bands` makes: a width that cuts the
    0 Hz to Nyquist range into exactly that many is allowed. The count was
    ``ceil(nyquist / width)``, which float rounding puts one past the cap (374.1 Hz at
    0.018705 Hz: 10000.000000000002, so 10001), while the bands made are 10 000 (the last
    edge falls within 1e-9 Hz of the Nyquist frequency and that sliver is dropped)."""
    rate_hz = decihertz / 10.0
    width = rate_hz / 2.0 / MAX_BANDS
    bands = linear_bands(rate_hz, width)
    assert len(bands) == MAX_BANDS
    assert bands[0][0] == 0.0 and bands[-1][1] == pytest.approx(rate_hz / 2.0, abs=1e-9)


@settings(max_examples=100, deadline=None)
@given(st.integers(10, 4000))
def test_a_width_that_cuts_one_band_more_is_refused(decihertz):
    """One band past the cap is refused before any is built."""
    rate_hz = decihertz / 10.0
    with pytest.raises(ConfigError, match=f"more than {MAX_BANDS}"):
        linear_bands(rate_hz, rate_hz / 2.0 / (MAX_BANDS + 1))


def test_the_pinned_case_of_the_max_band_count():
    """The rate and width of the report: 10 000 bands, allowed."""
    assert len(linear_bands(374.1, 0.018705)) == MAX_BANDS
    assert np.isclose(linear_bands(374.1, 0.018705)[-1][1], 187.05)
