"""Features review (ftr25): numerical robustness and determinism of the window features.

Signals with a large mean and a small variation (the moments against a float128 two-pass
reference), huge and tiny scales, float32 windows.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features import calculators
from features.transformers import WindowFeatures

MOMENTS = ("mean", "std", "skewness", "kurtosis")


def _reference_moments(x: np.ndarray) -> np.ndarray:
    """Mean, std, skewness and excess kurtosis of ``x`` in float128 (two-pass)."""
    x = np.asarray(x, dtype=np.longdouble)
    mu = x.mean()
    d = x - mu
    m2, m3, m4 = (d ** 2).mean(), (d ** 3).mean(), (d ** 4).mean()
    return np.array([mu, np.sqrt(m2), m3 / m2 ** 1.5, m4 / m2 ** 2 - 3], dtype=float)


# --- constant windows of a large value: the documented 0 ------------------------------------

@pytest.mark.parametrize("value, n", [(1.7e9 + 0.3, 1000), (1e6 + 0.1, 20000),
                                      (0.1, 1000), (9.81, 1000), (101325.7, 50000)])
def test_constant_window_has_zero_spread_and_moments(value, n):
    # a constant window's std is 0 and its skewness and kurtosis 0 (documented); the mean
    # rounded in a plain running sum left every sample a rounding error away from it, and a
    # window of 1000 samples of 1.7e9 + 0.3 read std 3e-5, skewness -1 and kurtosis -2
    out = calculators.statistics(np.full((1, n), value), MOMENTS)[0]
    assert out[0] == value
    assert out[1] == 0.0
    assert out[2] == 0.0 and out[3] == 0.0


@settings(max_examples=60, deadline=None)
@given(st.floats(-1e9, 1e9, allow_subnormal=False), st.integers(1, 3000))
def test_constant_window_any_value(value, n):
    out = calculators.statistics(np.full((2, n), value), MOMENTS)
    assert (out[:, 0] == value).all()
    assert (out[:, 1:] == 0.0).all()


# --- large mean, small variation: against float128 --------------------------------------------

@settings(max_examples=60, deadline=None)
@given(st.floats(-1e8, 1e8), st.floats(1e-3, 10.0), st.integers(10, 5000),
       st.integers(0, 2 ** 32 - 1))
def test_moments_of_offset_signal_match_float128(offset, scale, n, seed):
    # skewness and kurtosis of a signal whose mean dwarfs its spread (a biased sensor, a
    # gravity axis): the error of the window mean fed every central moment; the right
    # two-pass moments stay within the rounding of the samples themselves
    x = offset + scale * np.random.default_rng(seed).exponential(size=n)
    got = calculators.statistics(x[None], MOMENTS)[0]
    ref = _reference_moments(x)
    assert got[0] == pytest.approx(ref[0], rel=1e-15, abs=1e-300)
    assert got[1] == pytest.approx(ref[1], rel=1e-10)
    # the samples' own rounding bounds what any float64 method can reach: eps |x| / std
    tol = 1e-9 + 1e-15 * abs(offset) / ref[1]
    assert abs(got[2] - ref[2]) <= tol * max(1.0, abs(ref[2]))
    assert abs(got[3] - ref[3]) <= tol * max(1.0, abs(ref[3]))


def test_offset_signal_of_long_window_matches_float128():
    # the error of the plain running sum of the mean grew with the window length: 10 000
    # samples at 1e8 +- 1e-2 read the skewness 8e-7 off (30 times scipy's error)
    rng = np.random.default_rng(3)
    x = 1e8 + 1e-2 * rng.exponential(size=10_000)
    got = calculators.statistics(x[None], MOMENTS)[0]
    ref = _reference_moments(x)
    assert abs(got[2] - ref[2]) < 1e-9
    assert abs(got[3] - ref[3]) < 1e-8


# --- scale equivariance -----------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(st.sampled_from([1e-6, 1e-3, 1e3, 1e6]), st.integers(5, 500),
       st.integers(0, 2 ** 32 - 1), st.floats(-100.0, 100.0))
def test_statistics_scale_equivariant(c, n, seed, offset):
    # std, rms, min, max, mean_abs_diff scale with the signal; skewness and kurtosis do not
    # (above the documented constant-window cut-off: a std of at least 1e-3 here)
    x = offset + np.random.default_rng(seed).normal(size=n)
    names = ("mean", "std", "rms", "min", "max", "mean_abs_diff", "skewness", "kurtosis")
    a = calculators.statistics(x[None], names)[0]
    b = calculators.statistics(c * x[None], names)[0]
    np.testing.assert_allclose(b[:6], c * a[:6], rtol=1e-9, atol=0)
    if c >= 1e-3:     # (a std of 1e-6 reads skewness and kurtosis 0: the documented cut-off)
        np.testing.assert_allclose(b[6:], a[6:], rtol=1e-9, atol=1e-9)


# --- float32 windows ----------------------------------------------------------------------------

@pytest.mark.parametrize("offset", [0.0, 9.81, 100.0, 1e4])
def test_band_log_power_of_float32_windows_is_that_of_their_float64_values(offset):
    # a float32 window was transformed in float32 (NumPy's rfft keeps single precision):
    # 1e4 m/s^2 +- 1e-2 read 0.03 decades off the same samples' float64 band powers
    rate = 50.0
    t = np.arange(100) / rate
    rng = np.random.default_rng(0)
    x = (offset + 0.01 * np.sin(2 * np.pi * 5 * t) + 1e-3 * rng.normal(size=100)
         ).astype(np.float32)
    bands = ((0.0, 2.5), (2.5, 5.0), (5.0, 10.0), (10.0, 25.0))
    got = calculators.band_log_power(x[None, None], rate, bands)
    want = calculators.band_log_power(x.astype(float)[None, None], rate, bands)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert got.dtype == np.float64


def test_window_features_of_float32_windows_equal_their_float64_values():
    rng = np.random.default_rng(1)
    X = (9.81 + 0.1 * rng.normal(size=(4, 3, 100))).astype(np.float32)
    wf = WindowFeatures(("ax", "ay", "az"), 50.0).fit(X)
    np.testing.assert_array_equal(wf.transform(X), wf.transform(X.astype(float)))
