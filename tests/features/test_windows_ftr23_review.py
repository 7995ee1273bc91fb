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


@settings(max_examples=150, deadline=None)
@given(st.sampled_from([6.5, 15.0, 50.0, 100.0, 1 / 0.1538]), st.integers(4, 40),
       st.integers(1, 60), st.integers(0, 130), st.one_of(st.none(), st.integers(0, 40)))
def test_window_starts_cover_the_run_to_its_last_sample(rate_hz, n, hop, total, extra):
    """Windows start every ``hop`` samples from the first while a whole window fits, so the
    number of windows of a frame (or partition) of ``total`` samples is
    ``(total - n) // hop + 1`` (0 below ``n``): a window exactly as long as the frame is
    cut, and a window ending on the last sample too. Windows, the gaps a longer hop leaves
    between them, the tail after the last window and the tail after the last partition add
    up to the frame, to the sample."""
    partition = None if extra is None else n + extra
    config = WindowConfig(window_s=n / rate_hz, hop_s=hop / rate_hz, rate_hz=rate_hz,
                          partition_s=None if partition is None else partition / rate_hz)
    assert (config.n_samples, config.hop_samples) == (n, hop)
    assert config.partition_samples == partition
    frame = _wheel_frame(0.5, total, rate_hz)
    X, t0, t1, part, counts = window_frame(frame, ["vel_l"], config)
    spans = [(0, total)] if partition is None else [
        (s, s + partition) for s in range(0, total - partition + 1, partition)]
    expected = sum((b - a - n) // hop + 1 for a, b in spans if b - a >= n)
    assert len(X) == expected
    starts = np.rint(t0 * rate_hz).astype(int)
    for k, s in zip(part, starts):       # each window inside its partition
        a, b = spans[k]
        assert a <= s and s + n <= b
    covered = sum(min(hop, n) * (c - 1) + n for c in np.bincount(part, minlength=len(spans))
                  if c)
    # (windows of one partition overlap when hop < n: each sample counted once)
    total_s = (covered / rate_hz + counts["between_windows_s"] + counts["window_tail_s"]
               + counts["partition_tail_s"])
    assert total_s == pytest.approx(total / rate_hz, abs=1e-9)
    np.testing.assert_allclose(t1 - t0, n / rate_hz, rtol=1e-12)
    if len(X):
        np.testing.assert_array_equal(X[:, 0], 0.5)


@pytest.mark.parametrize("length_s, rate_hz, samples", [
    (2.0, 6.5, 13), (2.0, 15.0, 30), (2.0, 50.0, 100), (2.0, 100.0, 200),
    (1.0, 6.5, 6), (3.0, 6.5, 20), (5.0, 6.5, 32),     # ties: to the even count
    (0.5, 15.0, 8), (1.5, 15.0, 22), (1.7, 50.0, 85), (0.1, 50.0, 5),
    (2.0, 1 / 0.1538, 13),                              # 13.003901 samples
])
def test_lengths_in_seconds_round_to_the_nearest_sample_ties_to_even(length_s, rate_hz,
                                                                     samples):
    """Window, hop and partition lengths are ``round(length_s * rate_hz)`` samples, a tie
    (half a sample) going to the even count (documented on :class:`WindowConfig`)."""
    shortest = 4 / rate_hz
    assert WindowConfig(window_s=shortest, hop_s=length_s, rate_hz=rate_hz).hop_samples == \
        samples
    if samples >= 4:
        config = WindowConfig(window_s=length_s, rate_hz=rate_hz, partition_s=length_s)
        assert config.n_samples == config.partition_samples == samples


@pytest.mark.parametrize("field", ["hop_s", "partition_s"])
def test_a_length_whose_sample_count_overflows_is_refused_at_construction(field):
    """A finite hop or partition whose sample count overflows a float (1e308 s at 100 Hz)
    is a ConfigError naming it; the partition's was accepted and ended in a bare
    OverflowError of round() when the first frame was cut."""
    with pytest.raises(ConfigError, match=rf"{field} 1e\+308 s at 100 Hz is more samples"):
        WindowConfig(window_s=1.0, rate_hz=100.0, **{field: 1e308})
    ok = WindowConfig(window_s=1.0, rate_hz=100.0, partition_s=1e300)    # counts: fine
    X, *_, counts = window_frame(_wheel_frame(0.5, 300, 100.0), ["vel_l"], ok)
    assert len(X) == 0 and counts["partition_tail_s"] == pytest.approx(3.0)


@pytest.mark.parametrize("hop_s", [3.0, 4.0, 1e15, 1e17, 1e300])
def test_a_hop_longer_than_the_frame_cuts_its_first_window_only(hop_s):
    """A hop at least as long as the frame cuts one window, at its first sample, whatever
    the hop: one of 1e17 s at 100 Hz (1e19 samples, past a 64-bit count) made the window
    starts a float array and ended in NumPy's bare IndexError."""
    config = WindowConfig(window_s=1.0, rate_hz=100.0, hop_s=hop_s)
    X, t0, _, _, counts = window_frame(_wheel_frame(0.5, 300, 100.0), ["vel_l"], config)
    assert len(X) == 1 and t0[0] == 0.0
    assert counts["window_tail_s"] == pytest.approx(2.0) and counts["between_windows_s"] == 0
