"""Review svc11: where a restart of one stream's clock alone is flagged (a hand mutant
noting it at the newest held sample even when the decision clock starts again survived
every test)."""

from __future__ import annotations

import numpy as np

from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.config import StreamConfig
from terrain.serving.intake import DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES


def test_a_restart_alone_before_any_decision_is_flagged_from_its_first_held_sample():
    # IMU and wheels at 10 Hz for 20 s, then the IMU clock starts again from 0 while the
    # wheels go on: once its held samples have run as a clock for 5 s (clock_restart_s)
    # they are put on the wheels' clock. No decision was placed (the decision clock starts
    # with the samples that come), so every window holding one of the moved samples must
    # carry clock_restart: the span is noted from the first moved sample, not the newest
    # (the first window from the restarted buffer's start was left clean)
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    clock = DecisionClock(window_s=2.0, rate_hz=10.0)
    intake = StreamIntake(streams, StreamConfig(streams=streams), DEFAULT_RULES, clock)
    rng = np.random.default_rng(0)

    def push(stream, t):
        v = 0.1 * rng.standard_normal((1, len(streams[stream])))
        if stream == "imu":
            v[0, 5] += 9.81
        intake.ingest(stream, np.array([t]), v)

    for k in range(200):
        push("imu", k / 10)
        push("wheels", k / 10)
    for k in range(80):
        push("imu", k / 10)                  # the IMU's new clock
        push("wheels", 20.0 + k / 10)
        if intake.restarts:
            break
    assert intake.restarts == 1 and clock.next_t is None
    offset = intake.clocks["imu"].offset_s
    assert 19.9 < offset < 20.1               # half a wheel step after their newest sample
    first_moved = intake.buffers["imu"].first_t
    assert first_moved == offset               # the held run began at the IMU's new 0 s
    restart = [(a, b) for a, b, reason in intake.events["imu"] if reason == "clock_restart"]
    assert restart and restart[0][0] == first_moved
