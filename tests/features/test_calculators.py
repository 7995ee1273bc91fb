"""Feature calculators against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import signal
from scipy import stats as sps

from features import calculators as calc
from features.transformers import linear_bands
from terrain.errors import ConfigError, ShapeError

RAMP = np.array([1.0, 2.0, 3.0, 4.0])
# Bernoulli(p = 1/4) scaled by 3: skewness (1-2p)/sqrt(p(1-p)) = 2/sqrt(3),
# excess kurtosis (1 - 6p(1-p))/(p(1-p)) = -2/3
SPIKE = np.array([0.0, 0.0, 0.0, 3.0])
ALTERNATING = np.array([1.0, -1.0, 1.0, -1.0])


def _batch(*rows):
    """(n_windows, 1, n_samples) batch of the given 1-D windows."""
    return np.stack(rows)[:, None, :]


@pytest.mark.parametrize("name, expected", [
    ("mean", [2.5, 0.75, 0.0]),
    ("std", [np.sqrt(1.25), np.sqrt(1.6875), 1.0]),
    ("skewness", [0.0, 2.0 / np.sqrt(3.0), 0.0]),
    ("kurtosis", [2.5625 / 1.25 ** 2 - 3.0, -2.0 / 3.0, -2.0]),
    ("rms", [np.sqrt(7.5), 1.5, 1.0]),
    ("min", [1.0, 0.0, -1.0]),
    ("max", [4.0, 3.0, 1.0]),
    ("mean_abs_diff", [1.0, 1.0, 2.0]),
])
def test_statistic_hand_values(name, expected):
    out = calc.STATISTICS[name](_batch(RAMP, SPIKE, ALTERNATING))
    assert out.shape == (3, 1)
    np.testing.assert_allclose(out[:, 0], expected, rtol=1e-12, atol=1e-12)


def test_registry_is_explicit_and_complete():
    assert list(calc.STATISTICS) == ["mean", "std", "skewness", "kurtosis", "rms", "min",
                                     "max", "mean_abs_diff"]


def test_statistics_are_per_window_and_channel():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((5, 3, 64)) ** 3
    for name, fn in calc.STATISTICS.items():
        out = fn(x)
        assert out.shape == (5, 3), name
        # window (2, 1) alone gives the same value as in the batch
        np.testing.assert_allclose(fn(x[2:3, 1:2])[0, 0], out[2, 1], err_msg=name)
    np.testing.assert_allclose(calc.skewness(x), sps.skew(x, axis=-1, bias=True))
    np.testing.assert_allclose(calc.kurtosis(x), sps.kurtosis(x, axis=-1, bias=True))


@pytest.mark.parametrize("where", [0, 4, 9])
def test_a_nan_sample_makes_every_statistic_of_its_row_nan(where):
    """A NaN anywhere in a window makes all its statistics NaN (min and max included: a
    comparison with NaN is false, so a running minimum would skip it); the other rows and
    channels keep their values."""
    x = np.tile(np.arange(10.0), (2, 2, 1))
    x[1, 0, where] = np.nan
    names = list(calc.STATISTICS)
    out = calc.statistics(x, names)
    assert np.isnan(out[1, 0]).all(), dict(zip(names, out[1, 0]))
    clean = calc.statistics(np.arange(10.0)[None, None, :], names)[0, 0]
    for w, c in [(0, 0), (0, 1), (1, 1)]:
        np.testing.assert_array_equal(out[w, c], clean)


def test_constant_window_has_zero_shape_moments():
    x = np.full((1, 1, 10), 4.2)
    assert calc.skewness(x)[0, 0] == 0.0 and calc.kurtosis(x)[0, 0] == 0.0
    assert calc.std(x)[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert calc.mean_abs_diff(x)[0, 0] == 0.0


RATE = 50.0
N = 100  # 2 s windows: 0.5 Hz bins


@pytest.mark.parametrize("freq", [1.0, 3.0, 6.0, 11.0, 16.0, 21.0, 24.0])
def test_band_power_of_pure_tone_peaks_in_its_band(freq):
    t = np.arange(N) / RATE
    x = np.sin(2 * np.pi * freq * t)[None, None, :]
    bands = linear_bands(RATE, 2.5)
    out = calc.band_log_power(x, RATE, bands)
    assert out.shape == (1, 1, len(bands))
    expected = next(k for k, (lo, hi) in enumerate(bands) if lo <= freq < hi)
    assert int(np.argmax(out[0, 0])) == expected
    # far from the tone there is (almost) nothing: 4 decades below the peak
    far = [k for k, (lo, hi) in enumerate(bands) if min(abs(lo - freq), abs(hi - freq)) > 3]
    assert (out[0, 0, far] < out[0, 0, expected] - 4).all()


def _bin_bands(n, rate):
    """One band per FFT bin (each band holds exactly one bin)."""
    df = rate / n
    return tuple(((k - 0.5) * df, (k + 0.5) * df) for k in range(n // 2 + 1)), df


def test_band_power_parseval_tone():
    amplitude, freq = 2.0, 7.0  # on a bin
    t = np.arange(N) / RATE
    x = (amplitude * np.sin(2 * np.pi * freq * t) + 5.0)[None, None, :]  # offset removed
    bands, df = _bin_bands(N, RATE)
    psd = 10 ** calc.band_log_power(x, RATE, bands)[0, 0]
    assert psd.sum() * df == pytest.approx(amplitude ** 2 / 2, rel=0.01)  # power of a sine


def test_band_power_parseval_noise():
    rng = np.random.default_rng(0)
    n = 256
    x = rng.normal(0.0, 1.5, (20, 2, n))
    bands, df = _bin_bands(n, RATE)
    psd = 10 ** calc.band_log_power(x, RATE, bands)
    w = np.hanning(n)
    d = x - x.mean(axis=-1, keepdims=True)
    tapered_var = ((d * w) ** 2).sum(axis=-1) / (w ** 2).sum()
    np.testing.assert_allclose(psd.sum(axis=-1) * df, tapered_var, rtol=0.05)
    # and on average it is the signal variance
    assert (psd.sum(axis=-1) * df).mean() == pytest.approx(1.5 ** 2, rel=0.1)


@pytest.mark.parametrize("n", [100, 101])
def test_band_power_per_bin_equals_scipy_periodogram(n):
    # one band per bin, DC and (n even) Nyquist included: the one-sided density of
    # scipy.signal.periodogram, which doubles neither of them
    x = np.random.default_rng(1).normal(0.0, 1.0, (3, 2, n))
    bands, _ = _bin_bands(n, RATE)
    psd = 10 ** calc.band_log_power(x, RATE, bands)
    _, ref = signal.periodogram(x, fs=RATE, window="hann", detrend="constant", axis=-1)
    np.testing.assert_allclose(psd[..., 1:], ref[..., 1:], rtol=1e-9, atol=2e-12)  # _EPS


def test_band_without_bin_uses_nearest_bin():
    t = np.arange(N) / RATE
    x = np.sin(2 * np.pi * 7.0 * t)[None, None, :]
    narrow = calc.band_log_power(x, RATE, ((6.9, 7.1),))          # holds the 7.0 bin
    empty = calc.band_log_power(x, RATE, ((7.05, 7.15),))         # nearest bin: 7.0
    np.testing.assert_allclose(narrow, empty)


def test_band_between_two_bins_gets_both_nearest_bins():
    """A band holding no bin is averaged over the bin(s) nearest its centre: (7.05, 7.45) Hz
    lies between the 7.0 and 7.5 Hz bins of a 2 s window, at equal distance from its
    centre 7.25 Hz (its lower edge alone would pick 7.0 Hz only)."""
    W = calc.band_weights(N, RATE, ((7.05, 7.45),))
    freqs = np.fft.rfftfreq(N, 1.0 / RATE)
    assert sorted(freqs[W[:, 0] > 0]) == [7.0, 7.5]
    np.testing.assert_allclose(W[W[:, 0] > 0, 0], [0.5, 0.5])
    # off centre, the single nearest bin
    W = calc.band_weights(N, RATE, ((7.05, 7.2),))
    assert list(freqs[W[:, 0] > 0]) == [7.0]
    W = calc.band_weights(N, RATE, ((7.05, 7.4),))
    assert list(freqs[W[:, 0] > 0]) == [7.0]
    W = calc.band_weights(N, RATE, ((7.3, 7.45),))
    assert list(freqs[W[:, 0] > 0]) == [7.5]


def test_per_speed_floors_the_speed():
    current = np.array([[10.0, 10.0], [10.0, 10.0], [-4.0, -4.0], [6.0, 6.0]])
    speed = np.array([[0.01, 0.01], [2.0, 2.0], [-2.0, -2.0], [1.0, -1.0]])
    out = calc.per_speed(current, speed, min_speed_m_s=0.1)
    np.testing.assert_allclose(out, [100.0, 5.0, -2.0, 6.0])
    assert out.shape == (4,)


@pytest.mark.parametrize("chi", [1.0, 1.4, 2.2])
def test_regression_gain_recovers_inverse_icr_expansion(chi):
    t = np.arange(200) / 50.0
    yaw_rate_wheels = np.stack([0.8 * np.sin(2 * np.pi * 0.3 * t), np.full(200, 0.5)])
    wz = yaw_rate_wheels / chi
    np.testing.assert_allclose(calc.regression_gain(wz, yaw_rate_wheels, 0.0), 1.0 / chi,
                               rtol=1e-12)
    # the ridge floor shrinks the gain only a little when the robot turns
    floored = calc.regression_gain(wz, yaw_rate_wheels, 0.05)
    np.testing.assert_allclose(floored, 1.0 / chi, rtol=0.02)
    assert (floored < 1.0 / chi).all()


def test_regression_gain_goes_to_zero_when_not_turning():
    x = np.full((1, 100), 1e-4)
    assert abs(calc.regression_gain(x / 1.5, x, 0.05)[0]) < 1e-4


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.integers(1, 60),
                  elements=st.floats(-1e6, 1e6, allow_nan=False)),
       st.floats(0.0, 1.0))
def test_quantile_sorted_equals_numpy_quantile_bit_for_bit(x, q):
    """The compiled quantile is numpy.quantile's default (linear) method exactly, for any
    length, quantile and values (the service's 99th-percentile wheel-speed rule and the
    wheel-physics features rely on it)."""
    got = calc.quantile_sorted(np.sort(x), q)
    assert got == np.quantile(x, q)


def test_quantile_sorted_at_half_fraction_interpolates_from_above_like_numpy():
    """At a fraction of exactly 0.5 numpy interpolates from the upper neighbour; from the
    lower one these two values give a result one rounding step off (found by search)."""
    x = np.array([-0.013210486329130189, 0.01257302210933933])
    assert x[0] + (x[1] - x[0]) * 0.5 != np.quantile(x, 0.5)      # the cases differ here
    assert calc.quantile_sorted(x, 0.5) == np.quantile(x, 0.5)
    assert calc.quantile_sorted(x, 1.0) == x[1] and calc.quantile_sorted(x, 0.0) == x[0]


@pytest.mark.parametrize("band, match", [
    ((30.0, 40.0), "above the Nyquist frequency 25 Hz"),     # no content at 50 Hz
    ((5.0, 2.0), "lower edge below its upper"),
    ((2.0, 2.0), "lower edge below its upper"),
    ((-2.0, -1.0), "end above 0 Hz"),
    ((-1.0, 0.0), "end above 0 Hz"),                         # [-1, 0) holds no bin
    ((np.nan, 2.0), "finite"),
    ((1.0, np.inf), "finite"),
])
def test_band_weights_refuse_bands_without_content(band, match):
    """A band above the Nyquist frequency, inverted, below 0 Hz or not finite has no FFT bin
    of its own: it used to get the nearest bin without a word ((30, 40) Hz at 50 Hz was the
    25 Hz bin, named ``band_30_40hz``; NaN gave log10(1e-12) = -12)."""
    with pytest.raises(ConfigError, match=match):
        calc.band_weights(N, RATE, (band,))
    x = np.zeros((1, 1, N))
    with pytest.raises(ConfigError, match=match):
        calc.band_log_power(x, RATE, ((0.0, 2.5), band))
    # a band reaching past the Nyquist frequency keeps the bins it holds
    assert calc.band_weights(N, RATE, ((20.0, 30.0),))[:, 0].sum() == pytest.approx(1.0)


def test_a_band_starting_at_the_nyquist_frequency_holds_the_nyquist_bin():
    """``low`` may be the Nyquist frequency itself (an even-length window has a bin
    there): (25, 30) Hz at 50 Hz is the 25 Hz bin alone, not refused."""
    W = calc.band_weights(N, RATE, ((25.0, 30.0),))
    assert W[-1, 0] == 1.0 and W[:-1, 0].sum() == 0.0


@pytest.mark.parametrize("n, rate, width, edge_bin", [
    (70, 50.0, 2.5, 7),      # 1.4 s at 50 Hz: bin 7 is 5 Hz, rfftfreq says 4.999999999999999
    (200, 30.0, 0.2, 4),     # bin 4 is 0.6 Hz, linear_bands' edge is 0.6000000000000001
])
def test_a_bin_on_a_band_edge_belongs_to_the_band_it_starts(n, rate, width, edge_bin):
    """A bin exactly on an edge ``k w`` belongs to ``[k w, (k+1) w)`` (lower edge
    inclusive), whatever the float rounding of the bin frequency or of the edge: it was
    averaged into the band below, which then held one bin more than its neighbour."""
    bands = linear_bands(rate, width)
    W = calc.band_weights(n, rate, bands)
    k = round(edge_bin * rate / n / width)
    assert W[edge_bin, k] > 0 and W[edge_bin, k - 1] == 0
    # each bin of [0, Nyquist) in exactly one band
    inside = np.arange(n // 2 + (n % 2))
    np.testing.assert_array_equal(np.count_nonzero(W[inside], axis=1), 1)


def test_statistics_refuse_an_unknown_name_and_windows_of_no_sample():
    """An unknown statistic is a ConfigError listing the valid ones (it was NumPy's "tuple.index
    (x): x not in tuple"); windows of no sample are a ShapeError, not a compiled read past
    the end of each row."""
    with pytest.raises(ConfigError, match=r"unknown statistics \['median'\]; valid: \['mean'"):
        calc.statistics(np.ones((2, 1, 4)), ("mean", "median"))
    with pytest.raises(ShapeError, match="at least one sample"):
        calc.statistics(np.ones((2, 3, 0)), ("mean",))


@pytest.mark.parametrize("rate", ["50", True, 0.0, np.nan])
def test_band_weights_refuse_a_rate_that_is_not_a_positive_number(rate):
    """The sampling rate sets every bin frequency: a string or a bool is a ConfigError naming
    the setting (a string was NumPy's TypeError from isfinite), as 0 and NaN are."""
    with pytest.raises(ConfigError, match="rate_hz"):
        calc.band_weights(N, rate, ((0.0, 2.5),))
