"""Windowing review (ftr23): boundaries and off-by-one (thresholds, counts, last samples)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.windows import MAX_WINDOW_SAMPLES, WindowConfig, window_frame
from terrain.errors import ConfigError
from terrain.run import TIME


def _wheel_frame(vel, n=100, rate_hz=50.0):
    """An aligned frame of ``n`` samples whose both sides run at ``vel`` m/s."""
    v = np.broadcast_to(np.asarray(vel, dtype=float), (n,)).copy()
    return pd.DataFrame({TIME: np.arange(n) / rate_hz, "vel_l": v, "vel_r": v})


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([0.05, 0.1, 0.15, 0.2, 0.3, 0.7, 1.1]),
       st.sampled_from([13, 85, 100, 200]), st.booleans())
def test_a_window_driven_exactly_at_the_speed_floor_is_steady(speed, n, backwards):
    """``steady_only`` keeps windows with ``|mean(vel_mean)| >= min_speed_m_s``: a window
    driven at exactly the floor (0.1 m/s, the default) is steady. The float mean of 100
    samples of 0.1 m/s is 0.09999999999999998, and the window was dropped as unsteady."""
    v = -speed if backwards else speed
    config = WindowConfig(window_s=n / 50.0, rate_hz=50.0, steady_only=True,
                          min_speed_m_s=speed)
    X, _, _, _, counts = window_frame(_wheel_frame(v, n), ["vel_l"], config)
    assert len(X) == 1 and counts["dropped_unsteady"] == 0


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([0.05, 0.1, 0.15, 0.2, 0.3, 0.7, 1.1]),
       st.sampled_from([13, 85, 100, 200]))
def test_a_constant_speed_window_is_steady_under_a_zero_spread_limit(speed, n):
    """``max_speed_std_m_s`` may be 0 (``>= 0``; ``std <= 0`` keeps constant speeds only): a
    window of one constant speed has a spread of 0, not the 1e-16 m/s of its float std, and
    is steady."""
    config = WindowConfig(window_s=n / 50.0, rate_hz=50.0, steady_only=True,
                          min_speed_m_s=0.0, max_speed_std_m_s=0.0)
    X, _, _, _, counts = window_frame(_wheel_frame(speed, n), ["vel_l"], config)
    assert len(X) == 1 and counts["dropped_unsteady"] == 0


@pytest.mark.parametrize("vel, steady", [
    (0.1 - 1e-6, False),          # below the floor
    (0.1 + 1e-6, True),
    ([0.0, 0.2] * 50, True),      # mean 0.1 exactly, spread 0.1: both on their limit
    ([0.0, 0.2 + 1e-6] * 50, False),   # spread above its limit
])
def test_the_steady_limits_still_separate_windows_off_them(vel, steady):
    """The rounding allowance of the limits is no margin: a window a micrometre per second
    off a limit lands on its documented side."""
    config = WindowConfig(steady_only=True)
    X, _, _, _, counts = window_frame(_wheel_frame(vel), ["vel_l"], config)
    assert len(X) == int(steady) and counts["dropped_unsteady"] == int(not steady)


@pytest.mark.parametrize("window_s, n_samples", [
    (10_000.004, MAX_WINDOW_SAMPLES),      # 1 000 000.4 samples: rounds to the cap
    (10_000.005, MAX_WINDOW_SAMPLES),      # 1 000 000.4999999999: the cap
    (9_999.996, MAX_WINDOW_SAMPLES),       # 999 999.6: rounds up to the cap
])
def test_a_window_that_rounds_to_the_sample_cap_is_allowed(window_s, n_samples):
    """A window holds ``n_samples = round(window_s * rate_hz)`` samples, at most
    :data:`MAX_WINDOW_SAMPLES`: one that rounds to exactly the cap is allowed. The cap was
    checked on the unrounded product, so 10 000.004 s at 100 Hz (a window of 1 000 000
    samples) was refused as 'holds 1e+06 samples; at most 1,000,000'."""
    assert WindowConfig(window_s=window_s, rate_hz=100.0).n_samples == n_samples


@pytest.mark.parametrize("window_s", [10_000.006, 10_000.01, 1e300])
def test_a_window_that_rounds_past_the_sample_cap_is_refused_with_its_count(window_s):
    """One sample past the cap is refused, and the message states the rounded count (not
    '1e+06', which read as the cap itself)."""
    with pytest.raises(ConfigError, match=r"at most 1,000,000 \(a shorter window") as err:
        WindowConfig(window_s=window_s, rate_hz=100.0)
    assert "1e+06 samples" not in str(err.value)
