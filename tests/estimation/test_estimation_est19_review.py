"""Review tests (est19): estimation defects found by targeted and property-based checks."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer

HALF_TRACK_M = 0.3


def _arc(t_s: np.ndarray, v_m_s: float, yaw_rate_rad_s: float) -> np.ndarray:
    """Pose (x, y, theta) of a vehicle on a circle from the origin, heading 0 at t = 0."""
    th = yaw_rate_rad_s * t_s
    return np.c_[np.sin(th) * v_m_s / yaw_rate_rad_s,
                 (1.0 - np.cos(th)) * v_m_s / yaw_rate_rad_s, th]


@settings(max_examples=25, deadline=None)
@given(v=st.floats(0.3, 1.5), w=st.floats(0.2, 0.8), gap_s=st.floats(0.3, 1.5))
def test_observer_predicts_a_gap_after_a_missing_sample_in_median_steps(v, w, gap_s):
    """A time gap opened by a missing sample is predicted in steps of at most the median
    step, as one opened by a sample read (module docstring): one Euler step over the whole
    gap left the pose 0.25 m off the arc after a 1 s gap in a 0.5 rad/s turn."""
    t = np.r_[np.arange(0.0, 1.0, 0.01), 1.0 + gap_s + np.arange(0.0, 1.0, 0.01)]
    pose = _arc(t, v, w)
    vr = np.full(t.size, v + HALF_TRACK_M * w)
    vl = np.full(t.size, v - HALF_TRACK_M * w)
    s = AdaptiveObserverSettings(half_track_m=HALF_TRACK_M)
    read = run_adaptive_observer(t, pose, vr, vl, s)
    missing = pose.copy()
    missing[99] = np.nan                         # the sample that opens the gap
    skipped = run_adaptive_observer(t, missing, vr, vl, s)
    assert skipped.missing_samples == 1
    # the first sample after the gap sees the same error either way (to the one correction
    # step the missing sample lacks), a few mm, not the arc's v w h^2 / 2
    assert np.abs(skipped.error[100, :2]).max() < 0.01
    np.testing.assert_allclose(skipped.error[100, :2], read.error[100, :2], atol=2e-3)
