"""Review of the clock rules and the intake at the bounds their docstrings draw (hand
mutants of clocks.py and intake.py that the other tests let live)."""

from __future__ import annotations

import numpy as np

from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.clocks import UNITS_STEPS, StreamClock, steps_ahead
from terrain.serving.config import StreamConfig
from terrain.serving.intake import OVERFLOW, DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES
from test_intake import _chunk, _intake


def test_a_step_of_exactly_a_clocks_step_is_no_step_ahead():
    # "more than step_s past prev_t_s": 6 s after the stream's newest is a lag the config
    # tolerates, even when it is 7 s past the other stream (binary-exact stamps)
    assert not steps_ahead(16.0, 10.0, [9.0], 6.0, 60.0)
    assert steps_ahead(16.5, 10.0, [9.0], 6.0, 60.0)


def test_a_rejection_inside_a_noted_span_never_shortens_it():
    # a span of rejections [2, 10] s (an overflow run, noted with until_s); a rejection of
    # the same reason at 5 s falls inside it: every window holding 6-10 s keeps its flag
    intake, _ = _intake()
    intake.note("wheels", 2.0, OVERFLOW, until_s=10.0)
    intake.note("wheels", 5.0, OVERFLOW)
    assert list(intake.events["wheels"]) == [(2.0, 10.0, OVERFLOW)]
    intake.note("wheels", 11.0, OVERFLOW)       # within one window (2 s) after: extends
    assert list(intake.events["wheels"]) == [(2.0, 11.0, OVERFLOW)]
    intake.note("wheels", 13.5, OVERFLOW)       # more than a window after: a new span
    assert list(intake.events["wheels"])[-1] == (13.5, 13.5, OVERFLOW)


def test_a_clock_found_in_ms_stays_in_ms_while_too_few_steps_say_otherwise():
    # "as before when too little to judge": a clock judged in ms, then moved with only
    # three stamps remembered, is still in ms (its samples stay refused)
    clock = StreamClock(10, "imu")
    clock.remember(np.arange(UNITS_STEPS + 1) * 10.0)   # 100 Hz stamped in ms
    assert clock.judge_ms() == (True, True)
    clock.restamp(np.array([500.0, 510.0, 520.0]))
    assert clock.judge_ms() == (True, False) and clock.on_ms_clock


def test_a_clock_restart_beside_a_silent_stream_restarts_every_clock():
    # the wheels fall silent at 1.9 s, the IMU goes on to 9.98 s; its clock then goes back
    # to 0 and runs 6 s: no stream went on beside it (the wheels' newest did not advance),
    # so every clock restarts; a stream that merely did not move is no running clock
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t, w = _chunk(0.0, 20)
    intake.ingest("wheels", t, w)

    def imu(t_s):   # live values (no sample repeats an old one: no re-send)
        return np.column_stack([np.zeros((len(t_s), 5)), 9.81 + 0.01 * np.sin(7.0 * t_s)])

    t_imu = 0.02 * np.arange(500)                      # 50 Hz to 9.98 s
    intake.ingest("imu", t_imu, imu(t_imu + 0.5))
    for ti in 0.02 * np.arange(301):                   # the IMU again from 0 to 6 s
        intake.ingest("imu", np.array([ti]), imu(np.array([ti])))
    assert intake.restarts == 1
    assert len(intake.buffers["wheels"]) == 0          # every buffer started again
    assert intake.buffers["imu"].first_t == 0.0 and intake.buffers["imu"].last_t == 6.0
    assert intake.clocks["imu"].offset_s == 0.0        # not moved: no clock to move it on


def test_a_stream_that_never_sent_is_not_rejoining_after_a_restart():
    # only a stream silent *through* a restart (it had samples on the old clock) has its
    # first sample judged against the shorter step; one that never sent is judged as any
    # first sample: 10 s from the IMU is a lag (under max_backlog_s), taken, not held
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))

    def imu(t_s):
        return np.column_stack([np.zeros((len(t_s), 5)), 9.81 + 0.01 * np.sin(7.0 * t_s)])

    t_imu = 0.02 * np.arange(500)
    intake.ingest("imu", t_imu, imu(t_imu + 0.5))
    for ti in 0.02 * np.arange(301):
        intake.ingest("imu", np.array([ti]), imu(np.array([ti])))
    assert intake.restarts == 1
    assert not intake.clocks["wheels"].rejoining
    t, w = _chunk(16.0, 1)
    intake.ingest("wheels", t, w)
    assert intake.clocks["wheels"].held() == {}
    assert intake.buffers["wheels"].last_t == 16.0


def test_a_clock_stepped_back_by_a_run_of_exactly_stale_s_is_put_back():
    # the IMU's clock steps back 1 s (stale_s) at 10 s while the wheels go on: the late run
    # 9.0-10.0 s spans exactly stale_s, the IMU's next sample continues it, so it is a
    # restart of the IMU alone (binary-exact 8 Hz stamps)
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))

    def imu(ti):
        return np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 9.81 + 0.01 * np.sin(7.0 * ti)]])

    t = 0.125 * np.arange(81)                       # 0 to 10 s
    _, w = _chunk(0.0, 1)
    for ti in t:
        intake.ingest("imu", np.array([ti]), imu(ti + 0.3))
        intake.ingest("wheels", np.array([ti]), w)
    for k in range(1, 10):                          # the IMU from 9.0 s again, wheels on
        intake.ingest("imu", np.array([9.0 + 0.125 * (k - 1)]), imu(100.0 + k))
        intake.ingest("wheels", np.array([10.0 + 0.125 * k]), w)
    assert intake.restarts == 0 and len(intake.clocks["imu"].late) == 9   # 9.0-10.0 s
    intake.ingest("imu", np.array([10.125]), imu(200.0))
    assert intake.restarts == 1
    assert intake.clocks["imu"].offset_s > 0.9      # put back beside the wheels
