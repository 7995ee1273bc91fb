"""Feature transformers review (ftr23): boundaries (band counts, band edges, Nyquist)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features import calculators
from features.transformers import MAX_BANDS, linear_bands
from terrain.errors import ConfigError


@pytest.mark.slow
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


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([6.5, 10.0, 15.0, 50.0, 100.0]), st.sampled_from([0.5, 1.0, 2.5, 5.0]),
       st.integers(4, 220))
def test_every_fft_bin_but_nyquist_lies_in_exactly_one_default_band(rate_hz, width, n):
    """The default bands are ``[lo, hi)`` from 0 Hz to the Nyquist frequency: every one-sided
    FFT bin below Nyquist lies in exactly one band (a bin on an edge in the band it
    starts), the Nyquist bin of an even window length in none (documented on
    :func:`linear_bands`), weighted only by bands that hold no bin and borrow it."""
    bands = linear_bands(rate_hz, width)
    freqs = np.fft.rfftfreq(n, 1.0 / rate_hz)
    W = calculators.band_weights(n, rate_hz, bands)
    tol = 1e-9 * rate_hz / n
    owners = [[k for k, (lo, hi) in enumerate(bands) if lo - tol <= f < hi - tol]
              for f in freqs]
    held = {k for ks in owners for k in ks}
    for i, f in enumerate(freqs):
        if n % 2 == 0 and i == len(freqs) - 1:              # the Nyquist bin
            assert owners[i] == []
            assert not any(W[i, k] for k in held)
        else:
            assert len(owners[i]) == 1
            assert W[i, owners[i][0]] > 0


def test_a_nyquist_tone_shows_in_the_last_default_band():
    """A tone at exactly the Nyquist frequency (+1, -1, ...) is in no band's bins, yet the
    Hann taper leaks it into the bin below, so the last band sees it and the others not."""
    x = np.tile([1.0, -1.0], 50)[None, None]
    power = calculators.band_log_power(x, 50.0, linear_bands(50.0, 2.5))[0, 0]
    assert power[-1] > -1.0 and (power[:-1] == -12.0).all()
