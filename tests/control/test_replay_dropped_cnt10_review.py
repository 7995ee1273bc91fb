"""Review tests (cnt10): the samples of a recorded run that no call of measured_observations
receives (before the streams' common start, after the last call) are counted."""

from __future__ import annotations

import numpy as np

from terrain.control.replay import measured_observations
from test_measured_replay_review import _run  # same folder (pytest's prepend import)


def test_samples_outside_the_calls_are_counted_per_stream():
    # IMU 0.00-2.99 s at 100 Hz, wheels from 0.5 s at 10 Hz to 2.0 s: the 50 IMU samples
    # before 0.5 s and the 99 after the last call (2.0 s) were dropped without a word
    imu_t = np.arange(300) / 100.0
    wheel_t = 0.5 + np.arange(16) / 10.0
    replay = measured_observations(_run(imu_t, wheel_t), 0.2, 20.0)
    assert replay.dropped_before_start == {"imu": 50, "wheels": 0}
    assert replay.dropped_after_end == {"imu": 99, "wheels": 0}
    obs = list(replay)
    got = sum(len(o.imu) for o in obs)
    assert got + 50 + 99 == imu_t.size                       # every sample accounted for
    assert sum(len(o.wheels) for o in obs) == wheel_t.size


def test_the_last_call_short_of_the_common_end_counts_what_follows_it():
    # common span 0-1.03 s at 20 Hz: the last call at 1.0 s; the samples at 1.01-1.03 s of
    # both streams reach no call
    t = np.arange(104) / 100.0
    replay = measured_observations(_run(t, t), 0.2, 20.0)
    assert replay.dropped_before_start == {"imu": 0, "wheels": 0}
    assert replay.dropped_after_end == {"imu": 3, "wheels": 3}
    assert sum(len(o.wheels) for o in replay) == 101


def test_streams_over_the_same_span_drop_nothing():
    t = np.arange(201) / 100.0
    replay = measured_observations(_run(t, t[::10]), 0.2, 20.0)
    assert replay.dropped_before_start == {"imu": 0, "wheels": 0}
    assert replay.dropped_after_end == {"imu": 0, "wheels": 0}
