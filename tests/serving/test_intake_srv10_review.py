"""Review srv10 of the streaming service's ring buffer and intake at their bounds (hand
mutants of buffers.py and intake.py that the other tests let live)."""

from __future__ import annotations

import numpy as np

from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.buffers import RingBuffer
from terrain.serving.clocks import AHEAD, TIME_RULE
from terrain.serving.config import StreamConfig
from terrain.serving.intake import DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES
from test_intake import _chunk, _intake


def _stamps(*stamps: float) -> np.ndarray:
    return np.array(stamps, dtype=float)


def test_a_chunk_of_exactly_the_capacity_pushes_out_the_held_samples_only():
    # capacity 4 holding 0, 1; a chunk of 4 samples keeps all of its own: 0 and 1 go, none
    # of the chunk (mutant: its first sample counted lost too); one sample longer and its
    # first one goes as well
    buf = RingBuffer(1, 4)
    buf.append(_stamps(0, 1), np.zeros((2, 1)))
    assert buf.evicted_times(_stamps(5, 6, 7, 8), -np.inf).tolist() == [0.0, 1.0]
    assert buf.evicted(_stamps(5, 6, 7, 8), -np.inf) == 2
    assert buf.evicted_times(_stamps(5, 6, 7, 8, 9), -np.inf).tolist() == [0.0, 1.0, 5.0]
    # only those at or after the time still needed count
    assert buf.evicted(_stamps(5, 6, 7, 8, 9), 1.0) == 2
    buf.append(_stamps(5, 6, 7, 8), np.zeros((4, 1)))
    assert buf.times().tolist() == [5.0, 6.0, 7.0, 8.0]


def test_chunks_held_for_the_units_rule_stay_within_buffer_samples():
    # a long step (90 s: a switch to ms, or a dropout) opens the units hold; what follows
    # brings no finite stamp to judge it by (a driver sending NaN stamps): the hold is
    # bounded by buffer_samples, then released (the NaN stamps refused, counted), never
    # grown with every push (mutant: 300 held)
    intake, _ = _intake(buffer_samples=64)
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    t, v = _chunk(100.0, 1)
    intake.ingest("wheels", t, v)
    held = intake.clocks["wheels"].unjudged
    assert len(held) == 1
    most = 0
    for _ in range(300):
        intake.ingest("wheels", _stamps(np.nan), v)
        most = max(most, len(held))
    assert most <= 64 and len(held) == 0
    # every sample accounted for: 20 + 1 taken, 300 refused
    assert intake.refused == {("wheels", "non_finite"): 300}
    assert len(intake.buffers["wheels"]) == 21 and intake.buffers["wheels"].last_t == 100.0


def test_a_sample_back_before_a_units_hold_drops_it_only_past_max_backlog_s():
    # wheels to 1.9 s, one sample after a long step, then samples back on the old clock:
    # after a step of 40 s (< max_backlog_s = 60 s: a dropout's backlog may be that late)
    # the held sample is taken as it came and those back are late; after 61 s it was a
    # stray stamp ahead, refused as time_ahead, and the old clock goes on (mutant of the
    # bound at half max_backlog_s: the 40 s step refused too)
    for jump, refused, newest in ((40.0, {("wheels", TIME_RULE): 3}, 41.9),
                                  (61.0, {("wheels", AHEAD): 1}, 2.2)):
        intake, _ = _intake(buffer_samples=64)
        t, v = _chunk(0.0, 20)
        intake.ingest("wheels", t, v)
        t, v = _chunk(1.9 + jump, 1)
        intake.ingest("wheels", t, v)
        assert intake.clocks["wheels"].held() == {"timestamp_units": 1}
        t, v = _chunk(2.0, 3)
        intake.ingest("wheels", t, v)
        assert intake.refused == refused, jump
        assert intake.buffers["wheels"].last_t == newest and not intake.clocks["wheels"].held()


def _imu(t_s: np.ndarray) -> np.ndarray:
    """Live IMU values (no sample repeats another: no re-send)."""
    return np.column_stack([np.zeros((len(t_s), 5)), 9.81 + 0.01 * np.sin(7.0 * t_s)])


def test_a_step_back_shorter_than_stale_s_is_a_lag_not_a_clock_moved():
    # wheels (10 Hz) and IMU (50 Hz) to 9.9 s; the wheel clock steps back 0.4 s (less than
    # stale_s = 1 s) and runs on past its old newest while the IMU goes on live: the 5
    # samples back are refused as late, the clock is not moved (mutant without the stale_s
    # bound: a restart of the wheel clock alone, its offset moved by 0.51 s)
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t, w = _chunk(0.0, 100)
    intake.ingest("wheels", t, w)
    t_imu = 0.02 * np.arange(496)
    intake.ingest("imu", t_imu, _imu(t_imu))
    k = 496
    for t_wheel in (9.5, 9.6, 9.7, 9.8, 9.9, 10.0, 10.1):
        for _ in range(5):
            t_imu = np.array([0.02 * k])
            intake.ingest("imu", t_imu, _imu(t_imu))
            k += 1
        t, w = _chunk(t_wheel, 1)
        intake.ingest("wheels", t, w + 1e-4 * k)
    assert intake.restarts == 0 and intake.clocks["wheels"].offset_s == 0.0
    assert intake.refused == {("wheels", TIME_RULE): 5}
    np.testing.assert_allclose(intake.buffers["wheels"].times()[-3:], [9.9, 10.0, 10.1])
